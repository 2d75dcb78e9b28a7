"""The Warp reference (warpvol/reference/warp_render.py, kernels/reference.py) against the NumPy oracle.

Both evaluate Contract 2's ray integral exactly (up to rounding) with independent code; they must
agree to 1e-12 (max abs over RGBA) on every built-in scene and on the degenerate configurations
the exact predicates exist for: rays through grid vertices and along shared edges and faces, a
perspective eye inside the mesh, on a vertex, on an edge and on a face, sliver meshes, stiff
extinction, non-convex meshes.
"""

import warnings

import numpy as np
import pytest

from warpvol.errors import ConfigError
from warpvol.reference.numpy_render import render_reference
from warpvol.reference.warp_render import render_reference_warp
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.grids import grid_points, structured_to_tets
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import TransferFunction
from warpvol.tools.stress import build_case

TOL = 1e-12
TF_LIN = TransferFunction([[-1.0, 1.0, 0.2, 0.1, 0.5], [0.0, 0.3, 0.9, 0.2, 1.2], [1.0, 0.1, 0.3, 1.0, 2.0]])


def grid_box(n=5, lo=-1.0, hi=1.0):
    x = np.linspace(lo, hi, n)
    pts = grid_points(x, x, x)
    return TetMesh(pts, structured_to_tets((n, n, n)), pts[:, 2] + 0.3 * pts[:, 0])


def check(mesh, tf, cam, min_max=0.05):
    """Warp reference == NumPy reference; the image is not empty; no walk failed."""
    st = {}
    got = render_reference_warp(mesh, tf, cam, device="cpu", stats=st, show_progress=False)
    want = render_reference(mesh, tf, cam, method="numpy")
    assert got.shape == want.shape == (cam.height_px, cam.width_px, 4)
    assert np.isfinite(got).all()
    err = float(np.abs(got - want).max())
    assert err <= TOL, f"max abs {err:.3g} > {TOL}"
    assert float(np.abs(want).max()) >= min_max
    assert st["n_failed"] == 0 and "warning" not in st
    return st


@pytest.mark.parametrize("name", ["box", "linear_box", "sphere", "concave", "stiff"])
@pytest.mark.parametrize("projection", ["scene", "perspective"])
def test_builtin_scenes(name, projection):
    sc = builtin_scene(name)
    cam = sc.camera.replace(width_px=40, height_px=32)
    if projection == "perspective":
        cam = Camera(eye=[2.5, 1.6, 3.1], target=[0.1, -0.05, 0.0], fov_y_deg=45.0, width_px=32, height_px=40)
    check(sc.mesh, sc.transfer, cam)


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_both_emission_models_and_stiff_extinction(emission):
    m = grid_box()
    for ext in (1e-6, 3.0, 1e6):
        tf = TransferFunction([[-2.0, 1.0, 0.2, 0.1, ext], [0.0, 0.2, 1.0, 0.3, ext * 0.5],
                               [2.0, 0.1, 0.3, 1.0, ext]], emission)
        cam = Camera(eye=[3.0, 2.0, 4.0], target=[0, 0, 0], fov_y_deg=35.0, width_px=24, height_px=24)
        check(m, tf, cam, min_max=1e-7)


def test_sliver_delaunay_mesh():
    sc = build_case("slivers", quick=True).scene
    st = check(sc.mesh, sc.transfer, sc.camera.replace(width_px=40, height_px=40))
    assert st["n_segments"] > 0


def test_vertices_on_pixel_centres_orthographic_along_axis():
    """Down -z: interior grid vertices on pixel centres, rays inside shared faces and along edges."""
    sc = build_case("vertex_on_pixel_centre", quick=False).scene  # 63 x 63 px: 16 px per cell
    cam = sc.camera.replace(width_px=31, height_px=31, ortho_height=31 * 0.5 / 8)  # 8 px per cell
    st = check(sc.mesh, sc.transfer, cam)
    assert st["n_exact"] > 0  # exact zeros were met and broken by simulation of simplicity


def test_ray_along_shared_edge():
    sc = build_case("ray_along_shared_edge", quick=True).scene
    check(sc.mesh, sc.transfer, sc.camera.replace(width_px=47, height_px=47))


@pytest.mark.parametrize("eye, target", [
    ((0.01, 0.02, 0.03), (1.0, 0.5, -2.0)),  # inside a tet
    ((0.0, 0.0, 0.0), (1.0, 0.5, -2.0)),  # on an interior vertex
    ((0.0, 0.0, 0.0), (0.0, 0.0, -1.0)),  # on a vertex, looking along a grid line
    ((0.5, -0.5, 0.5), (0.5, -0.5, -1.0)),  # on a vertex, rays along grid edges and through vertices
    ((0.25, 0.0, 0.0), (-1.0, 0.3, 0.2)),  # on an edge
    ((0.2, 0.1, 0.0), (0.3, -1.0, 0.5)),  # on a face
    ((1.0, 0.0, 0.5), (-1.0, 0.2, 0.1)),  # on a boundary vertex
])
def test_perspective_eye_inside_mesh(eye, target):
    m = grid_box()
    cam = Camera(eye=eye, target=target, up=(0, 1, 0.3), fov_y_deg=100.0, width_px=33, height_px=27)
    check(m, TF_LIN, cam)


def test_eye_inside_non_convex_mesh():
    sc = builtin_scene("concave")
    cam = Camera(eye=[-1.25, 0.0, 0.0], target=[1.5, 0.1, 0.05], fov_y_deg=80.0, width_px=32, height_px=32)
    check(sc.mesh, sc.transfer, cam)


def test_orthographic_eye_plane_through_mesh():
    """Orthographic rays start on the eye plane, here inside the mesh: the part behind is clipped."""
    m = grid_box()
    cam = Camera(projection="orthographic", eye=[0.1, 0.0, 0.0], target=[0.1, 0.0, -1.0], ortho_height=2.6,
                 width_px=26, height_px=26)
    check(m, TF_LIN, cam)


def test_dispatch_and_choice():
    sc = builtin_scene("linear_box")
    cam = sc.camera.replace(width_px=12, height_px=12)
    a = render_reference(sc.mesh, sc.transfer, cam)  # default: the Warp kernels
    b = render_reference(sc.mesh, sc.transfer, cam, method="warp")
    c = render_reference(sc.mesh, sc.transfer, cam, method="numpy")
    assert np.array_equal(a, b)
    assert np.abs(a - c).max() <= TOL
    with pytest.raises(ConfigError, match="method"):
        render_reference(sc.mesh, sc.transfer, cam, method="fast")


def test_progress_and_stats():
    sc = builtin_scene("sphere")
    cam = sc.camera.replace(width_px=16, height_px=16)
    seen = []
    st = {}
    render_reference_warp(sc.mesh, sc.transfer, cam, device="cpu", progress=seen.append, stats=st,
                          show_progress=False, rows_per_block=4)
    assert len(seen) == 4 and seen[-1] == 1.0 and sorted(seen) == seen
    assert st["n_segments"] > 0 and st["n_steps"] >= st["n_segments"] and st["n_failed"] == 0


def test_disconnected_touching_pieces():
    """Two grids sharing no tets but touching along a plane: rays leave one and enter the other."""
    x = np.linspace(-1, 0, 3)
    a = grid_points(x, x, x)
    b = a + np.array([0.0, 0.0, 1.0])
    t = structured_to_tets((3, 3, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = TetMesh(np.vstack([a, b]), np.vstack([t, t + len(a)]), np.concatenate([a[:, 0], b[:, 1]]))
    cam = Camera(eye=[-0.4, -0.6, 4.0], target=[-0.5, -0.5, 0.0], fov_y_deg=25.0, width_px=30, height_px=30)
    check(m, TF_LIN, cam)


def test_row_bands_are_bit_identical():
    sc = builtin_scene("concave")
    cam = sc.camera.replace(width_px=20, height_px=18)
    whole = render_reference_warp(sc.mesh, sc.transfer, cam, device="cpu", show_progress=False)
    parts = [render_reference_warp(sc.mesh, sc.transfer, cam, device="cpu", show_progress=False, rows=r)
             for r in ((0, 6), (7, 7), (8, 17))]
    assert np.array_equal(np.concatenate(parts), whole)
    with pytest.raises(ConfigError, match="rows"):
        render_reference_warp(sc.mesh, sc.transfer, cam, device="cpu", rows=(5, 18))
