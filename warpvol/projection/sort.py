"""Visibility sorting of tetrahedra for cell projection (host stages; plain functions tests call).

Three orders, all *back to front* (draw ``order[0]`` first):

* **centroid** ("numeric") sort: cells by decreasing distance of their centroid from the eye, or
  along the view direction. Approximate for every mesh (a large cell behind a small one can have the
  nearer centroid); it is what Guthe et al.'s Table 5 calls numeric sorting.
* **MPVO** (Williams 1992): each interior face is a directed edge of the face-adjacency graph, from
  the cell on the side away from the eye to the cell on the eye's side (perspective: the side of the
  face's plane the eye point lies on; orthographic: the sign of the face normal against the view
  direction). A topological sort of this graph is a visibility order for convex meshes whose graph is
  acyclic (e.g. Delaunay meshes). Faces whose plane contains the eye give no edge.
* **MPVONC** (Williams' extension for non-convex meshes): the same graph, sorted so that among the
  cells whose predecessors are all drawn the farthest (largest centroid key) goes first. Cells that
  see each other across empty space (a concavity or a gap) have no edge between them; the depth
  priority orders them heuristically, so the order is *approximate* for non-convex meshes.

* **XMPVO** (Silva, Mitchell & Williams 1998): MPVO's graph plus ordering constraints between
  boundary faces that are consecutive along the pixel rays, found with the emulated rasteriser: all
  boundary faces are rasterised into fragment lists; along each pixel's ray, a back-facing boundary
  face (the ray leaves the mesh) followed by a front-facing one (it re-enters) makes the re-entered
  cell precede the left one. Exact at the pixel centres of the camera for any mesh whose visibility
  relation is acyclic. As published, the whole boundary is rasterised; ``off_hull=True`` (``pt_best``)
  leaves out the faces on the mesh's convex hull (:func:`hull_faces`, per mesh), which cannot be either
  side of such a pair: fewer fragments, the same constraints but where a float32 depth tie at a hull
  face made one.

Cycles (possible in non-Delaunay meshes) are detected by the sort running out of ready cells: the
farthest remaining cell is drawn next, the break is counted (``cycles_broken``) and the order is
marked approximate. The topological sort runs as one Warp thread on the CPU with a binary heap
(:mod:`warpvol.kernels.sort`); the face directions are vectorised NumPy in float64 with the origin
moved to the mesh centre.

Example
-------
>>> from warpvol.scene.builtin import builtin_scene
>>> sc = builtin_scene("box")
>>> r = visibility_order(sc.mesh, sc.camera, "mpvo")
>>> r.order.shape[0] == sc.mesh.n_tets, r.exact, r.cycles_broken
(True, True, 0)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from warpvol.errors import ConfigError, check_choice
from warpvol.gpu.raster import Rasterizer, Triangles
from warpvol.gpu.vertex import VertexStage
from warpvol.parallel import blocks, launch_blocks, preload
from warpvol.projection.pt import RASTER_RULES
from warpvol.projection.pt_thin import project_points
from warpvol.reference.numpy_render import trace_segments
from warpvol.scene.mesh import FACE_VERTS

METHODS = ("centroid", "mpvo", "mpvonc", "xmpvo", "auto")
METRICS = ("distance", "view")


@dataclass
class SortResult:
    """A back-to-front order of the cells and what is known about it.

    ``order`` (M,) int32 cell indices, back to front; ``method`` the method run; ``exact`` whether
    the order is a visibility order by construction (MPVO on a convex mesh without cycles);
    ``cycles_broken`` how many times a cycle was broken; ``edges`` constraints used (graph methods);
    ``note`` why the order is approximate (empty when exact).
    """

    order: np.ndarray
    method: str
    exact: bool
    cycles_broken: int = 0
    edges: int = 0
    note: str = ""
    extra: dict = field(default_factory=dict)


def _frame(mesh, camera):
    """Origin (mesh centre), eye relative to it, unit view direction, perspective flag (``camera`` None:
    the origin alone)."""
    lo, hi = mesh.bounds
    origin = 0.5 * (lo + hi)
    if camera is None:
        return origin, None, None, None
    return origin, np.asarray(camera.eye, np.float64) - origin, np.asarray(camera.forward, np.float64), \
        camera.projection == "perspective"


def centroid_keys(mesh, camera, metric: str = "distance") -> np.ndarray:
    """Depth key per cell (float64, larger = farther): squared distance of the centroid from the eye
    (``distance``) or its depth along the view direction (``view``; the only choice for orthographic)."""
    metric = check_choice("metric", metric, METRICS)
    origin, eye, fwd, persp = _frame(mesh, camera)
    c = centroids(mesh)
    if metric == "distance" and persp:
        d = c - eye
        return np.einsum("ij,ij->i", d, d)
    return (c - eye) @ fwd


def centroids(mesh) -> np.ndarray:
    """(M, 3) float64 cell centroids relative to the mesh centre (:func:`_frame`'s origin), kept on the mesh."""
    c = mesh.__dict__.get("_sort_centroids")
    if c is None:
        p, t = mesh.points - _frame(mesh, None)[0], mesh.tets
        c = mesh.__dict__["_sort_centroids"] = 0.25 * (p[t[:, 0]] + p[t[:, 1]] + p[t[:, 2]] + p[t[:, 3]])
    return c


def centroid_order(mesh, camera, metric: str = "distance") -> SortResult:
    """Numeric sort: cells by decreasing centroid key (stable, ties by index)."""
    order = cells_by_key(centroid_keys(mesh, camera, metric))
    return SortResult(order, "centroid", False, note="centroid (numeric) sort is approximate")


def face_directions(mesh, camera) -> np.ndarray:
    """(M, 4) int32 ``dirs``: +1 where the cell is drawn before its neighbour across local face i
    (the eye is on the neighbour's side), -1 where after, 0 on boundary faces and faces whose plane
    contains the eye. Each shared face is decided once (float64, one Warp thread per cell on the
    CPU, :func:`warpvol.kernels.sort.k_face_directions`), so both sides always agree."""
    import warp as wp

    from warpvol.kernels import sort as ks

    origin, eye, fwd, persp = _frame(mesh, camera)
    dev = "cpu"
    dirs = wp.zeros(mesh.adjacency.shape, dtype=wp.int32, device=dev)
    wp.launch(ks.k_face_directions, dim=mesh.n_tets,
              inputs=[wp.array(mesh.points - origin, dtype=wp.vec3d, device=dev),
                      wp.array(mesh.tets.astype(np.int32), dtype=wp.int32, device=dev),
                      wp.array(mesh.adjacency, dtype=wp.int32, device=dev),
                      wp.array(FACE_VERTS.astype(np.int32), dtype=wp.int32, device=dev),
                      wp.vec3d(*eye), wp.vec3d(*fwd), int(persp), dirs], device=dev)
    return dirs.numpy()


def kernel_arrays(mesh) -> dict:
    """The mesh's arrays the lean per-frame sort (``lean=True``) reads, as Warp arrays on the CPU, built once
    per mesh and kept on it (they depend on the mesh alone): points relative to the mesh centre (float64),
    cells, adjacency, the local faces' points."""
    got = mesh.__dict__.get("_sort_kernel_arrays")
    if got is None:
        import warp as wp

        dev = "cpu"
        got = {"points": wp.array(mesh.points - _frame(mesh, None)[0], dtype=wp.vec3d, device=dev),
               "tets": wp.array(mesh.tets.astype(np.int32), dtype=wp.int32, device=dev),
               "adj": wp.array(np.asarray(mesh.adjacency, np.int32), dtype=wp.int32, device=dev),
               "face_verts": wp.array(FACE_VERTS.astype(np.int32), dtype=wp.int32, device=dev),
               "no_key": wp.zeros(mesh.n_tets, dtype=wp.float64, device=dev)}
        mesh.__dict__["_sort_kernel_arrays"] = got
    return got


def lean_arrays_kept(mesh, off_hull: bool) -> bool:
    """Whether the lean sort's per-mesh arrays (:func:`kernel_arrays`, with ``off_hull``
    :func:`off_hull_boundary`) are kept on ``mesh`` (else :func:`keep_lean_arrays` builds them: set-up)."""
    return "_sort_kernel_arrays" in vars(mesh) and (not off_hull or "_sort_off_hull" in vars(mesh))


def keep_lean_arrays(mesh, off_hull: bool) -> None:
    """Build and keep the lean sort's per-mesh arrays (:func:`lean_arrays_kept`)."""
    kernel_arrays(mesh)
    if off_hull:
        off_hull_boundary(mesh)


def lean_face_directions(mesh, camera):
    """:func:`face_directions` as Warp arrays ``(dirs, indeg)`` from the mesh's kept arrays
    (:func:`kernel_arrays`), with each cell's in-degree (faces with ``dirs < 0``) counted by a kernel: no
    per-frame copies of the mesh, no NumPy pass over the cells. The same directions."""
    import warp as wp

    from warpvol.kernels import sort as ks

    _, eye, fwd, persp = _frame(mesh, camera)
    a, dev = kernel_arrays(mesh), "cpu"
    dirs = wp.zeros(a["adj"].shape, dtype=wp.int32, device=dev)
    wp.launch(ks.k_face_directions, dim=mesh.n_tets,
              inputs=[a["points"], a["tets"], a["adj"], a["face_verts"], wp.vec3d(*eye), wp.vec3d(*fwd), int(persp),
                      dirs], device=dev)
    indeg = wp.empty(mesh.n_tets, dtype=wp.int32, device=dev)
    wp.launch(ks.k_indegree, dim=mesh.n_tets, inputs=[dirs, indeg], device=dev)
    return dirs, indeg


def lean_topological_order(mesh, camera, dirs, indeg, extra: tuple[np.ndarray, np.ndarray] | None,
                           metric: str = "distance") -> tuple[np.ndarray, int, int]:
    """:func:`topological_order` with ``priority=False`` on :func:`lean_face_directions`' arrays: the
    same order (a queue in the same cell and edge order) without per-frame copies of the mesh's arrays;
    the depth keys are computed only where the sort meets a cycle. Returns ``(order, cycles_broken,
    face edges)``; ``extra`` ``(src, dst)`` sorted by ``src`` then ``dst`` (as
    :func:`boundary_ray_constraints` returns them)."""
    import warp as wp

    from warpvol.kernels import sort as ks

    m, dev, a = mesh.n_tets, "cpu", kernel_arrays(mesh)
    ind = indeg.numpy()  # a view of the Warp array (CPU): changed in place
    face_edges = int(ind.sum(dtype=np.int64))
    src, dst = (np.zeros(0, np.int64), np.zeros(0, np.int64)) if extra is None else extra
    off = np.zeros(m + 1, np.int32)
    if len(src):
        np.add.at(ind, dst, 1)
        np.cumsum(np.bincount(src, minlength=m), out=off[1:])
    graph = [a["adj"], dirs, wp.array(off, dtype=wp.int32, device=dev),
             wp.array(np.append(dst, 0).astype(np.int32), dtype=wp.int32, device=dev)]
    ind0 = ind.copy()  # the in-degrees again where a cycle makes the sort run twice
    by_key = wp.zeros(1, dtype=wp.int32, device=dev)
    key = a["no_key"]
    for _ in range(2):
        order = wp.empty(m, dtype=wp.int32, device=dev)
        stats = wp.zeros(2, dtype=wp.int32, device=dev)
        wp.launch(ks.k_priority_topo, dim=1,
                  inputs=[*graph, key, by_key, indeg, wp.empty(m, dtype=wp.int32, device=dev),
                          wp.zeros(m, dtype=wp.int32, device=dev), order, stats, 1], device=dev)
        st = stats.numpy()
        if not st[1]:
            break
        key_np = centroid_keys(mesh, camera, metric)  # a cycle: broken at the farthest remaining cell
        key = wp.array(key_np, dtype=wp.float64, device=dev)
        by_key = wp.array(cells_by_key(key_np), dtype=wp.int32, device=dev)
        indeg = wp.array(ind0, dtype=wp.int32, device=dev)
    return order.numpy(), int(st[0]), face_edges


def cells_by_key(key: np.ndarray) -> np.ndarray:
    """Cells by decreasing depth key (stable): where :func:`topological_order` breaks a cycle."""
    return np.argsort(-key, kind="stable").astype(np.int32)


def topological_order(mesh, dirs: np.ndarray, key: np.ndarray,
                      extra: tuple[np.ndarray, np.ndarray] | None = None, priority: bool = True,
                      by_key: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Priority topological sort of the face graph (one Warp thread on the CPU) with optional extra
    edges ``extra = (src, dst)`` (``src`` drawn before ``dst``); returns ``(order, cycles_broken)``.
    ``priority=False``: ready cells in the order they became ready (a queue; for exact orders, where
    any topological order draws the same image); cycles are broken at the farthest cell either way
    (``by_key``: :func:`cells_by_key`, when the caller has it; else sorted if the first run meets a cycle,
    which then runs again)."""
    import warp as wp

    from warpvol.kernels import sort as ks

    m = mesh.n_tets
    dev = "cpu"
    indeg = (dirs < 0).sum(axis=1).astype(np.int32)
    src, dst = (np.zeros(0, np.int64), np.zeros(0, np.int64)) if extra is None else extra
    indeg += np.bincount(dst, minlength=m).astype(np.int32)
    o = np.argsort(src, kind="stable")
    off = np.zeros(m + 1, np.int32)
    np.cumsum(np.bincount(src, minlength=m), out=off[1:])
    graph = [wp.array(mesh.adjacency, dtype=wp.int32, device=dev), wp.array(dirs, dtype=wp.int32, device=dev),
             wp.array(off, dtype=wp.int32, device=dev),
             wp.array(np.append(dst[o], 0).astype(np.int32), dtype=wp.int32, device=dev),
             wp.array(key.astype(np.float64), dtype=wp.float64, device=dev)]
    known = by_key is not None
    if not known:
        by_key = np.zeros(1, np.int32)  # cells by key: only to break a cycle, sorted when the first run meets one
    for _ in range(1 if known else 2):
        order = wp.zeros(m, dtype=wp.int32, device=dev)
        stats = wp.zeros(2, dtype=wp.int32, device=dev)
        wp.launch(ks.k_priority_topo, dim=1,
                  inputs=[*graph, wp.array(by_key, dtype=wp.int32, device=dev), wp.array(indeg, dtype=wp.int32, device=dev),
                          wp.zeros(m, dtype=wp.int32, device=dev), wp.zeros(m, dtype=wp.int32, device=dev), order, stats,
                          0 if priority else 1],
                  device=dev)
        st = stats.numpy()
        if known or not st[1]:
            break
        by_key = cells_by_key(key)
    return order.numpy(), int(st[0])


#: a boundary face is on the hull when no point of the mesh lies farther than this fraction of the
#: mesh's diameter beyond its plane (flat sides of many coplanar faces count as hull)
HULL_TOL = 1e-9
HULL_BLOCK = 64  # boundary points per block of :func:`hull_faces`' bounding-box test


def hull_faces(mesh) -> np.ndarray:
    """Bool per row of ``mesh.boundary_faces``: the face's plane supports the mesh (no point beyond it, to
    :data:`HULL_TOL` of the diameter), so a pixel ray crosses it first (entering) or last (leaving) and
    never beside a gap: XMPVO need not rasterise it. Per mesh, kept on it (``missing`` when asked with
    ``cached_only`` and not computed yet).

    The boundary points (the hull's vertices are among them) are grouped in blocks of
    :data:`HULL_BLOCK` in a spatial order; a face is tested against one point per block first (most faces
    off the hull fail there), then against the blocks whose bounding box reaches beyond its plane, point
    by point."""
    cache = mesh.__dict__.get("_hull_faces")
    if cache is not None:
        return cache

    bf = mesh.boundary_faces
    pts = np.asarray(mesh.points, np.float64)
    tri = mesh.tets[bf[:, 0][:, None], FACE_VERTS[bf[:, 1]]]
    n = np.cross(pts[tri[:, 1]] - pts[tri[:, 0]], pts[tri[:, 2]] - pts[tri[:, 0]])  # outward
    bp = pts[np.unique(tri)] if len(tri) else np.zeros((1, 3))
    lo, hi = bp.min(axis=0), bp.max(axis=0)
    lim = np.einsum("ij,ij->i", n, pts[tri[:, 0]]) + HULL_TOL * float(np.linalg.norm(hi - lo)) * np.linalg.norm(n, axis=1)
    cell = np.floor((bp - lo) / np.maximum((hi - lo) / 16.0, 1e-300)).clip(0, 15).astype(np.int64)
    bp = bp[np.argsort((cell[:, 0] * 16 + cell[:, 1]) * 16 + cell[:, 2], kind="stable")]
    nb = -(-len(bp) // HULL_BLOCK)
    blk = np.concatenate([bp, np.repeat(bp[-1:], nb * HULL_BLOCK - len(bp), axis=0)]).reshape(nb, HULL_BLOCK, 3)
    centre, half = 0.5 * (blk.max(axis=1) + blk.min(axis=1)), 0.5 * (blk.max(axis=1) - blk.min(axis=1))
    on = np.zeros(len(tri), dtype=bool)
    for f0 in range(0, len(tri), 1024):
        f = np.arange(f0, min(f0 + 1024, len(tri)))
        f = f[(n[f] @ blk[:, 0].T <= lim[f, None]).all(axis=1)]  # one point per block
        reach = n[f] @ centre.T + np.abs(n[f]) @ half.T > lim[f, None]
        fi, bi = np.nonzero(reach)
        beyond = (np.einsum("pk,pjk->pj", n[f][fi], blk[bi]) > lim[f][fi, None]).any(axis=1)
        ok = np.ones(len(f), dtype=bool)
        ok[fi[beyond]] = False
        on[f[ok]] = True
    mesh.__dict__["_hull_faces"] = on
    return on


def visible_submesh(mesh, visible: np.ndarray, cached_only: bool = False, off_hull: bool = True):
    """``(sub, cells)``: the cells ``visible`` (bool per tet) as a mesh of their own (the same points; its
    adjacency, boundary, centroids and (``off_hull``) hull faces built) and their indices in ``mesh``, kept on
    the mesh for the last visible set (per transfer function: set-up); ``cached_only``: ``None`` when not kept yet.
    ``sub`` is ``None`` where the cells do not make a mesh of their own cell for cell.

    XMPVO on ``sub`` orders the visible cells exactly at the pixel centres wherever its relation is
    acyclic: along a ray two consecutive visible cells share a face (an MPVO edge of ``sub``) or are apart
    (a gap of ``sub``'s boundary along that ray: a ray constraint)."""
    key = np.packbits(visible).tobytes()
    cache = mesh.__dict__.setdefault("_visible_submesh", {})
    if key not in cache:
        if cached_only:
            return None
        from warpvol.scene.mesh import TetMesh

        cells = np.flatnonzero(visible)
        sub = TetMesh(mesh.points, np.asarray(mesh.tets)[cells], mesh.scalars, name=f"{mesh.name} (visible cells)")
        if sub.n_tets == len(cells) and np.array_equal(sub.tets, np.asarray(mesh.tets)[cells]):
            _ = (sub.adjacency, sub.boundary_faces, centroids(sub), off_hull and hull_faces(sub))
        else:  # pragma: no cover - a mesh's own cells never change on the way
            sub = None
        cache.clear()
        cache[key] = (sub, cells)
    return cache[key]


def xmpvo_cost(mesh, camera, off_hull: bool = True, proj=None) -> float:
    """XMPVO's work on ``mesh`` for ``camera`` in fragment units: the projected area in pixels of the
    boundary faces it rasterises (``off_hull``: those off the hull; else all; faces beyond the image
    counted whole) plus two per cell (the face directions and the topological sort). ``proj``: the mesh
    points' projection (:func:`~warpvol.projection.pt_thin.project_points`), when the caller has it."""

    bf = mesh.boundary_faces[~hull_faces(mesh)] if off_hull else mesh.boundary_faces
    col, row, _ = project_points(mesh, camera) if proj is None else proj
    t = np.asarray(mesh.tets)[bf[:, 0][:, None], FACE_VERTS[bf[:, 1]]]
    c, r = col[t], row[t]
    area = 0.5 * np.abs((c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0]) - (c[:, 2] - c[:, 0]) * (r[:, 1] - r[:, 0]))
    return float(area.sum()) + 2.0 * mesh.n_tets


def boundary_ray_constraints(mesh, camera, device: str = "cpu", hull: bool = True) -> tuple[np.ndarray, np.ndarray, int]:
    """XMPVO's extra edges ``(src, dst)`` (``src`` drawn before ``dst``, deduplicated) from the boundary
    faces consecutive along the camera's pixel rays, and the number of boundary fragments rasterised.
    ``hull``: every boundary face is rasterised (Silva et al. 1998); ``False``: the faces on the hull
    (:func:`hull_faces`) are left out (along a ray an exit followed by an entry has neither on the hull)."""
    import warp as wp

    from warpvol.kernels import sort as ks

    bf = mesh.boundary_faces if hull else mesh.boundary_faces[~hull_faces(mesh)]
    empty = np.zeros(0, np.int64)
    if len(bf) == 0:
        return empty, empty, 0
    origin, eye, fwd, persp = _frame(mesh, camera)
    tri = mesh.tets[bf[:, 0][:, None], FACE_VERTS[bf[:, 1]]]
    p0 = mesh.points[tri[:, 0]] - origin
    n = np.cross(mesh.points[tri[:, 1]] - origin - p0, mesh.points[tri[:, 2]] - origin - p0)
    front = (np.einsum("ij,ij->i", n, eye - p0) if persp else -(n @ fwd)) > 0  # the ray enters here
    vs = VertexStage.from_camera(camera, *camera.depth_range(*mesh.bounds), device=device)
    frags = Rasterizer(camera.width_px, camera.height_px, device=device, **RASTER_RULES).fragments(
        vs.transform(mesh.points).window_array, tri, walk="triangle")  # the pixel walk's list, faster
    if frags.count < 2:
        return empty, empty, frags.count
    # per pixel along its ray (at equal depth the exit before the entry): where it leaves the mesh and
    # re-enters, the entered cell (farther: drawn first) and the left one (kernels/sort.py k_ray_gaps)
    n, npx = frags.count, camera.width_px * camera.height_px
    src_w, dst_w = wp.empty(n, dtype=wp.int32, device=device), wp.empty(n, dtype=wp.int32, device=device)
    args = [frags.offsets, frags.prim, frags.depth, wp.array(front.astype(np.int32), dtype=wp.int32, device=device),
            wp.array(bf[:, 0].astype(np.int32), dtype=wp.int32, device=device), src_w, dst_w]
    parts = blocks(npx, -(-npx // 16)) if str(device).startswith("cpu") else [(0, npx)]
    preload(device, ks)
    launch_blocks(device, len(parts), lambda b: wp.launch(ks.k_ray_gaps, dim=parts[b][1], inputs=[*args, parts[b][0]],
                                                          device=device))
    src, dst = src_w.numpy()[:n], dst_w.numpy()[:n]
    keep = (src >= 0) & (src != dst)
    pair = np.unique(src[keep].astype(np.int64) * mesh.n_tets + dst[keep])
    return pair // mesh.n_tets, pair % mesh.n_tets, frags.count


def off_hull_boundary(mesh) -> dict:
    """The boundary faces off the hull (:func:`hull_faces`) as the lean ray constraints read them, per mesh and
    kept on it: their cells, the points they use (float32, as the vertex stage takes them) with the faces'
    corners renumbered into that list, and each face's first corner and outward normal relative to the mesh
    centre (float64) for the per-frame entry/exit test."""
    got = mesh.__dict__.get("_sort_off_hull")
    if got is None:
        import warp as wp

        bf = mesh.boundary_faces[~hull_faces(mesh)]
        origin = _frame(mesh, None)[0]
        tri = mesh.tets[bf[:, 0][:, None], FACE_VERTS[bf[:, 1]]]
        used, local = np.unique(tri, return_inverse=True)
        p0 = mesh.points[tri[:, 0]] - origin
        n = np.cross(mesh.points[tri[:, 1]] - origin - p0, mesh.points[tri[:, 2]] - origin - p0)
        got = {"faces": len(bf), "points": np.asarray(mesh.points, np.float32)[used],
               "tris": local.reshape(tri.shape).astype(np.int32), "p0": p0, "normal": n,
               "cells": wp.array(bf[:, 0].astype(np.int32), dtype=wp.int32, device="cpu")}
        mesh.__dict__["_sort_off_hull"] = got
    return got


def lean_ray_constraints(mesh, camera) -> tuple[np.ndarray, np.ndarray, int]:
    """:func:`boundary_ray_constraints` with ``hull=False`` in lean form (``pt_best``): the same pairs and
    fragment count. The off-hull faces' data is kept per mesh (:func:`off_hull_boundary`); per frame only their
    points are transformed, their fragments are counted per pixel and scattered as (face, depth) alone
    (:func:`warpvol.kernels.sort.k_boundary_count`, ``k_boundary_scatter``: no attributes, no sort of the whole
    list, the pixels with one fragment left out), and each pixel's short list is sorted by (depth, exit before
    entry, face) before the exit -> entry pairs are read off (``k_ray_gaps_listed``)."""
    import warp as wp

    from warpvol.kernels import sort as ks

    hb = off_hull_boundary(mesh)
    empty = np.zeros(0, np.int64)
    if hb["faces"] == 0:
        return empty, empty, 0
    dev = "cpu"
    _, eye, fwd, persp = _frame(mesh, camera)
    front = (np.einsum("ij,ij->i", hb["normal"], eye - hb["p0"]) if persp else -(hb["normal"] @ fwd)) > 0
    vs = VertexStage.from_camera(camera, *camera.depth_range(*mesh.bounds), device=dev)
    rast = Rasterizer(camera.width_px, camera.height_px, device=dev, **RASTER_RULES)
    tr = Triangles(rast, vs.transform(hb["points"]).window_array, hb["tris"], binned=False)
    w, npx = camera.width_px, camera.width_px * camera.height_px
    counts = wp.zeros(npx, dtype=wp.int32, device=dev)
    wp.launch(ks.k_boundary_count, dim=tr.count, inputs=[tr.struct, w, counts], device=dev)
    offsets = wp.empty(npx + 1, dtype=wp.int32, device=dev)
    wp.utils.array_scan(counts, offsets[:npx], inclusive=False)
    c, o = counts.numpy(), offsets.numpy()
    n = int(o[npx - 1] + c[npx - 1])
    o[npx] = n
    multi = np.flatnonzero(c > 1).astype(np.int32)  # a pixel with one boundary fragment makes no pair
    if len(multi) == 0:
        return empty, empty, n
    m = int(o[multi[-1] + 1])  # the slots up to the last such pixel
    prim, depth = wp.empty(m, dtype=wp.int32, device=dev), wp.empty(m, dtype=wp.float32, device=dev)
    cursor = wp.zeros(npx, dtype=wp.int32, device=dev)
    wp.launch(ks.k_boundary_scatter, dim=tr.count, inputs=[tr.struct, tr.positions, w, counts, offsets, cursor, prim,
                                                          depth], device=dev)
    n_pairs = wp.zeros(1, dtype=wp.int32, device=dev)
    src_w, dst_w = wp.empty(m, dtype=wp.int32, device=dev), wp.empty(m, dtype=wp.int32, device=dev)
    wp.launch(ks.k_ray_gaps_listed, dim=len(multi),
              inputs=[wp.array(multi, dtype=wp.int32, device=dev), offsets, prim, depth,
                      wp.array(front.astype(np.int32), dtype=wp.int32, device=dev), hb["cells"], n_pairs, src_w, dst_w],
              device=dev)
    k = int(n_pairs.numpy()[0])
    src, dst = src_w.numpy()[:k], dst_w.numpy()[:k]
    keep = src != dst
    pair = np.unique(src[keep].astype(np.int64) * mesh.n_tets + dst[keep])
    return pair // mesh.n_tets, pair % mesh.n_tets, n


_RAYS_POOL: dict = {}
#: lean XMPVO overlaps its ray constraints (a second host thread) with the face directions only from this many
#: cells on: below, the directions take less than waking the thread costs on a loaded machine
LEAN_OVERLAP_CELLS = 65536


def _rays_thread():
    """The host thread XMPVO's ray constraints run on, kept for the process's next frames (a thread started
    per frame cost up to milliseconds on a loaded machine); a forked child starts its own."""
    import os
    from concurrent.futures import ThreadPoolExecutor

    pool = _RAYS_POOL.get(os.getpid())
    if pool is None:
        _RAYS_POOL.clear()
        pool = _RAYS_POOL[os.getpid()] = ThreadPoolExecutor(max_workers=1, thread_name_prefix="warpvol-xmpvo-rays")
    return pool


def mpvo_order(mesh, camera, nonconvex: bool | None = None, metric: str = "distance",
               exact_rays: bool = False, off_hull: bool = False, lean: bool = False) -> SortResult:
    """MPVO (``nonconvex=False``), MPVONC (``True``; default: ``not mesh.is_convex``) or, with
    ``exact_rays``, XMPVO order (``off_hull``: its boundary rasterised without the hull faces). ``lean``
    (``pt_best``; MPVO and XMPVO): the same order from per-mesh arrays kept on the mesh and per-frame
    kernels (:func:`lean_face_directions`, :func:`lean_topological_order`, with ``off_hull``
    :func:`lean_ray_constraints`)."""
    if nonconvex is None:
        nonconvex = not mesh.is_convex
    lean = lean and (exact_rays or not nonconvex)  # MPVONC's depth priority: the published path
    extra, info = None, {}
    if exact_rays:  # the boundary rays on a second host thread while this one decides the faces
        from warpvol.kernels import raster, raster_draw, sort, vertex
        from warpvol.parallel import preload

        _ = (mesh.boundary_faces, mesh.adjacency, centroids(mesh))  # built before the threads
        if off_hull:
            hull_faces(mesh)
            if lean:
                off_hull_boundary(mesh)
        if lean:
            kernel_arrays(mesh)
        preload("cpu", raster, raster_draw, sort, vertex)  # each thread's kernels compiled here, not concurrently
        if lean and off_hull and mesh.n_tets < LEAN_OVERLAP_CELLS:  # a small mesh: no second thread to wake
            import contextvars
            from concurrent.futures import Future

            rays = Future()  # run in a fresh context as on the rays' thread: no counters active (the sort's own)
            rays.set_result(contextvars.Context().run(lean_ray_constraints, mesh, camera))
        else:
            pool = _rays_thread()
            rays = (pool.submit(lean_ray_constraints, mesh, camera) if lean and off_hull
                    else pool.submit(boundary_ray_constraints, mesh, camera, hull=not off_hull))
        try:
            if lean:
                dirs, indeg = lean_face_directions(mesh, camera)
            else:
                key = centroid_keys(mesh, camera, metric)
                dirs = face_directions(mesh, camera)
        except BaseException:  # the rays' thread finishes its frame before the error goes on
            rays.exception()
            raise
        src, dst, nfrag = rays.result()
        extra, info = (src, dst), {"boundary_fragments": nfrag, "ray_constraints": len(src)}
    elif lean:
        dirs, indeg = lean_face_directions(mesh, camera)
    else:
        dirs = face_directions(mesh, camera)
        key = centroid_keys(mesh, camera, metric)
    # MPVONC needs its depth priority; MPVO (convex) and XMPVO orders are exact: a queue is enough. The cells
    # by depth key, where a cycle is broken, are sorted only when the sort meets one
    if lean:
        order, cycles, face_edges = lean_topological_order(mesh, camera, dirs, indeg, extra, metric)
    else:
        order, cycles = topological_order(mesh, dirs, key, extra, priority=nonconvex and not exact_rays)
        face_edges = int((dirs > 0).sum())
    method = "xmpvo" if exact_rays else "mpvonc" if nonconvex else "mpvo"
    notes = []
    if cycles:
        notes.append(f"{cycles} cycle(s) in the face graph broken at the farthest remaining cell")
    if not mesh.is_convex and not exact_rays:
        notes.append("non-convex mesh: cells facing each other across empty space are ordered by depth "
                     "priority only (MPVONC heuristic)")
    edges = face_edges + (len(extra[0]) if extra else 0)
    return SortResult(order, method, not notes, cycles, edges, "; ".join(notes), info)


def visibility_order(mesh, camera, method: str = "auto", metric: str = "distance",
                     off_hull: bool = False, lean: bool = False) -> SortResult:
    """Back-to-front order by ``method``: ``centroid`` | ``mpvo`` | ``mpvonc`` | ``xmpvo`` |
    ``auto`` (MPVO for convex meshes, MPVONC otherwise). XMPVO's order is exact at the camera's
    pixel centres; it rasterises the whole boundary as published (``off_hull``: the faces on the convex
    hull left out, :func:`boundary_ray_constraints`). ``lean``: the same order on per-frame kernels over
    arrays kept on the mesh (:func:`mpvo_order`)."""
    method = check_choice("method", method, METHODS)
    if off_hull and method != "xmpvo":
        raise ConfigError(f"off_hull: applies to method 'xmpvo' only, not {method!r}")
    if method == "centroid":
        return centroid_order(mesh, camera, metric)
    if method == "auto":
        return mpvo_order(mesh, camera, None, metric, lean=lean)
    if method == "xmpvo":
        return mpvo_order(mesh, camera, True, metric, exact_rays=True, off_hull=off_hull, lean=lean)
    return mpvo_order(mesh, camera, method == "mpvonc", metric, lean=lean)


def occlusion_violations(mesh, camera, order: np.ndarray) -> tuple[int, int]:
    """Brute force check of an order against the exact pixel rays: ``(violations, pairs)`` over
    consecutive cells along every pixel ray (a violation: the nearer cell is drawn first).

    Uses :func:`warpvol.reference.numpy_render.trace_segments` (exact, watertight); meant for small meshes/images.
    """

    seg = trace_segments(mesh, camera)
    pos = np.empty(mesh.n_tets, np.int64)
    pos[np.asarray(order)] = np.arange(len(order))
    o = np.lexsort((seg["t_in"], seg["pixel"]))
    pix, tet = seg["pixel"][o], seg["tet"][o]
    same = pix[1:] == pix[:-1]
    front, back = tet[:-1][same], tet[1:][same]
    keep = front != back
    return int((pos[front[keep]] < pos[back[keep]]).sum()), int(keep.sum())
