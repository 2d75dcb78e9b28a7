"""Structured grids as tets (Kuhn 6-tet and alternating 5-tet splits), grid points and the welding of
coincident points: plain numpy, below the mesh class.
"""

from __future__ import annotations

import itertools

import numpy as np

from warpvol.errors import MeshError

# -- structured grids -> tets --------------------------------------------------------------------
# Kuhn/Freudenthal split: 6 tets around the main diagonal (0,0,0)-(1,1,1) of each hex, one per
# permutation of the axes. The same split in every cell gives a conforming triangulation of the
# lattice (each quad face is cut along the same diagonal from both sides).
_CORNER = {(i, j, k): i + 2 * j + 4 * k for i in (0, 1) for j in (0, 1) for k in (0, 1)}


def _kuhn_tets() -> np.ndarray:
    out = []
    for perm in itertools.permutations(range(3)):
        v = [0, 0, 0]
        path = [_CORNER[tuple(v)]]
        for ax in perm:
            v[ax] = 1
            path.append(_CORNER[tuple(v)])
        out.append(path)
    return np.array(out, dtype=np.int64)


KUHN_TETS = _kuhn_tets()


def structured_to_tets(dims: tuple[int, int, int]) -> np.ndarray:
    """Tets (6 per hex cell) of a structured grid with ``dims = (ni, nj, nk)`` points whose point
    index is ``i + ni*(j + nj*k)`` (Fortran / VTK order). Returns (6*(ni-1)(nj-1)(nk-1), 4)."""
    ni, nj, nk = (int(d) for d in dims)
    if min(ni, nj, nk) < 2:
        raise MeshError(f"structured grid dims {dims}: need at least 2 points along each axis")
    i, j, k = np.meshgrid(np.arange(ni - 1), np.arange(nj - 1), np.arange(nk - 1), indexing="ij")
    base = (i + ni * (j + nj * k)).transpose(2, 1, 0).ravel()  # cells in Fortran order
    corner_off = np.array([ci + ni * (cj + nj * ck) for ck in (0, 1) for cj in (0, 1) for ci in (0, 1)])
    corners = base[:, None] + corner_off[None, :]  # (C, 8) with corner index i + 2j + 4k
    return corners[:, KUHN_TETS].reshape(-1, 4)


# -- grids ----------------------------------------------------------------------------------------
# 5-tet split of a cube with corners c = i + 2j + 4k: a central tet on 4 corners of one parity and
# 4 corner tets cut off at the other 4 corners. "even" uses the central tet {000, 110, 101, 011}.
_FIVE_EVEN = np.array([[0, 3, 5, 6], [1, 0, 3, 5], [2, 0, 3, 6], [4, 0, 5, 6], [7, 3, 5, 6]], dtype=np.int64)
_FIVE_ODD = np.array([[1, 2, 4, 7], [0, 1, 2, 4], [3, 1, 2, 7], [5, 1, 4, 7], [6, 2, 4, 7]], dtype=np.int64)


def grid_points(xs, ys, zs) -> np.ndarray:
    """Points of a rectilinear grid, index ``i + ni*(j + nj*k)`` (``i`` fastest), (N, 3) float64."""
    zz, yy, xx = np.meshgrid(np.asarray(zs, float), np.asarray(ys, float), np.asarray(xs, float), indexing="ij")
    return np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])


def cell_corners(dims) -> np.ndarray:
    """(C, 8) point indices of the hex cells of a structured grid of ``dims`` points, cells in VTK's
    order (``i`` fastest), corner ``i + 2j + 4k``."""
    ni, nj, nk = (int(d) for d in dims)
    i, j, k = np.meshgrid(np.arange(ni - 1), np.arange(nj - 1), np.arange(nk - 1), indexing="ij")
    base = (i + ni * (j + nj * k)).transpose(2, 1, 0).ravel()
    off = np.array([ci + ni * (cj + nj * ck) for ck in (0, 1) for cj in (0, 1) for ci in (0, 1)])
    return base[:, None] + off[None, :]


def structured_to_tets5(dims, *, alternate: bool = True) -> np.ndarray:
    """Tets (5 per hex cell) of a structured grid with ``dims = (ni, nj, nk)`` points, point index
    ``i + ni*(j + nj*k)``, cells in the same order. The split's parity alternates with
    ``(i + j + k) % 2`` so every quad face is cut along the same diagonal from both sides (the
    diagonals join grid points with even ``i + j + k``). ``alternate=False`` uses one parity
    everywhere, which does *not* conform (kept for tests). Returns (5*(ni-1)(nj-1)(nk-1), 4)."""
    ni, nj, nk = (int(d) for d in dims)
    if min(ni, nj, nk) < 2:
        raise MeshError(f"structured grid dims {dims}: need at least 2 points along each axis")
    corners = cell_corners((ni, nj, nk))
    i, j, k = np.meshgrid(np.arange(ni - 1), np.arange(nj - 1), np.arange(nk - 1), indexing="ij")
    odd = ((i + j + k) % 2).transpose(2, 1, 0).ravel().astype(bool) if alternate else np.zeros(len(corners), bool)
    out = np.where(odd[:, None, None], corners[:, _FIVE_ODD], corners[:, _FIVE_EVEN])
    return out.reshape(-1, 4)


def weld_coincident_points(points: np.ndarray, tets: np.ndarray, scalars: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray, int]:
    """Make tets refer to one representative of each group of bit-identical points.

    Returns ``(tets, scalars, n_welded)``: the points array is unchanged (duplicates stay, unused);
    every point of a group gets the group's mean scalar. Tets that contained two points of one group
    now repeat an index and have zero volume, so :class:`TetMesh` drops them.
    """
    _, first, inv, counts = np.unique(points, axis=0, return_index=True, return_inverse=True,
                                      return_counts=True)
    inv = inv.ravel()
    n_welded = int(len(points) - len(first))
    if n_welded == 0:
        return tets, scalars, 0
    rep = first[inv]
    mean = np.bincount(inv, weights=scalars, minlength=len(first)) / counts
    return rep[tets], mean[inv], n_welded
