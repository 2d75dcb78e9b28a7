"""Visibility sorting (``warpvol.projection.sort``) against brute-force occlusion along exact pixel rays."""

import numpy as np
import pytest

from helpers import box_points
from warpvol.projection.sort import centroid_order, face_directions, occlusion_violations, visibility_order
from warpvol.projection.stages.sort_cells import SortCells
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.grids import structured_to_tets
from warpvol.scene.mesh import TetMesh
from warpvol.stage import Context


def jittered_box(rng, dims=(5, 5, 5), jitter=0.12, drop=0.0):
    """Kuhn-split grid over [-1, 1]^3 with interior points jittered (convex boundary); with ``drop``
    that fraction of the hex cells removed (non-convex, possibly disconnected)."""
    pts = box_points((-1, -1, -1), (1, 1, 1), dims)
    h = 2.0 / (np.array(dims) - 1)
    inner = (np.abs(pts) < 1 - 1e-9).all(axis=1)
    pts[inner] += rng.uniform(-jitter, jitter, (inner.sum(), 3)) * h
    tets = structured_to_tets(dims).reshape(-1, 6, 4)
    if drop:
        keep = rng.random(len(tets)) >= drop
        tets = tets[keep]
    return TetMesh(pts, tets.reshape(-1, 4), pts[:, 0].copy(), name="jittered")


def random_camera(rng, size=24):
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    if rng.random() < 0.5:
        return Camera(projection="orthographic", eye=4 * d, target=(0, 0, 0), up=rng.normal(size=3), ortho_height=3.6,
                      width_px=size, height_px=size)
    return Camera(eye=rng.uniform(2.2, 4.0) * d, target=rng.uniform(-0.2, 0.2, 3), up=rng.normal(size=3),
                  fov_y_deg=60.0, width_px=size, height_px=size)


def test_mpvo_exact_on_random_convex_meshes():
    rng = np.random.default_rng(7)
    acyclic = 0
    for _ in range(12):
        mesh, cam = jittered_box(rng), random_camera(rng)
        r = visibility_order(mesh, cam, "mpvo")
        assert sorted(r.order.tolist()) == list(range(mesh.n_tets))
        bad, pairs = occlusion_violations(mesh, cam, r.order)
        assert pairs > 500
        if r.cycles_broken == 0:
            acyclic += 1
            assert r.exact and bad == 0, (bad, pairs)
        else:
            assert not r.exact and "cycle" in r.note
    assert acyclic >= 10


def test_centroid_sort_is_marked_approximate_and_fails_on_stiff_cells():
    sc = builtin_scene("stiff").with_camera(width_px=24, height_px=24)
    c = centroid_order(sc.mesh, sc.camera)
    assert not c.exact
    assert occlusion_violations(sc.mesh, sc.camera, c.order)[0] > 0      # long thin cells defeat centroids
    m = visibility_order(sc.mesh, sc.camera, "mpvo")
    assert m.exact and occlusion_violations(sc.mesh, sc.camera, m.order)[0] == 0


def test_mpvonc_on_non_convex_meshes():
    rng = np.random.default_rng(3)
    worse = 0
    for _ in range(10):
        mesh, cam = jittered_box(rng, drop=0.3), random_camera(rng)
        r = visibility_order(mesh, cam, "auto")
        assert r.method == "mpvonc" and not r.exact
        bad, pairs = occlusion_violations(mesh, cam, r.order)
        cbad, _ = occlusion_violations(mesh, cam, centroid_order(mesh, cam).order)
        worse += bad > cbad
        assert bad <= 0.01 * pairs
    assert worse <= 2


def test_concave_builtin_has_no_violation():
    sc = builtin_scene("concave").with_camera(width_px=48, height_px=48)
    r = visibility_order(sc.mesh, sc.camera, "auto")
    assert r.method == "mpvonc"
    assert occlusion_violations(sc.mesh, sc.camera, r.order)[0] == 0


def test_face_directions_antisymmetric_and_cycle_counted():
    rng = np.random.default_rng(1)
    mesh, cam = jittered_box(rng), random_camera(rng)
    d = face_directions(mesh, cam)
    a, f = np.nonzero(mesh.adjacency >= 0)
    b = mesh.adjacency[a, f]
    back = np.argmax(mesh.adjacency[b] == a[:, None], axis=1)
    assert (d[a, f] == -d[b, back]).all() and (d[mesh.adjacency < 0] == 0).all()
    # three cells around one edge, constrained in a ring A -> B -> C -> A
    from warpvol.projection.sort import topological_order

    ring = TetMesh([[0, 0, 0], [0, 0, 1], [1, 0, 0.5], [-0.5, 0.9, 0.5], [-0.5, -0.9, 0.5]],
                   [[0, 1, 2, 3], [0, 1, 3, 4], [0, 1, 4, 2]], np.zeros(5))
    adj = ring.adjacency
    dirs = np.zeros((3, 4), np.int32)
    for c, n in ((0, 1), (1, 2), (2, 0)):
        dirs[c, list(adj[c]).index(n)] = 1
        dirs[n, list(adj[n]).index(c)] = -1
    order, cycles = topological_order(ring, dirs, np.array([0.0, 1.0, 2.0]))
    assert cycles == 1 and sorted(order.tolist()) == [0, 1, 2]


def test_sort_stage_counts_and_reports():
    sc = builtin_scene("box").with_camera(width_px=8, height_px=8)
    ctx = Context(scene=sc, quiet=True)
    ctx.stage_key = "sort"
    SortCells(method="auto").run(ctx)
    assert ctx.stats["sort"] == {"method": "mpvo", "exact": True, "planner": "convex boundary: MPVO"}
    assert ctx.counters["sort"]["cells_sorted"] == sc.mesh.n_tets
    assert ctx.counters["sort"]["cycles_broken"] == 0
    # axis-aligned orthographic view: faces parallel to the view direction constrain nothing
    edges = ctx.counters["sort"]["graph_edges"]
    assert edges == int((face_directions(sc.mesh, sc.camera) > 0).sum()) < int((sc.mesh.adjacency >= 0).sum() // 2)


@pytest.mark.parametrize("name, ran, skipped", [("box", "mpvo", "sort#2"), ("concave", "mpvonc", "sort")])
def test_planner_picks_mpvo_for_convex_meshes(name, ran, skipped):
    from warpvol.pipeline import Pipeline

    res = Pipeline.load("pt_vertex_color").render(builtin_scene(name).with_camera(width_px=8, height_px=8),
                                                  quiet=True)
    assert res.report["stats"]["sort"]["method"] == ran
    (sk,) = res.report["skipped"]
    assert sk["stage"] == skipped and ("convex boundary" in sk["reason"])


def test_xmpvo_no_violation_at_any_pixel():
    """Same random non-convex meshes as the MPVONC test: MPVONC misorders a few pixels, XMPVO none."""
    rng = np.random.default_rng(3)
    acyclic = mpvonc_bad = 0
    for _ in range(10):
        mesh, cam = jittered_box(rng, drop=0.3), random_camera(rng)
        r = visibility_order(mesh, cam, "xmpvo")
        assert r.method == "xmpvo" and sorted(r.order.tolist()) == list(range(mesh.n_tets))
        assert r.extra["ray_constraints"] > 0
        mpvonc_bad += occlusion_violations(mesh, cam, visibility_order(mesh, cam, "mpvonc").order)[0]
        if r.cycles_broken == 0:
            acyclic += 1
            assert r.exact and occlusion_violations(mesh, cam, r.order)[0] == 0
    assert acyclic >= 8 and mpvonc_bad > 0


def test_xmpvo_leaves_the_hull_faces_out_and_keeps_every_ray_constraint():
    """A face on the convex hull is crossed first or last along any ray, never beside a gap: leaving them
    out of XMPVO's rasterised boundary keeps the same constraints (non-convex, partly disconnected
    jittered grids with flat sides, the concave mesh; random cameras), with fewer fragments. The hull
    test matches a brute-force one (no point beyond the face's plane)."""
    from warpvol.projection.sort import HULL_TOL, boundary_ray_constraints, hull_faces
    from warpvol.scene.mesh import FACE_VERTS

    rng = np.random.default_rng(11)
    cases = [(jittered_box(rng, drop=0.3), random_camera(rng)) for _ in range(8)]
    conc = builtin_scene("concave")
    cases += [(conc.mesh, random_camera(rng, 32)) for _ in range(3)]
    fewer = 0
    for mesh, cam in cases:
        bf = mesh.boundary_faces
        tri = mesh.tets[bf[:, 0][:, None], FACE_VERTS[bf[:, 1]]]
        p = np.asarray(mesh.points, np.float64)
        n = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])
        beyond = (n @ p[np.unique(tri)].T).max(axis=1) - np.einsum("ij,ij->i", n, p[tri[:, 0]])
        diam = np.linalg.norm(p.max(axis=0) - p.min(axis=0))
        on = hull_faces(mesh)
        np.testing.assert_array_equal(on, beyond <= HULL_TOL * diam * np.linalg.norm(n, axis=1))
        assert 0 < on.sum() < len(on)
        s0, d0, f0 = boundary_ray_constraints(mesh, cam, hull=True)
        s1, d1, f1 = boundary_ray_constraints(mesh, cam, hull=False)
        assert set(zip(s0.tolist(), d0.tolist())) == set(zip(s1.tolist(), d1.tolist()))
        fewer += f1 < f0
    assert fewer == len(cases)


def test_exact_orders_from_a_queue_draw_the_priority_orders_image(monkeypatch):
    """MPVO (convex) and XMPVO take ready cells from a queue instead of the depth-priority heap: any
    topological order of an exact constraint graph draws the same image, bit for bit (the concave
    mesh by XMPVO, the sphere by MPVO); MPVONC keeps its priority (the order changes without it)."""
    import numpy as np

    import warpvol.projection.sort as S
    from test_pt_render import preset
    from warpvol.scene.builtin import builtin_scene

    orig = S.topological_order
    for name in ("concave", "sphere"):
        sc = builtin_scene(name).with_camera(width_px=48, height_px=48)
        queue = preset("pt_best").render(sc, quiet=True)
        monkeypatch.setattr(S, "topological_order", lambda *a, **k: orig(*a, **{**k, "priority": True}))
        heap = preset("pt_best").render(sc, quiet=True)
        monkeypatch.setattr(S, "topological_order", orig)
        assert np.array_equal(queue.image, heap.image), name
    sc = builtin_scene("concave").with_camera(width_px=48, height_px=48)
    dirs, key = S.face_directions(sc.mesh, sc.camera), S.centroid_keys(sc.mesh, sc.camera)
    a, _ = orig(sc.mesh, dirs, key, priority=True)
    b, _ = orig(sc.mesh, dirs, key, priority=False)
    assert sorted(a) == sorted(b) and not np.array_equal(a, b)  # both permutations, different orders


def test_depth_order_is_lexsort_by_pixel_depth_and_tie():
    """The per-pixel fragment order of XMPVO's ray constraints and HARC's entry lists: one 64-bit key and a
    stable sort give exactly np.lexsort's permutation, with ties, -0.0 / +0.0, negative depths and an
    unsorted pixel column."""
    from warpvol.gpu.raster import depth_order

    rng = np.random.default_rng(7)
    n = 20_000
    pix = np.sort(rng.integers(0, 3000, n))
    depth = rng.choice(np.array([-0.5, -0.0, 0.0, 1e-30, 0.25, 0.25, 0.7, 1.0, 2.0], np.float32), n)
    depth[::7] = rng.random(len(depth[::7])).astype(np.float32)
    tie = rng.random(n) < 0.5
    np.testing.assert_array_equal(depth_order(pix, depth), np.lexsort((depth, pix)))
    np.testing.assert_array_equal(depth_order(pix, depth, tie), np.lexsort((tie, depth, pix)))
    shuffled = rng.permutation(n)
    np.testing.assert_array_equal(depth_order(pix[shuffled], depth[shuffled], tie[shuffled]),
                                  np.lexsort((tie[shuffled], depth[shuffled], pix[shuffled])))


def test_ray_gaps_kernel_matches_a_sort_of_all_fragments():
    """``k_ray_gaps`` (per pixel, insertion sort in place) finds the exit -> entry pairs that a stable sort
    of all fragments by (pixel, depth, entry flag) finds: random lists with equal depths, -0 and +0, a
    pixel with one fragment and empty pixels."""
    import warp as wp

    from warpvol.kernels import sort as ks

    rng = np.random.default_rng(3)
    npx, nfaces = 400, 60
    counts = rng.integers(0, 9, npx)
    counts[:50] = 0
    counts[50:60] = 1
    off = np.zeros(npx + 1, np.int32)
    np.cumsum(counts, out=off[1:])
    n = int(off[-1])
    prim = rng.integers(0, nfaces, n).astype(np.int32)
    depth = rng.choice(np.array([0.1, 0.2, 0.3, -0.0, 0.0, 0.5], np.float32), n)
    depth[::7] = rng.uniform(0, 1, len(depth[::7])).astype(np.float32)
    front = rng.integers(0, 2, nfaces).astype(np.int32)
    cell = rng.integers(0, 25, nfaces).astype(np.int32)
    pix = np.repeat(np.arange(npx), counts)
    o = np.lexsort((front[prim], depth + np.float32(0.0), pix))  # stable: primitive order at full ties
    p, f = prim[o], front[prim[o]].astype(bool)
    gap = (pix[o][1:] == pix[o][:-1]) & ~f[:-1] & f[1:]
    want = sorted(zip(cell[p[1:][gap]].tolist(), cell[p[:-1][gap]].tolist()))
    src, dst = wp.empty(n, dtype=wp.int32), wp.empty(n, dtype=wp.int32)
    wp.launch(ks.k_ray_gaps, dim=npx, inputs=[wp.array(off), wp.array(prim), wp.array(depth), wp.array(front),
                                              wp.array(cell), src, dst, 0], device="cpu")
    s, d = src.numpy(), dst.numpy()
    got = sorted(zip(s[s >= 0].tolist(), d[s >= 0].tolist()))
    assert len(want) > 100
    assert got == want


def test_xmpvo_rasterises_its_whole_boundary_unless_a_best_preset_asks():
    """XMPVO as published (Silva et al. 1998, run by Guthe et al. 2002) rasterises every boundary face: the
    sort stage's default counts the fragments of the whole boundary; ``boundary = "off_hull"`` (fewer
    fragments, same constraints here) and ``visible_alone`` are options that only ``*_best`` presets turn
    on, refused for the other methods with the field named."""
    import tomllib

    from warpvol.errors import ConfigError
    from warpvol.pipeline import _preset_files
    from warpvol.projection.sort import boundary_ray_constraints

    sc = builtin_scene("concave").with_camera(width_px=32, height_px=32)
    got = {}
    for boundary in ("all", "off_hull"):
        ctx = Context(scene=sc, quiet=True)
        ctx.stage_key = "sort"
        SortCells(method="xmpvo", boundary=boundary).run(ctx)
        got[boundary] = ctx.counters["sort"]
    whole = boundary_ray_constraints(sc.mesh, sc.camera, hull=True)
    assert got["all"]["boundary_fragments"] == whole[2] == 1466
    assert got["off_hull"]["boundary_fragments"] < got["all"]["boundary_fragments"]
    assert got["off_hull"]["ray_constraints"] == got["all"]["ray_constraints"] == len(whole[0]) > 0
    for bad in ({"boundary": "off_hull"}, {"visible_alone": True}):
        with pytest.raises(ConfigError, match=f"{next(iter(bad))}: applies to method = 'xmpvo' only"):
            SortCells(method="mpvonc", **bad)
    with pytest.raises(ConfigError, match="boundary"):
        SortCells(method="xmpvo", boundary="hull")
    for name, path in _preset_files().items():
        opts = {(k, s[k]) for s in tomllib.loads(path.read_text())["stages"] if s["stage"] == "sort"
                for k in ("boundary", "visible_alone") if k in s}
        if name == "pt_best":
            assert opts == {("boundary", "off_hull"), ("visible_alone", True)}
        elif not name.endswith("_best"):
            assert not opts, name


def test_lean_sort_gives_the_published_order():
    """``lean`` (pt_best: arrays kept on the mesh, in-degrees from a kernel, XMPVO's off-hull boundary as
    (face, depth) counted and scattered per pixel) gives the published path's order, edges, ray constraints
    and fragment count: convex and non-convex jittered grids (one with a cycle), the concave mesh, orthographic
    and perspective cameras, a second frame from the arrays kept."""
    from warpvol.projection.sort import boundary_ray_constraints, lean_ray_constraints

    rng = np.random.default_rng(5)
    cases = [(jittered_box(rng, drop=0.3), random_camera(rng, 48)) for _ in range(6)]
    cases += [(jittered_box(rng), random_camera(rng, 48)) for _ in range(2)]
    conc = builtin_scene("concave")
    cases += [(conc.mesh, random_camera(rng, 64)) for _ in range(2)]
    cycles = 0
    for mesh, cam in cases:
        for method in ("xmpvo", "mpvo" if mesh.is_convex else "xmpvo"):
            off_hull = method == "xmpvo"
            for _ in range(2):  # the second frame reads the arrays kept on the mesh
                a = visibility_order(mesh, cam, method, off_hull=off_hull)
                b = visibility_order(mesh, cam, method, off_hull=off_hull, lean=True)
                np.testing.assert_array_equal(a.order, b.order)
                assert (a.edges, a.extra, a.cycles_broken, a.exact) == (b.edges, b.extra, b.cycles_broken, b.exact)
            cycles += a.cycles_broken > 0
        s0, d0, f0 = boundary_ray_constraints(mesh, cam, hull=False)
        s1, d1, f1 = lean_ray_constraints(mesh, cam)
        np.testing.assert_array_equal(s0, s1)
        np.testing.assert_array_equal(d0, d1)
        assert f0 == f1
    assert cycles >= 1


def test_ray_gaps_listed_matches_ray_gaps_on_lists_in_face_order():
    """``k_ray_gaps_listed`` (the listed pixels, lists in any order, sorted by depth, exit before entry, face)
    finds the pairs ``k_ray_gaps`` finds on the same lists in face order, with equal depths, -0 and +0 and
    shuffled lists."""
    import warp as wp

    from warpvol.kernels import sort as ks

    rng = np.random.default_rng(4)
    npx, nfaces = 400, 60
    counts = rng.integers(0, 9, npx)
    off = np.zeros(npx + 1, np.int32)
    np.cumsum(counts, out=off[1:])
    n = int(off[-1])
    prim = rng.integers(0, nfaces, n).astype(np.int32)
    depth = rng.choice(np.array([0.1, 0.2, -0.0, 0.0, 0.5], np.float32), n)
    front = rng.integers(0, 2, nfaces).astype(np.int32)
    cell = rng.integers(0, 25, nfaces).astype(np.int32)
    pix = np.repeat(np.arange(npx), counts)
    ordered = np.lexsort((prim, pix))  # face order within each pixel
    shuffled = np.lexsort((rng.random(n), pix))
    src, dst = wp.empty(n, dtype=wp.int32), wp.empty(n, dtype=wp.int32)
    wp.launch(ks.k_ray_gaps, dim=npx, inputs=[wp.array(off), wp.array(prim[ordered]), wp.array(depth[ordered]),
                                              wp.array(front), wp.array(cell), src, dst, 0], device="cpu")
    s, d = src.numpy(), dst.numpy()
    want = sorted(zip(s[s >= 0].tolist(), d[s >= 0].tolist()))
    listed = np.flatnonzero(counts > 1).astype(np.int32)
    src, dst, k = wp.empty(n, dtype=wp.int32), wp.empty(n, dtype=wp.int32), wp.zeros(1, dtype=wp.int32)
    wp.launch(ks.k_ray_gaps_listed, dim=len(listed),
              inputs=[wp.array(listed), wp.array(off), wp.array(prim[shuffled]), wp.array(depth[shuffled]),
                      wp.array(front), wp.array(cell), k, src, dst], device="cpu")
    k = int(k.numpy()[0])
    assert len(want) > 100 and sorted(zip(src.numpy()[:k].tolist(), dst.numpy()[:k].tolist())) == want


@pytest.mark.parametrize("name", ["concave", "sphere", "stress:eye_in_diagonal_face_plane", "stress:pixel_centres_on_boundary_faces",
                                  "stress:face_edge_on", "stress:ray_along_shared_edge",
                                  "stress:topology_touching_parts", "stress:slivers"])
def test_pt_best_draws_the_same_bits_with_the_lean_sort(name):
    """pt_best with ``sort.lean`` on and off: the same image bits and counters (built-in scenes, stress classes;
    the concave one also with a sparse TF, where the visible cells are sorted alone)."""
    from warpvol.pipeline import Pipeline
    from warpvol.scene.transfer import TransferFunction
    from warpvol.tools.stress import build_case
    from warpvol.tools.sweep import pipeline_config

    scenes = []
    if name.startswith("stress:"):
        scenes.append(build_case(name[7:], quick=True).scene)
    else:
        scenes.append(builtin_scene(name).with_camera(width_px=40, height_px=40))
    if name == "concave":
        sc = builtin_scene(name).with_camera(width_px=40, height_px=40)
        s = np.asarray(sc.mesh.scalars, np.float64)
        mid = float(np.median(s))
        sc.transfer = TransferFunction([[s.min() - 1, 1, 0.5, 0.2, 0], [mid - 0.05, 1, 0.5, 0.2, 0],
                                        [mid, 1, 0.5, 0.2, 8.0], [mid + 0.05, 1, 0.5, 0.2, 0],
                                        [s.max() + 1, 1, 0.5, 0.2, 0]])
        scenes.append(sc)
    for sc in scenes:
        sc.camera = sc.camera.replace(width_px=min(sc.camera.width_px, 48), height_px=min(sc.camera.height_px, 48))
        res = [Pipeline.from_config(pipeline_config("pt_best", (("sort.lean", lean),))).render(sc, quiet=True)
               for lean in (False, True)]
        assert np.array_equal(res[0].image.view(np.uint32), res[1].image.view(np.uint32)), sc.name
        assert res[0].report["counters"] == res[1].report["counters"]
        assert res[0].report["stats"].get("sort") == res[1].report["stats"].get("sort")
