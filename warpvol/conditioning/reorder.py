"""Cells and points renumbered along a space-filling curve, for the cell walks' memory locality.

A ray walking through a mesh reads each cell's record and its new vertex: when neighbouring cells
have nearby indices, those reads hit the caches. Meshers and structured grids number cells coherently
(a neighbour is usually a few records away); a mesh whose cells come in an arbitrary order (a
Delaunay tetrahedralisation of scattered points, a shuffled file) sends most steps of a walk to a
record far away. :func:`reordered_mesh` renumbers the points, then the cells, by the Morton (Z-order)
code of their positions (points) and centroids (cells) on a 2^21 grid over the mesh's bounding cube;
:func:`far_neighbour_fraction` measures the order a mesh has, and :func:`needs_reorder` is the rule
the ``condition`` stage applies by default (``reorder = "auto"``).

Measured (``scripts/bench_reorder.py``: Warp on the CPU, 512^2, warm frames interleaved in one process,
images within 1e-5 of each other): a 1.06 M-tet Delaunay mesh of random points (87 % of its neighbour pairs
more than 4,096 cells apart, 5 % after the renumbering): ``raycast`` 1.25-1.34x, ``harc_best`` 1.24-1.31x,
``pt_best`` 1.28-1.35x faster; LOX Post (616 k tets as shipped, 17 % far): 0.94-1.01x -- a mesher's own
order is as good as the curve's, so ``auto`` leaves such meshes, and their images, exactly as they are.

Renumbering keeps every tet's local vertex order (so its orientation and its local faces), the
geometry and the scalars: the image is the same up to float32 rounding, which depends on the vertex
numbering through the walks' canonical edge order.
"""

from __future__ import annotations

import numpy as np

from warpvol.scene.mesh import derived_mesh

#: neighbour cells further apart than this many records count as far (~4,096 cells x 48 bytes of walk
#: records: about a core's L2 cache)
FAR_WINDOW = 4096
#: ``auto`` renumbers a mesh whose fraction of far neighbour pairs exceeds this (coherent meshes: 0-0.17
#: measured on the shipped data sets and grids; Delaunay meshes of random points: 0.80-0.87)
FAR_FRACTION = 0.5
REORDER_CHOICES = ("auto", "morton", "none")
_BITS = 21


def _spread(v: np.ndarray) -> np.ndarray:
    """The 21 low bits of ``v`` (uint64) spread to every third bit."""
    v = v & np.uint64(0x1FFFFF)
    v = (v | (v << np.uint64(32))) & np.uint64(0x1F00000000FFFF)
    v = (v | (v << np.uint64(16))) & np.uint64(0x1F0000FF0000FF)
    v = (v | (v << np.uint64(8))) & np.uint64(0x100F00F00F00F00F)
    v = (v | (v << np.uint64(4))) & np.uint64(0x10C30C30C30C30C3)
    v = (v | (v << np.uint64(2))) & np.uint64(0x1249249249249249)
    return v


def morton_codes(xyz: np.ndarray, lo: np.ndarray, extent: float) -> np.ndarray:
    """Morton codes (uint64, 3 x 21 bits) of points ``xyz`` (N, 3) on the cube ``[lo, lo + extent]^3``.

    Examples
    --------
    >>> import numpy as np
    >>> # on a cube of 2^21 - 1 the grid cells are unit cubes: x -> bit 0, y -> bit 1, z -> bit 2, ...
    >>> morton_codes(np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [2, 0, 0]]), np.zeros(3), 2**21 - 1).tolist()
    [1, 2, 4, 7, 8]
    """
    n = (1 << _BITS) - 1
    q = np.clip(np.floor((np.asarray(xyz, np.float64) - lo) / max(extent, 1e-300) * n), 0, n).astype(np.uint64)
    return _spread(q[:, 0]) | (_spread(q[:, 1]) << np.uint64(1)) | (_spread(q[:, 2]) << np.uint64(2))


def far_neighbour_fraction(adjacency: np.ndarray, window: int = FAR_WINDOW) -> float:
    """Fraction of interior face pairs whose two cells are more than ``window`` records apart (0: a
    mesh with no interior face)."""
    adj = np.asarray(adjacency)
    c, _ = np.nonzero(adj >= 0)
    if len(c) == 0:
        return 0.0
    return float(np.mean(np.abs(adj[adj >= 0].astype(np.int64) - c) > window))


def needs_reorder(mesh, mode: str = "auto") -> bool:
    """Whether the ``condition`` stage renumbers ``mesh``: always (``morton``), never (``none``), or
    (``auto``) when more than :data:`FAR_FRACTION` of its neighbour pairs lie :data:`FAR_WINDOW`
    records apart."""
    if mode not in REORDER_CHOICES:
        raise ValueError(f"reorder: {mode!r}; allowed: {', '.join(REORDER_CHOICES)}")
    if mode == "none":
        return False
    return mode == "morton" or far_neighbour_fraction(mesh.adjacency) > FAR_FRACTION


def morton_permutations(points: np.ndarray, tets: np.ndarray,
                        cell_start: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(point_order, cell_order)``: old indices of the points and of the tets in Morton order of
    the points and of the tets' centroids (stable: ties keep their order). With ``cell_start`` (tets
    grouped into the source cells they were split from) the groups move whole, in the Morton order of
    their centroids, their tets in the order they had."""
    lo = points.min(axis=0)
    extent = float((points.max(axis=0) - lo).max())
    point_order = np.argsort(morton_codes(points, lo, extent), kind="stable")
    centroids = points[tets].mean(axis=1)
    if cell_start is None:
        return point_order, np.argsort(morton_codes(centroids, lo, extent), kind="stable")
    cs = np.asarray(cell_start, dtype=np.int64)
    sizes = np.diff(cs)
    group_centroids = np.add.reduceat(centroids, cs[:-1], axis=0) / sizes[:, None]
    groups = np.argsort(morton_codes(group_centroids, lo, extent), kind="stable")
    # the tets of each group in the new group order: starts repeated over their sizes plus 0 .. size - 1
    n = sizes[groups]
    first = np.repeat(cs[:-1][groups], n)
    within = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    return point_order, first + within


def reordered_mesh(mesh, point_order: np.ndarray | None = None, cell_order: np.ndarray | None = None):
    """``mesh`` with points and cells renumbered (default: :func:`morton_permutations`).

    The result is a :class:`~warpvol.scene.mesh.TetMesh` of the same tets, points and scalars (no
    validation again), with ``point_order`` and ``cell_order`` attributes (the old index of each new
    point and tet); its adjacency is the old one renumbered, the other index-bearing caches
    (boundary faces, cracks) are computed again on use. A mesh whose tets are grouped into source cells
    (``cell_start``) keeps each group whole and consecutive, its ``cell_start`` renumbered with it.

    Examples
    --------
    >>> import numpy as np
    >>> from warpvol.scene.builtin import builtin_mesh
    >>> m = builtin_mesh("sphere")
    >>> r = reordered_mesh(m)
    >>> bool(np.allclose(np.sort(r.points[r.tets].mean(1), axis=0), np.sort(m.points[m.tets].mean(1), axis=0)))
    True
    >>> bool((r.adjacency >= 0).sum() == (m.adjacency >= 0).sum())
    True
    """

    cell_start = getattr(mesh, "cell_start", None)
    if point_order is None or cell_order is None:
        point_order, cell_order = morton_permutations(mesh.points, mesh.tets, cell_start)
    point_order = np.asarray(point_order, dtype=np.int64)
    cell_order = np.asarray(cell_order, dtype=np.int64)
    new_point = np.empty_like(point_order)
    new_point[point_order] = np.arange(len(point_order))
    new_cell = np.empty_like(cell_order)
    new_cell[cell_order] = np.arange(len(cell_order))
    adj = np.asarray(mesh.adjacency)[cell_order]
    adjacency = np.where(adj >= 0, new_cell[np.maximum(adj, 0)], -1).astype(np.int32)

    out = derived_mesh(mesh, ("is_convex", "bounds", "scalar_range"))  # invariant under renumbering
    out.points = mesh.points[point_order]
    out.scalars = mesh.scalars[point_order]
    out.tets = new_point[mesh.tets[cell_order]]
    dropped = getattr(mesh, "dropped_tets", None)
    if dropped is not None:
        out.dropped_tets = new_point[dropped]
    out.__dict__["adjacency"] = adjacency
    if cell_start is not None:  # the source cells' groups, in their new order (cell_order keeps them whole)
        first = np.asarray(cell_start)[:-1]
        group_of = np.repeat(np.arange(len(first)), np.diff(cell_start))
        moved = group_of[cell_order]
        starts = np.flatnonzero(np.r_[True, moved[1:] != moved[:-1]])
        if len(starts) != len(first):
            raise ValueError("cell_order splits a source cell's tets (cell_start groups must stay whole)")
        out.cell_start = np.r_[starts, len(cell_order)].astype(np.int64)
        out.cell_start.setflags(write=False)
    out.point_order, out.cell_order = point_order, cell_order
    for a in (out.points, out.scalars, out.tets, adjacency):
        a.setflags(write=False)
    return out
