"""Projected tetrahedra: decomposition coverage (exact, on the emulated rasteriser) and renders."""

from pathlib import Path

import numpy as np
import pytest

from helpers import DEVICES
from test_sort import jittered_box, random_camera
from tolerances import preset_tolerance
from warpvol.gpu.raster import Rasterizer
from warpvol.gpu.vertex import VertexStage
from warpvol.projection.pt import RASTER_RULES, decompose
from warpvol.projection.sort import visibility_order
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import FACE_VERTS


def pixel_tet_pairs(frags, tet_of_prim):
    """Sorted (pixel, tet) keys of a fragment list."""
    pix = frags.pixel_index()
    tet = tet_of_prim[frags.prim.numpy()[:frags.count]]
    return np.sort(pix.astype(np.int64) * (int(tet_of_prim.max()) + 1) + tet)


def coverage_pairs(mesh, cam, device="cpu", walk="pixel"):
    """(PT fragments, front-face fragments) as sorted (pixel, tet) keys, and the geometry; the PT
    fragments from the rasteriser's ``walk`` (the front faces always from the emulated pixel walk)."""
    vs = VertexStage.from_camera(cam, *cam.depth_range(*mesh.bounds), device=device)
    vt = vs.transform(mesh.points)
    order = visibility_order(mesh, cam, "centroid").order
    geo = decompose(mesh, vt, order, device=device)
    r = Rasterizer(cam.width_px, cam.height_px, device=device, **RASTER_RULES)
    pt = pixel_tet_pairs(r.fragments(geo.positions, geo.tris, walk=walk), np.repeat(order, 4))
    # independent: every tet's front faces tile its projection exactly once (same snapped vertices)
    faces = mesh.tets[:, FACE_VERTS].reshape(-1, 3)
    rf = Rasterizer(cam.width_px, cam.height_px, device=device, cull="back", **RASTER_RULES)
    ff = pixel_tet_pairs(rf.fragments(vt.window_array, faces), np.repeat(np.arange(mesh.n_tets), 4))
    return pt, ff, geo


def degenerate_views(size=20):
    """Views along grid axes and diagonals: vertices project onto edges and other vertices, tets
    project to triangles and segments."""
    out = []
    for d in ([0, 0, 1], [1, 0, 0], [1, 1, 0], [1, 1, 1], [1, -1, 0]):
        d = np.asarray(d, float) / np.linalg.norm(d)
        up = [0, 1, 0] if abs(d[1]) < 0.9 else [1, 0, 0]
        out.append(Camera(projection="orthographic", eye=4 * d, target=(0, 0, 0), up=up, ortho_height=2.9,
                          width_px=size, height_px=size))
        out.append(Camera(eye=3.5 * d, target=(0, 0, 0), up=up, fov_y_deg=50, width_px=size, height_px=size))
    return out


@pytest.mark.parametrize("device", DEVICES)
def test_one_fragment_per_tet_and_pixel_random_views(device):
    rng = np.random.default_rng(11)
    for _ in range(6):
        mesh, cam = jittered_box(rng, dims=(4, 4, 4), jitter=0.2), random_camera(rng, size=32)
        pt, ff, geo = coverage_pairs(mesh, cam, device)
        assert len(ff) > 1000
        assert np.array_equal(pt, ff)          # no crack, no double fragment
        assert geo.classes["four_triangle"] > 0 and geo.classes["three_triangle"] > 0


@pytest.mark.parametrize("walk", ["pixel", "triangle"])
def test_one_fragment_per_tet_and_pixel_degenerate_views(walk):
    """Both fragment walks (``triangle``: pt_best's) give every (pixel, tet) pair exactly one fragment."""
    from helpers import box_mesh

    mesh = box_mesh(dims=(4, 4, 4))
    seen = {"three_triangle": 0, "flat": 0, "four_triangle": 0, "vertex_on_edge": 0, "vertex_on_vertex": 0}
    for cam in degenerate_views():
        pt, ff, geo = coverage_pairs(mesh, cam, walk=walk)
        assert len(ff) > 100 and np.array_equal(pt, ff)
        for k in seen:
            seen[k] += geo.classes[k]
    # 2e-5 thin layers seen edge-on snap to segments: flat projections
    sc = builtin_scene("stiff")
    for cam in (Camera(projection="orthographic", eye=(4, 0.3, 0), target=(0, 0.3, 0), ortho_height=2.5, width_px=24,
                       height_px=24), Camera(eye=(3, 0.2, 0.05), target=(0, 0, 0), fov_y_deg=50, width_px=24, height_px=24)):
        pt, ff, geo = coverage_pairs(sc.mesh, cam, walk=walk)
        assert len(ff) > 100 and np.array_equal(pt, ff)
        for k in seen:
            seen[k] += geo.classes[k]
    assert all(v > 0 for v in seen.values()), seen    # the degenerate classes were exercised


def test_non_convex_coverage_and_layers():
    sc = builtin_scene("concave").with_camera(width_px=40, height_px=40)
    pt, ff, _ = coverage_pairs(sc.mesh, sc.camera)
    assert np.array_equal(pt, ff)
    # per pixel, each tet at most once
    assert len(np.unique(pt)) == len(pt)


DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


@pytest.mark.skipif(not DATA.is_dir(), reason=f"reference data folder {DATA} not present")
def test_bluntfin_coverage_exact_with_moved_thick_vertices():
    """Real data: 224,759 tets at 96^2 (seen: 431 thick vertices moved off slivers, 3 flat projections);
    every (pixel, tet) pair still gets exactly one fragment."""
    import warnings

    from warpvol.scene.scene_file import load_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = load_scene(Path(__file__).resolve().parents[1] / "scenes" / "bluntfin.toml")
    pt, ff, geo = coverage_pairs(sc.mesh, sc.camera.replace(width_px=96, height_px=96))
    assert len(ff) > 100_000 and np.array_equal(pt, ff)
    assert geo.moved > 0 and geo.classes["flat"] > 0


@pytest.mark.skipif(not DATA.is_dir(), reason=f"reference data folder {DATA} not present")
def test_pt_best_on_bluntfin_at_256_keeps_its_tolerance():
    """Real data at 256^2: pixel centres the snapped coverage takes past an unsnapped sliver edge take
    the triangle's nearest point's attributes (seen: max abs 7.5e-4; 5.4e-3 with the planes extrapolated)."""
    import warnings

    from warpvol.pipeline import Pipeline
    from warpvol.reference.numpy_render import render_reference
    from warpvol.scene.scene_file import load_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = load_scene(Path(__file__).resolve().parents[1] / "scenes" / "bluntfin.toml")
    sc = sc.with_camera(width_px=256, height_px=256)
    res = Pipeline.load("pt_best").render(sc, reference=render_reference(sc.mesh, sc.transfer, sc.camera), quiet=True)
    e, tol = res.report["error"], preset_tolerance("pt_best")
    assert e["max_abs"] <= tol["max_abs"] and e["rmse"] <= tol["rmse"], e
