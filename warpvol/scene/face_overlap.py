"""Geometry of mesh faces that no adjacency records: keys for face rows, and boundary triangles that
overlap a coplanar triangle facing the other way (cracks and non-conforming interfaces of a mesh,
:attr:`warpvol.scene.mesh.TetMesh.crack_faces` and :attr:`~warpvol.scene.mesh.TetMesh.nonconforming_faces`).
"""

from __future__ import annotations

import numpy as np


def row_keys(rows: np.ndarray, top: int) -> np.ndarray:
    """One comparable key per row of a (K, 3) int array with values in ``[0, top)`` (int64 when it
    fits; keys made with the same ``top`` compare)."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    if top < 2_000_000:
        return (rows[:, 0] * top + rows[:, 1]) * top + rows[:, 2]
    return rows.view([("", np.int64)] * 3).ravel()


def _candidate_pairs(lo: np.ndarray, hi: np.ndarray, side: np.ndarray, size: float, accept
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(i, j)`` of boxes ``[lo, hi]`` sharing a cell of a uniform grid of spacing ``size``,
    with ``side[i] & 1``, ``side[j] & 2`` and ``accept(i, j)`` true (each pair once)."""
    k0 = np.floor(lo / size).astype(np.int64)
    span = np.floor(hi / size).astype(np.int64) - k0 + 1
    count = span.prod(axis=1)
    face = np.repeat(np.arange(len(lo)), count)
    local = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    sx, sy = span[face, 0], span[face, 1]
    cell = k0[face] + np.stack([local % sx, (local // sx) % sy, local // (sx * sy)], axis=1)
    cell -= cell.min(axis=0)
    dims = cell.max(axis=0) + 1
    key = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
    in_a, in_b = (side[face] & 1) > 0, (side[face] & 2) > 0
    ka, fa, kb, fb = key[in_a], face[in_a], key[in_b], face[in_b]
    oa, ob = np.argsort(ka, kind="stable"), np.argsort(kb, kind="stable")
    ka, fa, kb, fb = ka[oa], fa[oa], kb[ob], fb[ob]
    # for each A entry, the run of B entries with the same grid cell
    start = np.searchsorted(kb, ka, side="left")
    stop = np.searchsorted(kb, ka, side="right")
    n = stop - start
    ia = np.repeat(fa, n)
    jb = fb[np.repeat(start, n) + np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)]
    keep = ia != jb
    keep[keep] = accept(ia[keep], jb[keep])
    if not keep.any():
        return ia[:0], jb[:0]
    pair = np.unique(ia[keep] * np.int64(len(lo)) + jb[keep])
    return pair // len(lo), pair % len(lo)


def overlapping_opposite_faces(points: np.ndarray, tris: np.ndarray, skip: np.ndarray | None = None,
                               rtol: float = 1e-9) -> np.ndarray:
    """(B,) bool: triangles ``tris`` (point indices, outward order) whose interior overlaps that of a
    coplanar triangle facing the other way (each vertex within ``rtol`` times the points' bounding
    box diagonal of the other's plane). Rows with ``skip`` set take no part.

    Examples
    --------
    >>> p = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.]])
    >>> overlapping_opposite_faces(p, np.array([[0, 1, 2], [0, 2, 3], [1, 0, 3], [1, 3, 2]])).tolist()
    [True, True, True, True]
    >>> overlapping_opposite_faces(p, np.array([[0, 1, 2], [0, 2, 3], [2, 1, 0], [3, 2, 0]])).tolist()
    [True, True, True, True]
    >>> overlapping_opposite_faces(p, np.array([[0, 1, 2], [3, 2, 0]])).tolist()
    [False, False]
    """
    nb = len(tris)
    hit = np.zeros(nb, dtype=bool)
    if nb < 2:
        return hit
    live = np.ones(nb, dtype=bool) if skip is None else ~np.asarray(skip, dtype=bool)
    idx = np.flatnonzero(live)
    if len(idx) < 2:
        return hit
    lo_b, hi_b = points.min(axis=0), points.max(axis=0)
    scale = float(np.linalg.norm(hi_b - lo_b)) or 1.0
    c = (points[tris[idx]] - 0.5 * (lo_b + hi_b)) / scale  # (K, 3, 3) in units of the mesh size
    n = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    nn = np.linalg.norm(n, axis=1)
    ok = nn > 0
    n = n / np.where(ok, nn, 1.0)[:, None]
    # the two facing classes: opposite normals fall in opposite classes (both near the divide)
    v = np.array([0.5773, 0.5778, 0.5768])
    dv = n @ v
    side = (((dv > -0.1) & ok) * 1 + ((dv < 0.1) & ok) * 2).astype(np.int64)
    lo, hi = c.min(axis=1), c.max(axis=1)
    ext = (hi - lo).max(axis=1)
    size = max(float(np.median(ext)), 1e-6)
    span = np.floor(hi / size) - np.floor(lo / size) + 1
    while span.prod(axis=1).sum() > 8 * len(idx) + 1000:  # a few huge faces: coarser cells
        size *= 2.0
        span = np.floor(hi / size) - np.floor(lo / size) + 1
    tol = rtol
    lo, hi = lo - tol, hi + tol
    off = np.einsum("ij,ij->i", n, c[:, 0])

    def facing(i, j):  # opposite normals, opposite plane offsets (the same plane)
        return (np.einsum("ij,ij->i", n[i], n[j]) < -1.0 + 1e-6) & (np.abs(off[i] + off[j]) <= 4 * tol)

    i, j = _candidate_pairs(lo, hi, side, size, facing)
    if len(i) == 0:
        return hit
    # coplanar: every vertex of each on the other's plane
    dist = np.abs(np.einsum("ik,ijk->ij", n[i], c[j] - c[i][:, :1, :])).max(axis=1)
    dist2 = np.abs(np.einsum("ik,ijk->ij", n[j], c[i] - c[j][:, :1, :])).max(axis=1)
    keep = (dist <= tol) & (dist2 <= tol)
    i, j = i[keep], j[keep]
    if len(i) == 0:
        return hit
    # overlap in the plane of i: project along its dominant axis, both triangles counter-clockwise
    ax = np.abs(n[i]).argmax(axis=1)
    u, w = (ax + 1) % 3, (ax + 2) % 3
    r, k3 = np.arange(len(i))[:, None], np.arange(3)[None, :]
    flip = n[i, ax] < 0  # i is clockwise in (u, w); j, facing the other way, is counter-clockwise
    a = np.stack([c[i][r, k3, u[:, None]], c[i][r, k3, w[:, None]]], axis=-1)  # (P, 3, 2)
    b = np.stack([c[j][r, k3, u[:, None]], c[j][r, k3, w[:, None]]], axis=-1)
    a[flip] = a[flip][:, ::-1]
    b[~flip] = b[~flip][:, ::-1]

    def separated(p, q):
        """Some edge line of counter-clockwise p has all of q on its outer side (or on it)."""
        e = np.roll(p, -1, axis=1) - p  # (P, 3, 2)
        el = np.linalg.norm(e, axis=2)
        d = e[:, :, None, 0] * (q[:, None, :, 1] - p[:, :, None, 1]) - \
            e[:, :, None, 1] * (q[:, None, :, 0] - p[:, :, None, 0])  # (P, edge, q vertex)
        return (d <= tol * el[:, :, None]).all(axis=2).any(axis=1)

    over = ~separated(a, b) & ~separated(b, a)
    hit[idx[i[over]]] = True
    hit[idx[j[over]]] = True
    return hit
