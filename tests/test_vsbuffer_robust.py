"""VSBUFFER on everyday real-data inputs (issue 25): hexahedra with non-planar faces, pixel centres
exactly on boundary faces seen edge-on, a thin layer carrying the image, and Ctrl-C between plane
batches. vsbuffer_best stays within its tolerance row or says in its report what it cannot resolve."""

import numpy as np
import pytest

import warpvol
from helpers import box_mesh, merge
from tolerances import preset_tolerance
from warpvol.metrics import image_error
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.transfer import TransferFunction
from warpvol.tools.stress_real import jittered_hex_grid
from warpvol.vsbuffer.vsbuffer import BATCH_PIXELS, ConvexCellMesh, render_vsbuffer

TOL = preset_tolerance("vsbuffer_best")


def _err(img, ref):
    e = image_error(img, ref)
    return e["rmse"], e["max_abs"]


TF_HEX = TransferFunction([[0.0, 1.0, 0.1, 0.0, 9.0], [0.4, 0.0, 1.0, 0.1, 0.5], [0.8, 0.1, 0.0, 1.0, 9.0]],
                          "color_extinction")
CAM_HEX = warpvol.Camera(projection="orthographic", eye=(2.2, 1.7, 3.1), target=(0, 0, 0), ortho_height=2.8,
                         width_px=32, height_px=32)


def test_nonplanar_hexahedra_drawn_as_tets():
    g = jittered_hex_grid(0.2, 3)
    mesh = warpvol.TetMesh.from_pyvista(g, "s")
    ref = render_reference(mesh, TF_HEX, CAM_HEX)
    r = warpvol.render(g, TF_HEX, CAM_HEX, scalars="s", pipeline="vsbuffer_best", reference=False, quiet=True)
    st = r.report["stats"]["vsb_setup"]
    assert st["nonconvex_cells"] > 0 and "drawn as their tets" in st["note"]
    rmse, mx = _err(r.image, ref)
    assert rmse <= TOL["rmse"] and mx <= TOL["max_abs"], (rmse, mx)
    # the same cells drawn whole as if convex: wrong pixels the audit does not see
    whole = ConvexCellMesh(mesh, mesh.cell_start)
    whole.__dict__["nonconvex"] = np.zeros(whole.n_cells, bool)
    img, _ = render_vsbuffer(whole, TF_HEX, CAM_HEX, integration="exact", adjacency="recover", rewalk=True)
    assert _err(img, ref)[1] > 1e-2


def test_planar_hexahedra_stay_whole():
    g = jittered_hex_grid(0.0, 0)
    r = warpvol.render(g, TF_HEX, CAM_HEX.replace(width_px=8, height_px=8), scalars="s", pipeline="vsbuffer_best",
                       reference=False, quiet=True)
    st = r.report["stats"]["vsb_setup"]
    assert st["nonconvex_cells"] == 0 and st["cells_by_type"] == {"hex": 80} and "note" not in st


def test_pixel_centres_on_boundary_faces():
    # orthographic view down -z, pixel size 1/4: the first and last rows and columns of pixel centres
    # lie exactly in the boundary planes x = +-1, y = +-1, seen edge-on
    mesh = box_mesh(dims=(4, 4, 4), scalar=lambda p: 0.6 + 0.25 * p[:, 0] - 0.15 * p[:, 1] * p[:, 2])
    tf = TransferFunction([[0.0, 0.9, 0.5, 0.1, 2.5], [1.0, 0.2, 0.4, 1.0, 5.0]], "color_extinction")
    cam = warpvol.Camera(projection="orthographic", eye=(0, 0, 5), target=(0, 0, 0), ortho_height=2.25, width_px=9,
                         height_px=9)
    ref = render_reference(mesh, tf, cam)
    # the reference's rule: rays in x = -1 and y = -1 are inside, in x = +1 and y = +1 outside
    assert ref[4, 0, 3] > 0.9 and ref[4, 8, 3] == 0 and ref[0, 4, 3] == 0 and ref[8, 4, 3] > 0.9
    r = warpvol.render(mesh, tf, cam, pipeline="vsbuffer_best", reference=False, quiet=True)
    rmse, mx = _err(r.image, ref)
    assert rmse <= TOL["rmse"] and mx <= TOL["max_abs"], (rmse, mx)
    w = warpvol.render(mesh, tf, cam, pipeline="westermann1997", reference=False, quiet=True)
    assert _err(w.image, ref)[1] < 1e-3 or "missed" in w.report["stats"]["vsbuffer"]["warning"]


@pytest.mark.parametrize("thickness", [3e-6, 3e-5])
def test_thin_layer_exact(thickness):
    # a slab carrying optical depth 0.25 in front of a dim block (disconnected): too thin for float32 segment
    # lengths, so vsbuffer_best traces the rays that may cross it again in float64; the paper's preset warns
    slab = box_mesh(lo=(-0.8, -0.9, 0.35), hi=(0.9, 0.7, 0.35 + thickness), dims=(4, 4, 2),
                    scalar=lambda p: np.ones(len(p)))
    back = box_mesh(lo=(-1, -1, -1), hi=(1, 1, 0.1), dims=(3, 3, 3), scalar=lambda p: np.zeros(len(p)))
    mesh = merge(slab, back, name="thin")
    tf = TransferFunction([[0.0, 0.1, 0.4, 0.8, 0.4], [1.0, 0.9, 0.7, 0.1, 0.25 / thickness]], "color_extinction")
    cam = warpvol.Camera(projection="orthographic", eye=(0.2, 0.4, 5), target=(0.1, -0.1, 0), ortho_height=2.4,
                         width_px=24, height_px=24)
    ref = render_reference(mesh, tf, cam)
    r = warpvol.render(mesh, tf, cam, pipeline="vsbuffer_best", reference=False, quiet=True)
    rmse, mx = _err(r.image, ref)
    assert rmse <= TOL["rmse"] and mx <= TOL["max_abs"], (rmse, mx)
    assert r.report["stats"]["vsbuffer"]["thin_rays_redone"] > 0
    assert "warning" not in r.report["stats"]["vsbuffer"]
    w = warpvol.render(mesh, tf, cam, pipeline="westermann1997", reference=False, quiet=True)
    assert "thinner than float32" in w.report["stats"]["vsbuffer"]["warning"]


def test_ctrl_c_between_plane_batches():
    # the sweep calls on_batch before every batch of planes; a KeyboardInterrupt raised there (as a
    # Ctrl-C's is at the next Python step) stops it; batches stay within BATCH_PIXELS ID-buffer pixels
    s = warpvol.builtin_scene("concave").with_camera(width_px=64, height_px=64)
    cm = ConvexCellMesh.from_tetmesh(s.mesh)
    seen = []

    def on_batch(j0, n):
        seen.append((j0, n))
        assert n * (64 + 2) * 64 <= BATCH_PIXELS
        if len(seen) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        render_vsbuffer(cm, s.transfer, s.camera, integration="exact", planes_per_batch=4096, on_batch=on_batch)
    assert seen[0][0] == 0 and seen[1][0] == seen[0][1] and len(seen) == 2 and seen[0][1] < 64
