"""Meshes whose cells meet without sharing faces, for tests and stress cases.

* :func:`glued_blocks`: two blocks of Kuhn-split cubes glued along ``x = 0``, the second mirrored in
  ``y`` so every quad of the interface is cut along the other diagonal from each side (watertight, no
  hanging vertex): ``2 * 2 * (n - 1)^2`` non-conforming faces.
* :func:`hybrid_grid`: an unstructured grid of hexahedra, pyramids and wedges in conforming layers,
  point ids shuffled (a split must pick the same diagonal on a shared quad face from both sides).
* :func:`explode`: the same grid with every cell on its own copies of its points, as exporters
  that write cell by cell produce (interior faces coincide without being shared).
* :func:`two_blocks`: two blocks on separate points, overlapping (an assembly whose parts overlap, a
  part written twice: declined) or touching along a shifted, non-conforming interface (rendered).
"""

from __future__ import annotations

import numpy as np

from warpvol.scene.camera import Camera
from warpvol.scene.grids import grid_points, structured_to_tets
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import TransferFunction


def _field(p: np.ndarray) -> np.ndarray:
    return np.sin(2.0 * p[:, 0]) + 0.5 * p[:, 1] + p[:, 2] ** 2


def glued_blocks(n: int = 3) -> TetMesh:
    """Blocks ``[-1, 0] x [-1, 1]^2`` and ``[0, 1] x [-1, 1]^2`` of ``(n - 1)^3`` Kuhn-split cubes each,
    sharing the points of ``x = 0`` but not one face there."""
    dims = (n, n, n)
    axis = np.linspace(-1.0, 1.0, n)
    pa = grid_points(np.linspace(-1.0, 0.0, n), axis, axis)
    pb = pa.copy()
    pb[:, 0] += 1.0
    pb[:, 1] *= -1.0  # mirrored in y: the interface quads are cut along the other diagonal
    tets = np.vstack([structured_to_tets(dims), structured_to_tets(dims) + len(pa)])
    pts = np.vstack([pa, pb])
    _, first, inv = np.unique(np.round(pts, 12), axis=0, return_index=True, return_inverse=True)
    tets = first[inv.ravel()][tets]  # one point on the interface, used by both blocks
    keep = np.unique(tets)
    remap = np.full(len(pts), -1)
    remap[keep] = np.arange(len(keep))
    pts = pts[keep]
    return TetMesh(pts, remap[tets], _field(pts), name=f"glued_blocks_{n}")


def hybrid_grid(n: int = 3, seed: int = 5, spacing=(0.7, 0.6, 0.65)):
    """pyvista UnstructuredGrid of ``n^3`` boxes: layer ``k = 0`` hexahedra, ``k = 1`` six pyramids
    around the box centre, ``k >= 2`` two wedges (cut by the box's plane ``x = z``, triangles on
    ``y = const``). Point ids shuffled by ``seed``; point data ``"s"``."""
    import pyvista as pv

    m = n + 1
    g = np.stack(np.meshgrid(*[np.arange(m)] * 3, indexing="ij"), -1).reshape(-1, 3)
    h = np.asarray(spacing, dtype=np.float64)
    pts = g * h - h * n / 2.0
    cells = {pv.CellType.HEXAHEDRON: [], pv.CellType.PYRAMID: [], pv.CellType.WEDGE: []}
    extra = []
    for i in range(n):
        for j in range(n):
            for k in range(n):
                c = {(a, b, d): ((i + a) * m + j + b) * m + k + d for a in (0, 1) for b in (0, 1) for d in (0, 1)}
                hx = [c[0, 0, 0], c[1, 0, 0], c[1, 1, 0], c[0, 1, 0], c[0, 0, 1], c[1, 0, 1], c[1, 1, 1], c[0, 1, 1]]
                if k == 0:
                    cells[pv.CellType.HEXAHEDRON].append(hx)
                elif k == 1:
                    centre = len(pts) + len(extra)
                    extra.append(pts[hx].mean(axis=0))
                    # bases ordered so their right-hand normal points to the apex (VTK)
                    for q in ([0, 1, 2, 3], [7, 6, 5, 4], [0, 4, 5, 1], [1, 5, 6, 2], [2, 6, 7, 3], [3, 7, 4, 0]):
                        cells[pv.CellType.PYRAMID].append([hx[q[0]], hx[q[1]], hx[q[2]], hx[q[3]], centre])
                else:
                    cells[pv.CellType.WEDGE].append([c[0, 0, 0], c[0, 0, 1], c[1, 0, 1], c[0, 1, 0], c[0, 1, 1], c[1, 1, 1]])
                    cells[pv.CellType.WEDGE].append([c[0, 0, 0], c[1, 0, 1], c[1, 0, 0], c[0, 1, 0], c[1, 1, 1], c[1, 1, 0]])
    if extra:
        pts = np.vstack([pts, extra])
    perm = np.random.default_rng(seed).permutation(len(pts))
    new_id = np.argsort(perm)
    grid = pv.UnstructuredGrid({k: new_id[np.array(v)] for k, v in cells.items() if v}, pts[perm])
    grid.point_data["s"] = _field(np.asarray(grid.points))
    return grid


def explode(grid):
    """``grid`` with every cell on its own copies of its points (same positions and scalars)."""
    import pyvista as pv

    conn = np.asarray(grid.cell_connectivity)
    off = np.asarray(grid.cell_offsets)
    types = np.asarray(grid.celltypes)
    cells: dict[int, list] = {}
    for c in range(grid.n_cells):
        cells.setdefault(int(types[c]), []).append(np.arange(off[c], off[c + 1]))
    out = pv.UnstructuredGrid({k: np.array(v) for k, v in cells.items()}, np.asarray(grid.points)[conn])
    for name in grid.point_data.keys():
        out.point_data[name] = np.asarray(grid.point_data[name])[conn]
    return out


def two_blocks(n: int = 3, shift=(1.0, 0.0, 0.0)) -> TetMesh:
    """Blocks ``[-1, 0] x [-1, 1]^2`` of ``(n - 1)^3`` Kuhn-split cubes and a copy moved by ``shift``,
    each on its own points: ``(1, 0, 0)`` touches at ``x = 0``, ``(1, 0.3, 0.2)`` touches on a shifted,
    non-conforming interface, ``(0.5, 0, 0)`` overlaps by half, ``(0, 0, 0)`` is the part written twice."""
    axis = np.linspace(-1.0, 1.0, n)
    pa = grid_points(np.linspace(-1.0, 0.0, n), axis, axis)
    pts = np.vstack([pa, pa + np.asarray(shift, dtype=np.float64)])
    t = structured_to_tets((n, n, n))
    return TetMesh(pts, np.vstack([t, t + len(pa)]), _field(pts), name=f"two_blocks_{n}")


#: TF of the topology cases over the field's range (about [-1.7, 2.7]): [s, r, g, b, extinction]
TOPOLOGY_TF = ((-1.7, 0.9, 0.3, 0.1, 0.7), (0.3, 0.2, 0.8, 0.4, 1.8), (2.7, 0.2, 0.3, 1.0, 0.9))


def add_topology_cases(simple, sc) -> None:
    """Register the stress cases of this module with ``simple(name, doc, build)`` (see
    :func:`warpvol.tools.stress_real.topology_cases`)."""

    def cam(quick: bool) -> Camera:
        px = 24 if quick else 128
        return Camera(eye=(2.4, 1.8, 3.0), target=(0.05, -0.05, 0.0), fov_y_deg=42.0, width_px=px, height_px=px)

    def tf() -> TransferFunction:
        return TransferFunction([list(p) for p in TOPOLOGY_TF])

    def hybrid(quick: bool, exploded: bool) -> TetMesh:
        g = hybrid_grid(n=3 if quick else 6, seed=3, spacing=(0.7, 0.6, 0.65) if quick else (0.35, 0.3, 0.325))
        return TetMesh.from_pyvista(explode(g) if exploded else g, "s", name="hybrid_cells")

    simple("topology_glued_blocks", "two tet blocks glued along x = 0 with opposite quad diagonals (watertight, "
           "no shared face across the interface): non-conforming faces, re-entry at the interface",
           lambda q: sc(glued_blocks(3 if q else 7), tf(), cam(q), "topology_glued_blocks"))
    simple("topology_hybrid_cells", "unstructured hexahedra, pyramids and wedges with shuffled point ids, split "
           "into tets by the loader (conforming quad diagonals)",
           lambda q: sc(hybrid(q, False), tf(), cam(q), "topology_hybrid_cells"))
    simple("topology_duplicated_points", "the hexahedron / pyramid / wedge grid with every cell on its own copies "
           "of its points: interior faces coincide without being shared (crack faces)",
           lambda q: sc(hybrid(q, True), tf(), cam(q), "topology_duplicated_points"))
    for name, shift, doc in (
            ("topology_overlapping_parts", (0.5, 0.0, 0.0), "two blocks on separate points overlapping by half "
             "(an assembly whose parts overlap): declined naming the parts, the reference too"),
            ("topology_part_twice", (0.0, 0.0, 0.0), "a block written twice on separate points: declined"),
            ("topology_touching_parts", (1.0, 0.3, 0.2), "two blocks on separate points touching on a shifted, "
             "non-conforming interface: rendered (re-entry at the interface)")):
        simple(name, doc, lambda q, shift=shift, name=name: sc(two_blocks(3 if q else 7, shift), tf(), cam(q), name))
