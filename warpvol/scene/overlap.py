"""Bodies of one mesh that overlap in space (:attr:`warpvol.scene.mesh.TetMesh.overlapping_parts`): an
assembly of parts on separate points whose volumes overlap, overset grids without blanking, a part
written twice. A ray through such a place meets two media at once, which no renderer (the reference
included) reads one agreed way; the mesh is declined naming the parts and the overlap's size.

* Parts (:func:`mesh_parts`): connected components of the tets through shared points, joined where two
  boundary faces lie on the same three positions facing opposite ways (cells that meet on duplicated
  points). Parts that only touch (a non-conforming interface, hanging nodes, cells glued on duplicated
  points) are separate parts and pass.
* Broad phase: a part's tets whose boxes reach into another part's box, then, slab by slab along x, a
  uniform grid over their boxes (each pair tested in the one grid cell that holds the lower corner of the
  two boxes' overlap). Each slab stops at its share of :data:`MAX_PAIRS` overlapping pairs (its blocks
  taken in a scattered order); the counts reported are then lower bounds.
* Narrow phase (:func:`tet_overlap_depth`): the separating-axis test of two tets in float64 (4 + 4 face
  normals, 36 edge cross products); two tets overlap when every axis sees their projections overlap by
  more than ``1e-9`` of the mesh's bounding-box diagonal, so tets sharing a face, an edge or a vertex, or
  touching on a face, do not.

A single-part mesh costs one connected-components pass (numpy union-find by hooking and pointer
jumping). Plain numpy, below the mesh class.
"""

from __future__ import annotations

import numpy as np

#: two tets overlap when their projections on every separating axis overlap by more than this fraction
#: of the mesh's bounding-box diagonal
OVERLAP_RTOL = 1e-9
#: candidate pairs per block of the narrow phase (memory bound)
_PAIR_BLOCK = 200_000
#: candidate tets per slab of the broad phase (memory bound; the search may stop after one)
_SLAB = 250_000
#: the search stops after about this many overlapping pairs (the mesh is declined anyway), each slab of
#: the broad phase after its share, its blocks taken in a scattered order: the pairs found spread over
#: the overlap
MAX_PAIRS = 5_000

_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])


def union_components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) label per node of the graph with edges ``(a[k], b[k])``: the smallest node of its connected
    component. Hooking of each root onto the smaller root across an edge, then pointer jumping, until no
    edge joins two roots.

    Examples
    --------
    >>> union_components(6, np.array([0, 4, 2]), np.array([3, 5, 3])).tolist()
    [0, 1, 0, 0, 4, 4]
    """
    dt = np.int32 if n < 2**31 - 1 else np.int64
    parent = np.arange(n, dtype=dt)
    a, b = np.asarray(a, dtype=dt), np.asarray(b, dtype=dt)
    while len(a):
        ra, rb = parent[a], parent[b]
        live = ra != rb
        if not live.any():
            break
        a, b, ra, rb = a[live], b[live], ra[live], rb[live]
        np.minimum.at(parent, np.maximum(ra, rb), np.minimum(ra, rb))
        while True:  # pointer jumping: every node onto its root
            up = parent[parent]
            if np.array_equal(up, parent):
                break
            parent = up
    return parent


def mesh_parts(points: np.ndarray, tets: np.ndarray, tris: np.ndarray | None = None) -> np.ndarray:
    """(M,) part index per tet (0, 1, ... in order of each part's first tet): connected components of
    the tets through shared points, joined across pairs of boundary triangles ``tris`` (outward point
    indices) on the same three positions facing opposite ways."""
    n = len(points)
    t = np.asarray(tets)
    a = np.concatenate([t[:, 0], t[:, 0], t[:, 0]])
    b = np.concatenate([t[:, 1], t[:, 2], t[:, 3]])
    lab = union_components(n, a, b)
    if tris is not None and len(tris) > 1:
        roots = lab[tris[:, 0]]
        if (roots != roots[0]).any():  # several parts: are some glued on duplicated points?
            used = np.unique(tris)
            pos = np.full(n, -1, dtype=np.int64)
            _, inv = np.unique(points[used], axis=0, return_inverse=True)
            pos[used] = inv.ravel()
            key = np.sort(pos[tris], axis=1)
            _, g, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
            g = g.ravel()
            pair = np.flatnonzero(cnt[g] == 2)
            if len(pair):
                order = pair[np.argsort(g[pair], kind="stable")]
                f1, f2 = order[0::2], order[1::2]
                p = points[tris]
                nrm = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
                opp = np.einsum("ij,ij->i", nrm[f1], nrm[f2]) < 0
                f1, f2 = f1[opp], f2[opp]
                if len(f1):
                    lab2 = union_components(n, roots[f1], roots[f2])
                    lab = lab2[lab]
    _, first, part = np.unique(lab[t[:, 0]], return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[part.ravel()]


def tet_overlap_depth(a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray:
    """(P,) for pairs of tets ``a``, ``b`` ((P, 4, 3) float64 corners): the smallest overlap of their
    projections over the separating axes (face normals of both, cross products of their edges), or
    ``-1`` where some axis separates them to within ``tol`` (they are apart or only touch).

    Examples
    --------
    >>> t = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]])
    >>> tet_overlap_depth(t, t + [0.2, 0.2, 0.2], 1e-9).round(3).tolist()
    [0.231]
    >>> tet_overlap_depth(t, t * [-1, 1, 1], 1e-9).tolist()  # mirrored across x = 0: a shared face
    [-1.0]
    """
    depth = np.full(len(a), np.inf)
    alive = np.ones(len(a), dtype=bool)

    def axes_test(axes, idx):
        ln = np.linalg.norm(axes, axis=-1)
        ok = ln > 0
        u = axes / np.where(ok, ln, 1.0)[..., None]
        pa = np.einsum("pak,pvk->pav", u, a[idx])
        pb = np.einsum("pak,pvk->pav", u, b[idx])
        ov = np.minimum(pa.max(axis=2), pb.max(axis=2)) - np.maximum(pa.min(axis=2), pb.min(axis=2))
        ov = np.where(ok, ov, np.inf)
        d = ov.min(axis=1)
        depth[idx] = np.minimum(depth[idx], d)
        alive[idx[d <= tol]] = False

    idx = np.arange(len(a))
    for t in (a, b):
        tri = t[idx][:, _FACES]
        axes_test(np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0]), idx)
        idx = np.flatnonzero(alive)
    if len(idx):
        ea = a[idx][:, _EDGES[:, 1]] - a[idx][:, _EDGES[:, 0]]
        eb = b[idx][:, _EDGES[:, 1]] - b[idx][:, _EDGES[:, 0]]
        # parallel edges give no axis (a zero cross product is skipped)
        axes_test(np.cross(ea[:, :, None, :], eb[:, None, :, :]).reshape(len(idx), 36, 3), idx)
    return np.where(alive, depth, -1.0)


def _boxes(c: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lo = c[tets[:, 0]]
    hi = lo.copy()
    for k in (1, 2, 3):
        p = c[tets[:, k]]
        np.minimum(lo, p, out=lo)
        np.maximum(hi, p, out=hi)
    return lo, hi


def _grid_pairs(sub, clo, chi, cpart, size, tol, x0, x1):
    """Blocks ``(i, j)`` of pairs of the boxes ``sub`` (indices into ``clo``, ``chi``, ``cpart``) of
    different parts whose boxes overlap by more than ``tol``, each pair once: in the cell of a uniform
    grid of spacing ``size`` holding the lower corner of the boxes' overlap, that corner's x in
    ``[x0, x1)``; in blocks of about :data:`_PAIR_BLOCK` candidate pairs, in a fixed scattered order."""
    if len(sub) < 2:
        return
    blo, bhi = clo[sub], chi[sub]
    k0 = np.floor(blo / size).astype(np.int64)
    span = np.floor(bhi / size).astype(np.int64) - k0 + 1
    count = span.prod(axis=1)
    ent = np.repeat(np.arange(len(sub)), count)
    local = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    sx, sy = span[ent, 0], span[ent, 1]
    cell = k0[ent] + np.stack([local % sx, (local // sx) % sy, local // (sx * sy)], axis=1)
    del local, sx, sy
    base = cell.min(axis=0)
    dims = cell.max(axis=0) - base + 1
    key = ((cell[:, 0] - base[0]) * dims[1] + (cell[:, 1] - base[1])) * dims[2] + (cell[:, 2] - base[2])
    kp = cpart[sub][ent]
    order = np.lexsort((kp, key))
    key, ent, cell, kp = key[order], ent[order], cell[order], kp[order]
    run_end = np.searchsorted(key, key, side="right")
    # the entries of another part later in the cell: after the run of the entry's own part
    kk = key * np.int64(int(kp.max()) + 1) + kp
    own_end = np.searchsorted(kk, kk, side="right")
    del kk, order
    per = run_end - own_end
    cum = np.cumsum(per)
    total = int(cum[-1]) if len(cum) else 0
    cuts = np.unique(np.searchsorted(cum, np.arange(_PAIR_BLOCK, total, _PAIR_BLOCK), side="left"))
    bounds = np.concatenate([[0], cuts + 1, [len(key)]]).clip(0, len(key))
    blocks = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
    for k in np.random.default_rng(1).permutation(len(blocks)):
        e = np.arange(*blocks[k])
        n = per[e]
        first = np.repeat(e, n)
        second = np.repeat(own_end[e], n) + np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        i, j = sub[ent[first]], sub[ent[second]]
        olo = np.maximum(clo[i], clo[j])
        keep = ((np.minimum(chi[i], chi[j]) - olo) > tol).all(axis=1)
        keep &= (np.floor(olo / size).astype(np.int64) == cell[first]).all(axis=1)
        keep &= (olo[:, 0] >= x0) & (olo[:, 0] < x1)
        yield i[keep], j[keep]


def _candidates(part: np.ndarray, lo: np.ndarray, hi: np.ndarray, tol: float, n_parts: int) -> np.ndarray:
    """Tets whose box reaches more than ``tol`` into the box of another part."""
    if n_parts > 64:
        return np.arange(len(part))
    mine = [part == p for p in range(n_parts)]
    plo = np.array([lo[m].min(axis=0) for m in mine])
    phi = np.array([hi[m].max(axis=0) for m in mine])
    keep = np.zeros(len(part), dtype=bool)
    for p in range(n_parts):
        for q in range(p + 1, n_parts):
            if (np.minimum(phi[p], phi[q]) - np.maximum(plo[p], plo[q]) > tol).all():
                for x, y in ((p, q), (q, p)):
                    m = mine[x]
                    keep[m] |= ((np.minimum(hi[m], phi[y]) - np.maximum(lo[m], plo[y])) > tol).all(axis=1)
    return np.flatnonzero(keep)


def overlapping_parts(points: np.ndarray, tets: np.ndarray, tris: np.ndarray | None = None) -> dict | None:
    """``None`` when the mesh's parts (:func:`mesh_parts`) do not overlap, else what overlaps:
    ``parts`` (tets per part), ``pairs`` (overlapping tet pairs found; ``capped``: the search stopped
    after about :data:`MAX_PAIRS`, having searched the share ``searched`` of the candidate tets to the end,
    and every count is a lower bound), ``by_parts`` (``{(p, q): pairs}``), ``cells`` (tets of each
    part in an overlap, ``{p: count}``), ``box`` (lower and upper corner of the overlapping pairs'
    box intersections) and ``depth`` (the deepest pair's separating-axis overlap, in the points'
    units).

    Examples
    --------
    >>> from warpvol.scene.grids import grid_points, structured_to_tets
    >>> p = grid_points([0, 1, 2], [0, 1], [0, 1]); t = structured_to_tets((3, 2, 2))
    >>> overlapping_parts(np.concatenate([p, p + [3, 0, 0]]), np.concatenate([t, t + 12])) is None
    True
    >>> info = overlapping_parts(np.concatenate([p, p + [1, 0, 0]]), np.concatenate([t, t + 12]))
    >>> info["parts"], info["by_parts"], info["box"]
    ([12, 12], {(0, 1): 6}, ([1.0, 0.0, 0.0], [2.0, 1.0, 1.0]))
    """
    points = np.asarray(points, dtype=np.float64)
    tets = np.asarray(tets, dtype=np.int64)
    part = mesh_parts(points, tets, tris)
    n_parts = int(part.max()) + 1
    if n_parts < 2:
        return None
    used = np.zeros(len(points), dtype=bool)
    used[tets.ravel()] = True
    blo, bhi = points[used].min(axis=0), points[used].max(axis=0)
    centre = 0.5 * (blo + bhi)
    c = points - centre
    diag = float(np.linalg.norm(bhi - blo))
    tol = OVERLAP_RTOL * diag + 8 * np.finfo(float).eps * float(np.abs(centre).max())
    lo, hi = _boxes(c, tets)
    cand = _candidates(part, lo, hi, tol, n_parts)
    if len(cand) < 2:
        return None
    clo, chi = lo[cand], hi[cand]
    cpart = part[cand]
    ext = (chi - clo).max(axis=1)
    size = max(float(np.median(ext)), tol, 1e-300)
    while (np.floor(chi / size) - np.floor(clo / size) + 1).prod(axis=1).sum() > 8 * len(cand) + 1000:
        size *= 2.0  # a few huge cells: a coarser grid
    # slabs along x of about _SLAB candidates each (by the boxes' lower x); a slab's search stops at its
    # share of MAX_PAIRS, so the pairs found spread over the whole overlap
    order = np.argsort(clo[:, 0], kind="stable")
    xs = clo[order, 0]
    n_slabs = max(1, -(-len(cand) // _SLAB))
    edges = [-np.inf] + [float(xs[k * _SLAB]) for k in range(1, n_slabs)] + [np.inf]
    reach = float(ext.max())
    found_i, found_j, found_d = [], [], []
    n_found = 0
    done = 0  # candidates whose slab was searched to its end
    capped = False
    per_slab = max(MAX_PAIRS // n_slabs, 200)  # every slab searched, each up to its share of MAX_PAIRS
    for k in range(n_slabs):
        x0, x1 = edges[k], edges[k + 1]
        # the slab's own boxes and those reaching into it from the left
        a0 = int(np.searchsorted(xs, x0 - reach, side="left")) if np.isfinite(x0) else 0
        a1 = int(np.searchsorted(xs, x1, side="left")) if np.isfinite(x1) else len(xs)
        sub = order[a0:a1]
        if np.isfinite(x0):
            sub = sub[chi[sub, 0] > x0]
        own = int(np.sum((clo[sub, 0] >= x0) & (clo[sub, 0] < x1)))
        in_slab = 0
        for i, j in _grid_pairs(sub, clo, chi, cpart, size, tol, x0, x1):
            ti, tj = cand[i], cand[j]
            d = tet_overlap_depth(c[tets[ti]], c[tets[tj]], tol)
            hit = d > tol
            found_i.append(ti[hit])
            found_j.append(tj[hit])
            found_d.append(d[hit])
            in_slab += int(hit.sum())
            if in_slab >= per_slab:  # this slab's share of the pairs: on to the next
                capped = True
                break
        else:
            done += own
        n_found += in_slab
    if not n_found:
        return None
    ti, tj, d = np.concatenate(found_i), np.concatenate(found_j), np.concatenate(found_d)
    pi, pj = part[ti], part[tj]
    swap = pi > pj
    ti, tj = np.where(swap, tj, ti), np.where(swap, ti, tj)
    pi, pj = np.minimum(pi, pj), np.maximum(pi, pj)
    keys, cnt = np.unique(pi * n_parts + pj, return_counts=True)
    share = done / len(cand) if capped else 1.0
    olo = np.maximum(lo[ti], lo[tj]).min(axis=0) + centre
    ohi = np.minimum(hi[ti], hi[tj]).max(axis=0) + centre
    cells_p = np.unique(np.concatenate([ti, tj]))
    pc, cc = np.unique(part[cells_p], return_counts=True)
    return {"parts": np.bincount(part, minlength=n_parts).tolist(), "part": part, "found": (ti, tj),
            "pairs": n_found, "capped": capped, "searched": share,
            "by_parts": {(int(k // n_parts), int(k % n_parts)): int(v) for k, v in zip(keys, cnt)},
            "cells": {int(p): int(v) for p, v in zip(pc, cc)},
            "box": ([float(v) for v in olo], [float(v) for v in ohi]), "depth": float(d.max())}


def overlap_message(name: str, info: dict, cell_start: np.ndarray | None = None) -> str:
    """The decline of a mesh whose parts overlap (``info`` from :func:`overlapping_parts`); with
    ``cell_start`` (the mesh's tets grouped into the file's cells) the parts' cells are counted too."""
    parts = info["parts"]
    (p, q), _ = max(info["by_parts"].items(), key=lambda kv: kv[1])
    cells = None
    if cell_start is not None:
        cell = np.searchsorted(cell_start, np.arange(len(info["part"])), side="right") - 1
        cells = [len(np.unique(cell[info["part"] == k])) for k in (p, q)]

    def size(k, i):
        return f"{parts[k]:,} tets" if cells is None else f"{cells[i]:,} cells, {parts[k]:,} tets"

    lo, hi = info["box"]
    box = " .. ".join("(" + ", ".join(f"{v:.4g}" for v in corner) + ")" for corner in (lo, hi))
    more = len(info["by_parts"]) - 1
    others = f" (and {more} other pair(s) of parts)" if more else ""
    count = (f"at least {info['pairs']:,} (the search stops there)" if info["capped"] else f"{info['pairs']:,}")
    found = " found" if info["capped"] else ""
    return (f"{name}: parts of the mesh overlap in space: part {p} ({size(p, 0)}) and part {q} ({size(q, 1)})"
            f"{others}, of the mesh's {len(parts)} parts (cells connected through shared points); {count} "
            f"overlapping tet pair(s), {info['cells'].get(p, 0):,} and {info['cells'].get(q, 0):,} of their tets"
            f"{found}, within the box {box}, up to {info['depth']:.3g} deep. A ray there meets two media at once, "
            "which no preset renders one agreed way: remove the duplicate or overlapping part, or blank the "
            "overlap (vtkGhostType HIDDENCELL) as overset grids do")
