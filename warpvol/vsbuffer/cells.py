"""Convex polyhedral cells for the VSBUFFER renderer (Westermann & Ertl 1997).

The VSBUFFER draws every cell as the triangles of its boundary, with the cell's ID as flat colour, so
any convex polyhedron can be drawn without splitting it. A :class:`ConvexCellMesh` carries such
cells: tetrahedra, hexahedra, wedges (prisms) and pyramids. Inside a cell the scalar is interpolated
piecewise linearly on a fixed decomposition of the cell into tetrahedra (the one
:meth:`ConvexCellMesh.to_tetmesh` returns), so a cell rendered directly and the same mesh split into
tets show the same field; the renderer clips the ray against the cell's *boundary* faces for
visibility (one ID run per cell) and against the pieces only to integrate.

Conventions: ``tets`` (T, 4) lists the pieces, grouped by cell (``cell_start[c] .. cell_start[c+1]``);
``boundary`` (F, 3) are the cell-boundary triangles with outward winding (a piece face whose
neighbour piece belongs to another cell or to none), ``face_cell`` (F,) their cell and
``face_piece`` (F, 2) the ``(piece, local face)`` they come from.

The sweep needs every cell convex: a point of the sweep plane belongs to a cell where the nearest back
face behind it and the nearest front face before it are both that cell's. A hexahedron with a
non-planar face folded inwards (a jittered or curvilinear grid) is not, and drawn whole it claims
points in its concavity and loses the neighbour there. :attr:`ConvexCellMesh.nonconvex` finds such
cells (every vertex of a cell must lie behind the plane of each of its boundary triangles, up to what
float32 resolves at the mesh's scale) and :meth:`ConvexCellMesh.drawable` draws them as their tets.

Example
-------
>>> import numpy as np, pyvista as pv
>>> g = pv.ImageData(dimensions=(3, 2, 2)).cast_to_unstructured_grid()
>>> g.point_data["s"] = g.points[:, 0]
>>> m = ConvexCellMesh.from_pyvista(g, "s")
>>> m.n_cells, m.n_tets, len(m.boundary)                # 2 hexes, 6 tets each, 6 quads = 12 triangles each
(2, 12, 24)
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from warpvol.errors import ConfigError
from warpvol.scene.grids import KUHN_TETS
from warpvol.scene.mesh import FACE_VERTS, TetMesh
from warpvol.shared.thin_cells import thin_tets

# VTK cell types and their decompositions into tets (local vertex indices, VTK point order)
VTK_TETRA, VTK_HEXAHEDRON, VTK_WEDGE, VTK_PYRAMID, VTK_VOXEL = 10, 12, 13, 14, 11
# hexahedron: the Kuhn split around the diagonal 0-6, the one structured grids use (conforming
# between hexes of a lattice); KUHN_TETS index corners as i + 2j + 4k, VTK orders the bottom quad
# counter-clockwise (0,0,0) (1,0,0) (1,1,0) (0,1,0), then the top quad
_HEX_FROM_IJK = np.array([0, 1, 3, 2, 4, 5, 7, 6])
_VOXEL_FROM_IJK = np.arange(8)  # a voxel orders its points i + 2j + 4k already
SPLITS = {
    VTK_TETRA: np.array([[0, 1, 2, 3]]),
    VTK_HEXAHEDRON: _HEX_FROM_IJK[KUHN_TETS],
    VTK_VOXEL: _VOXEL_FROM_IJK[KUHN_TETS],
    # wedge: triangle 0 1 2 below, 3 4 5 above (3 over 0, ...); three tets sharing the quads' diagonals
    VTK_WEDGE: np.array([[0, 1, 2, 3], [1, 2, 3, 4], [2, 3, 4, 5]]),
    # pyramid: quad 0 1 2 3, apex 4, cut along the diagonal 0-2
    VTK_PYRAMID: np.array([[0, 1, 2, 4], [0, 2, 3, 4]]),
}
#: number of points per VTK cell type accepted
CELL_POINTS = {VTK_TETRA: 4, VTK_HEXAHEDRON: 8, VTK_VOXEL: 8, VTK_WEDGE: 6, VTK_PYRAMID: 5}
#: a cell is convex when no vertex lies in front of a boundary triangle's plane by more than this
#: fraction of the mesh's radius: 8 float32 units of roundoff, what the sweep's float32 geometry (points
#: relative to the mesh centre) can resolve
CONVEX_RTOL = 8.0 * 2.0 ** -24


class ConvexCellMesh:
    """Convex cells (tets, hexes, wedges, pyramids) and their piecewise-linear decomposition.

    Parameters
    ----------
    tetmesh : TetMesh
        The pieces, grouped by cell (each cell's pieces contiguous).
    cell_start : (C + 1,) array of int
        Piece ranges per cell; ``None``: every tet is a cell.
    name : str
        Used in messages.
    """

    def __init__(self, tetmesh: TetMesh, cell_start=None, name: str | None = None):
        if not isinstance(tetmesh, TetMesh):
            raise ConfigError(f"tetmesh: expected a TetMesh, got {type(tetmesh).__name__}")
        self.pieces = tetmesh
        t = tetmesh.n_tets
        cs = np.arange(t + 1, dtype=np.int64) if cell_start is None else np.asarray(cell_start, np.int64)
        if cs.ndim != 1 or cs[0] != 0 or cs[-1] != t or (np.diff(cs) < 1).any():
            raise ConfigError(f"cell_start: expected ascending offsets from 0 to {t} with >= 1 piece per cell")
        self.cell_start = cs
        self.name = name or tetmesh.name

    # -- constructors ---------------------------------------------------------------------------
    @classmethod
    def from_tetmesh(cls, mesh: TetMesh) -> "ConvexCellMesh":
        """Every tet one cell (the paper's tetrahedral data sets)."""
        return cls(mesh)

    @classmethod
    def from_pyvista(cls, grid, scalars: str, *, name: str | None = None) -> "ConvexCellMesh":
        """Cells of a pyvista ``UnstructuredGrid`` (tets, hexahedra, voxels, wedges, pyramids) kept whole.

        ``scalars`` names a point-data array. Other cell types are refused, naming them.
        """
        import pyvista as pv

        if not isinstance(grid, pv.UnstructuredGrid):
            raise ConfigError(f"grid: expected a pyvista.UnstructuredGrid, got {type(grid).__name__}")
        if scalars not in grid.point_data:
            raise ConfigError(f"scalars: point-data array {scalars!r} not found; available: {list(grid.point_data)}")
        types = np.asarray(grid.celltypes)
        bad = sorted(set(types.tolist()) - set(SPLITS))
        if bad:
            raise ConfigError(f"grid: cell types {bad} are not convex cells this renderer carries; "
                              f"allowed VTK types: {sorted(SPLITS)} (tetra, voxel, hexahedron, wedge, pyramid)")
        offs = np.asarray(grid.cell_offsets if hasattr(grid, "cell_offsets") else grid.offset, dtype=np.int64)
        conn = np.asarray(grid.cell_connectivity, dtype=np.int64)
        pieces, counts = [], np.zeros(len(types), np.int64)
        for ct, split in SPLITS.items():
            sel = np.nonzero(types == ct)[0]
            if not len(sel):
                continue
            verts = conn[offs[sel][:, None] + np.arange(CELL_POINTS[ct])[None, :]]
            pieces.append((sel, verts[:, split]))  # (n, k, 4)
            counts[sel] = len(split)
        cell_start = np.concatenate([[0], np.cumsum(counts)])
        tets = np.zeros((int(cell_start[-1]), 4), np.int64)
        for sel, p in pieces:
            idx = cell_start[sel][:, None] + np.arange(p.shape[1])[None, :]
            tets[idx.ravel()] = p.reshape(-1, 4)
        pts = np.asarray(grid.points, dtype=np.float64)
        s = np.asarray(grid.point_data[scalars], dtype=np.float64).reshape(-1)
        tm = TetMesh(pts, tets, s, name=name or "pyvista grid", strict=True)
        return cls(tm, cell_start, name=name)

    def to_tetmesh(self) -> TetMesh:
        """The same field as a tet mesh (each piece a tet): what ``warpvol.reference.numpy_render`` integrates."""
        return self.pieces

    # -- sizes and derived data -----------------------------------------------------------------
    @property
    def n_cells(self) -> int:
        return len(self.cell_start) - 1

    @property
    def n_tets(self) -> int:
        return self.pieces.n_tets

    @property
    def points(self) -> np.ndarray:
        return self.pieces.points

    @property
    def scalars(self) -> np.ndarray:
        return self.pieces.scalars

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.pieces.bounds

    @cached_property
    def piece_cell(self) -> np.ndarray:
        """(T,) int64: the cell of every piece."""
        return np.repeat(np.arange(self.n_cells), np.diff(self.cell_start))

    @cached_property
    def _boundary(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        adj = self.pieces.adjacency  # (T, 4); connectivity of the pieces is derived here, never required
        pc = self.piece_cell
        own = pc[:, None] == np.where(adj >= 0, pc[np.maximum(adj, 0)], -1)
        t, f = np.nonzero(~own)
        tris = self.pieces.tets[t[:, None], FACE_VERTS[f]]
        return tris, pc[t], np.stack([t, f], axis=1)

    @property
    def boundary(self) -> np.ndarray:
        """(F, 3) cell-boundary triangles, outward winding."""
        return self._boundary[0]

    @property
    def face_cell(self) -> np.ndarray:
        """(F,) the cell each boundary triangle belongs to."""
        return self._boundary[1]

    @property
    def face_piece(self) -> np.ndarray:
        """(F, 2) ``(piece, local face)`` of each boundary triangle."""
        return self._boundary[2]

    @cached_property
    def cell_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-cell axis-aligned bounding boxes ``(lo (C, 3), hi (C, 3))``."""
        p = self.points[self.pieces.tets]  # (T, 4, 3)
        lo = np.minimum.reduceat(p.min(axis=1), self.cell_start[:-1], axis=0)
        hi = np.maximum.reduceat(p.max(axis=1), self.cell_start[:-1], axis=0)
        return lo, hi

    @cached_property
    def nonconvex(self) -> np.ndarray:
        """(C,) bool: cells whose triangulated boundary is not a convex polyhedron within float32
        resolution: some vertex of the cell lies in front of the plane of one of its boundary
        triangles by more than :data:`CONVEX_RTOL` of the mesh's radius (a non-planar face folded
        inwards, or any other concavity), or a boundary triangle has no area. One-piece cells (tets)
        are convex.

        Examples
        --------
        >>> import pyvista as pv
        >>> g = pv.ImageData(dimensions=(3, 2, 2)).cast_to_unstructured_grid()
        >>> g.point_data["s"] = g.points[:, 0]
        >>> m = ConvexCellMesh.from_pyvista(g, "s"); m.nonconvex.tolist()
        [False, False]
        >>> g.points[11] += (0.0, 0.0, -0.2)   # pull a top corner of the second hex in: its top face folds in
        >>> bent = ConvexCellMesh.from_pyvista(g, "s"); bent.nonconvex.tolist()
        [False, True]
        >>> bent.drawable.n_cells, bent.drawable.n_tets                   # drawn as the first hex and 6 tets
        (7, 12)
        """
        out = np.zeros(self.n_cells, bool)
        multi = np.diff(self.cell_start) > 1
        if not multi.any():
            return out
        lo, hi = self.bounds
        centre = 0.5 * (lo + hi)
        pts = self.points - centre
        tol = CONVEX_RTOL * max(float((0.5 * (hi - lo)).max()), 1e-300)  # max |pts| over the used points
        # the distinct vertices of every multi-piece cell (CSR over cells)
        pc = self.piece_cell
        sel = multi[pc]
        key = np.unique(pc[sel][:, None] * np.int64(self.pieces.n_points) + self.pieces.tets[sel])
        vcell, vert = np.divmod(key, np.int64(self.pieces.n_points))
        vcnt = np.bincount(vcell, minlength=self.n_cells)
        vstart = np.concatenate([[0], np.cumsum(vcnt)])[:-1]
        faces = np.nonzero(multi[self.face_cell])[0]
        tri = pts[self.boundary[faces]]  # (F', 3, 3)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area = np.linalg.norm(n, axis=1)
        np.logical_or.at(out, self.face_cell[faces], ~(area > 0.0))
        n = n / np.maximum(area, 1e-300)[:, None]
        fc = self.face_cell[faces]
        step = 1 << 20  # (triangle, vertex) pairs per chunk
        for f0 in range(0, len(faces), max(1, step // 16)):
            f1 = min(len(faces), f0 + max(1, step // 16))
            counts = vcnt[fc[f0:f1]]
            owner = np.repeat(np.arange(f0, f1), counts)
            item = np.repeat(vstart[fc[f0:f1]] - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)
            v = vert[item + np.arange(len(owner))]
            d = np.einsum("ik,ik->i", pts[v] - tri[owner, 0], n[owner])
            np.logical_or.at(out, fc[owner], d > tol)
        return out

    @cached_property
    def drawable(self) -> "ConvexCellMesh":
        """This mesh with every :attr:`nonconvex` cell replaced by its pieces, one cell each (the
        same field; the sweep draws convex cells only). ``self`` where every cell is convex."""
        bad = self.nonconvex
        if not bad.any():
            return self
        keep = np.ones(self.n_tets + 1, bool)
        keep[1:-1] = False
        keep[self.cell_start] = True  # every cell's first piece starts a cell ...
        keep[np.nonzero(bad[self.piece_cell])[0]] = True  # ... and every piece of a non-convex cell
        return ConvexCellMesh(self.pieces, np.nonzero(keep)[0], name=self.name)

    def thin_pieces(self, transfer) -> np.ndarray:
        """(T,) bool: pieces thinner than float32 resolves for their extinction
        (:func:`warpvol.shared.thin_cells.thin_tets`)."""

        return thin_tets(self.pieces, transfer)

    def __repr__(self) -> str:
        return f"ConvexCellMesh({self.name!r}, {self.n_cells} cells, {self.n_tets} tets)"
