"""Thin layers that carry the image, and faces seen edge-on from the eye: the exact presets find the rays
or pixels float32 cannot resolve, redo them in float64 and count them, and stay within their
tests/tolerances.py rows against the float64 reference."""

import numpy as np
import pytest

from tolerances import preset_tolerance
from warpvol.metrics import image_error
from warpvol.pipeline import Pipeline
from warpvol.projection.pt_thin import density_max, thin_tets
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.grids import grid_points, structured_to_tets
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction
from warpvol.tools.stress_meshes import _box, _tf


def layer_scene(thick: float, depth: float, camera: Camera, z0: float = 0.15) -> Scene:
    """Box [-1, 1]^3, 4 x 4 cells across, a layer ``thick`` thick at ``z0`` across which the scalar
    steps from 0 to 1; the TF's extinction is a tent over s in [0.25, 0.75], so only the layer is
    visible, with optical depth ``depth`` along z."""
    x = np.linspace(-1.0, 1.0, 5)
    zs = np.array([-1.0, -0.4, z0, z0 + thick, 1.0])
    pts = grid_points(x, x, zs)
    s = np.where(pts[:, 2] > z0 + 0.5 * thick, 1.0, 0.0)
    peak = depth / (0.25 * thick)  # mean extinction over s in [0, 1]: peak / 4
    tf = TransferFunction([[0.0, 0.7, 0.2, 0.3, 0.0], [0.25, 0.7, 0.2, 0.3, 0.0], [0.5, 0.1, 0.9, 0.5, peak],
                           [0.75, 0.2, 0.3, 0.8, 0.0], [1.0, 0.2, 0.3, 0.8, 0.0]])
    mesh = TetMesh(pts, structured_to_tets((5, 5, len(zs))), s, name="thin_layer")
    return Scene(mesh=mesh, transfer=tf, camera=camera, name="thin_layer")


VIEWS = {
    "ortho_down": Camera(projection="orthographic", eye=(0.11, -0.06, 4.0), target=(0.11, -0.06, 0.0), up=(0, 1, 0),
                         ortho_height=2.6, width_px=24, height_px=24),
    "persp": Camera(eye=(1.7, -1.1, 3.9), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=35.0, width_px=24, height_px=24),
    "grazing": Camera(eye=(3.8, 0.7, 0.9), target=(0, 0, 0.15), up=(0, 0, 1), fov_y_deg=40.0, width_px=24,
                      height_px=24),
}


def _stat(report, key):
    return sum(int(v.get(key, 0)) for v in report["stats"].values() if isinstance(v, dict))


@pytest.mark.parametrize("view", sorted(VIEWS))
@pytest.mark.parametrize("preset", ["raycast", "harc_best"])
def test_ray_casters_redo_thin_layer_rays_in_float64(preset, view):
    sc = layer_scene(4e-6, 0.25, VIEWS[view])
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    assert ref[..., 3].max() > 0.2  # the layer carries the image
    res = Pipeline.load(preset).render(sc, quiet=True)
    err = image_error(res.image, ref)
    tol = preset_tolerance(preset)
    assert err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"], err
    assert _stat(res.report, "thin_layer_rays") > 0
    assert _stat(res.report, "float64_rays") >= _stat(res.report, "thin_layer_rays")


@pytest.mark.parametrize("view", sorted(VIEWS))
def test_pt_best_redoes_thin_layer_pixels_in_float64(view):
    sc = layer_scene(4e-6, 0.25, VIEWS[view])
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load("pt_best").render(sc, quiet=True)
    err = image_error(res.image, ref)
    tol = preset_tolerance("pt_best")
    assert err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"], err
    st = res.report["stats"]["pt_integrate"]
    assert st["thin_tets"] > 0 and st["float64_rays"] > 0


def _pt_best_diagonal_view(eye, size: int) -> dict:
    """pt_best of the 6-tet box (each cube cut along x = y planes) seen from ``eye`` towards a point of
    such a plane, checked against the reference within pt_best's tolerance row; its pt_integrate stats."""
    sc = Scene(mesh=_box(5), transfer=_tf(2.5), name="diag",
               camera=Camera(eye=eye, target=(0.05, 0.05, 0.0), up=(0, 1, 0), fov_y_deg=30.0, width_px=size,
                             height_px=size))
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load("pt_best").render(sc, quiet=True)
    err = image_error(res.image, ref)
    tol = preset_tolerance("pt_best")
    assert err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"], err
    return res.report["stats"]["pt_integrate"]


def test_pt_best_eye_in_the_plane_of_interior_diagonal_faces():
    # the eye at x = y sees the diagonal faces edge-on
    st = _pt_best_diagonal_view((0.42, 0.42, 3.7), 40)
    assert st["edge_on_faces"] > 0 and st["float64_rays"] > 0


def test_pt_best_redoes_pixels_inside_faces_narrower_than_the_snapping():
    # the eye 5e-4 off the x = y plane of the diagonal faces (over 10x float32's edge-on distance): those
    # faces project to slivers ~0.002 px wide, narrower than the rasteriser's 1/256-px snapping, and the
    # centre pixel's ray (eye -> target, a point of such a face) runs inside one; snapped, the cut of its
    # two tets into triangles takes that pixel's front or back point from a face on the wrong side
    st = _pt_best_diagonal_view((0.42 + 5e-4, 0.42, 3.7), 41)
    assert st["edge_on_faces"] == 0 and st["sliver_faces"] > 0 and st["float64_rays"] > 0


def test_sliver_pixels_are_the_centres_near_its_edges():
    """``_mark_near_edges`` (each edge stepped along its major axis) marks exactly the pixel centres a
    brute-force distance test finds within ``delta`` of the triangles' edges."""
    from warpvol.projection.pt_thin import _mark_near_edges

    rng = np.random.default_rng(5)
    h, w, delta = 23, 31, 4.0 / 256.0
    col = rng.uniform(-3, w + 3, (60, 3))
    row = rng.uniform(-3, h + 3, (60, 3))
    col[:20, 1] = col[:20, 0] + 1e-3  # near-degenerate edges and slivers
    row[20:30] = np.rint(row[20:30]) + 0.5  # edges through rows of pixel centres
    got = np.zeros((h, w), dtype=bool)
    _mark_near_edges(got, col, row, delta)
    jj, ii = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    want = np.zeros((h, w), dtype=bool)
    for c, r in zip(col, row):
        for a, b in ((0, 1), (1, 2), (2, 0)):
            ex, ey = c[b] - c[a], r[b] - r[a]
            t = np.clip(((jj - c[a]) * ex + (ii - r[a]) * ey) / max(ex * ex + ey * ey, 1e-300), 0.0, 1.0)
            want |= np.hypot(jj - c[a] - t * ex, ii - r[a] - t * ey) <= delta
    assert want.sum() > 50
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("preset", ["raycast", "harc_best"])
def test_no_thin_layer_rays_on_ordinary_scenes(preset):
    for name in ("box", "linear_box", "stiff"):
        sc = builtin_scene(name).with_camera(width_px=24, height_px=24)
        res = Pipeline.load(preset).render(sc, quiet=True)
        assert _stat(res.report, "thin_layer_rays") == 0, name


def test_thin_tets_need_density():
    thick = layer_scene(4e-6, 0.25, VIEWS["persp"])
    assert len(thin_tets(thick.mesh, thick.transfer, thick.camera)) > 0
    clear = TransferFunction([[0.0, 1, 1, 1, 0.0], [1.0, 1, 1, 1, 0.0]])
    assert len(thin_tets(thick.mesh, clear, thick.camera)) == 0


def test_density_max_matches_dense_sampling():
    rng = np.random.default_rng(3)
    pts = np.column_stack([np.sort(rng.uniform(-2, 2, 40)), rng.uniform(0, 1, (40, 3)), rng.uniform(0, 9, 40)])
    tf = TransferFunction(pts)
    a, b = np.sort(rng.uniform(-3, 3, (2, 200)), axis=0)
    got = density_max(tf, a, b)
    for lo, hi, g in zip(a, b, got):
        s = np.concatenate([np.linspace(lo, hi, 2001), pts[(pts[:, 0] > lo) & (pts[:, 0] < hi), 0]])
        assert g == pytest.approx(np.interp(s, pts[:, 0], pts[:, 4]).max(), rel=1e-12)


def test_pt_best_redoes_silhouette_pixels_at_high_extinction():
    """Extinction 60 per unit length: a 1/256-pixel snap of a silhouette edge changes the thickness of the
    grazing fragments beside it by more than pt_best's tolerance; those pixels are redone in float64."""
    from warpvol.projection.pt_thin import silhouette_edges

    cam = Camera(eye=(2.6, 1.7, 3.9), target=(0.05, -0.1, 0.0), fov_y_deg=33.0, width_px=40, height_px=40)
    sc = Scene(mesh=_box(4), transfer=_tf(60.0), camera=cam, name="dense_box")
    assert len(silhouette_edges(sc.mesh, sc.transfer, cam)) > 0
    ref = render_reference(sc.mesh, sc.transfer, cam)
    res = Pipeline.load("pt_best").render(sc, reference=ref, quiet=True)
    st = res.report["stats"]["pt_integrate"]
    tol = preset_tolerance("pt_best")
    assert st["silhouette_edges"] > 0 and st["float64_rays"] > 0
    assert res.report["error"]["rmse"] <= tol["rmse"] and res.report["error"]["max_abs"] <= tol["max_abs"]
    # at extinction 0.5 the same view has no silhouette edge to redo
    assert len(silhouette_edges(sc.mesh, _tf(0.5), cam)) == 0


@pytest.mark.parametrize("preset", ["raycast", "harc_best"])
def test_steep_transfer_function_on_cells_of_constant_scalar(preset):
    """Cells whose four scalars are equal sit at a TF point where the extinction climbs by 3e5 per unit of
    scalar: the scalar at each face crossing must be that value exactly (a barycentric sum's rounding of
    1e-7 would change the extinction by ~10 %)."""
    mesh = _box(4, scalar=lambda p: np.where(p[:, 2] > 0.5, 1.0, 0.0))
    tf = TransferFunction([[0.0, 0.1, 0.4, 0.8, 0.6], [1.0, 0.9, 0.7, 0.1, 3e5]])
    cam = Camera(eye=(1.3, 0.9, -4.0), target=(0.0, 0.0, -0.3), fov_y_deg=30.0, width_px=20, height_px=20)
    sc = Scene(mesh=mesh, transfer=tf, camera=cam, name="steep_tf")
    ref = render_reference(sc.mesh, sc.transfer, cam)
    res = Pipeline.load(preset).render(sc, reference=ref, quiet=True)
    tol = preset_tolerance(preset)
    assert res.report["error"]["rmse"] <= tol["rmse"] and res.report["error"]["max_abs"] <= tol["max_abs"]
