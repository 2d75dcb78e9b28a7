"""``raycast`` on meshes and cameras that break naive float32 walks (issue 7).

Every case renders a small image and compares it with the exact float64 reference
(:mod:`warpvol.reference.numpy_render`) within the ``raycast/fp32`` entry of ``tests/tolerances.py`` -- slivers
included: the walk's edge tests, depths and scalars never use a cell's gradient or face planes. The
cases: Delaunay meshes of jittered grids (slivers of every shape), flat
"cap" and "kite" slivers, rays exactly through vertices and along edges, eyes up to 1e6 mesh sizes
away, cameras looking away from the mesh and orthographic eye planes inside it.
"""

import warnings

import numpy as np
import pytest

from helpers import DEVICES, box_mesh, scene
from tolerances import preset_tolerance
from warpvol.metrics import image_error
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import TransferFunction

TOL = preset_tolerance("raycast")

TF = TransferFunction([[-1.0, 0.1, 0.2, 1.0, 0.4], [0.0, 1.0, 0.6, 0.1, 1.5], [1.0, 0.9, 1.0, 0.3, 0.6],
                       [3.0, 1.0, 0.2, 0.2, 2.0]])


def render(sc, device="cpu"):
    return Pipeline.load("raycast", device=device).render(sc, quiet=True)


def check(sc, tol=TOL, visible=True, device="cpu"):
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = render(sc, device)
    err = image_error(res.image, ref)
    if visible:
        assert ref[..., 3].max() > 0.05, "the scene must show something"
    assert err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"], (err, res.report["stats"]["raycast"])
    return res, ref


def jittered_delaunay(n: int, jitter: float, seed: int) -> TetMesh:
    """Delaunay tetrahedralisation (VTK, via pyvista) of an ``n^3`` unit-spaced grid jittered by
    ``jitter`` of the spacing: nearly cospherical points give slivers of every kind."""
    import pyvista as pv

    rng = np.random.default_rng(seed)
    g = np.arange(n, dtype=float)
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    p = p + jitter * rng.uniform(-1, 1, p.shape)
    ug = pv.PolyData(p).delaunay_3d()
    tets = ug.cells.reshape(-1, 5)[:, 1:]
    pts = np.asarray(ug.points, dtype=float)
    c = pts - (n - 1) / 2
    s = 0.6 * np.sin(1.3 * c[:, 0]) + 0.4 * c[:, 1] - 0.3 * c[:, 2] + 0.2 * (c ** 2).sum(1) / n
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zero-volume tets are dropped with a warning
        return TetMesh(pts, tets, s, name=f"delaunay_{jitter:g}_{seed}")


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("jitter", [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7])
@pytest.mark.parametrize("seed", [0, 1])
def test_jittered_delaunay(jitter, seed, device):
    m = jittered_delaunay(5, jitter, seed)
    rng = np.random.default_rng(100 + seed)
    ctr = np.full(3, 2.0)
    eye = ctr + 9.0 * rng.normal(size=3) / 1.0
    eye = ctr + 9.0 * (eye - ctr) / np.linalg.norm(eye - ctr)
    proj = "perspective" if seed == 0 else "orthographic"
    cam = Camera(projection=proj, eye=eye, target=ctr, fov_y_deg=45, ortho_height=8.0, width_px=40, height_px=40)
    check(scene(m, TF, cam), device=device)


def cap_mesh(eps: float) -> TetMesh:
    """A unit tet and a flat 'cap' on its slanted face: apex ``eps`` above the face centroid, with a
    steep scalar (the cap's gradient is ~1/eps)."""
    a = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    n = np.ones(3) / np.sqrt(3)
    apex = a[1:].mean(0) + eps * n
    pts = np.vstack([a, apex])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # at 1e-12 the cap counts as zero-volume and is dropped
        return TetMesh(pts, [[0, 1, 2, 3], [1, 2, 3, 4]], [0.0, 0.5, -0.5, 1.0, 3.0], name=f"cap_{eps:g}")


def kite_mesh(eps: float) -> TetMesh:
    """A 'kite' sliver (four nearly coplanar points, one lifted by ``eps``) between two tets above
    and two below it, with a steep scalar at the lifted point."""
    q = np.array([[-1, 0, 0], [0, -0.7, 0], [1.2, 0, 0], [0, 0.8, eps]], dtype=float)
    top, bot = np.array([0.1, 0.05, 1.0]), np.array([-0.1, 0.0, -1.0])
    pts = np.vstack([q, top, bot])
    # the sliver's diagonals: 0-2 below, 1-3 above (point 3 is lifted)
    tets = [[0, 1, 2, 3], [0, 1, 3, 4], [1, 2, 3, 4], [0, 1, 2, 5], [0, 2, 3, 5]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # at 1e-12 the sliver is dropped: a crack, so peel runs
        return TetMesh(pts, tets, [0.0, 1.0, -0.5, 2.5, 0.3, -0.8], name=f"kite_{eps:g}")


@pytest.mark.parametrize("eps", [1e-6, 1e-8, 1e-10, 1e-12])
@pytest.mark.parametrize("kind", ["cap", "kite"])
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_flat_slivers(kind, eps, projection):
    m = cap_mesh(eps) if kind == "cap" else kite_mesh(eps)
    ctr = 0.5 * (m.bounds[0] + m.bounds[1])
    eye = ctr + np.array([0.9, 1.3, 3.1]) if kind == "cap" else ctr + np.array([0.4, -0.3, 3.0])
    cam = Camera(projection=projection, eye=eye, target=ctr, fov_y_deg=40, ortho_height=2.4, width_px=32, height_px=32)
    check(scene(m, TF, cam))


def grid_scene_mesh():
    return box_mesh(dims=(5, 5, 5), scalar=lambda p: np.sin(2 * p[:, 0]) + p[:, 1] * p[:, 2])


@pytest.mark.parametrize("direction", [(0, 0, 1), (1, 1, 1), (1, 1, 0), (0.3, -1, 1)])
def test_rays_through_vertices_and_along_edges(direction):
    # orthographic: the pixel centres of a 9x9 image of height 4.5 sit on the grid's lattice lines for
    # axis views (rays run along edges through vertices); for the diagonal views the centre pixel's ray
    # runs through vertices along the Kuhn split's diagonal edges
    m = grid_scene_mesh()
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    up = [0, 1, 0] if abs(d[1]) < 0.9 else [1, 0, 0]
    cam = Camera(projection="orthographic", eye=5 * d, target=[0, 0, 0], up=up, ortho_height=4.5, width_px=9, height_px=9)
    check(scene(m, TF, cam))


def test_random_rays_through_vertices():
    # perspective, odd image size: the centre pixel's ray passes exactly through a chosen vertex
    m = grid_scene_mesh()
    rng = np.random.default_rng(5)
    for v in rng.choice(m.n_points, 4, replace=False):
        eye = m.points[v] + rng.normal(size=3) * 2 + np.array([0, 0, 4.0])
        cam = Camera(eye=eye, target=m.points[v], fov_y_deg=50, width_px=11, height_px=11)
        check(scene(m, TF, cam))


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("distance", [1e2, 1e4, 1e6])
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_distant_eye(distance, projection, device):
    m = grid_scene_mesh()
    d = np.array([0.3, 0.5, 1.0])
    d /= np.linalg.norm(d)
    size = float(np.linalg.norm(m.bounds[1] - m.bounds[0]))
    eye = d * distance * size
    fov = float(np.degrees(2 * np.arctan(0.6 * size / (distance * size))))
    cam = Camera(projection=projection, eye=eye, target=[0, 0, 0], fov_y_deg=fov, ortho_height=1.2 * size,
                 width_px=32, height_px=32)
    check(scene(m, TF, cam), device=device)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("where", ["behind", "beside"])
def test_camera_looking_away_is_transparent(projection, where):
    m = grid_scene_mesh()
    eye = np.array([0.2, 0.1, 4.0])
    target = eye + (np.array([0, 0, 1.0]) if where == "behind" else np.array([1.0, 0, 0]))
    cam = Camera(projection=projection, eye=eye, target=target, fov_y_deg=40, ortho_height=2.0, width_px=16, height_px=16)
    res, ref = check(scene(m, TF, cam), visible=False)
    assert (ref == 0).all() and (res.image == 0).all()


@pytest.mark.parametrize("eye", [[0.1, 0.05, 0.3], [0.0, 0.0, 0.0], [0.3, -0.2, 0.5]])
def test_orthographic_eye_plane_inside_mesh(eye):
    m = grid_scene_mesh()
    cam = Camera(projection="orthographic", eye=eye, target=np.add(eye, [0.2, -0.1, -1.0]), ortho_height=1.5,
                 width_px=24, height_px=24)
    res, ref = check(scene(m, TF, cam))
    assert ref[12, 12, 3] > 0.0  # the centre ray starts inside the medium


def test_perspective_eye_far_inside_large_mesh():
    m = box_mesh(lo=(-1e3, -1e3, -1e3), hi=(1e3, 1e3, 1e3), dims=(4, 4, 4),
                 scalar=lambda p: p[:, 0] * 1e-3 + 0.5 * p[:, 1] * 1e-3)
    cam = Camera(eye=[10.0, 20.0, 30.0], target=[400, 100, -900], fov_y_deg=60, width_px=16, height_px=16)
    tf = TransferFunction([[-2, 1, 0.5, 0.2, 6e-4], [2, 0.2, 0.5, 1, 1.4e-3]])
    check(scene(m, tf, cam))
