"""Tetrahedral meshes: validation and derived data (adjacency, planes, gradients, ...).

Conventions
-----------
* ``tets[c]`` lists 4 point indices with positive signed volume
  ``det(p1 - p0, p2 - p0, p3 - p0) > 0`` (inverted tets are reoriented on load).
* Local face ``i`` of a tet is the face *opposite* vertex ``i`` (``FACE_VERTS[i]``);
  ``adjacency[c, i]`` is the tet across it, ``-1`` on the boundary.
* ``face_planes[c, i] = (n, o)`` with unit outward normal ``n``: ``n . x + o = 0`` on the face,
  ``< 0`` inside the tet.
* ``gradients[c] = g`` and ``offsets[c] = g0`` with ``s(x) = g . x + g0`` inside tet ``c``.
"""

from __future__ import annotations

import warnings
from functools import cached_property

import numpy as np

from warpvol.errors import MeshError, check_finite_array
from warpvol.scene import interop
from warpvol.scene.face_overlap import overlapping_opposite_faces, row_keys
from warpvol.scene.overlap import overlap_message, overlapping_parts

# face i is opposite vertex i; the order gives an outward normal for positively oriented tets
FACE_VERTS = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], dtype=np.int64)
#: tets per chunk of the per-tet geometry (face planes): bounds its temporaries
_CHUNK_TETS = 1 << 16


def _face_planes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """``(len(tets), 4, 4)`` face planes (:attr:`TetMesh.face_planes`) of ``tets``."""
    p = points[tets]  # (M,4,3)
    tri = p[:, FACE_VERTS]  # (M,4,3,3)
    n = np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    o = -np.einsum("mfk,mfk->mf", n, tri[:, :, 0])
    # orient outward: the opposite vertex must be on the negative side
    side = np.einsum("mfk,mfk->mf", n, p) + o
    flip = side > 0
    n[flip] *= -1
    o[flip] *= -1
    return np.concatenate([n, o[..., None]], axis=-1)


EDGE_VERTS = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)


def signed_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Six times the signed volume of each tet (float64)."""
    p = points[tets]
    a, b, c = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
    return np.einsum("ij,ij->i", a, np.cross(b, c))


def _as_array(name: str, arg: str, value, dtype) -> np.ndarray:
    """A fresh numpy copy of ``value``; ragged or non-numeric input is an error naming ``arg``."""
    if isinstance(value, (str, bytes, dict, set)) or value is None:
        raise MeshError(f"{name}: {arg} must be an array of numbers, got {type(value).__name__} {value!r:.60}")
    try:
        arr = np.array(value, dtype=dtype, copy=True)
    except (TypeError, ValueError) as e:
        raise MeshError(f"{name}: {arg} must be a rectangular array of numbers (ragged or non-numeric "
                        f"input: {e})") from None
    if arr.dtype == object or arr.dtype.kind in "USV":
        raise MeshError(f"{name}: {arg} must be an array of numbers, got dtype {arr.dtype}")
    return arr


class TetMesh:
    """A validated tetrahedral mesh with point scalars.

    Parameters
    ----------
    points : (N, 3) array of float
    tets : (M, 4) array of int, indices into ``points``
    scalars : (N,) array of float
    name : str
        Used in messages (e.g. the file it came from).
    strict : bool
        Zero-volume tets are an error instead of being dropped with a warning.
    zero_volume_rtol : float
        A tet counts as zero-volume when ``|6 V| <= zero_volume_rtol * (longest edge)^3``.
    cell_start : (C + 1,) array of int, optional
        Consecutive tets grouped into the source cells they were split from (tets ``cell_start[c]
        .. cell_start[c + 1]`` are cell ``c``; loaders set it when they split convex cells). Only the
        VSBUFFER renderer uses it, to draw such cells whole (``vsb_setup cells = "native"``); dropped
        zero-volume tets leave their cells, a cell left without tets is dropped.
    load_notes : dict, optional
        What the loader left out of the data set it read, as counts (ghost cells of other pieces,
        zero-volume pieces of collapsed cells, ...); every render's report repeats them under
        ``"mesh_notes"``. Given (even empty), it also takes the zero-volume tets dropped here, counted
        in the source cells (``cell_start``) instead of a warning: ``zero_volume_cells_dropped``
        (cells without volume, as a cohesive layer's), and ``collapsed_cells`` /
        ``collapsed_pieces_dropped`` (cells that keep a volume and lose their flat pieces).

    Examples
    --------
    >>> m = TetMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]], [0, 1, 2, 3])
    >>> m.n_tets, m.adjacency.tolist(), m.is_convex
    (1, [[-1, -1, -1, -1]], True)
    """

    def __init__(self, points, tets, scalars, *, name: str = "mesh", strict: bool = False,
                 zero_volume_rtol: float = 1e-12, cell_start=None, load_notes: dict | None = None):
        self.name = name
        self.load_notes = dict(load_notes or {})
        # copies: the caller's arrays stay writable and later edits to them cannot reach the mesh
        points = _as_array(name, "points", points, np.float64)
        tets = _as_array(name, "tets", tets, None)
        scalars = _as_array(name, "scalars", scalars, np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise MeshError(f"{name}: points must have shape (N, 3), got {points.shape}")
        if tets.ndim != 2 or tets.shape[1] != 4:
            raise MeshError(f"{name}: tets must have shape (M, 4), got {tets.shape}")
        if len(points) == 0 or len(tets) == 0:
            raise MeshError(f"{name}: empty mesh ({len(points)} points, {len(tets)} tets)")
        if not np.issubdtype(tets.dtype, np.integer):
            raise MeshError(f"{name}: tets: indices must be integers, got dtype {tets.dtype}")
        if scalars.shape != (len(points),):
            raise MeshError(f"{name}: scalars must have one value per point ({len(points)}), got shape {scalars.shape}")
        check_finite_array(f"{name}: points", points)
        check_finite_array(f"{name}: scalars", scalars)
        tets = tets.astype(np.int64)
        bad = (tets < 0) | (tets >= len(points))
        if bad.any():
            c, k = np.argwhere(bad)[0]
            raise MeshError(
                f"{name}: tet index out of range: tets[{c}][{k}] = {tets[c, k]}, expected 0 <= index < {len(points)}"
            )
        self.n_input_tets = len(tets)
        check_duplicate_tets(name, tets)
        vol6 = signed_volumes(points, tets)
        edges = points[tets[:, EDGE_VERTS[:, 1]]] - points[tets[:, EDGE_VERTS[:, 0]]]
        longest = np.sqrt((edges ** 2).sum(-1).max(axis=1))
        zero = np.abs(vol6) <= zero_volume_rtol * np.maximum(longest, 1e-300) ** 3
        if zero.any():
            msg = f"{name}: {int(zero.sum())} zero-volume tet(s) (first: tets[{int(np.argmax(zero))}])"
            if strict:
                raise MeshError(msg + "; strict mode forbids them")
            if load_notes is None:
                warnings.warn(msg + " dropped", stacklevel=2)
            else:  # a reader's mesh: counted in the file's cells among its load notes
                _count_zero_volume(self.load_notes, zero, cell_start)
            self.dropped_tets = tets[zero]
            tets, vol6 = tets[~zero], vol6[~zero]
            if len(tets) == 0:
                raise MeshError(f"{name}: empty mesh (every tet has zero volume)")
        inverted = vol6 < 0
        self.n_reoriented = int(inverted.sum())
        if self.n_reoriented:
            tets = tets.copy()
            tets[inverted, 2], tets[inverted, 3] = tets[inverted, 3].copy(), tets[inverted, 2].copy()
        self.n_dropped = int(zero.sum())
        self.points, self.tets, self.scalars = points, tets, scalars
        self.cell_start = None if cell_start is None else _cell_groups(name, cell_start, zero)
        for a in (self.points, self.tets, self.scalars) + (() if self.cell_start is None else (self.cell_start,)):
            a.setflags(write=False)
        _ = self.adjacency  # eager: non-manifold faces are an input error, report it on load

    # -- sizes ----------------------------------------------------------------------------------
    @property
    def n_points(self) -> int:
        return len(self.points)

    @property
    def n_tets(self) -> int:
        return len(self.tets)

    @cached_property
    def point_used(self) -> np.ndarray | None:
        """Which points a tet uses (bool per point), or ``None`` when every point is used. A part cut
        from a larger model often keeps its parent's points; bounds, scalar ranges and every frame
        built from them come from the used points alone."""
        used = np.zeros(len(self.points), dtype=bool)
        used[self.tets.ravel()] = True
        if used.all():
            return None
        used.setflags(write=False)
        return used

    @property
    def n_unused_points(self) -> int:
        used = self.point_used
        return 0 if used is None else int(len(used) - used.sum())

    @cached_property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(min, max)`` corners of the points the tets use."""
        p = self.points if self.point_used is None else self.points[self.point_used]
        return p.min(axis=0), p.max(axis=0)

    @cached_property
    def bounding_radius(self) -> float:
        """Largest distance of a point from the centre of :attr:`bounds` (every point, used or not: the sphere
        about that centre holds the whole point set)."""
        lo, hi = self.bounds
        return float(np.sqrt(((self.points - 0.5 * (lo + hi)) ** 2).sum(axis=1).max()))

    @cached_property
    def scalar_range(self) -> tuple[float, float]:
        """Smallest and largest scalar of the points the tets use."""
        s = self.scalars if self.point_used is None else self.scalars[self.point_used]
        return float(s.min()), float(s.max())

    # -- topology ---------------------------------------------------------------------------------
    @cached_property
    def sorted_tets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(tets, parity, perm)``: each tet's vertex indices in ascending order (M, 4), the parity of
        that reordering (M,) int8 (+1 even, -1 odd: the sorted tet's orientation relative to the
        stored, positively oriented one) and the permutation itself (M, 4) -- the canonical vertex order
        the exact walkers take their edge and face predicates in."""
        perm = np.argsort(self.tets, axis=1, kind="stable")
        inv = np.zeros(len(perm), dtype=np.int64)
        for i in range(4):
            for j in range(i + 1, 4):
                inv += perm[:, i] > perm[:, j]
        parity = np.where(inv % 2 == 0, 1, -1).astype(np.int8)
        return np.take_along_axis(self.tets, perm, axis=1), parity, perm

    @cached_property
    def adjacency(self) -> np.ndarray:
        """(M, 4) int32: tet across local face i, -1 on the boundary."""
        m = self.n_tets
        n = np.int64(self.n_points)
        # one key per (tet, local face) at 4 tet + face, built a face at a time: the build holds about 120
        # bytes per tet at its peak (a (4M, 3) table of the faces' points and np.unique held three times that)
        if n < 2_000_000:
            key = np.empty((m, 4), dtype=np.int64)
            for f in range(4):
                tri = np.sort(self.tets[:, FACE_VERTS[f]], axis=1)
                key[:, f] = (tri[:, 0] * n + tri[:, 1]) * n + tri[:, 2]
            key = key.reshape(-1)
            order = np.argsort(key, kind="stable")
            sk = key[order]
            del key
            same = sk[1:] == sk[:-1]
        else:
            faces = np.sort(self.tets[:, FACE_VERTS].reshape(-1, 3), axis=1)  # (4M, 3)
            order = np.lexsort((faces[:, 2], faces[:, 1], faces[:, 0]))
            sk = faces[order]
            same = (sk[1:] == sk[:-1]).all(axis=1)
        three = same[1:] & same[:-1]
        if three.any():
            g = int(np.argmax(three))
            run = g + 1
            while run < len(same) and same[run]:
                run += 1
            who = np.sort(order[g:run + 1]) // 4
            face = np.sort(self.tets[who[0], FACE_VERTS[int(np.sort(order[g:run + 1])[0] % 4)]])
            raise MeshError(
                f"{self.name}: face {face.tolist()} is shared by "
                f"{run + 1 - g} tets ({who.tolist()[:6]}); a face may be shared by at most 2"
            )
        pair = np.flatnonzero(same)
        a, b = order[pair], order[pair + 1]
        adj = np.full(4 * m, -1, dtype=np.int32)
        adj[a], adj[b] = b // 4, a // 4
        return adj.reshape(m, 4)

    @cached_property
    def boundary_faces(self) -> np.ndarray:
        """(B, 2) int64 rows ``(tet, local face)`` of faces without a neighbour."""
        return np.argwhere(self.adjacency < 0).astype(np.int64)

    def boundary_triangles(self) -> np.ndarray:
        """(B, 3) point indices of boundary faces, ordered so the normal points outward."""
        bf = self.boundary_faces
        return self.tets[bf[:, 0][:, None], FACE_VERTS[bf[:, 1]]]

    # -- geometry -------------------------------------------------------------------------------
    @cached_property
    def face_planes(self) -> np.ndarray:
        """(M, 4, 4) float64: ``(nx, ny, nz, o)`` per local face, unit outward normal."""
        out = np.empty((self.n_tets, 4, 4), dtype=np.float64)
        for a in range(0, self.n_tets, _CHUNK_TETS):  # in chunks: the temporaries stay small
            out[a:a + _CHUNK_TETS] = _face_planes(self.points, self.tets[a:a + _CHUNK_TETS])
        return out

    @cached_property
    def _gradient_and_offset(self) -> tuple[np.ndarray, np.ndarray]:
        p = self.points[self.tets]
        s = self.scalars[self.tets]
        a = p[:, 1:] - p[:, :1]  # (M,3,3)
        b = s[:, 1:] - s[:, :1]
        g = np.linalg.solve(a, b[..., None])[..., 0]
        g0 = s[:, 0] - np.einsum("mk,mk->m", g, p[:, 0])
        return g, g0

    @property
    def gradients(self) -> np.ndarray:
        """(M, 3) scalar gradient per tet."""
        return self._gradient_and_offset[0]

    @property
    def offsets(self) -> np.ndarray:
        """(M,) offset g0 with ``s(x) = g . x + g0``."""
        return self._gradient_and_offset[1]

    @cached_property
    def edge_lengths(self) -> np.ndarray:
        """(M, 6) edge lengths per tet (``EDGE_VERTS`` order)."""
        p = self.points[self.tets]
        return np.linalg.norm(p[:, EDGE_VERTS[:, 1]] - p[:, EDGE_VERTS[:, 0]], axis=-1)

    @property
    def lmax(self) -> float:
        """Longest edge of the mesh (world units)."""
        return float(self.edge_lengths.max())

    @property
    def edge_ratio(self) -> float:
        """Longest / shortest edge over the whole mesh."""
        e = self.edge_lengths
        return float(e.max() / e.min())

    @cached_property
    def is_convex(self) -> bool:
        """Whether the boundary is one closed, locally convex surface (so every ray enters once).

        False when the mesh has faces without a neighbour inside its hull (``crack_faces``,
        ``nonconforming_faces``: a ray leaves the mesh there and re-enters at once). Otherwise checked
        edge by edge: at every boundary edge the two incident boundary faces must not fold inward, and
        the boundary must form a single connected component.
        """
        tris = self.boundary_triangles()
        if len(tris) == 0 or len(self.crack_faces) or len(self.nonconforming_faces):
            return False
        p = self.points
        # each directed edge (a->b) of an outward triangle; its twin (b->a) belongs to the neighbour
        e = np.stack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]], axis=1).reshape(-1, 2)
        opp = np.stack([tris[:, 2], tris[:, 0], tris[:, 1]], axis=1).reshape(-1)
        n = np.int64(self.n_points)
        fwd = e[:, 0] * n + e[:, 1]
        rev = e[:, 1] * n + e[:, 0]
        order = np.argsort(fwd)
        pos = np.searchsorted(fwd[order], rev)
        pos = np.minimum(pos, len(fwd) - 1)
        twin = order[pos]
        if not (fwd[twin] == rev).all():
            return False  # open or non-manifold boundary
        fid = np.repeat(np.arange(len(tris)), 3)
        # convex at the edge: the opposite vertex of the twin face lies on the inner side of this face
        a, b, c = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
        nrm = np.cross(b - a, c - a)
        scale = np.linalg.norm(nrm, axis=1)
        d = np.einsum("ij,ij->i", nrm[fid], p[opp[twin]] - a[fid]) / scale[fid]
        tol = 1e-9 * float(np.linalg.norm(self.bounds[1] - self.bounds[0]))
        if (d > tol).any():
            return False
        # single connected component of the boundary surface: min-label propagation over edges
        lab = np.arange(len(tris))
        f1, f2 = fid, fid[twin]
        while True:
            m = np.minimum(lab[f1], lab[f2])
            new = lab.copy()
            np.minimum.at(new, f1, m)
            np.minimum.at(new, f2, m)
            new = new[new]
            if (new == lab).all():
                break
            lab = new
        return bool((lab == lab[0]).all())

    #: tets dropped on load as zero-volume (empty when none were)
    dropped_tets = np.zeros((0, 4), dtype=np.int64)

    @cached_property
    def crack_faces(self) -> np.ndarray:
        """(K, 2) rows ``(tet, local face)`` of boundary faces that lie inside the mesh: faces left by
        dropped zero-volume tets, and faces whose three vertices coincide in position with another
        boundary face's (cells that meet on duplicated points).

        A dropped sliver between other tets leaves a crack: faces that were interior are now on the
        boundary, so a ray leaves the mesh there and must re-enter on the other side (``peel``).
        A tet collapsed onto repeated points leaves none (its two copies of a face pair up). Cells on
        duplicated points (same positions, other indices) are not each other's neighbours either; a
        ray re-enters at the coincident face.

        Examples
        --------
        >>> import warnings
        >>> pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1e-14], [0.3, 0.3, 1], [0.3, 0.3, -1]]
        >>> with warnings.catch_warnings():
        ...     warnings.simplefilter("ignore")
        ...     m = TetMesh(pts, [[0, 1, 2, 3], [1, 3, 2, 4], [0, 1, 2, 5]], [0, 1, 2, 3, 4, 5])
        >>> len(m.crack_faces), m.is_convex
        (2, False)
        >>> pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, -1]]
        >>> m = TetMesh(pts, [[0, 1, 2, 3], [4, 6, 5, 7]], np.arange(8.0))
        >>> len(m.crack_faces), m.is_convex
        (2, False)
        """
        bf = self.boundary_faces
        if len(bf) == 0:
            return np.zeros((0, 2), dtype=np.int64)
        tris = self.boundary_triangles()
        hit = np.zeros(len(bf), dtype=bool)
        if len(self.dropped_tets):
            dropped = np.sort(self.dropped_tets[:, FACE_VERTS].reshape(-1, 3), axis=1)
            dropped = dropped[(dropped[:, 0] != dropped[:, 1]) & (dropped[:, 1] != dropped[:, 2])]
            faces = np.sort(tris, axis=1)
            if len(dropped):
                hit |= np.isin(row_keys(faces, self.n_points), row_keys(dropped, self.n_points))
        # coincident faces: the same three positions under other point indices
        key = row_keys(np.sort(self._position_ids[tris], axis=1), self.n_points)
        _, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
        hit |= counts[inv.ravel()] > 1
        return bf[hit]

    @cached_property
    def _position_ids(self) -> np.ndarray:
        """(N,) int64: one id per distinct position among the boundary faces' points (-1 elsewhere)."""
        tris = self.boundary_triangles()
        used = np.unique(tris)
        ids = np.full(self.n_points, -1, dtype=np.int64)
        _, inv = np.unique(self.points[used], axis=0, return_inverse=True)
        ids[used] = inv.ravel()
        return ids

    @cached_property
    def nonconforming_faces(self) -> np.ndarray:
        """(K, 2) rows ``(tet, local face)`` of boundary faces that overlap a coplanar, oppositely
        oriented boundary face of another triangulation (cells glued along a plane whose quad faces
        are cut along different diagonals, hanging vertices). Faces counted in ``crack_faces`` are
        not counted again.

        Found with a grid over the boundary faces' boxes: candidate pairs share a grid cell and face
        opposite ways; they count when each vertex lies within ``1e-9`` of the mesh size of the other's
        plane and the triangles' interiors overlap in that plane (no separating edge line).

        Examples
        --------
        >>> pts = [[0, 0, 0], [0, 1, 0], [0, 1, 1], [0, 0, 1], [-1, 0.5, 0.5], [1, 0.5, 0.5]]
        >>> m = TetMesh(pts, [[0, 1, 2, 4], [0, 2, 3, 4], [1, 2, 3, 5], [1, 3, 0, 5]], np.zeros(6))
        >>> len(m.nonconforming_faces), len(m.crack_faces), m.is_convex
        (4, 0, False)
        """
        bf = self.boundary_faces
        skip = np.zeros(len(bf), dtype=bool)
        if len(self.crack_faces):
            skip = np.isin(bf[:, 0] * 4 + bf[:, 1], self.crack_faces[:, 0] * 4 + self.crack_faces[:, 1])
        hit = overlapping_opposite_faces(self.points, self.boundary_triangles(), skip)
        return bf[hit]

    @cached_property
    def overlapping_parts(self) -> dict | None:
        """What of the mesh's parts (cells connected through shared points, or glued on duplicated points)
        overlaps in space, ``None`` when nothing does (:func:`warpvol.scene.overlap.overlapping_parts`):
        a part written twice, overset grids without blanking. Parts that only touch (non-conforming
        interfaces) do not count. :meth:`check_overlap` declines such a mesh.

        Examples
        --------
        >>> p = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
        >>> m = TetMesh(p + [[x + 0.2 for x in q] for q in p], [[0, 1, 2, 3], [4, 5, 6, 7]], np.zeros(8))
        >>> m.overlapping_parts["parts"], m.overlapping_parts["pairs"]
        ([1, 1], 1)
        """
        return overlapping_parts(self.points, self.tets, self.boundary_triangles())

    def check_overlap(self) -> None:
        """Raise :class:`MeshError` naming the parts and the overlap's size when parts of the mesh overlap
        (:attr:`overlapping_parts`)."""
        info = self.overlapping_parts
        if info is not None:
            raise MeshError(overlap_message(self.name, info, self.cell_start))

    def __repr__(self) -> str:
        return f"TetMesh({self.name!r}, {self.n_points} points, {self.n_tets} tets)"

    # -- pyvista in and out (conversion in warpvol.scene.interop) ----------------------------------
    @classmethod
    def from_pyvista(cls, dataset, scalars: str | None = None, split: int | None = None, *,
                     strict: bool = False, name: str | None = None) -> "TetMesh":
        """A tetrahedral mesh from a pyvista (or VTK) data set, converted as scene files are.

        Parameters
        ----------
        dataset : pyvista.UnstructuredGrid, StructuredGrid, ImageData or RectilinearGrid
            Tet-only unstructured grids are taken as they are; hexahedra, voxels, wedges and pyramids
            are split into tets conforming (each quad face along the diagonal through its smallest
            vertex, :mod:`warpvol.scene.split_cells`), other cells by ``vtkDataSetTriangleFilter``;
            structured grids by ``split``.
        scalars : str, optional
            Name of a point-data array (one component); default: the active point scalars, or
            the only point array. Cell data is refused with the hint to convert it with
            ``dataset.cell_data_to_point_data()``.
        split : {None, 6, 5}
            Tets per hex cell of a structured grid: 6 (Kuhn split, the default) or 5 (alternating
            5-tet split). Not allowed for unstructured grids.
        strict : bool
            Zero-volume tets are an error instead of being dropped with a warning.
        name : str, optional
            Used in messages.

        Examples
        --------
        >>> import pyvista as pv
        >>> grid = pv.ImageData(dimensions=(3, 3, 3))
        >>> grid.point_data["x"] = grid.points[:, 0]
        >>> TetMesh.from_pyvista(grid, scalars="x").n_tets, TetMesh.from_pyvista(grid, "x", split=5).n_tets
        (48, 40)
        """
        notes: dict = {}
        points, tets, values, cell_start, name = interop.pyvista_arrays(dataset, scalars, split, name=name,
                                                                        notes=notes)
        return cls(points, tets, values, name=name, strict=strict, cell_start=cell_start, load_notes=notes)

    def to_pyvista(self, scalars_name: str = "scalars"):
        """This mesh as a ``pyvista.UnstructuredGrid`` of tets with the scalars as active point data.

        Examples
        --------
        >>> m = TetMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]], [0, 1, 2, 3])
        >>> g = m.to_pyvista()
        >>> g.n_cells, g.point_data["scalars"].tolist()
        (1, [0.0, 1.0, 2.0, 3.0])
        """
        return interop.mesh_to_pyvista(self, scalars_name)


def check_duplicate_tets(name: str, tets: np.ndarray) -> None:
    """Raise :class:`MeshError` naming the first tets listed twice (same four points, any order).

    Examples
    --------
    >>> check_duplicate_tets("m", np.array([[0, 1, 2, 3], [4, 5, 6, 7], [3, 2, 1, 0]]))
    Traceback (most recent call last):
    ...
    warpvol.errors.MeshError: m: tets[0] and tets[2] are the same tet (points [0, 1, 2, 3]); 1 duplicated tet(s)
    """
    key = np.sort(np.asarray(tets), axis=1)
    _, first, inv, counts = np.unique(key, axis=0, return_index=True, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    dup = np.flatnonzero(counts[inv] > 1)
    if len(dup):
        i = int(dup[0])
        j = int(dup[1]) if inv[dup[1]] == inv[i] else int(dup[np.argmax(inv[dup[1:]] == inv[i]) + 1])
        n = int(len(dup) - (counts > 1).sum())
        raise MeshError(f"{name}: tets[{i}] and tets[{j}] are the same tet (points {key[i].tolist()}); "
                        f"{n} duplicated tet(s)")


def derived_mesh(mesh: TetMesh, keep_cached: tuple[str, ...]) -> TetMesh:
    """An unvalidated copy of ``mesh`` for a caller that then replaces some of its arrays: its public
    attributes (points, tets, scalars, ``cell_start``, counts, ...) and, of its cached properties, those
    named in ``keep_cached`` (what the caller's change leaves valid); private caches (content hashes) and
    the other cached properties are computed again on use."""
    out = TetMesh.__new__(TetMesh)
    cls_attrs = vars(TetMesh)
    for key, value in vars(mesh).items():
        if isinstance(cls_attrs.get(key), cached_property):
            if key in keep_cached:
                out.__dict__[key] = value
        elif not key.startswith("_"):
            out.__dict__[key] = value
    return out


def _count_zero_volume(notes: dict, zero: np.ndarray, cell_start) -> None:
    """Add the zero-volume tets ``zero`` (bool per input tet) to ``notes`` counted in source cells
    (``cell_start``; without it each tet is its own cell)."""
    cs = None if cell_start is None else np.asarray(cell_start)
    if cs is None or cs.ndim != 1 or len(cs) < 2 or cs[0] != 0 or cs[-1] != len(zero) or (np.diff(cs) < 1).any():
        flat, part, pieces = int(zero.sum()), np.zeros(0, dtype=bool), 0  # (a bad cell_start is refused later)
    else:
        cs = cs.astype(np.int64)
        n_zero = np.add.reduceat(zero.astype(np.int64), cs[:-1])
        whole = n_zero == np.diff(cs)
        flat = int(whole.sum())
        part = (n_zero > 0) & ~whole
        pieces = int(n_zero[part].sum())
    for key, n in (("zero_volume_cells_dropped", flat), ("collapsed_cells", int(part.sum())),
                   ("collapsed_pieces_dropped", pieces)):
        if n:
            notes[key] = notes.get(key, 0) + n


def _cell_groups(name: str, cell_start, dropped: np.ndarray) -> np.ndarray:
    """``cell_start`` validated against the input tets, with the ``dropped`` tets taken out."""
    cs = np.asarray(cell_start)
    n = len(dropped)
    if cs.ndim != 1 or len(cs) < 2 or not np.issubdtype(cs.dtype, np.integer) or cs[0] != 0 or cs[-1] != n \
            or (np.diff(cs) < 1).any():
        raise MeshError(f"{name}: cell_start: expected ascending offsets from 0 to {n} with >= 1 tet per cell")
    kept = np.add.reduceat((~dropped).astype(np.int64), cs[:-1])
    return np.concatenate([[0], np.cumsum(kept[kept > 0])]).astype(np.int64)


