"""Mesh loading (Contract 1, ``[mesh]``): files pyvista reads, PLOT3D, raw volumes, built-ins.

A ``[mesh]`` table names exactly one source:

=============  ===================================================================================
key            source
=============  ===================================================================================
``path``       any file pyvista reads; ``scalars`` names the point-data array (required)
``plot3d``     ``{ xyz = FILE, q = FILE, function = N }``: single-block PLOT3D (own reader)
``raw``        ``{ path = FILE, dims = [nx, ny, nz], dtype = "uint8", spacing = [sx, sy, sz] }``
               with optional ``origin = [x, y, z]``
``builtin``    ``"NAME"``: a synthetic scene of :mod:`warpvol.scene.builtin`
=============  ===================================================================================

plus the optional keys ``scalars`` (``path`` only) and ``strict`` (zero-volume tets become an error
instead of being dropped with a warning). Relative file names are relative to the scene file.

How cells become tets
---------------------
* Structured grids (PLOT3D, raw volumes, VTK ``StructuredGrid`` / ``ImageData`` /
  ``RectilinearGrid``) use the 6-tet Kuhn split of :func:`warpvol.scene.grids.structured_to_tets` (point
  index ``i + ni*(j + nj*k)``, ``i`` fastest), which conforms across cells by construction.
* Unstructured grids made only of tets are taken as they are.
* Hexahedra, voxels, wedges and pyramids (with tets, and with cells without volume, which are
  skipped) are split by :func:`warpvol.scene.split_cells.split_cells`: every quad face is cut along the
  diagonal through its smallest vertex key (the rank of the vertex position), so two cells sharing
  a quad face cut it alike and the tets conform (Dompierre et al. 1999). Each cell's tets are
  consecutive (``cell_start``). A collapsed cell (one point at several corners: a hexahedron on an
  O-grid axis is a wedge) loses the pieces that have no volume or cancel, counted in
  :attr:`TetMesh.load_notes`.
* Ghost cells of unstructured grids (``vtkGhostType``: the layer a ``.pvtu`` piece carries from its
  neighbours) whose owning copy is in the file are dropped and counted; the pieces' copies of each
  other's points (ghost points, and each piece's own copy of the points on its interface where their
  point data agree) are joined (:func:`warpvol.scene.interop.drop_ghosts`).
* Hidden cells (``HIDDENCELL``, and cells using a ``HIDDENPOINT``) are dropped and counted in every
  kind of grid (:func:`warpvol.scene.interop.hidden_structured_cells` for the structured ones).
  ``.pvts`` files are read with VTK's ``vtkXMLPStructuredGridReader`` (pyvista has no reader for them).
* Any other cell type (polyhedra, higher-order cells) goes through VTK's
  ``vtkDataSetTriangleFilter`` (tets only). Faces that do not conform after that are counted by
  :class:`~warpvol.scene.mesh.TetMesh` (``crack_faces``, ``nonconforming_faces``) and walked by the
  re-entry passes.

Curvilinear grids can carry coincident grid points (the NASA Blunt Fin collapses one grid edge onto
its neighbour along the wall). Such points are *welded* (tets refer to one representative, whose
scalar becomes the mean over the coincident points) before the mesh is validated, so that the tets
that collapse are dropped as zero-volume tets without leaving a crack of unconnected faces behind.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from warpvol.errors import ConfigError, MeshError, check_keys, check_number, check_vec3
from warpvol.scene import datasets, interop
from warpvol.scene.builtin import BUILTIN_SCENES, builtin_mesh
from warpvol.scene.interop import SPLITS
from warpvol.scene.mesh import TetMesh

MESH_KEYS = ("path", "plot3d", "raw", "builtin", "scalars", "strict", "split", "step", "time")
SOURCE_KEYS = ("path", "plot3d", "raw", "builtin")
#: the keys of ``mesh.plot3d`` and ``mesh.raw``
PLOT3D_KEYS = ("xyz", "q", "function")
RAW_KEYS = ("path", "dims", "dtype", "spacing", "origin")

#: PLOT3D function numbers (VTK's numbering) -> description.
PLOT3D_FUNCTIONS = {
    100: "density rho",
    110: "pressure (gamma - 1)(rho E - rho |v|^2 / 2), gamma = 1.4",
    144: "kinetic energy |v|^2 / 2 (per unit mass, as VTK)",
    153: "velocity magnitude |v|",
    163: "stagnation energy rho E (per unit volume, as VTK)",
}
PLOT3D_GAMMA = 1.4

#: raw-volume sample types: name -> numpy type code (little endian unless a '>' code is given)
RAW_DTYPES = {"uint8": "u1", "uint16": "u2", "int16": "i2", "float32": "f4", "float64": "f8"}


# -- helpers ------------------------------------------------------------------------------------
def _file(base_dir: Path | str, value: Any, key: str) -> Path:
    """Resolve a file name relative to ``base_dir``; ``key`` names the field in errors. A data-set file
    named in ``shared/data`` that is not there is taken from the data cache
    (:func:`warpvol.scene.datasets.cached_copy`)."""
    if not isinstance(value, (str, Path)) or str(value) == "":
        raise ConfigError(f"{key}: expected a file name, got {value!r}")
    p = Path(value).expanduser()
    if not p.is_absolute():
        p = Path(base_dir) / p
    if p.is_file():
        return p
    cached = datasets.cached_copy(p)  # a data-set file of shared/data that `warpvol data fetch` downloaded
    if cached is not None:
        return cached
    raise ConfigError(f"{key}: file not found: {datasets.normal(p)}{datasets.missing_hint(p)}")


def _bool(value: Any, key: str) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{key}: expected true or false, got {value!r}")
    return value


def _structured_mesh(dims, points, scalars, *, name: str, strict: bool, weld: bool, split: int = 6) -> TetMesh:
    points, tets, scalars, cell_start = interop.structured_arrays(dims, points, scalars, name=name, weld=weld,
                                                                  split=split)
    return TetMesh(points, tets, scalars, name=name, strict=strict, cell_start=cell_start)


# -- files pyvista reads --------------------------------------------------------------------------
def _read_quietly(p: Path, step: Any = None, time: Any = None, keys: tuple[str, str] = ("step", "time")):
    """``pyvista.read(p)`` (a time series: the step ``step`` or ``time`` names, else its first, see
    :func:`_read_step`), the VTK errors it raised and the load notes of the reading, with VTK's logger,
    pyvista's logging and warnings kept off the terminal (the caller reports the errors in one line)."""
    import logging
    import warnings

    import pyvista as pv

    disabled = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    notes: dict = {}
    try:
        with pv.vtk_verbosity("off"), pv.VtkErrorCatcher(send_to_logging=False) as caught, \
                warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if p.suffix.lower() == ".pvts":
                for key, v in zip(keys, (step, time)):
                    if v is not None and not (key == keys[0] and v == 0 and not isinstance(v, bool)):
                        raise ConfigError(f"{key}: {p} is not a time series (it holds one data set); leave "
                                          f"{key} out")
                ds = _read_pvts(p)
            else:
                ds = _read_step(p, step, time, keys, notes)
                if ds is None:
                    ds = pv.read(p)
    finally:
        logging.disable(disabled)
    return ds, [" ".join(e.alert.split()) for e in caught.events if e.kind == "ERROR"], notes


def _time_reader(p: Path):
    """pyvista's reader of ``p`` where it reads a time series (``.pvd``, Exodus II, ``.series``, ...),
    else ``None``."""
    import pyvista as pv
    from pyvista.core.utilities.reader import TimeReader

    try:
        r = pv.get_reader(str(p))
    except Exception:  # not a file pyvista has a reader class for: pyvista.read says why
        return None
    return r if isinstance(r, TimeReader) else None


def _read_step(p: Path, step: Any, time: Any, keys: tuple[str, str], notes: dict):
    """One step of a time series: ``step`` (index from 0) or ``time`` (one of the file's time values),
    by default the first; ``notes['time_step']`` says which of how many where there are several.
    ``None`` (read the file as a whole) where it is no time series and neither is given."""
    skey, tkey = keys
    if step is not None and time is not None:
        raise ConfigError(f"{skey}/{tkey}: give one of them, not both")
    reader = _time_reader(p) if p.is_file() else None
    n = int(reader.number_time_points) if reader is not None else 0
    if n <= 1 and step is None and time is None:
        return None
    times = [float(t) for t in reader.time_values] if n else []
    span = f"{times[0]:g} to {times[-1]:g}" if times else ""
    if step is not None:
        if isinstance(step, bool) or not isinstance(step, (int, np.integer)):
            raise ConfigError(f"{skey}: expected a whole number (the time step, counted from 0), got {step!r}")
        if n == 0 and step == 0:
            return None  # one data set: its only step
        if n == 0:
            raise ConfigError(f"{skey}: {p} is not a time series (it holds one data set); leave {skey} out")
        if not 0 <= step < n:
            raise ConfigError(f"{skey}: {step} is outside the time steps of {p}: 0 to {n - 1} ({n} steps, "
                              f"times {span})")
        i = int(step)
    elif time is not None:
        if isinstance(time, bool) or not isinstance(time, (int, float, np.integer, np.floating)) \
                or not np.isfinite(time):
            raise ConfigError(f"{tkey}: expected a number (one of the file's time values), got {time!r}")
        if n == 0:
            raise ConfigError(f"{tkey}: {p} is not a time series (it holds one data set); leave {tkey} out")
        t = np.asarray(times)
        gap = np.abs(t - float(time))
        i = int(np.argmin(gap))
        if gap[i] > 1e-9 * max(1.0, float(np.abs(t).max())):
            listed = ", ".join(f"{v:g}" for v in times) if n <= 8 else \
                f"{', '.join(f'{v:g}' for v in times[:3])}, ..., {times[-1]:g}"
            raise ConfigError(f"{tkey}: {p} has no step at time {float(time):g}; its {n} times run from {span}: "
                              f"{listed} (or name a step with {skey}, 0 to {n - 1})")
    else:
        i = 0
    reader.set_active_time_point(i)
    if n > 1:
        notes["time_step"] = f"{i} of {n} (time {times[i]:g}; steps 0 to {n - 1}, times {span})"
    return reader.read()


def _read_pvts(p: Path):
    """A ``.pvts`` (ParaView's parallel structured grid: a list of ``.vts`` pieces) read whole, as pyvista
    reads ``.pvtu`` and ``.pvti``: pyvista has no reader for it, VTK's ``vtkXMLPStructuredGridReader``
    assembles the pieces into one grid (each cell once)."""
    import pyvista as pv
    from vtkmodules.vtkIOXML import vtkXMLPStructuredGridReader

    if not p.is_file():
        raise FileNotFoundError(f"no such file: {p}")
    r = vtkXMLPStructuredGridReader()
    r.SetFileName(str(p))
    r.Update()
    return pv.wrap(r.GetOutput())


def read_mesh_file(path: Path | str, scalars: str | None, *, strict: bool = False,
                   where: str = "mesh", split: int | None = None, active_scalars: bool = False,
                   scalars_key: str | None = None, step: Any = None, time: Any = None,
                   option_prefix: str | None = None) -> TetMesh:
    """Read any data set pyvista can read and turn it into a :class:`TetMesh`.

    ``scalars`` names a point-data array (one component); with ``active_scalars``, ``None`` takes
    the file's active point scalars or its only point array, as pyvista does (VTK's reserved arrays,
    such as ``vtkGhostType``, never). Structured grids use the 6-tet split,
    tet-only unstructured grids are taken as they are, other cells are split conforming (see the
    module docstring). A multi-block file (``.vtm``, Exodus II, ...) must hold one data set with cells,
    at any depth of nesting. A time series (``.pvd``, ...) gives its step ``step`` (from 0) or the step
    at ``time``, by default its first, and says which in the load notes (``time_step``).
    ``option_prefix`` names the options in messages (``--`` on the command line: ``--scalars``,
    ``--step``; default ``{where}.``); ``scalars_key`` overrides the scalars' name alone.
    """
    import pyvista as pv

    p = Path(path)
    prefix = f"{where}." if option_prefix is None else option_prefix
    try:
        ds, errors, notes = _read_quietly(p, step, time, (f"{prefix}step", f"{prefix}time"))
    except ConfigError:
        raise
    except Exception as e:  # pyvista raises assorted types for unknown or corrupt files
        raise ConfigError(f"{where}.path: cannot read {p}: {e}") from None
    if errors:  # VTK readers report a corrupt or truncated file as errors and return an empty data set
        raise ConfigError(f"{where}.path: cannot read {p}: the file is corrupt or truncated "
                          f"(VTK: {errors[0]})")
    if isinstance(ds, pv.MultiBlock):
        blocks = interop.data_blocks(ds)
        if len(blocks) != 1:
            what = f"{len(blocks)} blocks with cells" if blocks else "no data set"
            raise ConfigError(f"{where}.path: {p} holds {what}; warpvol needs a single data set: "
                              "combine the blocks into one file, e.g. python -c \"import pyvista as pv; "
                              f"pv.read('{p}').combine(merge_points=True).save('{p.with_suffix('.vtu').name}')\" "
                              "(ParaView: the Merge Blocks filter, then save as .vtu)")
        ds = blocks[0]
    return mesh_from_dataset(ds, scalars, strict=strict, name=str(p), source=str(p), split=split,
                             scalars_key=scalars_key or f"{prefix}scalars", dataset_key=f"{where}.path",
                             split_key=f"{prefix}split", pick=active_scalars, notes=notes)


def mesh_from_dataset(ds, scalars: str | None, *, strict: bool = False, name: str = "mesh",
                      source: str | None = None, split: int | None = None, scalars_key: str = "scalars",
                      dataset_key: str = "mesh", split_key: str = "split", pick: bool = False,
                      notes: dict | None = None) -> TetMesh:
    """Turn an in-memory pyvista data set into a :class:`TetMesh` (see the module docstring and
    :func:`warpvol.scene.interop.dataset_arrays`); ``notes`` are load notes of the reading that
    come first."""
    notes = dict(notes or {})
    points, tets, values, cell_start = interop.dataset_arrays(
        ds, scalars, name=name, source=source, split=split, scalars_key=scalars_key, dataset_key=dataset_key,
        split_key=split_key, notes=notes, pick=pick)
    return TetMesh(points, tets, values, name=name, strict=strict, cell_start=cell_start, load_notes=notes)


def mesh_from_pyvista(dataset: Any, scalars: str | None = None, split: int | None = None, *,
                      strict: bool = False, name: str | None = None, arg: str = "dataset") -> TetMesh:
    """:meth:`TetMesh.from_pyvista` with the argument name ``arg`` in messages."""
    notes: dict = {}
    points, tets, values, cell_start, name = interop.pyvista_arrays(dataset, scalars, split, name=name, arg=arg,
                                                                    notes=notes)
    return TetMesh(points, tets, values, name=name, strict=strict, cell_start=cell_start, load_notes=notes)


# -- PLOT3D ---------------------------------------------------------------------------------------
def read_plot3d_grid(path: Path | str, *, where: str = "plot3d.xyz"
                     ) -> tuple[tuple[int, int, int], np.ndarray, np.ndarray | None]:
    """Read a single-block, big-endian PLOT3D grid file without Fortran record markers.

    Layout: int32 ``ni, nj, nk``; float32 ``X``, ``Y``, ``Z`` (each ``ni*nj*nk`` values, ``i``
    fastest); optionally an int32 IBlank array, detected by the file size. Trailing bytes beyond
    that are ignored. Returns ``(dims, points (N, 3) float64, iblank or None)``.
    """
    p = Path(path)
    size = p.stat().st_size
    if size < 12:
        raise ConfigError(f"{where}: {p} is too short ({size} bytes) for a PLOT3D grid header")
    dims = np.fromfile(p, dtype=">i4", count=3)
    hint = "expected a single-block, big-endian PLOT3D grid without record markers"
    if (dims < 1).any() or int(np.prod(dims.astype(np.int64))) > 2**31:
        raise ConfigError(f"{where}: {p} has implausible dims {dims.tolist()}; {hint}")
    n = int(np.prod(dims.astype(np.int64)))
    need = 12 + 12 * n
    if size < need:
        raise ConfigError(f"{where}: {p} is too short: {size} bytes, a {'x'.join(map(str, dims))} grid needs "
                          f"at least {need} bytes; {hint}")
    xyz = np.fromfile(p, dtype=">f4", count=3 * n, offset=12).reshape(3, n).T.astype(np.float64)
    iblank = None
    if size >= need + 4 * n:
        iblank = np.fromfile(p, dtype=">i4", count=n, offset=need).astype(np.int32)
    return (int(dims[0]), int(dims[1]), int(dims[2])), xyz, iblank


def read_plot3d_solution(path: Path | str, dims: tuple[int, int, int] | None = None, *,
                         where: str = "plot3d.q") -> tuple[np.ndarray, np.ndarray]:
    """Read a single-block, big-endian PLOT3D solution (q) file without record markers.

    Layout: int32 ``ni, nj, nk``; float32 ``mach, alpha, re, time``; float32 ``rho, rho u, rho v,
    rho w, rho E`` (each ``ni*nj*nk`` values). Trailing bytes are ignored. ``dims`` (from the grid
    file) must agree. Returns ``(header (4,), q (5, N))`` in float64.
    """
    p = Path(path)
    size = p.stat().st_size
    if size < 28:
        raise ConfigError(f"{where}: {p} is too short ({size} bytes) for a PLOT3D solution header")
    qd = np.fromfile(p, dtype=">i4", count=3)
    if dims is not None and tuple(int(d) for d in qd) != tuple(dims):
        raise ConfigError(f"{where}: dims {qd.tolist()} in {p} disagree with the grid dims {list(dims)}")
    if (qd < 1).any():
        raise ConfigError(f"{where}: {p} has implausible dims {qd.tolist()}")
    n = int(np.prod(qd.astype(np.int64)))
    need = 28 + 20 * n
    if size < need:
        raise ConfigError(f"{where}: {p} is too short: {size} bytes, a {'x'.join(map(str, qd))} solution "
                          f"needs at least {need} bytes")
    header = np.fromfile(p, dtype=">f4", count=4, offset=12).astype(np.float64)
    q = np.fromfile(p, dtype=">f4", count=5 * n, offset=28).reshape(5, n).astype(np.float64)
    return header, q


def plot3d_function(q: np.ndarray, number: int, *, where: str = "plot3d.function") -> np.ndarray:
    """Scalar function ``number`` (see :data:`PLOT3D_FUNCTIONS`) of a ``(5, N)`` solution array."""
    if isinstance(number, bool) or not isinstance(number, (int, np.integer)) or int(number) not in PLOT3D_FUNCTIONS:
        supported = ", ".join(f"{k} ({v.split(' (')[0]})" for k, v in PLOT3D_FUNCTIONS.items())
        raise ConfigError(f"{where}: unsupported PLOT3D function {number!r}; supported: {supported}")
    number = int(number)
    rho = q[0]
    if number == 100:
        return rho.copy()
    if number == 163:
        return q[4].copy()
    if (rho == 0).any():
        k = int(np.argmax(rho == 0))
        raise MeshError(f"{where}: function {number} divides by the density, which is 0 at point {k}")
    v2 = (q[1] ** 2 + q[2] ** 2 + q[3] ** 2) / rho ** 2
    if number == 144:
        return 0.5 * v2
    if number == 153:
        return np.sqrt(v2)
    return (PLOT3D_GAMMA - 1.0) * (q[4] - 0.5 * rho * v2)  # 110


def read_plot3d(xyz: Path | str, q: Path | str, function: int = 100, *, strict: bool = False, split: int = 6,
                where: str = "plot3d") -> TetMesh:
    """Single-block PLOT3D grid + solution -> :class:`TetMesh` (``split`` = 6 or 5 tets per hex cell).

    IBlank values, when the grid carries them, are read but *not* applied: every cell is kept, as in
    the tetrahedral versions used by the VSBUFFER and HARC papers (the LOX Post gives 616,050 tets).
    Coincident grid points are welded (see the module docstring).
    """
    dims, points, _iblank = read_plot3d_grid(xyz, where=f"{where}.xyz")
    _header, qarr = read_plot3d_solution(q, dims, where=f"{where}.q")
    s = plot3d_function(qarr, function, where=f"{where}.function")
    name = f"{xyz} + {Path(q).name} (function {function})"
    return _structured_mesh(dims, points, s, name=name, strict=strict, weld=True, split=split)


# -- raw volumes ----------------------------------------------------------------------------------
def raw_dtype(value: Any, *, where: str = "raw.dtype") -> np.dtype:
    """Parse a raw sample type: a name of :data:`RAW_DTYPES` or a numpy code such as ``"<u2"``,
    ``">f4"``; little endian unless ``>`` is given."""
    msg = (f"{where}: unsupported sample type {value!r}; allowed: {', '.join(map(repr, RAW_DTYPES))} "
           "(little endian) or codes such as '<u2', '>u2', '>f4'")
    if not isinstance(value, str) or not value:
        raise ConfigError(msg)
    order, code = ("<", value) if value[0] not in "<>" else (value[0], value[1:])
    code = RAW_DTYPES.get(code, code)
    if code not in RAW_DTYPES.values():
        raise ConfigError(msg)
    return np.dtype(order + code)


def read_raw(path: Path | str, dims, dtype: Any = "uint8", spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), *,
             strict: bool = False, where: str = "raw", split: int = 6) -> TetMesh:
    """Raw volume of ``nx*ny*nz`` samples (``x`` fastest) -> :class:`TetMesh` (6 tets per voxel cell).

    Point ``(i, j, k)`` sits at ``origin + (i sx, j sy, k sz)``. The file size must equal
    ``nx*ny*nz*itemsize`` exactly.
    """
    p = Path(path)
    if not (isinstance(dims, (list, tuple, np.ndarray)) and len(dims) == 3):
        raise ConfigError(f"{where}.dims: expected [nx, ny, nz], got {dims!r}")
    d = [check_number(f"{where}.dims[{a}]", v, lo=2, integer=True) for a, v in enumerate(dims)]
    dt = raw_dtype(dtype, where=f"{where}.dtype")
    if not (isinstance(spacing, (list, tuple, np.ndarray)) and len(spacing) == 3):
        raise ConfigError(f"{where}.spacing: expected [sx, sy, sz], got {spacing!r}")
    sp = np.array([check_number(f"{where}.spacing[{a}]", v, lo=0, lo_open=True) for a, v in enumerate(spacing)])
    org = check_vec3(f"{where}.origin", origin)
    n = d[0] * d[1] * d[2]
    check_raw_size(p, d, dt, where=where)
    values = np.fromfile(p, dtype=dt, count=n).astype(np.float64)
    kk, jj, ii = np.meshgrid(np.arange(d[2]), np.arange(d[1]), np.arange(d[0]), indexing="ij")
    points = np.column_stack([ii.ravel(), jj.ravel(), kk.ravel()]).astype(np.float64) * sp + org
    return _structured_mesh(d, points, values, name=str(p), strict=strict, weld=False, split=split)


def check_raw_size(path: Path, dims, dt: np.dtype, *, where: str = "raw") -> None:
    """A raw volume's file must hold exactly ``nx*ny*nz`` samples of ``dt``; else an error saying what
    the file holds and what the dims need."""
    d = [int(v) for v in dims]
    need = d[0] * d[1] * d[2] * dt.itemsize
    have = Path(path).stat().st_size
    if have != need:
        why = ("shorter than the dims say: check dims and dtype" if have < need else
               "longer than the dims say: check dims and dtype (raw files have no header)")
        raise ConfigError(f"{where}.path: file {path} holds {have:,} bytes, dims {d[0]}x{d[1]}x{d[2]} of "
                          f"{dt.name} ({dt.itemsize} byte(s) per sample) need {need:,}; the file is {why}")


# -- [mesh] table ---------------------------------------------------------------------------------
def load_mesh(cfg: dict, base_dir: Path | str = ".", where: str = "mesh", strict: bool = False) -> TetMesh:
    """Build the :class:`TetMesh` of a ``[mesh]`` table (Contract 1).

    Exactly one of ``path``, ``plot3d``, ``raw``, ``builtin``; ``scalars`` (required with ``path``,
    not allowed otherwise), ``strict`` and ``split`` (tets per hex cell of a structured grid: 6, the
    Kuhn split and the default, or 5, the alternating split that conforms between neighbouring hexes;
    not with ``builtin``) are optional. ``strict`` is on when either the argument or
    the key says so. Errors name ``where`` and the offending key, file or value.

    Examples
    --------
    >>> load_mesh({"builtin": "box"}).n_tets
    384
    """
    if not isinstance(cfg, dict):
        raise ConfigError(f"{where}: expected a table, got {cfg!r}")
    check_keys(where, cfg, MESH_KEYS)
    sources = [k for k in SOURCE_KEYS if k in cfg]
    if len(sources) != 1:
        got = ", ".join(map(repr, sources)) if sources else "none"
        raise ConfigError(f"{where}: give exactly one of {', '.join(map(repr, SOURCE_KEYS))}; got {got}")
    src = sources[0]
    strict = bool(strict) or _bool(cfg.get("strict", False), f"{where}.strict")
    split = cfg.get("split")
    if split is not None:
        if isinstance(split, bool) or split not in SPLITS:
            raise ConfigError(f"{where}.split: expected 6 (Kuhn split, the default) or 5 (alternating 5-tet split, "
                              f"conforming) tets per hex cell, got {split!r}")
        if src == "builtin":
            raise ConfigError(f"{where}.split: not used with 'builtin' (a built-in scene fixes its mesh)")
    if "scalars" in cfg and src != "path":
        raise ConfigError(f"{where}.scalars: only used with 'path' (the {src!r} source defines its own scalars)")
    for k in ("step", "time"):
        if k in cfg and src != "path":
            raise ConfigError(f"{where}.{k}: only used with 'path' (a time step of a time series such as a .pvd)")

    if src == "path":
        p = _file(base_dir, cfg["path"], f"{where}.path")
        return read_mesh_file(p, cfg.get("scalars"), strict=strict, where=where, split=split,
                              step=cfg.get("step"), time=cfg.get("time"))

    if src == "plot3d":
        t = cfg["plot3d"]
        w = f"{where}.plot3d"
        if not isinstance(t, dict):
            raise ConfigError(f"{w}: expected {{ xyz = FILE, q = FILE, function = N }}, got {t!r}")
        check_keys(w, t, PLOT3D_KEYS)
        for k in ("xyz", "q"):
            if k not in t:
                raise ConfigError(f"{w}: missing key {k!r}")
        xyz = _file(base_dir, t["xyz"], f"{w}.xyz")
        q = _file(base_dir, t["q"], f"{w}.q")
        return read_plot3d(xyz, q, t.get("function", 100), strict=strict, where=w, split=split or 6)

    if src == "raw":
        t = cfg["raw"]
        w = f"{where}.raw"
        if not isinstance(t, dict):
            raise ConfigError(f"{w}: expected {{ path = FILE, dims = [nx, ny, nz], dtype = ..., spacing = [...] }}, "
                              f"got {t!r}")
        check_keys(w, t, RAW_KEYS)
        for k in ("path", "dims", "dtype", "spacing"):
            if k not in t:
                raise ConfigError(f"{w}: missing key {k!r}")
        p = _file(base_dir, t["path"], f"{w}.path")
        return read_raw(p, t["dims"], t["dtype"], t["spacing"], t.get("origin", (0.0, 0.0, 0.0)),
                        strict=strict, where=w, split=split or 6)

    name = cfg["builtin"]
    if not isinstance(name, str) or name not in BUILTIN_SCENES:
        raise ConfigError(f"{where}.builtin: unknown built-in scene {name!r}; available: "
                          f"{', '.join(map(repr, BUILTIN_SCENES))}")
    return builtin_mesh(name, strict=strict)
