"""A mesh in pieces on Dask: each piece of a ``.pvtu`` rendered on a worker into segments, merged by depth.

Along one ray the intervals of disjoint pieces never overlap, so each piece integrates on its own into
segments (:mod:`warpvol.segments`: one per entry of the ray into the piece) and the segments of all pieces,
merged by depth front to back, give the whole ray's value exactly, for pieces of any shape. A worker reads
only its piece's file (its ghost cells, copies of a neighbour's cells, dropped), renders it and sends back
its segments; the client reads the ``.pvtu`` (a list of file names) and the scene's transfer function and
camera, never the mesh, and merges. What travels: the scene's transfer function and camera to each worker,
each piece's segments back (56 bytes per segment).

``scheduler`` is ``"local"`` (a local cluster of worker processes), the address of a running Dask
scheduler, or a ``dask.distributed.Client``. A worker lost mid-render loses only its piece: Dask's
scheduler gives it to another worker. A piece file that is missing or unreadable is an error naming it.

:func:`partition_mesh` cuts a mesh file spatially (recursive bisection at the median of the cells'
centres) into pieces and writes the ``.pvtu`` naming them.
"""

from __future__ import annotations

import os
import time
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any, Callable

import numpy as np

from warpvol.errors import ConfigError, WarpvolError

#: presets that render a piece into segments (``warpvol render PIECES --scheduler``;
#: :data:`warpvol.raycast_segments.PRESETS`)
PIECE_PIPELINES: tuple[str, ...] = ("raycast", "harc_best")
#: what the pieces can be rendered as (segments): the exact reference or a preset of :data:`PIECE_PIPELINES`
PIECE_RENDERERS = ("reference",) + PIECE_PIPELINES


def pvtu_pieces(path: Path | str) -> list[Path]:
    """The piece files a ``.pvtu`` names (relative names are relative to its folder), checked to exist."""
    p = Path(path)
    try:
        root = ET.parse(p).getroot()
    except (OSError, ET.ParseError) as e:
        raise ConfigError(f"{p}: cannot read the .pvtu: {e}") from None
    grid = root.find("PUnstructuredGrid")
    if root.get("type") != "PUnstructuredGrid" or grid is None:
        raise ConfigError(f"{p}: not a parallel unstructured grid (.pvtu)")
    out = []
    for k, piece in enumerate(grid.findall("Piece")):
        src = piece.get("Source")
        if not src:
            raise ConfigError(f"{p}: piece {k} names no Source file")
        f = (p.parent / src) if not Path(src).is_absolute() else Path(src)
        if not f.is_file():
            raise ConfigError(f"{p}: piece {k} ({src}) not found: {f}")
        out.append(f)
    if not out:
        raise ConfigError(f"{p}: names no pieces")
    return out


def scene_pieces(spec: Any) -> dict | None:
    """For a scene ``.toml`` whose ``[mesh] path`` is a ``.pvtu`` of several pieces: its pieces, scalars'
    name, transfer function, camera and name, read without loading the mesh; ``None`` for any other scene."""
    from warpvol.scene.camera import Camera
    from warpvol.scene.scene_file import _read_toml
    from warpvol.scene.transfer import TransferFunction

    if not isinstance(spec, (str, Path)) or Path(spec).suffix.lower() != ".toml" or not Path(spec).is_file():
        return None
    p = Path(spec)
    cfg = _read_toml(p)
    mesh = cfg.get("mesh")
    if not isinstance(mesh, dict) or not isinstance(mesh.get("path"), str) or not mesh["path"].lower().endswith(".pvtu"):
        return None
    files = pvtu_pieces(p.parent / mesh["path"])
    if len(files) < 2:
        return None
    missing = [k for k in ("transfer", "camera") if k not in cfg]
    if missing:
        raise ConfigError(f"{p}: a .pvtu rendered piece by piece needs the scene's {' and '.join(f'[{k}]' for k in missing)} "
                          "table (the client never loads the mesh, so it cannot fit them to it)")
    if not isinstance(mesh.get("scalars"), str):
        raise ConfigError(f"{p}: mesh.scalars: name the point-data array of the pieces")
    return {"pieces": files, "scalars": mesh["scalars"], "name": cfg.get("name", p.stem),
            "transfer": TransferFunction.from_config(cfg["transfer"], p.parent, where=f"{p}: transfer"),
            "camera": Camera.from_config(cfg["camera"], where=f"{p}: camera")}


def read_piece(path: Path | str, scalars: str):
    """One piece file as a :class:`~warpvol.scene.mesh.TetMesh`, its ghost cells (``vtkGhostType`` bit 1:
    cells another piece owns) dropped and counted (``ghost_cells_dropped``); errors name the piece."""
    import pyvista as pv

    from warpvol.scene.loaders import mesh_from_dataset

    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"piece {p.name}: file not found: {p}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # pyvista reports a VTK reader's error as a warning
            ds = pv.read(p)
    except Exception as e:  # noqa: BLE001 - VTK and pyvista raise assorted types for corrupt files
        raise ConfigError(f"piece {p.name}: cannot read {p}: {str(e).splitlines()[0]}") from None
    if ds is None or ds.n_cells == 0:
        raise ConfigError(f"piece {p.name}: cannot read {p}: no cells (corrupt or truncated file?)")
    notes = {}
    if "vtkGhostType" in ds.cell_data:
        ghost = (np.asarray(ds.cell_data["vtkGhostType"]) & 1) != 0
        if ghost.any():
            ds = ds.extract_cells(np.flatnonzero(~ghost))
            notes["ghost_cells_dropped"] = int(ghost.sum())
    gid = next((k for k in GLOBAL_ID_ARRAYS if k in ds.point_data), None)
    if gid is not None:  # points in global order: rays through shared edges and vertices tie-break as the whole
        g = np.asarray(ds.point_data[gid]).astype(np.int64)
        if len(g) > 1 and not (np.diff(g) > 0).all():
            ds = _points_in_order(ds.cast_to_unstructured_grid(), np.argsort(g, kind="stable"))
            notes["points_in_global_order"] = int(len(g))
    for data in (ds.point_data, ds.cell_data):
        for k in [k for k in data.keys() if k.startswith("vtk") or k in GLOBAL_ID_ARRAYS]:
            del data[k]
    try:
        return mesh_from_dataset(ds, scalars, name=p.name, source=str(p), scalars_key=f"piece {p.name}: scalars",
                                 dataset_key=f"piece {p.name}", notes=notes)
    except ConfigError as e:
        raise ConfigError(f"piece {p.name}: {e}") from None


#: point-data arrays that carry global point ids (ParaView's, VTK's and :func:`partition_mesh`'s names)
GLOBAL_ID_ARRAYS = ("GlobalPointIds", "vtkGlobalIds", "GlobalNodeId", "GlobalNodeIds")


def _points_in_order(grid, order: np.ndarray):
    """``grid`` (an unstructured grid) with its points in ``order`` (old index of each new point)."""
    import pyvista as pv

    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    conn = np.asarray(grid.cells).copy()  # VTK's legacy cell array: (count, ids...) per cell
    ids = np.ones(len(conn), dtype=bool)
    ids[np.asarray(grid.cell_offsets)[:-1] + np.arange(grid.n_cells)] = False
    conn[ids] = rank[conn[ids]]
    out = pv.UnstructuredGrid(conn, np.asarray(grid.celltypes), np.asarray(grid.points)[order])
    for k in grid.point_data.keys():
        out.point_data[k] = np.asarray(grid.point_data[k])[order]
    for k in grid.cell_data.keys():
        out.cell_data[k] = np.asarray(grid.cell_data[k])
    return out


class _RssWatch:
    """Samples this process's resident memory every 2 ms while it runs (a thread): ``rise`` is the largest
    sample above the first, what one task added at its peak."""

    def __init__(self):
        import threading

        import psutil

        self._proc = psutil.Process()
        self.start = self.top = self._proc.memory_info().rss
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.002):
            self.top = max(self.top, self._proc.memory_info().rss)

    def stop(self) -> int:
        self._stop.set()
        self._thread.join()
        self.top = max(self.top, self._proc.memory_info().rss)
        return self.top - self.start


def _worker_threads() -> int:
    """The threads Dask gives the worker running this task (0 outside a worker: all cores)."""
    try:
        from dask.distributed import get_worker

        return int(get_worker().state.nthreads)
    except (ImportError, ValueError, AttributeError):
        return 0


def piece_bounds(path: str, scalars: str) -> dict:
    """A piece's bounds and scalar range (the first pass of a render in pieces; runs on a worker)."""
    mesh = read_piece(path, scalars)
    lo, hi = mesh.bounds
    return {"lo": np.asarray(lo).tolist(), "hi": np.asarray(hi).tolist(), "range": list(mesh.scalar_range)}


def piece_segments(path: str, scalars: str, tf, camera, what: str = "reference", frame: dict | None = None):
    """Render one piece into segments (runs on a worker; top-level so it pickles). Returns
    ``(segments, info)`` with ``info``: piece, cells, seconds, peak_bytes (the worker process's largest
    resident size during this task), piece_bytes (its resident memory's largest rise over this task: reading and
    rendering the piece, sampled every 2 ms), bytes_per_tet (piece_bytes over the piece's cells), segments."""
    from warpvol.pipeline import quiet_warp
    from warpvol.reference.segments import reference_segments

    quiet_warp()
    t0 = time.perf_counter()
    watch = _RssWatch()
    if what not in PIECE_RENDERERS:
        watch.stop()
        raise ConfigError(f"pieces: cannot render {what!r} into segments; allowed: {', '.join(PIECE_RENDERERS)}")
    try:
        mesh = read_piece(path, scalars)
    except BaseException:
        watch.stop()
        raise
    extra: dict = {}
    try:
        if what in PIECE_PIPELINES:
            from warpvol.raycast_segments import preset_segments
            from warpvol.scene.scene import Scene

            segs = preset_segments(Scene(mesh=mesh, transfer=tf, camera=camera, name=mesh.name), what, stats=extra,
                                   frame=frame, threads=_worker_threads())
        else:  # bands of at most 4 million candidate (tet, pixel) pairs: a worker's memory stays small
            segs = reference_segments(mesh, tf, camera, band_pairs=4_000_000)
    finally:
        rise = watch.stop()
    info = {"piece": Path(path).name, "cells": int(mesh.n_tets), "seconds": time.perf_counter() - t0,
            "peak_bytes": watch.top, "piece_bytes": rise, "bytes_per_tet": rise / max(1, mesh.n_tets),
            "segments": len(segs), **extra, **mesh.load_notes}
    return segs, info


def _client(scheduler: Any, workers: int, memory_limit: str | int | None = None):
    """``(client, owned)``: a Dask client for ``scheduler`` (a Client is used as it is; owned ones are closed)."""
    from dask.distributed import Client

    from warpvol.bands import _client as band_client

    if isinstance(scheduler, Client):
        return scheduler, None, False
    client, cluster = band_client(scheduler, workers, memory_limit)
    return client, cluster, True


def render_pieces(pieces: list[Path], scalars: str, tf, camera, scheduler: Any = "local", *, what: str = "reference",
                  workers: int = 2, on_piece: Callable[[int, Any], None] | None = None,
                  stats: dict | None = None):
    """The segments of all ``pieces`` rendered on a Dask cluster and merged by depth.

    Returns
    -------
    (Segments, dict)
        The merged segments (``.flatten()`` is the image) and the report's piece entries: ``pieces`` (per
        piece: piece, cells, seconds, peak_bytes, segments), ``workers``, ``compositing_s``, ``seconds``.
    """
    from dask.distributed import as_completed
    from distributed.scheduler import KilledWorker

    from warpvol.segments import merge

    if what not in PIECE_RENDERERS:
        raise ConfigError(f"pieces: cannot render {what!r} into segments; allowed: {', '.join(PIECE_RENDERERS)}")
    t0 = time.perf_counter()
    client, cluster, owned = _client(scheduler, workers)
    try:
        n_workers = max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
        tag = f"{os.getpid()}-{id(pieces)}-{time.monotonic_ns()}"
        frame = None
        if what in PIECE_PIPELINES:  # first pass: the whole mesh's frame from the pieces' bounds and scalar ranges
            from warpvol.conditioning.conditioning import shared_frame

            heads = client.gather([client.submit(piece_bounds, str(p), scalars, key=f"bounds-{k}-{tag}", pure=False)
                                   for k, p in enumerate(pieces)])
            frame = shared_frame(tf, np.min([h["lo"] for h in heads], axis=0), np.max([h["hi"] for h in heads], axis=0),
                                 (min(h["range"][0] for h in heads), max(h["range"][1] for h in heads)))
        futs = {client.submit(piece_segments, str(p), scalars, tf, camera, what, frame, key=f"piece-{k}-{tag}",
                              pure=False): k for k, p in enumerate(pieces)}
        parts: list = [None] * len(pieces)
        for f in as_completed(futs):
            k = futs[f]
            try:
                parts[k] = f.result()
            except KilledWorker:
                raise WarpvolError(f"piece {Path(pieces[k]).name}: every worker that ran it died (Dask's allowed "
                                   "failures); a worker killed for memory needs a larger limit or smaller pieces "
                                   "(warpvol partition -n with more pieces)") from None
            if on_piece is not None:
                on_piece(k, client)
    finally:
        if owned:
            client.close()
            if cluster is not None:
                cluster.close()
    t1 = time.perf_counter()
    segs = merge([s for s, _ in parts])
    rep = {"pieces": [i for _, i in parts], "workers": n_workers, "compositing_s": time.perf_counter() - t1,
           "seconds": time.perf_counter() - t0}
    if frame is not None:
        rep["frame"] = {k: frame[k] for k in ("centre", "h", "scalar_offset", "scalar_scale")}
    if stats is not None:
        stats.update(rep)
    return segs, rep


# ------------------------------------------------------------------------------------------------
# cutting a mesh into pieces
# ------------------------------------------------------------------------------------------------
def _bisect(centres: np.ndarray, ids: np.ndarray, n: int, out: list) -> None:
    if n == 1:
        out.append(np.sort(ids))
        return
    c = centres[ids]
    axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
    n0 = n // 2
    order = ids[np.argsort(c[:, axis], kind="stable")]
    cut = int(round(len(ids) * n0 / n))
    _bisect(centres, order[:cut], n0, out)
    _bisect(centres, order[cut:], n - n0, out)


def partition_mesh(mesh_path: Path | str, n: int, outdir: Path | str, scalars: str | None = None) -> Path:
    """Cut the mesh file ``mesh_path`` spatially into ``n`` pieces (recursive bisection of the cells' centres
    at the median along the longest axis: compact pieces of equal cell counts) and write them as
    ``outdir/piece{k}.vtu`` with the ``outdir/<name>.pvtu`` naming them; returns the ``.pvtu`` path. Each
    piece keeps its points in the whole mesh's order (ties break alike on both sides of a piece boundary)
    and carries their global ids (``GlobalPointIds``)."""
    import pyvista as pv

    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ConfigError(f"-n: expected an integer >= 1, got {n!r}")
    src = Path(mesh_path)
    out = Path(outdir)
    if not src.is_file():
        raise ConfigError(f"mesh file not found: {src}")
    try:
        ds = pv.read(src)
    except Exception as e:  # noqa: BLE001
        raise ConfigError(f"cannot read {src}: {e}") from None
    if isinstance(ds, pv.MultiBlock):
        ds = ds.combine(merge_points=True)
    ds = ds.cast_to_unstructured_grid()
    if ds.n_cells < n:
        raise ConfigError(f"-n: {n} pieces of a mesh of {ds.n_cells} cells")
    name = scalars or ds.active_scalars_name or (list(ds.point_data.keys()) or [None])[0]
    if name is None or name not in ds.point_data:
        raise ConfigError(f"--scalars: {src} has no point array {name!r}; arrays: {', '.join(ds.point_data.keys())}")
    out.mkdir(parents=True, exist_ok=True)
    centres = np.asarray(ds.cell_centers().points, dtype=np.float64)
    groups: list = []
    _bisect(centres, np.arange(ds.n_cells), n, groups)
    gids = np.arange(ds.n_points, dtype=np.int64)
    arrays = []
    for k, cells in enumerate(groups):
        piece = ds.extract_cells(cells)
        # extract_cells keeps the points in first-use order: put them back in the whole mesh's order
        orig = np.asarray(piece.point_data["vtkOriginalPointIds"], dtype=np.int64)
        g = _points_in_order(piece, np.argsort(orig, kind="stable"))
        for data in (g.point_data, g.cell_data):
            for key in [key for key in data.keys() if key.startswith("vtk")]:
                del data[key]
        g.point_data["GlobalPointIds"] = gids[np.sort(orig)]
        arrays = [(name, g.point_data[name].dtype), ("GlobalPointIds", np.dtype(np.int64))]
        g.save(out / f"piece{k}.vtu")
    vtk_type = {np.dtype(np.float64): "Float64", np.dtype(np.float32): "Float32", np.dtype(np.int64): "Int64",
                np.dtype(np.int32): "Int32", np.dtype(np.uint8): "UInt8", np.dtype(np.int16): "Int16",
                np.dtype(np.uint16): "UInt16"}
    pdata = "".join(f'<PDataArray type="{vtk_type.get(np.dtype(t), "Float64")}" Name="{a}"/>' for a, t in arrays)
    pieces = "\n".join(f'<Piece Source="piece{k}.vtu"/>' for k in range(len(groups)))
    pvtu = out / f"{src.stem}.pvtu"
    pvtu.write_text(f'''<?xml version="1.0"?>
<VTKFile type="PUnstructuredGrid" version="0.1" byte_order="LittleEndian">
<PUnstructuredGrid GhostLevel="0">
<PPointData Scalars="{name}">{pdata}</PPointData>
<PPoints><PDataArray type="Float64" NumberOfComponents="3"/></PPoints>
{pieces}
</PUnstructuredGrid></VTKFile>
''')
    return pvtu


def render_in_pieces(scene: Path | str, pipeline: str = "raycast", scheduler: Any = "local", *, workers: int = 2,
                     reference: bool = False, camera=None, worker_memory: str | int | None = None) -> dict:
    """Render a scene file whose mesh is a ``.pvtu`` of several pieces, each piece on a Dask worker.

    Parameters
    ----------
    scene : path
        Scene ``.toml`` with ``[mesh] path = "....pvtu"`` (and ``scalars``), ``[transfer]`` and ``[camera]``.
    pipeline : str
        A preset that renders into segments (:data:`PIECE_PIPELINES`) or ``"reference"`` (the exact one).
    scheduler : str or dask.distributed.Client
        ``"local"`` (``workers`` worker processes here, closed afterwards), a scheduler address, or a client.
    reference : bool
        Also compute the exact reference piece by piece and add the error to the report.
    camera : Camera, optional
        Replaces the scene's camera.
    worker_memory : str or int, optional
        With ``"local"``: each worker's memory limit (``"2GB"``, bytes); Dask's nanny restarts a worker past
        95 % of it (its piece then goes to another worker).

    Returns
    -------
    dict
        ``image`` ((H, W, 4) float64), ``segments`` (merged :class:`~warpvol.segments.Segments`), ``reference``
        (image or ``None``) and ``report`` (``pipeline``, ``stages``, ``total_s``, ``pieces``, ``workers``,
        ``compositing_s``, with ``reference`` also ``reference_s`` and ``error``).
    """
    from warpvol.metrics import image_error

    info = scene_pieces(scene)
    if info is None:
        raise ConfigError(f"scene: {scene} is not a scene file whose mesh is a .pvtu of several pieces")
    if pipeline not in PIECE_PIPELINES + ("reference",):
        raise ConfigError(f"pipeline {pipeline!r}: cannot render a mesh piece by piece: it emits no segments "
                          f"(presets that do: {', '.join(PIECE_PIPELINES)}, and the exact reference)")
    cam = camera if camera is not None else info["camera"]
    t0 = time.perf_counter()
    watch = _RssWatch()  # the client's resident memory over the render (getrusage's peak may be a parent's)
    client, cluster, owned = _client(scheduler, workers, worker_memory)
    try:
        segs, rep = render_pieces(info["pieces"], info["scalars"], info["transfer"], cam, client, what=pipeline)
        img = segs.flatten()
        report = {"pipeline": pipeline, "stages": {"pieces": rep["seconds"] - rep["compositing_s"],
                                                   "compositing": rep["compositing_s"]},
                  "total_s": time.perf_counter() - t0, "pieces": rep["pieces"], "workers": rep["workers"],
                  "compositing_s": rep["compositing_s"]}
        if "frame" in rep:
            report["frame"] = rep["frame"]
        ref = None
        if reference:
            rsegs, rrep = (segs, rep) if pipeline == "reference" else \
                render_pieces(info["pieces"], info["scalars"], info["transfer"], cam, client)
            ref = rsegs.flatten()
            report["reference_s"] = rrep["seconds"]
            report["error"] = image_error(img, ref)
    finally:
        watch.stop()
        if owned:
            client.close()
            if cluster is not None:
                cluster.close()
    report["client_peak_bytes"] = watch.top  # this process's largest resident size over the render
    return {"image": img, "segments": segs, "reference": ref, "report": report}
