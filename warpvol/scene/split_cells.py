"""Conforming splits of unstructured hexahedra, voxels, wedges and pyramids into tets (numpy).

A quad face shared by two cells must be cut along the same diagonal from both sides, or the tets of
the two cells do not share faces (a ray walking the adjacency stops there). Every quad face is cut
along the diagonal through its smallest vertex key (Dompierre et al. 1999, "How to subdivide
pyramids, prisms and hexahedra into tetrahedra"), a rule both neighbours evaluate alike. The key is
the rank of the vertex position, so cells that meet on duplicated points (same positions, other
indices) choose alike too.

Each cell type's split for a given set of face diagonals comes from a table: every triangulation of
the reference cell without added points is enumerated once (exact integer arithmetic), and each
diagonal configuration gets one with the fewest tets. A configuration no triangulation matches
(possible for hexahedra only, never under the smallest-key rule) is split around an added centre
point whose scalar is the mean of the cell's corners.

A collapsed cell names one point at several corners (a hexahedron on the axis of an O-grid has a
face collapsed onto an edge: a wedge; a face collapsed onto a point: a pyramid). Its split is
taken as the split of the cell before the collapse, moved with the points: pieces that name a
point twice have no volume, and two pieces that become the same tet with opposite orientations
cancel (they lay on either side of a face the collapse flattened). Both are dropped, and what
remains tiles the collapsed cell, since the signed volumes of a split sum to the cell's volume
for any corner positions. :func:`split_cells` counts them (``notes``).
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np

from warpvol.errors import MeshError

VTK_TETRA, VTK_VOXEL, VTK_HEXAHEDRON, VTK_WEDGE, VTK_PYRAMID = 10, 11, 12, 13, 14
#: cell types split here (others with volume go through VTK's triangulation filter)
SPLIT_TYPES = (VTK_TETRA, VTK_VOXEL, VTK_HEXAHEDRON, VTK_WEDGE, VTK_PYRAMID)
#: cell types without volume (vertices, lines, polygons): not part of a tet mesh
FLAT_TYPES = (1, 2, 3, 4, 5, 6, 7, 8, 9, 21, 22, 23, 28, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40)

# reference cells in VTK's corner order (integer coordinates) and their quad faces (cyclic order)
_REF = {
    VTK_HEXAHEDRON: (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                               [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]),
                     np.array([[0, 4, 7, 3], [1, 2, 6, 5], [0, 1, 5, 4], [3, 7, 6, 2], [0, 3, 2, 1], [4, 5, 6, 7]])),
    VTK_WEDGE: (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1]]),
                np.array([[0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]])),
    VTK_PYRAMID: (np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0], [1, 1, 2]]),
                  np.array([[0, 1, 2, 3]])),
}
#: triangular faces of the reference cells and six times their volumes
_TRIS = {VTK_HEXAHEDRON: np.zeros((0, 3), dtype=np.int64), VTK_WEDGE: np.array([[0, 2, 1], [3, 4, 5]]),
         VTK_PYRAMID: np.array([[0, 4, 1], [1, 4, 2], [2, 4, 3], [3, 4, 0]])}
_VOL6 = {VTK_HEXAHEDRON: 6, VTK_WEDGE: 3, VTK_PYRAMID: 16}
#: VTK voxel corner order (i + 2j + 4k) -> hexahedron order
VOXEL_TO_HEX = np.array([0, 1, 3, 2, 4, 5, 7, 6])


def _vol6(p: np.ndarray) -> int:
    return int(np.dot(p[1] - p[0], np.cross(p[2] - p[0], p[3] - p[0])))


def _disjoint(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(P,) whether tets ``a[p]``, ``b[p]`` ((P, 4, 3) integer points) have disjoint interiors: a
    separating plane among their face planes and the planes through an edge of each."""
    faces = np.array(list(itertools.combinations(range(4), 3)))
    edges = np.array(list(itertools.combinations(range(4), 2)))
    nrm = []
    for t in (a, b):
        nrm.append(np.cross(t[:, faces[:, 1]] - t[:, faces[:, 0]], t[:, faces[:, 2]] - t[:, faces[:, 0]]))
    ea = a[:, edges[:, 1]] - a[:, edges[:, 0]]  # (P, 6, 3)
    eb = b[:, edges[:, 1]] - b[:, edges[:, 0]]
    nrm.append(np.cross(ea[:, :, None], eb[:, None, :]).reshape(len(a), 36, 3))
    n = np.concatenate(nrm, axis=1)  # (P, 44, 3)
    pa = np.einsum("pvk,pnk->pnv", a, n)
    pb = np.einsum("pvk,pnk->pnv", b, n)
    sep = (pa.max(axis=2) <= pb.min(axis=2)) | (pb.max(axis=2) <= pa.min(axis=2))
    return (sep & n.any(axis=2)).any(axis=1)


@lru_cache(maxsize=None)
def split_table(cell_type: int) -> tuple[dict[int, np.ndarray], int]:
    """``({config: (T, 4) local tets}, n_quads)`` of a cell type: bit ``q`` of ``config`` is 0 when
    quad face ``q`` is cut along its corners 0-2, 1 along 1-3. Tets are positively oriented on the
    reference cell; configurations without a triangulation are absent."""
    pts, quads = _REF[cell_type]
    n = len(pts)
    total = _VOL6[cell_type]
    cand = [t for t in itertools.combinations(range(n), 4) if _vol6(pts[list(t)]) != 0]
    vol = [abs(_vol6(pts[list(t)])) for t in cand]
    ii, jj = np.meshgrid(np.arange(len(cand)), np.arange(len(cand)), indexing="ij")
    ct = pts[np.array(cand)]
    ok = _disjoint(ct[ii.ravel()], ct[jj.ravel()]).reshape(len(cand), len(cand)) & (ii != jj)
    faces_on_hull = {tuple(sorted(f)) for q in quads for f in itertools.combinations(q.tolist(), 3)}
    faces_on_hull |= {tuple(sorted(t)) for t in _TRIS[cell_type].tolist()}
    found: dict[int, list] = {}

    def conforming(sel) -> bool:
        count: dict[tuple, int] = {}
        for t in sel:
            for f in itertools.combinations(cand[t], 3):
                count[f] = count.get(f, 0) + 1
        return all(c == (1 if f in faces_on_hull else 2) for f, c in count.items())

    def search(sel, start, left):
        if left == 0:
            if conforming(sel):
                cfg = _config_of([cand[t] for t in sel], quads)
                if cfg is not None and (cfg not in found or len(sel) < len(found[cfg])):
                    found[cfg] = list(sel)
            return
        for t in range(start, len(cand)):
            if vol[t] <= left and all(ok[t, s] for s in sel):
                search(sel + [t], t + 1, left - vol[t])

    search([], 0, total)
    table = {}
    for cfg, sel in found.items():
        tets = np.array([cand[t] for t in sel], dtype=np.int64)
        for r in range(len(tets)):
            if _vol6(pts[tets[r]]) < 0:
                tets[r, [2, 3]] = tets[r, [3, 2]]
        table[cfg] = tets
    return table, len(quads)


def _config_of(tets, quads) -> int | None:
    """Diagonal configuration of a triangulation's boundary on the quad faces (None if a quad face
    is not cut by one of its diagonals)."""
    cfg = 0
    for q, quad in enumerate(quads):
        d02 = frozenset((quad[0], quad[2]))
        d13 = frozenset((quad[1], quad[3]))
        on = set(quad.tolist())
        cut = None
        for t in tets:
            for f in itertools.combinations(t, 3):
                if set(f) <= on:
                    missing = on - set(f)
                    cut = d13 if missing <= d02 else d02  # the triangle's edge across the quad
        if cut is None:
            return None
        cfg |= (1 << q) if cut == d13 else 0
    return cfg


def quad_bits(keys: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(C,) int configuration of cells with corner keys ``keys`` (C, corners): each quad face cut
    along the diagonal through its smallest key."""
    cfg = np.zeros(len(keys), dtype=np.int64)
    for q, quad in enumerate(quads):
        k = keys[:, quad]
        cfg |= (np.argmin(k, axis=1) % 2).astype(np.int64) << q  # corner 1 or 3: diagonal 1-3
    return cfg


def split_cells(points: np.ndarray, scalars: np.ndarray, cell_types: np.ndarray, offsets: np.ndarray,
                conn: np.ndarray, notes: dict | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Split the volume cells of an unstructured grid (types :data:`SPLIT_TYPES`; cells of
    :data:`FLAT_TYPES` are skipped) into conforming tets.

    ``offsets`` (C + 1) and ``conn`` are VTK's cell arrays. Returns ``(points, scalars, tets,
    cell_start)``: points and scalars gain one centre point per cell split around its centre (none
    under the smallest-key rule); the tets of each cell are consecutive, cells in input order.
    The pieces of collapsed cells that have no volume or cancel are dropped (see the module
    docstring); ``notes`` (a dict, if given) gets ``collapsed_cells`` and ``collapsed_pieces_dropped``.
    """
    cell_types = np.asarray(cell_types)
    offsets = np.asarray(offsets, dtype=np.int64)
    conn = np.asarray(conn, dtype=np.int64)
    _, key = np.unique(points, axis=0, return_inverse=True)
    key = key.ravel()
    parts_cell, parts_tets = [], []
    extra_pts, extra_s = [], []
    n_pts = len(points)
    for ct in SPLIT_TYPES:
        cells = np.flatnonzero(cell_types == ct)
        if len(cells) == 0:
            continue
        nc = {VTK_TETRA: 4, VTK_VOXEL: 8, VTK_HEXAHEDRON: 8, VTK_WEDGE: 6, VTK_PYRAMID: 5}[ct]
        corners = conn[offsets[cells][:, None] + np.arange(nc)[None, :]]
        if ct == VTK_TETRA:
            parts_cell.append(cells)
            parts_tets.append(corners)
            continue
        if ct == VTK_VOXEL:
            corners, ct = corners[:, VOXEL_TO_HEX], VTK_HEXAHEDRON
        table, _ = split_table(ct)
        cfg = quad_bits(key[corners], _REF[ct][1])
        for c in np.unique(cfg):
            sel = cfg == c
            if int(c) in table:
                local = table[int(c)]
                parts_cell.append(np.repeat(cells[sel], len(local)))
                parts_tets.append(corners[sel][:, local].reshape(-1, 4))
            else:  # no triangulation without a point inside: one tet per boundary triangle and the centre
                cc = corners[sel]
                centre = n_pts + sum(len(e) for e in extra_pts) + np.arange(len(cc))
                extra_pts.append(points[cc].mean(axis=1))
                extra_s.append(scalars[cc].mean(axis=1))
                tris = _boundary_triangles(ct, int(c))
                parts_cell.append(np.repeat(cells[sel], len(tris)))
                parts_tets.append(np.concatenate([cc[:, tris], np.broadcast_to(centre[:, None, None],
                                                                                 (len(cc), len(tris), 1))],
                                                 axis=2).reshape(-1, 4))
    if extra_pts:
        points = np.vstack([points] + extra_pts)
        scalars = np.concatenate([scalars] + extra_s)
    if not parts_cell:
        return points, scalars, np.zeros((0, 4), dtype=np.int64), np.zeros(1, dtype=np.int64)
    cell = np.concatenate(parts_cell)
    tets = np.concatenate(parts_tets)
    keep = _collapsed_pieces(points, cell, tets, cell_types)
    if not keep.all():
        if notes is not None:
            notes["collapsed_cells"] = int(len(np.unique(cell[~keep])))
            notes["collapsed_pieces_dropped"] = int((~keep).sum())
        cell, tets = cell[keep], tets[keep]
    order = np.argsort(cell, kind="stable")
    cell, tets = cell[order], tets[order]
    counts = np.bincount(cell, minlength=len(cell_types))
    cell_start = np.concatenate([[0], np.cumsum(counts[counts > 0])]).astype(np.int64)
    return points, scalars, tets, cell_start


def _boundary_triangles(cell_type: int, cfg: int) -> np.ndarray:
    """(F, 3) local corner triples of the reference cell's boundary with its quads cut by ``cfg``."""
    _, quads = _REF[cell_type]
    tris = [t for t in _TRIS[cell_type].tolist()]
    for i, q in enumerate(quads.tolist()):
        if (cfg >> i) & 1:
            tris += [[q[1], q[2], q[3]], [q[3], q[0], q[1]]]
        else:
            tris += [[q[0], q[1], q[2]], [q[2], q[3], q[0]]]
    return np.array(tris, dtype=np.int64)


def _parity(rows: np.ndarray) -> np.ndarray:
    """(T,) parity (0 even, 1 odd) of the permutation that sorts each row of ``rows`` (T, 4)."""
    perm = np.argsort(rows, axis=1, kind="stable")
    inv = sum((perm[:, i] > perm[:, j]).astype(np.int64) for i in range(4) for j in range(i + 1, 4))
    return inv % 2


def _collapsed_pieces(points: np.ndarray, cell: np.ndarray, tets: np.ndarray, cell_types: np.ndarray) -> np.ndarray:
    """(T,) bool: the split tets to keep. Pieces of a split cell (not a tet) that name a point twice
    are dropped, and so are pairs of pieces of one cell with the same points in opposite orientations
    (see the module docstring). Pieces left that coincide, or that turn opposite ways (the flattened
    cell folds over itself), would overlap: an error naming the cell."""
    srt = np.sort(tets, axis=1)
    keep = ~((srt[:, 1:] == srt[:, :-1]).any(axis=1) & (cell_types[cell] != VTK_TETRA))
    if keep.all():
        return keep
    bad = np.unique(cell[~keep])
    idx = np.flatnonzero(np.isin(cell, bad) & keep)  # the other pieces of the collapsed cells
    rows = np.column_stack([cell[idx], srt[idx]])
    _, inv, counts = np.unique(rows, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    dup = counts[inv] > 1
    if dup.any():
        par = _parity(tets[idx])
        odd = np.bincount(inv, weights=par, minlength=len(counts))
        if (counts > 2).any() or (odd[counts == 2] != 1).any():
            _overlap(int(cell[idx[np.argmax(dup)]]), cell, tets)
        keep[idx[dup]] = False
    idx = idx[keep[idx]]
    p = points[tets[idx]]
    vol6 = np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]))
    size = np.abs(p - p[:, :1]).max(axis=(1, 2))
    tiny = np.abs(vol6) <= 1e-12 * size ** 3
    pos = np.zeros(len(cell_types), dtype=bool)
    neg = np.zeros(len(cell_types), dtype=bool)
    pos[cell[idx[(vol6 > 0) & ~tiny]]] = True
    neg[cell[idx[(vol6 < 0) & ~tiny]]] = True
    if (pos & neg).any():  # the flattened cell folds over itself: its pieces overlap
        _overlap(int(np.argmax(pos & neg)), cell, tets)
    return keep


def _overlap(c: int, cell: np.ndarray, tets: np.ndarray):
    raise MeshError(f"cell {c} (points {np.unique(tets[cell == c]).tolist()}) collapses so that the pieces "
                    "of its split overlap; a collapsed cell must be a wedge, pyramid or tet")
