"""``vsbuffer_best`` leaves out the cells the transfer function makes invisible (left out of the octree,
met by the walk as empty space) and stops rays at its stated transmittance: images against
``skip=False`` and the reference, counts on analytic cases."""

import numpy as np
import pytest

from test_skip_pt import _within
from test_visibility import _scene, _shell_tf
from tolerances import TOLERANCES, preset_tolerance
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction

ROW = preset_tolerance("vsbuffer_best")


def _on_off(sc):
    pipe = Pipeline.load("vsbuffer_best")
    return pipe.render(sc, quiet=True), pipe.render(sc, quiet=True, skip=False)


def test_vsbuffer_best_leaves_out_a_known_fraction():
    sc = _scene(px=24)  # 10 layers along z, the TF's shell meets 2 of them
    on, off = _on_off(sc)
    n = sc.mesh.n_tets
    assert on.report["left_out"]["vsb_sweep"]["cells_culled"] == n - n // 5
    w_on, w_off = on.report["stats"]["vsbuffer"]["walk"], off.report["stats"]["vsbuffer"]["walk"]
    assert w_on["drawn_cells"] < 0.3 * w_off["drawn_cells"] and w_on["cells_integrated"] < w_off["cells_integrated"]
    assert "left_out" not in off.report and w_off["cells_culled"] == 0
    ok, d = _within(on.image, off.image, TOLERANCES["skip/on_off"])
    assert ok, d
    ok, d = _within(on.image, render_reference(sc.mesh, sc.transfer, sc.camera), ROW)
    assert ok, d
    assert on.image[..., 3].max() > 0.3


@pytest.mark.parametrize("name", ["sphere", "concave"])
def test_vsbuffer_best_same_image_on_builtins(name):
    """The sphere's TF shows two thin shells (most cells invisible); the concave mesh is non-convex:
    its visible part here is a band of its scalar (x^2 + y^2 + z^2 in [1, 2])."""
    sc = builtin_scene(name).with_camera(width_px=24, height_px=24)
    if name == "concave":
        sc = Scene(mesh=sc.mesh, camera=sc.camera, name=name,
                   transfer=TransferFunction([[0, 0, 0, 0, 0], [1.0, 0.9, 0.4, 0.1, 0.0], [1.5, 0.9, 0.4, 0.1, 2.0],
                                              [2.0, 0.2, 0.6, 0.9, 0.0], [3.5, 0, 0, 0, 0]]))
    on, off = _on_off(sc)
    vis = on.report["stats"]["visibility"]
    assert 0 < vis["visible"] < vis["cells"]
    assert on.report["left_out"]["vsb_sweep"]["cells_culled"] == vis["cells"] - vis["visible"]
    ok, d = _within(on.image, off.image, TOLERANCES["skip/on_off"])
    assert ok, d
    ok, d = _within(on.image, render_reference(sc.mesh, sc.transfer, sc.camera), ROW)
    assert ok, d


def test_vsbuffer_best_culls_native_cells_whole():
    """Hexahedra drawn whole: a hex is left out when none of its pieces is visible (8 layers of 3x3
    hexes, scalar z; the shell (-0.15, 0.15) meets the 2 layers around z = 0)."""
    import pyvista as pv

    import warpvol

    g = pv.ImageData(dimensions=(4, 4, 9), spacing=(2 / 3, 2 / 3, 0.25), origin=(-1, -1, -1))
    g.point_data["s"] = g.points[:, 2].copy()
    cam = builtin_scene("box").with_camera(width_px=16, height_px=16).camera
    r = warpvol.render(g, _shell_tf(), cam, scalars="s", pipeline="vsbuffer_best", reference=True)
    assert r.report["stats"]["vsb_setup"]["cells_by_type"] == {"hex": 72}
    assert r.report["left_out"]["vsb_sweep"]["cells_culled"] == 72 - 18
    ok, d = _within(r.image, r.reference, ROW)
    assert ok, d


def test_vsbuffer_best_rays_terminated_and_nothing_visible():
    base = builtin_scene("box").with_camera(width_px=16, height_px=16)  # cube [-1, 1]^3, ortho height 3
    opaque = Scene(mesh=base.mesh, camera=base.camera, name="opaque box",
                   transfer=TransferFunction([[0.0, 0.8, 0.6, 0.4, 20.0], [2.0, 0.8, 0.6, 0.4, 20.0]]))
    on, off = _on_off(opaque)
    centres = -1.5 + 3.0 / 16 * (np.arange(16) + 0.5)
    assert on.report["left_out"]["vsb_sweep"]["rays_terminated"] == int(np.count_nonzero(np.abs(centres) < 1)) ** 2
    ok, d = _within(on.image, off.image, TOLERANCES["skip/on_off"])
    assert ok, d
    empty = Scene(mesh=base.mesh, camera=base.camera, name="invisible box",
                  transfer=TransferFunction([[0.0, 0.8, 0.6, 0.4, 0.0], [2.0, 0.8, 0.6, 0.4, 0.0]]))
    on = Pipeline.load("vsbuffer_best").render(empty, quiet=True)
    assert (on.image == 0).all() and on.report["left_out"]["vsb_sweep"]["cells_culled"] == base.mesh.n_tets
