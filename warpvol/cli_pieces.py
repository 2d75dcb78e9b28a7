"""Command line for a mesh in pieces (:mod:`warpvol.pieces`): ``render`` and ``reference`` of a multi-piece
``.pvtu`` scene with ``--scheduler`` (each piece on a Dask worker, segments merged by depth, ``--deep`` for
the segments as an OpenEXR deep image), and ``partition`` (cut a mesh file into a ``.pvtu`` of pieces)."""

from __future__ import annotations

import time
from pathlib import Path

from warpvol.cli_checks import IMAGE_OUTPUT, check_bands, check_outputs, check_sizes
from warpvol.errors import ConfigError

DEEP_OUTPUT = {"--deep": (".exr",)}


def check_deep(args) -> None:
    """``--deep`` is written from segments: a multi-piece ``.pvtu`` scene with ``--scheduler``, or the reference."""
    if getattr(args, "worker_memory", None) is not None:
        raise ConfigError("--worker-memory: only used with --scheduler local and a scene whose mesh is a .pvtu of "
                          "several pieces (reference bands run in workers of Dask's default size)")
    if getattr(args, "deep", None) and args.scheduler is None and args.cmd != "reference":
        raise ConfigError("--deep: the segments of a render come from its pieces: give --scheduler with a scene whose "
                          "mesh is a .pvtu of several pieces (warpvol reference writes --deep on its own)")


def _camera(info: dict, args):
    over = {k: v for k, v in (("width_px", args.width), ("height_px", args.height)) if v is not None}
    return info["camera"].replace(**over) if over else info["camera"]


def _no_mesh_options(args) -> None:
    for flag, v in (("--scalars", "scalars"), ("--colormap", "colormap"), ("--step", "step"), ("--time", "time"),
                    ("--bands", "bands")):
        if getattr(args, v, None) is not None:
            raise ConfigError(f"{flag}: not used with a .pvtu scene rendered piece by piece (--scheduler)")


def _write(outs: dict, img, segs, camera, args, report: str | None = None) -> dict:
    """The image, its preview and the report first (all or none), then the deep file, off the image's
    critical path; returns the deep file's ``samples`` and ``seconds``."""
    import numpy as np

    from warpvol.deep import write_deep
    from warpvol.io import Outputs

    bg = getattr(args, "background", (0.0, 0.0, 0.0))
    with Outputs() as out:
        if outs["-o"].suffix.lower() == ".png":
            out.png(outs["-o"], img, background=bg)
        else:
            out.exr(outs["-o"], np.asarray(img, np.float32))
        if getattr(args, "png", None):
            out.png(outs["--png"], img, background=args.background)
        if report is not None:
            out.text(outs["--report"], report)
    deep: dict = {}
    if "--deep" in outs:
        write_deep(outs["--deep"], segs, camera, stats=deep)
    return deep


def _worker_memory(args):
    """``--worker-memory`` (local clusters only)."""
    mem = getattr(args, "worker_memory", None)
    if mem is not None and args.scheduler != "local":
        raise ConfigError("--worker-memory: limits the workers of --scheduler local; a running cluster's workers "
                          "take theirs from `dask worker --memory-limit`")
    if mem is not None:
        from dask.utils import parse_bytes

        try:
            if parse_bytes(mem) <= 0:
                raise ValueError
        except (ValueError, TypeError):
            raise ConfigError(f"--worker-memory: expected a size such as 2GB or 500MB, got {mem!r}") from None
    return mem


def _piece_line(rep: dict) -> str:
    cells = sum(p["cells"] for p in rep["pieces"])
    peak = max(p["peak_bytes"] for p in rep["pieces"])
    return (f"{len(rep['pieces'])} pieces ({cells} tets) on {rep['workers']} workers, worker peak "
            f"{peak / 2**20:.0f} MiB, compositing {rep['compositing_s']:.3f} s")


def cmd_reference_pieces(args, info: dict) -> int:
    """``warpvol reference PIECES-SCENE --scheduler ...``: the exact reference of each piece on a worker."""
    from warpvol.pieces import render_pieces

    outs = check_outputs({"-o": args.output, "--deep": args.deep}, {**IMAGE_OUTPUT, **DEEP_OUTPUT})
    _no_mesh_options(args)
    check_sizes(args)
    check_bands(args)
    _worker_memory(args)
    cam = _camera(info, args)
    t0 = time.perf_counter()
    from warpvol.pieces import _client

    client, cluster, owned = _client(args.scheduler, args.workers or 2, _worker_memory(args))
    try:
        segs, rep = render_pieces(info["pieces"], info["scalars"], info["transfer"], cam, client)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    img = segs.flatten()
    dt = time.perf_counter() - t0
    deep = _write(outs, img, segs, cam, args)
    extra = f", deep {deep['samples']} samples in {deep['seconds']:.2f} s -> {outs['--deep']}" if deep else ""
    print(f"reference: {dt:.2f} s, {cam.width_px}x{cam.height_px}, {_piece_line(rep)} -> {outs['-o']}{extra}")
    return 0


def cmd_render_pieces(args, info: dict) -> int:
    """``warpvol render PIECES-SCENE --pipeline raycast --scheduler ...``: each piece rendered into segments on a
    worker, merged by depth; ``--compute-reference`` does the same for the exact reference. A preset that
    cannot render a piece into segments is refused in words."""
    from warpvol.io import read_exr
    from warpvol.metrics import image_error
    from warpvol.pieces import PIECE_PIPELINES, render_in_pieces
    from warpvol.pipeline import report_json

    if args.pipeline not in PIECE_PIPELINES:
        raise ConfigError(f"--pipeline {args.pipeline}: cannot render a mesh piece by piece: it emits no segments "
                          f"(presets that do: {', '.join(PIECE_PIPELINES)}). Without --scheduler the whole mesh "
                          "renders in one process")
    for flag, v in (("--gpu", args.gpu), ("--error-image", args.error_image), ("--no-skip", args.no_skip or None)):
        if v is not None:
            raise ConfigError(f"{flag}: not available for a .pvtu scene rendered piece by piece (--scheduler)")
    if args.reference and args.compute_reference:
        raise ConfigError("--compute-reference: give either it or --reference, not both")
    outs = check_outputs({"-o": args.output, "--report": args.report, "--png": args.png, "--deep": args.deep},
                         {**IMAGE_OUTPUT, **DEEP_OUTPUT})
    _no_mesh_options(args)
    check_sizes(args)
    check_bands(args)
    cam = _camera(info, args)
    ref = read_exr(args.reference) if args.reference else None
    if ref is not None and ref.shape != (cam.height_px, cam.width_px, 4):
        raise ConfigError(f"--reference: {args.reference} has shape {ref.shape}, expected "
                          f"{(cam.height_px, cam.width_px, 4)}")
    res = render_in_pieces(args.scene, args.pipeline, args.scheduler, workers=args.workers or 2,
                           reference=args.compute_reference, camera=cam, worker_memory=_worker_memory(args))
    img, segs, report = res["image"], res["segments"], res["report"]
    total = report["total_s"]
    if ref is not None:  # --reference (with --compute-reference the report has the error already)
        report["error"] = image_error(img, ref)
    deep = _write(outs, img, segs, cam, args, report_json(report) if args.report else None)
    line = f"{args.pipeline}: {total:.2f} s, {_piece_line(report)}"
    if "error" in report:
        e = report["error"]
        line += f"  rmse={e['rmse']:.3e} max_abs={e['max_abs']:.3e}"
    if deep:
        line += f"; deep: {deep['samples']} samples in {deep['seconds']:.2f} s -> {outs['--deep']}"
    print(line)
    return 0


def cmd_partition(args) -> int:
    from warpvol.pieces import partition_mesh

    t0 = time.perf_counter()
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"-o: {out} is a file; expected a folder (created if missing)")
    pvtu = partition_mesh(args.mesh, args.n, out, args.scalars)
    print(f"partition: {args.mesh} -> {args.n} pieces, {pvtu} ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_partition_parser(sub) -> None:
    pt = sub.add_parser("partition", help="cut a mesh file spatially into pieces: a .pvtu for --scheduler renders")
    pt.add_argument("mesh", help="mesh file pyvista reads (.vtu, .vtk, ...)")
    pt.add_argument("-n", type=int, required=True, help="number of pieces")
    pt.add_argument("-o", "--output", required=True, help="folder for the pieces (piece0.vtu, ...) and NAME.pvtu")
    pt.add_argument("--scalars", help="point-data array the pieces keep (default: the active scalars)")
    pt.set_defaults(func=cmd_partition)


def add_worker_memory(sp) -> None:
    sp.add_argument("--worker-memory", help="with --scheduler local and a .pvtu scene of several pieces: each "
                    "worker's memory limit (2GB, 500MB; Dask restarts a worker past 95 %% of it)")


def maybe_pieces(args) -> dict | None:
    """The pieces of ``args.scene`` when ``--scheduler`` is given and it is a multi-piece ``.pvtu`` scene."""
    from warpvol.pieces import scene_pieces

    if args.scheduler is None:
        return None
    return scene_pieces(args.scene)


__all__ = ["cmd_reference_pieces", "cmd_render_pieces", "cmd_partition", "add_partition_parser", "maybe_pieces",
           "check_deep"]
