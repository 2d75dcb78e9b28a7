"""``harc_best``'s ray start where the rasterised boundary leaves out a face a pixel's ray crosses.

Generated scenes of many small, thin and disconnected parts on pixel rays (:mod:`warpvol.tools.stress_subpixel`):
needles a few thousandths of a pixel wide, specks of a thousandth of a pixel, slabs 1e-9 and 1e-6 thick
seen edge-on, a block whose silhouette the snapping moves onto pixel centres with a deeper block listed
behind. Each render is held to the reference within ``harc_best``'s tolerance row, and the ray start must
have found entries the rasterised lists left out. :func:`warpvol.shared.thin_cells.edge_pixels` is checked
against a brute-force distance test.
"""

import numpy as np
import pytest

from tolerances import preset_tolerance
from warpvol.metrics import image_error
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.tools.stress_subpixel import silhouette_scene, subpixel_scene

CASES = {
    "needle_2e-3_ortho_s0": lambda: subpixel_scene("needle", 2e-3, seed=0),
    "needle_2e-3_ortho_s1": lambda: subpixel_scene("needle", 2e-3, seed=1),
    "needle_4e-3_ortho_s2_px32": lambda: subpixel_scene("needle", 4e-3, n=30, px=32, seed=2),
    "speck_1e-3_ortho_s0": lambda: subpixel_scene("speck", 1e-3, seed=0),
    "speck_1e-3_persp_s1": lambda: subpixel_scene("speck", 1e-3, seed=1, perspective=True),
    "slab_1e-9_ortho_s0": lambda: subpixel_scene("slab", 1e-9, n=1, seed=0, block=False),
    "slab_1e-6_ortho_s1": lambda: subpixel_scene("slab", 1e-6, n=1, seed=1, block=False),
    "silhouette_px16": lambda: silhouette_scene(16, 1e-6),
    "silhouette_px32": lambda: silhouette_scene(32, 1e-7),
    "silhouette_px96": lambda: silhouette_scene(96, 1e-6),  # a ray past the corner: a face without an open edge
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_harc_best_enters_faces_the_rasteriser_left_out(case):
    sc = CASES[case]()
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    assert ref[..., 3].max() > 0.5  # the parts are in the image
    res = Pipeline.load("harc_best").render(sc, quiet=True)
    err = image_error(res.image, ref)
    tol = preset_tolerance("harc_best")
    assert err["max_abs"] <= tol["max_abs"] and err["rmse"] <= tol["rmse"], (case, err)
    stats = res.report["stats"]
    found = stats["harc"]["edge_entries"] + stats.get("harc_peel", {}).get("edge_entries", 0)
    # the rasterised lists alone missed these entries: found by the exact test at open edges, or the rays were
    # traced in float64 from the start (cells too thin for the float32 walk)
    assert found > 0 or stats["harc"]["thin_cell_rays"] > 0, stats["harc"]
    if case.startswith("silhouette"):
        assert found > 0


def test_edge_pixels_are_the_centres_near_open_edges():
    from warpvol.shared.entry_bins import entry_face_mask, window_xy
    from warpvol.shared.thin_cells import EDGE_PX, edge_pixels, surface_neighbours

    sc = subpixel_scene("needle", 0.3, n=6, px=16, seed=3, block=False)
    mesh, cam = sc.mesh, sc.camera
    tris = mesh.boundary_triangles()[entry_face_mask(mesh, cam)]
    nbr = surface_neighbours(tris)
    start, face = edge_pixels(mesh, cam, tris, nbr, delta=0.4)  # wide: many pairs to compare
    got = {(p, int(f)) for p in range(len(start) - 1) for f in face[start[p]:start[p + 1]]}
    wx, wy, _, _ = window_xy(cam, mesh.points[tris.reshape(-1)])
    win = np.stack([wx, wy], -1).reshape(-1, 3, 2)
    cy, cx = np.mgrid[0:16, 0:16] + 0.5
    want = set()
    for b in range(len(tris)):  # every edge of a needle's front faces is open: the needle is its own part
        for k in range(3):
            if nbr[b, k] >= 0:
                continue
            a, e = win[b, (k + 1) % 3], win[b, (k + 2) % 3]
            d = e - a
            s = np.clip(((cx - a[0]) * d[0] + (cy - a[1]) * d[1]) / (d @ d), 0, 1)
            dist = np.hypot(cx - a[0] - s * d[0], cy - a[1] - s * d[1])
            want |= {(int(p), b) for p in np.flatnonzero(dist.reshape(-1) <= 0.4)}
    assert want and got == want
    assert EDGE_PX < 0.4


def test_edge_pixels_with_open_edges_behind_the_eye():
    # perspective eye 1e-4 outside the boundary, 120 degree field of view: open edges reaching behind the eye
    # are clipped to its front half-space (their ends with them)
    from warpvol.raycasting.harc import entry_fragments
    from warpvol.tools.stress import build_case

    sc = build_case("near_plane_cuts_cells", quick=True).scene
    e = entry_fragments(sc.mesh, sc.camera)
    assert e["edge_start"].shape[0] == sc.camera.width_px * sc.camera.height_px + 1
