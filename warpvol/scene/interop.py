"""pyvista / VTK in and out: meshes and cameras.

Data sets become plain arrays here (:func:`dataset_arrays`; scene files use the same code, so a data set
renders identically from memory and from a file) and cameras plain settings: this module knows no warpvol
class, and :class:`~warpvol.TetMesh`, :class:`~warpvol.Camera` and the loaders build theirs from it.
Cameras map one to one:

==========================  =====================================  ==============================
warpvol :class:`Camera`      VTK ``vtkCamera`` / ``pyvista.Camera``   note
==========================  =====================================  ==============================
``eye``                      ``position``
``target``                   ``focal_point``
``up``                       ``up`` (``ViewUp``)                    VTK keeps it orthogonal
``fov_y_deg``                ``view_angle``                         vertical unless
                                                                    ``UseHorizontalViewAngle``
``projection``               ``parallel_projection``
``ortho_height``             ``2 * parallel_scale``                 orthographic image height
``width_px, height_px``      the plotter's ``window_size``          (times the renderer viewport)
==========================  =====================================  ==============================

VTK's window centre, view shear, off-axis projection, explicit projection matrix and model transform
have no warpvol counterpart; a camera that uses them is refused with the setting named.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from warpvol.errors import ConfigError, MeshError
from warpvol.scene.grids import cell_corners, structured_to_tets, structured_to_tets5, weld_coincident_points
from warpvol.scene.split_cells import FLAT_TYPES, SPLIT_TYPES, split_cells

_VTK_TETRA = 10
_DATASET_TYPES = "pyvista.UnstructuredGrid, StructuredGrid, ImageData or RectilinearGrid"


def as_pyvista_dataset(obj: Any, arg: str = "dataset"):
    """``obj`` as a pyvista data set (raw VTK data sets are wrapped; a one-block MultiBlock is
    unwrapped); anything else is an error naming ``arg``."""
    import pyvista as pv

    if isinstance(obj, pv.MultiBlock):
        blocks = data_blocks(obj)
        if len(blocks) != 1:
            raise ConfigError(f"{arg}: a MultiBlock with {len(blocks)} blocks of cells; pass a single data set "
                              f"({_DATASET_TYPES}), e.g. multiblock.combine(merge_points=True)")
        obj = blocks[0]
    if not isinstance(obj, pv.DataSet):
        try:
            from vtkmodules.vtkCommonDataModel import vtkDataSet
        except ImportError:  # pragma: no cover - VTK ships with pyvista
            vtkDataSet = ()
        if not isinstance(obj, vtkDataSet):
            raise ConfigError(f"{arg}: expected a {_DATASET_TYPES} (or a TetMesh), got {type(obj).__name__}")
        obj = pv.wrap(obj)
    if not isinstance(obj, (pv.UnstructuredGrid, pv.StructuredGrid, pv.ImageData, pv.RectilinearGrid)):
        raise ConfigError(f"{arg}: expected a {_DATASET_TYPES}, got {type(obj).__name__}, which has no volume cells")
    return obj


def data_blocks(mb) -> list:
    """The data sets of a (possibly nested) ``pyvista.MultiBlock`` that hold cells, in order: nested
    MultiBlocks are opened, ``None`` blocks, empty MultiBlocks and data sets without cells (an Exodus
    file's empty element blocks) left out. A MultiBlock without any cells gives its first data set (so
    that its emptiness is reported as a data set's), or nothing."""
    import pyvista as pv

    leaves: list = []

    def walk(b):
        if b is None:
            return
        if isinstance(b, pv.MultiBlock):
            for child in b:
                walk(child)
        else:
            leaves.append(b)

    walk(mb)
    full = [b for b in leaves if getattr(b, "n_cells", 0) > 0]
    return full if full or not leaves else leaves[:1]


#: arrays VTK and its readers reserve for their own bookkeeping (ghost and blanking flags, ids of the
#: cells and points a filter started from, validity masks, block and process ids, Exodus' global and
#: pedigree ids): never data, so never chosen as the scalars (:func:`reserved_array`)
RESERVED_ARRAYS = ("vtkGhostType", "vtkGhostLevels", "vtkOriginalCellIds", "vtkOriginalPointIds",
                   "vtkOriginalIndices", "vtkValidPointMask", "vtkCompositeIndex", "vtkBlockColors",
                   "vtkProcessId", "vtkDomainId", "vtkInsidedness", "GlobalNodeId", "GlobalElementId",
                   "PedigreeNodeId", "PedigreeElementId", "ObjectId", "warpvol_source_cell")


def reserved_array(ds, name: str, point: bool = True) -> bool:
    """Whether point (or cell) array ``name`` of ``ds`` is VTK bookkeeping rather than data: a name of
    :data:`RESERVED_ARRAYS`, or the data set's global or pedigree ids."""
    if name in RESERVED_ARRAYS:
        return True
    attrs = ds.GetPointData() if point else ds.GetCellData()
    ids = [a.GetName() for a in (attrs.GetGlobalIds(), attrs.GetPedigreeIds()) if a is not None]
    return name in ids


def data_arrays(ds, point: bool = True) -> list[str]:
    """Names of the point (or cell) arrays of ``ds`` that hold data (not :func:`reserved_array`)."""
    data = ds.point_data if point else ds.cell_data
    return [k for k in data.keys() if not reserved_array(ds, k, point)]


def default_scalars(ds) -> str | None:
    """The point array a data set given without ``scalars`` is rendered with: its active point scalars,
    else its only point array, VTK's reserved arrays (:data:`RESERVED_ARRAYS`) never; ``None`` where
    there is no such array."""
    active = ds.point_data.active_scalars_name
    if active is not None and not reserved_array(ds, active):
        return active
    keys = data_arrays(ds)
    return keys[0] if len(keys) == 1 else None


def _one_component(ds) -> list[str]:
    return [k for k in data_arrays(ds) if np.asarray(ds.point_data[k]).ndim == 1
            or np.asarray(ds.point_data[k]).shape[1] == 1]


def pick_hint(scalars_key: str) -> str:
    """How a user names the scalars through ``scalars_key``: ``--scalars NAME`` on the command line,
    ``mesh.scalars = "NAME"`` in a scene file, ``scalars="NAME"`` in Python."""
    if scalars_key.startswith("--"):
        return f"{scalars_key} NAME"
    if "." in scalars_key:
        return f'{scalars_key} = "NAME" in the scene file'
    return f'{scalars_key}="NAME"'


#: how to turn cell data into the point data warpvol needs (said in every cell-data error)
CELL_TO_POINT = ("convert it with pyvista's dataset.cell_data_to_point_data() "
                 "(ParaView: the Cell Data to Point Data filter)")

#: tets per hex cell of a structured grid -> splitter (6: Kuhn split, the default; 5: alternating)
SPLITS = (6, 5)


_CELL_TAG = "warpvol_source_cell"  # cell-data array naming each tet's source cell through the split



def structured_arrays(dims, points, scalars, *, name: str, weld: bool, split: int = 6, keep=None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(points, tets, scalars, cell_start)`` of a structured grid of ``dims`` points (``split`` tets per
    hex cell; ``weld`` joins bit-identical points), the tets of each hex consecutive. ``keep`` (a bool per
    cell, VTK's cell order) leaves the other cells out, and the points only they use."""
    dims = tuple(int(d) for d in dims)
    if min(dims) < 2:
        raise MeshError(f"{name}: structured grid dims {list(dims)} have an axis with fewer than 2 points; "
                        "a volume needs at least 2 points along each axis")
    if split == 5:
        tets = structured_to_tets5(dims)
    else:
        tets = structured_to_tets(dims)
    if keep is not None:
        tets = tets.reshape(-1, split, 4)[keep].reshape(-1, 4)
        used = np.unique(tets)
        remap = np.full(len(points), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        points, scalars, tets = points[used], scalars[used], remap[tets]
    if weld:
        tets, scalars, _ = weld_coincident_points(points, tets, scalars)
    # the hex cells' tets are consecutive: remember the grouping (the VSBUFFER draws hexes whole)
    return points, tets, scalars, np.arange(0, len(tets) + 1, split, dtype=np.int64)


def hidden_structured_cells(ds, name: str = "mesh") -> np.ndarray | None:
    """(C,) bool: the cells of a structured grid (image, rectilinear or curvilinear) that ``vtkGhostType``
    hides -- flagged ``HIDDENCELL``, or with a corner flagged ``HIDDENPOINT`` (VTK's convention: a hidden
    point hides every cell that uses it), as blanked overset grids and ParaView's Resample To Image
    outside its source write them -- or ``None`` where none is hidden."""
    dims = tuple(int(d) for d in ds.dimensions)
    hidden = np.zeros(ds.n_cells, dtype=bool)
    if _GHOSTS in ds.cell_data:
        hidden |= (np.asarray(ds.cell_data[_GHOSTS]) & _HIDDENCELL) != 0
    if _GHOSTS in ds.point_data:
        hp = (np.asarray(ds.point_data[_GHOSTS]) & _HIDDENPOINT) != 0
        if hp.any() and min(dims) >= 2:
            hidden |= hp[cell_corners(dims)].any(axis=1)
    if not hidden.any():
        return None
    if hidden.all():
        raise MeshError(f"{name}: every cell is hidden (vtkGhostType HIDDENCELL / HIDDENPOINT on all "
                        f"{len(hidden)} cells): nothing to render")
    return hidden


def dataset_arrays(ds, scalars: str | None, *, name: str = "mesh",
                      source: str | None = None, split: int | None = None, scalars_key: str = "scalars",
                      dataset_key: str = "mesh", split_key: str = "split", notes: dict | None = None,
                      pick: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """``(points, tets, scalars, cell_start)`` of an in-memory pyvista data set: tet-only grids as they
    are, other cells split into tets (see :mod:`warpvol.scene.loaders`).

    ``scalars`` names a point-data array (one component). ``split`` (structured grids only) is the
    number of tets per hex cell: 6 (Kuhn split, the default) or 5 (alternating 5-tet split).
    ``source`` names the data set in messages (default: its type); ``scalars_key`` and
    ``dataset_key`` are the argument or key names errors start with; with ``pick``, ``scalars=None``
    takes :func:`default_scalars`. Ghost cells of an unstructured grid
    are dropped (:func:`drop_ghosts`), and the hidden cells of every grid (:func:`hidden_structured_cells`);
    ``notes`` (a dict, if given) gets the counts of what was dropped.
    """
    import pyvista as pv

    p = source or f"the {type(ds).__name__}"
    if split is not None and split not in SPLITS:
        raise ConfigError(f"{split_key}: expected 6 (Kuhn) or 5 (alternating) tets per hex cell, got {split!r}")
    structured = isinstance(ds, (pv.StructuredGrid, pv.ImageData, pv.RectilinearGrid))
    if split is not None and not structured:
        raise ConfigError(f"{split_key}: only applies to structured grids (StructuredGrid, ImageData, RectilinearGrid); "
                          f"{p} is a {type(ds).__name__}, whose non-tet cells are split conforming")

    # scalars first: the error lists what the file has
    pkeys = data_arrays(ds)
    ckeys = data_arrays(ds, point=False)
    hint = pick_hint(scalars_key)
    picked = scalars is None and pick
    # where the scalars were not named, the message starts with the data set, not a key nobody wrote
    lead, it = (f"{p}: the data set", "the data set") if picked else (f"{scalars_key}: {p}", p)
    if picked:
        scalars = default_scalars(ds)
    if scalars is None:
        if not pkeys and ckeys:
            raise ConfigError(f"{lead} has cell data only ({', '.join(map(repr, ckeys))}); "
                              f"warpvol needs a point-data array (values at the vertices); {CELL_TO_POINT}")
        if picked:
            raise ConfigError(f"{lead} has no active point scalars; name one of its point arrays {pkeys} "
                              f"with {hint}")
        raise ConfigError(f"{scalars_key}: required{' with ' + repr('path') if source else ''} (name of a "
                          f"point-data array); available point arrays in {p}: {pkeys}")
    if not isinstance(scalars, str):
        raise ConfigError(f"{scalars_key}: expected an array name, got {scalars!r}")
    if scalars in ds.point_data.keys() and reserved_array(ds, scalars):
        raise ConfigError(f"{scalars_key}: {scalars!r} in {p} is an array VTK reserves for its own bookkeeping "
                          f"(ghost flags, ids, masks), not data; point arrays with data: {pkeys}")
    if scalars not in pkeys:
        if not pkeys and ckeys:
            raise ConfigError(f"{scalars_key}: {p} has cell data only ({', '.join(map(repr, ckeys))}); "
                              f"warpvol needs {scalars!r} as a point-data array (values at the vertices); "
                              f"{CELL_TO_POINT}")
        why = (f" ({scalars!r} is a cell-data array; warpvol needs point data: {CELL_TO_POINT})"
               if scalars in ckeys else "")
        raise ConfigError(f"{scalars_key}: point-data array {scalars!r} not found in {p}{why}; "
                          f"available point arrays: {pkeys}")
    arr = np.asarray(ds.point_data[scalars])
    if arr.ndim > 1 and arr.shape[1] != 1:
        ones = _one_component(ds)
        what = f"{p}: its active scalars {scalars!r} have" if picked else f"{scalars_key}: array {scalars!r} in {p} has"
        pick_one = (f"one-component point arrays in {it}: {', '.join(map(repr, ones))}; pick one with {hint}"
                    if ones else f"{it} has no one-component point array (compute one, then name it with {hint})")
        raise ConfigError(f"{what} {arr.shape[1]} components; warpvol renders a scalar (1 component): {pick_one}")

    notes = {} if notes is None else notes
    if structured:
        hidden = hidden_structured_cells(ds, name) if min(ds.dimensions) >= 2 else None
        if hidden is not None:
            notes["hidden_cells_dropped"] = int(hidden.sum())
        return structured_arrays(ds.dimensions, np.asarray(ds.points, dtype=np.float64),
                                 arr.reshape(-1).astype(np.float64), name=name,
                                 weld=isinstance(ds, pv.StructuredGrid), split=split or 6,
                                 keep=None if hidden is None else ~hidden)
    if not isinstance(ds, pv.UnstructuredGrid):
        raise ConfigError(f"{dataset_key}: {p} is a {type(ds).__name__}, which has no volume cells; "
                          "expected an unstructured, structured, image or rectilinear grid")

    ds, weld = drop_ghosts(ds, notes, name)
    points, tets, values, cell_start = _unstructured_arrays(ds, scalars, name, notes)
    if weld is not None:  # the ghost points left (copies of a neighbour piece's points) join their owners
        tets = np.concatenate([weld, np.arange(len(weld), len(points))])[tets]  # (+ points the split added)
        used = np.unique(tets)
        if len(used) < len(points):
            remap = np.full(len(points), -1, dtype=np.int64)
            remap[used] = np.arange(len(used))
            points, values, tets = points[used], values[used], remap[tets]
    return points, tets, values, cell_start


#: vtkGhostType bits (vtkDataSetAttributes): a cell another piece owns, a cell or point not in the data set
_DUPLICATECELL, _HIDDENCELL, _DUPLICATEPOINT, _HIDDENPOINT = 1, 32, 1, 2
_GHOSTS = "vtkGhostType"


def drop_ghosts(ds, notes: dict, name: str = "mesh"):
    """``(ds, weld)``: an unstructured grid without its ghost cells (``vtkGhostType`` cells another piece
    owns, as the pieces of a ``.pvtu`` written with ghost levels carry them) and without cells that use a
    hidden point; ``weld`` maps each point of the result to the point it stands for (a ghost point onto
    the owned point at the same position), or is ``None`` when nothing was dropped. ``notes`` gets
    ``ghost_cells_dropped`` and ``hidden_cells_dropped`` (when not 0), ``ghost_points_joined`` and
    ``piece_points_joined`` (:func:`_join_piece_points`).

    A ghost cell is dropped only where the data set holds the cell it copies (a cell of the same type on
    points at the same positions, not itself a ghost): a piece read on its own keeps its ghost layer,
    counted as ``ghost_cells_kept``, and a data set whose pieces were already assembled (flags left on
    cells that now exist once) loses nothing.

    Written here rather than with ``vtkRemoveGhosts``: that filter drops the point flags the joining of
    the pieces needs.
    """
    cg = np.asarray(ds.cell_data[_GHOSTS]) if _GHOSTS in ds.cell_data else np.zeros(ds.n_cells, np.uint8)
    pg = np.asarray(ds.point_data[_GHOSTS]) if _GHOSTS in ds.point_data else np.zeros(ds.n_points, np.uint8)
    ghost = (cg & _DUPLICATECELL) != 0
    if ghost.any():
        copies = ghost & _has_copy(ds, ghost)
        if (ghost & ~copies).any():
            notes["ghost_cells_kept"] = int((ghost & ~copies).sum())
        ghost = copies
    hidden = (cg & _HIDDENCELL) != 0
    if (pg & _HIDDENPOINT).any():
        conn = np.asarray(ds.cell_connectivity)
        uses = np.add.reduceat((pg[conn] & _HIDDENPOINT) != 0, np.asarray(ds.cell_offsets)[:-1]) > 0
        hidden |= uses & ~ghost
    drop = ghost | hidden
    if not drop.any():
        return ds, None
    for key, n in (("ghost_cells_dropped", ghost.sum()), ("hidden_cells_dropped", (hidden & ~ghost).sum())):
        if n:
            notes[key] = int(n)
    if drop.all():
        raise MeshError(f"{name}: every cell is a ghost or hidden cell ({int(drop.sum())} cells)")
    out = ds.extract_cells(np.flatnonzero(~drop))
    return out, _join_piece_points(out, notes, pieces=bool(ghost.any()))


def _join_piece_points(out, notes: dict, pieces: bool) -> np.ndarray:
    """``weld`` of :func:`drop_ghosts`: each point of ``out`` mapped to the point it stands for. A ghost
    point (``DUPLICATEPOINT``) joins the first owned point at its position (``ghost_points_joined``);
    with ``pieces`` (ghost cells of other pieces were dropped: the data set was assembled from pieces)
    an owned point joins the first owned point at its position too where every point-data array agrees
    (each piece owns its copy of the points on its interface; ``piece_points_joined``). Coincident points
    whose data differ (a field discontinuous across an internal surface) stay apart."""
    weld = np.arange(out.n_points)
    if out.n_points == 0:
        return weld
    pts = np.asarray(out.points, dtype=np.float64)
    pg = np.asarray(out.point_data[_GHOSTS]) if _GHOSTS in out.point_data else np.zeros(out.n_points, np.uint8)
    dup = (pg & _DUPLICATEPOINT) != 0
    own = np.flatnonzero(~dup)
    if len(own) == 0 or not (dup.any() or pieces):
        return weld
    _, key = np.unique(pts, axis=0, return_inverse=True)
    key = key.ravel()
    owner = np.full(key.max() + 1, -1, dtype=np.int64)
    owner[key[own[::-1]]] = own[::-1]  # the first owned point at each position
    target = owner[key[dup]]
    found = target >= 0
    weld[np.flatnonzero(dup)[found]] = target[found]
    if found.any():
        notes["ghost_points_joined"] = int(found.sum())
    if pieces:
        rep = owner[key[own]]
        other = rep != own
        same = other.copy()
        for name in out.point_data.keys():
            if name != _GHOSTS and not name.startswith("vtkOriginal"):  # (extract_cells' own ids)
                a = np.asarray(out.point_data[name])
                same &= (a[own] == a[rep]).reshape(len(own), -1).all(axis=1)
        weld[own[same]] = rep[same]
        if same.any():
            notes["piece_points_joined"] = int(same.sum())
    return weld


def _has_copy(ds, ghost: np.ndarray) -> np.ndarray:
    """(C,) bool: whether a cell that is not a ghost has the same type and corner positions as this one."""
    _, rank = np.unique(np.asarray(ds.points, dtype=np.float64), axis=0, return_inverse=True)
    off = np.asarray(ds.cell_offsets, dtype=np.int64)
    conn = rank.ravel()[np.asarray(ds.cell_connectivity, dtype=np.int64)]
    sizes = np.diff(off)
    rows = np.full((len(sizes), int(sizes.max()) + 1), -1, dtype=np.int64)
    rows[:, 0] = np.asarray(ds.celltypes)
    cell = np.repeat(np.arange(len(sizes)), sizes)
    rows[cell, 1 + np.arange(len(conn)) - off[:-1][cell]] = conn
    rows[:, 1:].sort(axis=1)
    _, key = np.unique(rows, axis=0, return_inverse=True)
    key = key.ravel()
    return np.isin(key, key[~ghost])


def _unstructured_arrays(ds, scalars: str, name: str, notes: dict):
    """:func:`dataset_arrays` of an unstructured grid whose ghost cells are gone."""
    import pyvista as pv

    arr = np.asarray(ds.point_data[scalars])
    points = np.asarray(ds.points, dtype=np.float64)
    values = arr.reshape(-1).astype(np.float64)
    ctypes = np.asarray(ds.celltypes)
    cell_start = None
    if len(ctypes) == 0:
        tets = np.empty((0, 4), dtype=np.int64)
    elif (ctypes == _VTK_TETRA).all():
        tets = np.asarray(ds.cells).reshape(-1, 5)[:, 1:]
    else:
        conn = np.asarray(ds.cell_connectivity)
        if len(conn) and (conn.min() < 0 or conn.max() >= ds.n_points):
            bad = int(conn[(conn < 0) | (conn >= ds.n_points)][0])
            raise MeshError(f"{name}: cell point index out of range: {bad}, expected 0 <= index < {ds.n_points}")
        kinds = set(np.unique(ctypes).tolist())
        if kinds <= set(SPLIT_TYPES) | set(FLAT_TYPES):
            volume = np.isin(ctypes, SPLIT_TYPES)
            if not volume.any():
                raise MeshError(f"{name}: no volume cells (cell types {sorted(kinds)}); "
                                "only 2D/1D cells cannot be split into tets")
            points, values, tets, cell_start = split_cells(points, values, ctypes, np.asarray(ds.cell_offsets),
                                                           conn, notes)
            return points, tets, values, cell_start
        from vtkmodules.vtkFiltersGeneral import vtkDataSetTriangleFilter

        tagged = ds.copy(deep=False)  # shares the arrays; the tag below is the only new one
        tagged.cell_data[_CELL_TAG] = np.arange(ds.n_cells, dtype=np.int64)
        f = vtkDataSetTriangleFilter()
        f.SetInputData(tagged)
        f.TetrahedraOnlyOn()
        f.Update()
        out = pv.wrap(f.GetOutput())
        if out.n_cells == 0:
            raise MeshError(f"{name}: no volume cells (cell types {sorted(set(ctypes.tolist()))}); "
                            "only 2D/1D cells cannot be split into tets")
        points = np.asarray(out.points, dtype=np.float64)
        values = np.asarray(out.point_data[scalars]).reshape(-1).astype(np.float64)
        tets = np.asarray(out.cells).reshape(-1, 5)[:, 1:]
        # the filter passes cell data to each cell's tets: group them by source cell (the VSBUFFER
        # draws the cells whole) where they come out consecutive, as they do cell by cell
        src = np.asarray(out.cell_data[_CELL_TAG]) if _CELL_TAG in out.cell_data else None
        if src is not None and len(src) == len(tets) and (np.diff(src) >= 0).all():
            cell_start = np.concatenate([[0], np.nonzero(np.diff(src))[0] + 1, [len(src)]])
    return points, tets, values, cell_start


def pyvista_arrays(dataset: Any, scalars: str | None = None, split: int | None = None, *,
                   name: str | None = None, arg: str = "dataset", notes: dict | None = None):
    """``(points, tets, scalars, cell_start, name)`` of a pyvista (or VTK) data set, converted as scene
    files are (see :meth:`warpvol.TetMesh.from_pyvista`)."""
    ds = as_pyvista_dataset(dataset, arg)
    name = name or f"pyvista {type(ds).__name__}"
    return (*dataset_arrays(ds, scalars, split=split, name=name, scalars_key="scalars", dataset_key=arg,
                            notes=notes, pick=True), name)


def mesh_to_pyvista(mesh, scalars_name: str = "scalars"):
    """See :meth:`warpvol.TetMesh.to_pyvista`."""
    import pyvista as pv

    if not isinstance(scalars_name, str) or not scalars_name:
        raise ConfigError(f"scalars_name: expected a non-empty string, got {scalars_name!r}")
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array(mesh.tets, dtype=np.int64)},
                               np.array(mesh.points, dtype=np.float64))
    grid.point_data[scalars_name] = np.array(mesh.scalars, dtype=np.float64)
    grid.point_data.active_scalars_name = scalars_name
    return grid


# -- cameras ---------------------------------------------------------------------------------------
def _window_size(value: Any, arg: str = "window_size") -> tuple[int, int]:
    try:
        w, h = value
        ok = all(not isinstance(v, bool) and float(v).is_integer() and v >= 1 for v in (w, h))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ConfigError(f"{arg}: expected (width, height) in whole pixels >= 1, got {value!r}")
    return int(w), int(h)


def _check_plain_vtk_camera(cam, arg: str) -> None:
    """Refuse VTK camera settings warpvol's camera model cannot express."""
    checks = [
        ("GetWindowCenter", (0.0, 0.0), "window centre"),
        ("GetViewShear", (0.0, 0.0, 1.0), "view shear"),
        ("GetUseOffAxisProjection", 0, "off-axis projection"),
        ("GetUseExplicitProjectionTransformMatrix", 0, "explicit projection matrix"),
        ("GetUseExplicitAspectRatio", 0, "explicit aspect ratio"),
    ]
    for getter, plain, what in checks:
        if hasattr(cam, getter):
            v = getattr(cam, getter)()
            if not np.allclose(np.atleast_1d(np.asarray(v, dtype=float)), np.atleast_1d(plain), rtol=0, atol=0):
                raise ConfigError(f"{arg}: the VTK camera uses a {what} ({getter[3:]} = {v}), which warpvol's "
                                  "camera cannot express")
    m = cam.GetModelTransformMatrix()
    if not np.array_equal([[m.GetElement(i, j) for j in range(4)] for i in range(4)], np.eye(4)):
        raise ConfigError(f"{arg}: the VTK camera has a model transform, which warpvol's camera cannot express")


def camera_settings(source: Any, window_size: Any = None, *, arg: str = "plotter_or_camera") -> dict:
    """The :class:`~warpvol.Camera` fields of a pyvista plotter or a pyvista/VTK camera (see
    :meth:`warpvol.Camera.from_pyvista`)."""
    from vtkmodules.vtkRenderingCore import vtkCamera


    size = None
    if hasattr(source, "renderer") and hasattr(source, "window_size"):  # a pyvista Plotter
        cam = source.camera  # pyvista sets its default view here when none was set yet (as show() does)
        vp = source.renderer.GetViewport()
        ws = source.window_size
        size = (max(1, round(ws[0] * (vp[2] - vp[0]))), max(1, round(ws[1] * (vp[3] - vp[1]))))
    elif isinstance(source, vtkCamera):  # pyvista.Camera is a vtkCamera
        cam = source
    else:
        raise ConfigError(f"{arg}: expected a pyvista Plotter or a pyvista/VTK camera, got {type(source).__name__}")
    if window_size is not None:
        size = _window_size(window_size)
    if size is None:
        raise ConfigError("window_size: required with a camera (a camera has no image size); give "
                          "(width, height) in pixels, e.g. plotter.window_size")
    _check_plain_vtk_camera(cam, arg)
    w, h = size
    fov = float(cam.GetViewAngle())
    if cam.GetUseHorizontalViewAngle():
        fov = float(np.degrees(2.0 * np.arctan(np.tan(np.radians(fov) / 2.0) * h / w)))
    return dict(projection="orthographic" if cam.GetParallelProjection() else "perspective",
                  eye=cam.GetPosition(), target=cam.GetFocalPoint(), up=cam.GetViewUp(), fov_y_deg=fov,
                  ortho_height=2.0 * float(cam.GetParallelScale()), width_px=w, height_px=h, where=arg)


def camera_to_pyvista(camera, plotter: Any = None):
    """See :meth:`warpvol.Camera.to_pyvista`."""
    import pyvista as pv

    cam = pv.Camera()
    cam.position = tuple(camera.eye)
    cam.focal_point = tuple(camera.target)
    cam.up = tuple(camera.true_up)
    cam.view_angle = float(camera.fov_y_deg)
    cam.parallel_projection = camera.projection == "orthographic"
    cam.parallel_scale = float(camera.ortho_height) / 2.0
    if plotter is not None:
        if not (hasattr(plotter, "renderer") and hasattr(plotter, "window_size")):
            raise ConfigError(f"plotter: expected a pyvista Plotter, got {type(plotter).__name__}")
        plotter.window_size = [int(camera.width_px), int(camera.height_px)]
        plotter.camera = cam
    return cam
