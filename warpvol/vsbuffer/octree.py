"""Octree of cell bounding boxes for the VSBUFFER sweep (:mod:`warpvol.vsbuffer.vsbuffer`): which cells each
sweep plane draws."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from warpvol.errors import ConfigError


@dataclass
class Octree:
    """Regular octree: node boxes (world), parent links and the cells stored at each node (CSR)."""

    lo: np.ndarray          # (N, 3)
    hi: np.ndarray          # (N, 3)
    parent: np.ndarray      # (N,) -1 for the root
    cell_start: np.ndarray  # (N + 1,)
    cells: np.ndarray       # cells grouped by node
    depth: int

    @property
    def n_nodes(self) -> int:
        return len(self.parent)


def build_octree(cell_lo: np.ndarray, cell_hi: np.ndarray, depth: int, insert: str = "containing") -> Octree:
    """Regular octree of ``depth`` levels below the root over the cells' bounding boxes.

    ``insert="containing"`` (the paper's rule, the default): every cell at the deepest node whose
    region fully contains the cell's box, node boxes the regions (cells straddling a split stay high,
    so a plane visits them for many scanlines: with every cell of a cut node drawn, 11.92 M drawn tets
    on the Blunt Fin at 450 scanlines; with each visited cell's own box tested, as the sweep does by
    default, 1.37 M, against the paper's 2.10 M).
    ``insert="centroid"``: every cell in the leaf holding its box centre; a node's box is the union of
    the boxes of the cells below it (with every cell of a cut node drawn, 2.29 M drawn tets on the
    Blunt Fin; with the per-cell test the same 1.37 M, from fewer box tests).
    Only non-empty nodes and their ancestors are kept.

    Examples
    --------
    >>> lo = np.array([[0, 0, 0], [0.6, 0.6, 0.6], [0.4, 0, 0]]); hi = lo + 0.3
    >>> t = build_octree(lo, hi, 2)
    >>> t.n_nodes, [int(n) for n in np.diff(t.cell_start)]        # root holds the straddling cell
    (3, [1, 1, 1])
    >>> t = build_octree(lo, hi, 2, "centroid")
    >>> [int(n) for n in np.diff(t.cell_start)], t.hi[0].round(6).tolist()  # cells in leaves; tight root box
    ([0, 0, 0, 0, 1, 1, 1], [0.9, 0.9, 0.9])
    """
    glo, ghi = cell_lo.min(axis=0), cell_hi.max(axis=0)
    ext = np.maximum(ghi - glo, 1e-300)
    n_leaf = 2 ** depth
    if insert == "centroid":
        level = np.full(len(cell_lo), depth, np.int64)
        idx = np.clip(np.floor((0.5 * (cell_lo + cell_hi) - glo) / ext * n_leaf), 0, n_leaf - 1).astype(np.int64)
    elif insert == "containing":
        level = np.zeros(len(cell_lo), np.int64)
        idx = np.zeros((len(cell_lo), 3), np.int64)
        for lv in range(1, depth + 1):
            n = 2 ** lv
            a = np.clip(np.floor((cell_lo - glo) / ext * n), 0, n - 1).astype(np.int64)
            b = np.clip(np.floor((cell_hi - glo) / ext * n), 0, n - 1).astype(np.int64)
            ok = (a == b).all(axis=1) & (level == lv - 1)
            level[ok], idx[ok] = lv, a[ok]
    else:
        raise ConfigError(f"insert: {insert!r} not allowed; allowed: centroid, containing")
    # node keys: (level, ix, iy, iz) for every cell's node and all its ancestors
    keys = []
    for lv in range(depth + 1):
        sel = level >= lv
        keys.append(np.column_stack([np.full(sel.sum(), lv), idx[sel] >> (level[sel] - lv)[:, None]]))
    def code(k: np.ndarray) -> np.ndarray:  # (level, ix, iy, iz) -> one int64, ordered by level first
        return ((k[:, 0] * (1 << 20) + k[:, 1]) * (1 << 20) + k[:, 2]) * (1 << 20) + k[:, 3]

    allk = np.concatenate(keys)
    ncode, first = np.unique(code(allk), return_index=True)
    allk = allk[first]
    size = ext / (2.0 ** allk[:, 0])[:, None]
    nlo = glo + allk[:, 1:] * size
    nhi = nlo + size
    par = allk.copy()
    par[:, 0] -= 1
    par[:, 1:] >>= 1
    parent = np.where(allk[:, 0] > 0, np.searchsorted(ncode, code(np.maximum(par, 0))), -1)
    node_of_cell = np.searchsorted(ncode, code(np.column_stack([level, idx])))
    cells = np.argsort(node_of_cell, kind="stable")
    start = np.concatenate([[0], np.cumsum(np.bincount(node_of_cell, minlength=len(allk)))])
    if insert == "centroid":
        # tight boxes: union of the cells' boxes, propagated from the leaves up (deepest level first)
        nlo = np.full((len(allk), 3), np.inf)
        nhi = np.full((len(allk), 3), -np.inf)
        np.minimum.at(nlo, node_of_cell, cell_lo)
        np.maximum.at(nhi, node_of_cell, cell_hi)
        for lv in range(depth, 0, -1):
            sel = np.nonzero(allk[:, 0] == lv)[0]
            np.minimum.at(nlo, parent[sel], nlo[sel])
            np.maximum.at(nhi, parent[sel], nhi[sel])
    return Octree(nlo, nhi, parent, start, cells, depth)


def box_corners_yz(lo: np.ndarray, hi: np.ndarray, camera) -> tuple[np.ndarray, np.ndarray]:
    """(N, 8) eye-space ``y`` (along the camera's true up) and ``z`` (along its forward axis) of the 8
    corners of each world box ``lo[i] .. hi[i]``."""
    corners = np.stack([np.where(np.array([(m >> k) & 1 for k in range(3)], bool), hi, lo)
                        for m in range(8)], axis=1) - camera.eye  # (N, 8, 3)
    return corners @ camera.true_up, corners @ camera.forward


def _plane_terms(camera, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row ``(offset, slope)``: a point's signed distance from the row's sweep plane (world units
    along ``y``) is ``y - offset - slope * z``."""
    yn = 1.0 - 2.0 * (np.asarray(rows, np.float64) + 0.5) / camera.height_px
    if camera.projection == "orthographic":
        return yn * camera.ortho_height / 2.0, np.zeros_like(yn)
    # plane through the eye containing the row's rays: y = z * tan(fov/2) * y_ndc
    return np.zeros_like(yn), yn * np.tan(np.radians(camera.fov_y_deg) / 2.0)


def plane_node_hits(tree: Octree, camera, rows: np.ndarray) -> np.ndarray:
    """(P, N) bool: sweep plane of image row ``rows[p]`` cuts node ``n``'s box (world-space test: the
    box's 8 corners do not all lie strictly on one side of the plane)."""
    y, z = box_corners_yz(tree.lo, tree.hi, camera)
    off, slope = _plane_terms(camera, rows)
    dist = y[None] - off[:, None, None] - slope[:, None, None] * z[None]
    return (dist.min(axis=2) <= 0.0) & (dist.max(axis=2) >= 0.0)


def plane_box_cut(y: np.ndarray, z: np.ndarray, camera, rows: np.ndarray) -> np.ndarray:
    """(K,) bool: sweep plane of image row ``rows[k]`` cuts box ``k``, given its corners' ``y, z``
    (:func:`box_corners_yz`, rows ``k``): the test of :func:`plane_node_hits`, one (plane, box) pair
    per entry (a sweep plane's per-cell selection).

    Examples
    --------
    >>> from warpvol.scene.camera import Camera
    >>> cam = Camera(projection="orthographic", eye=(0, 0, 5), target=(0, 0, 0), ortho_height=2.0,
    ...              width_px=4, height_px=4)   # row j's plane: y = 1 - (j + 0.5) / 2
    >>> y, z = box_corners_yz(np.array([[0.0, 0.1, 0.0]] * 2), np.array([[1.0, 0.3, 1.0]] * 2), cam)
    >>> plane_box_cut(y, z, cam, np.array([1, 2])).tolist()   # y = 0.25 cuts [0.1, 0.3]; y = -0.25 does not
    [True, False]
    """
    off, slope = _plane_terms(camera, rows)
    dist = y - off[:, None] - slope[:, None] * z
    return (dist.min(axis=1) <= 0.0) & (dist.max(axis=1) >= 0.0)


def _expand(starts: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For CSR ranges ``starts[i] .. starts[i] + counts[i]``: (owner index, item index) of every item."""
    owner = np.repeat(np.arange(len(counts)), counts)
    base = np.repeat(starts - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)
    return owner, base + np.arange(len(owner))
