"""Command line (Contract 3).

::

    warpvol render SCENE [--pipeline PRESET_OR_FILE] -o OUT.exr|OUT.png [--reference REF.exr] [--report OUT.json]
    warpvol reference SCENE -o REF.exr                # exact float64 ray integral
    warpvol pipelines [--long]                        # the presets by family, one line each
    warpvol gpus                                      # GPU profiles for render --gpu NAME (modelled time)
    warpvol demo                                      # built-in scene, default pipeline, image + report
    warpvol bench SCENE [--pipelines all|NAME...] [--gpu NAME] -o OUTDIR   # table, plots, HTML
    warpvol plan SCENE... [--pipeline NAME...|all]    # stages a preset leaves out, why, time saved
    warpvol stress [--quick]                          # stiff and extreme cases x every preset
    warpvol sweep CONFIG.toml [--scheduler tcp://HOST:PORT] -o OUTDIR   # Dask, resumable
    warpvol data [list] | fetch NAME...|all           # the real data sets of scenes/, into a cache
    warpvol partition MESH -n 8 -o PIECES/            # cut a mesh into a .pvtu of pieces (for --scheduler)

``SCENE`` is a scene file, ``builtin:NAME`` or a mesh file pyvista reads (``.vtu``, ``.vtk``, ...;
its point scalars under a default colour map and opacity ramp, the camera fitted to it: see
:mod:`warpvol.scene.defaults`; ``--scalars`` and ``--colormap`` choose). Bad input ends with ``warpvol: error: ...`` naming the
file / key / value, exit status 2, and no output file.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from warpvol.bands import compute_reference
from warpvol.cli_checks import (  # noqa: F401
    BYTES_PER_PIXEL,
    IMAGE_OUTPUT,
    MAX_PIXELS,
    OUTPUT_EXTENSIONS,
    check_bands,
    check_image_memory,
    check_outputs,
    check_sizes,
    check_writable,
    folder_outputs,
    load_scene,
    out_of_memory,
    output_folder,
    pipeline_inputs,
    scene_inputs,
)
from warpvol.errors import ConfigError, WarpvolError
from warpvol.io import check_inputs
from warpvol.timing import process_age_s, time_summary, wall_fields, wall_summary


def _available_memory() -> int | None:
    """Bytes of memory available to this process now (:func:`warpvol.io.available_memory`), for the memory
    checks of :mod:`warpvol.cli_checks`."""
    from warpvol.io import available_memory

    return available_memory()


def cmd_render(args) -> int:
    from warpvol.cli_pieces import check_deep, cmd_render_pieces, maybe_pieces
    from warpvol.io import Outputs, read_exr
    from warpvol.metrics import write_error_png
    from warpvol.pipeline import Pipeline, report_json

    if (info := maybe_pieces(args)) is not None:  # a .pvtu of several pieces on Dask: each piece on a worker
        return cmd_render_pieces(args, info)
    check_deep(args)
    # everything a user can get wrong is checked before any costly work
    outs = check_outputs({"-o": args.output, "--report": args.report, "--png": args.png,
                          "--error-image": args.error_image}, IMAGE_OUTPUT)
    if args.error_image and not (args.reference or args.compute_reference):
        raise ConfigError("--error-image: needs --reference or --compute-reference")
    if args.reference and args.compute_reference:
        raise ConfigError("--compute-reference: give either it or --reference, not both")
    if args.scheduler is not None and not args.compute_reference:
        raise ConfigError("--scheduler: spreads the reference of --compute-reference over a Dask cluster; "
                          "give --compute-reference too")
    check_bands(args)
    check_inputs(scene_inputs(args.scene) + pipeline_inputs([args.pipeline])
                 + ([(Path(args.reference), "--reference image")] if args.reference else []), outs)
    check_sizes(args)
    pipe = Pipeline.load(args.pipeline, device=args.device)
    t_scene = time.perf_counter()  # up to here: the interpreter, imports, Warp's start-up, the checks
    ref = read_exr(args.reference) if args.reference else None
    scene = load_scene(args.scene, args)
    conversion_s = time.perf_counter() - t_scene
    check_image_memory(scene.camera, ["render"] + (["png"] if args.png else [])
                       + (["reference"] if ref is not None or args.compute_reference else [])
                       + (["error_image"] if args.error_image else []), _available_memory())
    pipe.check_scene(scene)  # overlapping parts, inputs the pipeline cannot hold: declined before the reference
    if ref is not None:
        want = (scene.camera.height_px, scene.camera.width_px, 4)
        if ref.shape != want:
            raise ConfigError(f"--reference: {args.reference} has shape {ref.shape}, expected {want}")
    elif args.compute_reference:
        ref, ref_s = compute_reference(scene, args.quiet, args.scheduler, args.bands, args.workers or 2)
    try:
        res = pipe.render(scene, reference=ref, quiet=args.quiet, gpu=args.gpu, skip=not args.no_skip)
    except MemoryError:
        raise out_of_memory(scene, ["render"], f"rendering with {pipe.name}", _available_memory()) from None
    if args.compute_reference:
        res.report["reference_s"] = ref_s
    t0 = getattr(args, "t_start", t_scene)
    wall_fields(res.report, startup_s=t_scene - t0, conversion_s=conversion_s, wall_s=time.perf_counter() - t0)
    # all outputs or none: each is written beside its target, then all are renamed together
    with Outputs() as out:
        _write_image(out, outs["-o"], res.image, args.background)
        if args.png:
            out.png(outs["--png"], res.image, background=args.background)
        if args.error_image:
            res.report["error"]["error_image_scale"] = write_error_png(outs["--error-image"], res.image, ref, out)
        if args.report:
            out.text(outs["--report"], report_json(res.report))
    _summary(res.report)
    return 0


def _write_image(out, path: Path, image, background=(0.0, 0.0, 0.0)) -> None:
    """Stage ``image`` as ``path``: float32 OpenEXR for ``.exr``, the 8-bit PNG preview (composited
    over ``background``) for ``.png``."""
    if path.suffix.lower() == ".png":
        out.png(path, image, background=background)
    else:
        out.exr(path, np.asarray(image, np.float32))


def _summary(report: dict) -> None:
    line = f"{report['pipeline']}: {time_summary(report)}"
    if "error" in report:
        e = report["error"]
        psnr = "exact" if e["psnr"] is None else f"{e['psnr']:.1f} dB"
        line += f"  rmse={e['rmse']:.3e} max_abs={e['max_abs']:.3e} psnr={psnr}"
    if "modelled_s" in report:
        t = report["modelled_s"]["total"]
        line += f"  modelled on {report['gpu']}: " + ("-" if t is None else f"{t:.4f} s")
    print(line + wall_summary(report))
    _mesh_notes(report.get("mesh_notes"))


def _mesh_notes(notes) -> None:
    """What the mesh reader left out or changed, counted (also in the report), in one line on stderr."""
    if notes:
        print("warpvol: mesh: " + ", ".join(f"{k.replace('_', ' ')}: {v}" for k, v in notes.items()), file=sys.stderr)


def cmd_gpus(args) -> int:
    from warpvol.model import list_profiles

    for name, title, host in list_profiles():
        print(f"{name:<16} {title}" + (f"; host: {host}" if host else ""))
    return 0


def cmd_reference(args) -> int:
    from warpvol.cli_pieces import DEEP_OUTPUT, check_deep, cmd_reference_pieces, maybe_pieces
    from warpvol.io import Outputs

    if (info := maybe_pieces(args)) is not None:  # a .pvtu of several pieces on Dask: each piece on a worker
        return cmd_reference_pieces(args, info)
    check_deep(args)
    outs = check_outputs({"-o": args.output, "--deep": args.deep}, {**IMAGE_OUTPUT, **DEEP_OUTPUT})
    out = outs["-o"]
    check_inputs(scene_inputs(args.scene), outs)
    check_sizes(args)
    check_bands(args)
    scene = load_scene(args.scene, args)
    check_image_memory(scene.camera, ["reference"], _available_memory())
    if hasattr(scene.mesh, "check_overlap"):  # parts overlapping in space: declined before the reference
        scene.mesh.check_overlap()
    try:
        img, dt = compute_reference(scene, args.quiet, args.scheduler, args.bands, args.workers or 2)
    except MemoryError:
        raise out_of_memory(scene, ["reference"], "computing the reference", _available_memory()) from None
    with Outputs() as staged:
        _write_image(staged, out, img)
    if args.deep:  # the segments, after the image: one per entry of a ray into the mesh
        from warpvol.deep import write_deep
        from warpvol.reference.segments import reference_segments

        write_deep(outs["--deep"], reference_segments(scene.mesh, scene.transfer, scene.camera), scene.camera)
    print(f"reference: {dt:.2f} s, {scene.camera.width_px}x{scene.camera.height_px}, {scene.mesh.n_tets} tets -> {out}")
    _mesh_notes(getattr(scene.mesh, "load_notes", None))
    return 0


def cmd_pipelines(args) -> int:
    import textwrap

    from warpvol.families import PIPELINES_WIDTH, fit_line, preset_groups
    from warpvol.pipeline import _load_builtin_stages
    from warpvol.stage import STAGES

    for k, (family, rows) in enumerate(preset_groups()):
        print(("\n" if k else "") + family)
        for name, short, desc in rows:
            if args.long:
                print(f"  {name}")
                print(textwrap.fill(desc, PIPELINES_WIDTH, initial_indent="    ", subsequent_indent="    "))
            else:
                print(fit_line(f"  {name:<26}{short}", PIPELINES_WIDTH))
    if not args.long:
        print("\n`warpvol pipelines --long` describes each preset in full; `--stages` lists every stage.")
    if args.stages:
        _load_builtin_stages()
        print()
        for n in sorted(STAGES):
            print(STAGES[n].doc_table())
    return 0


def cmd_demo(args) -> int:
    from warpvol.demo import DEMO_BACKGROUND, DEMO_FILES, demo_page
    from warpvol.io import Outputs, OwnedFiles
    from warpvol.metrics import write_error_png
    from warpvol.pipeline import DEFAULT_PIPELINE, Pipeline, report_json
    from warpvol.scene.builtin import BUILTIN_SCENES, builtin_scene

    if args.scene not in BUILTIN_SCENES:
        raise ConfigError(f"--scene: unknown built-in scene {args.scene!r}; allowed: {', '.join(BUILTIN_SCENES)}")
    check_sizes(args)
    outdir = Path(args.output)
    if outdir.exists() and not outdir.is_dir():
        raise ConfigError(f"-o: {outdir} exists and is not a folder")
    pipe = Pipeline.load(args.pipeline or DEFAULT_PIPELINE, device=args.device)
    t0, startup_s = getattr(args, "t_start", None), None
    if t0 is not None:  # the interpreter, imports, Warp's start-up and the pipeline's loading
        startup_s = time.perf_counter() - t0
    scene = builtin_scene(args.scene)
    scene.camera = scene.camera.replace(width_px=args.size, height_px=args.size)
    check_image_memory(scene.camera, ["render", "png", "reference", "error_image"], _available_memory(), "--size")
    outdir.mkdir(parents=True, exist_ok=True)
    check_writable("-o", outdir)
    owned = OwnedFiles(outdir, "demo")
    owned.check(DEMO_FILES)  # a user's own file of one of these names is left alone
    print(f"demo: scene {args.scene!r} ({scene.mesh.n_tets} tets, {args.size}x{args.size}), "
          f"pipeline {pipe.name!r}", file=sys.stderr)
    ref, ref_s = compute_reference(scene, args.quiet)
    first = pipe.render(scene, reference=ref, quiet=args.quiet)  # compiles kernels (once per machine), builds set-up
    res = pipe.render(scene, reference=ref, quiet=True)  # the warm frame: what a render of this scene costs
    res.report["reference_s"] = ref_s
    res.report["first_render"] = {k: first.report[k] for k in ("compile_s", "setup_s", "render_s", "total_s")}
    print(f"first render: {first.report['total_s']:.3f} s, of which kernel compilation / loading "
          f"{first.report['compile_s']:.3f} s (once per machine: Warp keeps compiled kernels in its cache) and "
          f"set-up {first.report['setup_s']:.3f} s (kept for later frames); the warm frame:", file=sys.stderr)
    with Outputs(owned) as out:  # recorded as warpvol's once written
        out.exr(outdir / "image.exr", res.image)
        out.exr(outdir / "reference.exr", ref.astype(np.float32))
        out.png(outdir / "image.png", res.image, background=DEMO_BACKGROUND)
        out.png(outdir / "reference.png", ref, background=DEMO_BACKGROUND)
        err_max = write_error_png(outdir / "error.png", res.image, ref, out)
        out.text(outdir / "report.json", report_json(res.report))
        out.text(outdir / "index.html", demo_page(scene, res.report, err_max))
    _summary(res.report)
    print(f"wrote {outdir}/index.html (image, reference and error side by side), image.exr, image.png, reference.exr, "
          f"reference.png, error.png (log scale, max {err_max:.2e}), report.json"
          + ("" if t0 is None else f"; {time.perf_counter() - t0:.2f} s in all (start-up {startup_s:.2f} s, "
                                  f"reference {ref_s:.2f} s, two renders, the files)"))
    return 0


def build_parser() -> argparse.ArgumentParser:
    from warpvol.cli_tools import cmd_bench, cmd_plan, cmd_stress, cmd_sweep

    p = argparse.ArgumentParser(prog="warpvol", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)

    def common(sp, device=True):
        sp.add_argument("--quiet", action="store_true", help="no progress output on stderr")
        if device:
            sp.add_argument("--device", default="cpu", help="Warp device (cpu, cuda:0)")

    def band_args(sp, what):
        sp.add_argument("--scheduler", help=f"compute {what} in row bands on a Dask cluster: 'local' (worker "
                        "processes on this machine) or a scheduler address tcp://HOST:8786")
        sp.add_argument("--bands", type=int, help="row bands with --scheduler (default: 4 per worker)")
        sp.add_argument("--workers", type=int, help="worker processes of --scheduler local (default: 2)")

    def mesh_args(sp):
        sp.add_argument("--scalars", help="point-data array of a mesh file given as SCENE (default: its active "
                        "scalars)")
        sp.add_argument("--colormap", help="transfer function: this matplotlib colour map or ParaView preset over the "
                        "scalars' range with ParaView's opacity ramp (the default for a mesh file: viridis)")
        sp.add_argument("--step", type=int, help="time step of a time series given as SCENE (.pvd, ...), "
                        "counted from 0 (default: the first)")
        sp.add_argument("--time", type=float, help="the step at this time value of a time series given as SCENE")

    r = sub.add_parser("render", help="render a scene with a pipeline")
    r.add_argument("scene", help="scene TOML file, builtin:NAME or a mesh file (.vtu, .vtk, ...)")
    r.add_argument("--pipeline", default="raycast", help="preset name or pipeline TOML file (default: raycast)")
    r.add_argument("-o", "--output", required=True, help="output image: OpenEXR (.exr, float32 RGBA) or the 8-bit "
                   "PNG preview (.png)")
    r.add_argument("--reference", help="reference EXR: adds the error to the report")
    r.add_argument("--compute-reference", action="store_true",
                   help="compute the exact reference in this run (instead of --reference) for the report's error")
    r.add_argument("--report", help="write the JSON report here")
    r.add_argument("--png", help="also write an 8-bit PNG preview")
    r.add_argument("--error-image", help="with --reference: PNG of the per-pixel max |error| on a logarithmic colour "
                   "scale (1e-8 to its maximum) with a colour bar")
    r.add_argument("--background", type=float, nargs=3, default=(0.0, 0.0, 0.0), help="PNG background RGB")
    r.add_argument("--width", type=int, help="override camera.width_px")
    r.add_argument("--height", type=int, help="override camera.height_px")
    r.add_argument("--strict", action="store_true", help="zero-volume tets are an error")
    r.add_argument("--gpu", help="GPU profile (warpvol gpus): check capabilities, add modelled_s to the report")
    r.add_argument("--no-skip", action="store_true", help="do all the work: no culling of cells the transfer "
                   "function makes invisible, no empty-space skipping, no early ray termination (for comparison; "
                   "the report's left_out section says what is left out otherwise)")
    mesh_args(r)
    band_args(r, "the reference of --compute-reference")
    from warpvol.cli_pieces import add_worker_memory

    add_worker_memory(r)
    r.add_argument("--deep", help="with --scheduler and a .pvtu scene of several pieces: also write the merged segments "
                   "as an OpenEXR deep image (RGBA, Z, ZBack; Z is view-space depth)")
    common(r)
    r.set_defaults(func=cmd_render)

    f = sub.add_parser("reference", help="exact float64 reference image")
    f.add_argument("scene", help="scene TOML file, builtin:NAME or a mesh file (.vtu, .vtk, ...)")
    f.add_argument("-o", "--output", required=True, help="output image: .exr (float32 RGBA) or .png (8-bit preview)")
    f.add_argument("--width", type=int)
    f.add_argument("--height", type=int)
    f.add_argument("--strict", action="store_true")
    mesh_args(f)
    band_args(f, "the reference (a .pvtu scene of several pieces: each piece on a worker)")
    add_worker_memory(f)
    f.add_argument("--deep", help="also write the reference's segments (one per entry of a ray into the mesh or a piece) "
                   "as an OpenEXR deep image (RGBA, Z, ZBack; Z is view-space depth)")
    common(f, device=False)
    f.set_defaults(func=cmd_reference)

    ls = sub.add_parser("pipelines", help="list presets")
    ls.add_argument("--long", action="store_true", help="each preset's full description")
    ls.add_argument("--stages", action="store_true", help="also list every stage with its parameter table")
    ls.set_defaults(func=cmd_pipelines)

    sub.add_parser("gpus", help="list the GPU profiles of the throughput model").set_defaults(func=cmd_gpus)

    d = sub.add_parser("demo", help="built-in scene, default pipeline, image + reference + report")
    d.add_argument("--scene", default="sphere", help="built-in scene name")
    d.add_argument("--pipeline", default=None, help="preset or file (default: raycast)")
    d.add_argument("-o", "--output", default="out/demo", help="output folder")
    d.add_argument("--size", type=int, default=256, help="image width and height in pixels")
    common(d)
    d.set_defaults(func=cmd_demo)

    def scene_args(sp, many=False):
        sp.add_argument("scene", nargs="+" if many else None, help="scene TOML file, builtin:NAME or mesh file"
                        + ("(s)" if many else ""))
        mesh_args(sp)
        sp.add_argument("--width", type=int, help="override camera.width_px")
        sp.add_argument("--height", type=int, help="override camera.height_px")
        sp.add_argument("--strict", action="store_true", help="zero-volume tets are an error")
        common(sp)

    b = sub.add_parser("bench", help="every pipeline on one scene: table, error-vs-time plot, HTML page")
    b.add_argument("--pipelines", nargs="+", default=["all"], help="'all' (every preset) or names/files, "
                   "space- or comma-separated")
    b.add_argument("--gpu", help="GPU profile for modelled times (where the build has GPU profiles)")
    b.add_argument("-o", "--output", required=True, help="output folder")
    b.add_argument("--repeats", type=int, default=3, help="timed renders per pipeline after a warm-up (median)")
    b.add_argument("--cache-dir", help="reference cache folder (default OUTDIR/reference-cache)")
    b.add_argument("--audit", action="store_true", help="also the planner audit: each stage a preset leaves out "
                   "forced back on and timed (more renders per such preset)")
    b.add_argument("--no-audit", dest="audit", action="store_false", help="no planner audit (the default)")
    b.add_argument("--progress", action="store_true", help="progress on stderr also when it is not a terminal "
                   "(lines for a log; --quiet wins)")
    b.add_argument("--quick", action="store_true", help="cap pre-integration table resolutions (as stress --quick)")
    b.add_argument("--resume", action="store_true", help="reuse the pipelines already saved in -o's pipelines/ (an "
                   "interrupted bench of the same scene and settings) and run the rest")
    b.add_argument("--no-skip", action="store_true", help="every render does all the work (render --no-skip): "
                   "no culling of invisible cells, no empty-space skipping, no early ray termination")
    scene_args(b)
    b.set_defaults(func=cmd_bench)

    pl = sub.add_parser("plan", help="which stages a preset leaves out for a scene, why, and the time saved")
    pl.add_argument("--pipeline", nargs="+", default=["raycast"], help="preset(s), space- or comma-separated, or "
                    "'all' (every preset, one after the other: minutes; the expected time is announced; presets "
                    "that decline the scene are listed with the reason) (default: raycast)")
    pl.add_argument("--repeats", type=int, default=3)
    pl.add_argument("--no-measure", action="store_true", help="dry run only: no renders")
    pl.add_argument("--no-skip", action="store_true", help="plan with skipping off (render --no-skip): no stage "
                    "leaves out invisible cells, empty space or occluded depth")
    scene_args(pl, many=True)
    pl.set_defaults(func=cmd_plan)

    st = sub.add_parser("stress", help="stiff and extreme scenes x every pipeline: finite? error? time? (exit 1 on a failure)")
    st.add_argument("--quick", action="store_true", help="the same cases at reduced sizes (CI)")
    st.add_argument("--cases", nargs="+", help="case names (default: all; see warpvol.tools.stress.CASES)")
    st.add_argument("--pipelines", nargs="+", default=["all"], help="'all' (every preset) or names/files, "
                    "space- or comma-separated")
    st.add_argument("-o", "--output", help="folder for stress.json / .csv / .md / .html (and cases/: each case's rows "
                    "saved as it finishes)")
    st.add_argument("--progress", action="store_true", help="progress on stderr also when it is not a "
                    "terminal (lines for a log; --quiet wins)")
    st.add_argument("--resume", action="store_true", help="reuse the cases already saved in -o's cases/ (an "
                    "interrupted run; same --quick and pipelines) and run the rest")
    st.add_argument("--no-skip", action="store_true", help="every render does all the work (render --no-skip): "
                    "no culling of invisible cells, no empty-space skipping, no early ray termination")
    common(st)
    st.set_defaults(func=cmd_stress)

    from warpvol.cli_pieces import add_partition_parser

    add_partition_parser(sub)

    sw = sub.add_parser("sweep", help="scenes x views x presets x options as tasks on Dask (resumable)")
    sw.add_argument("config", help="sweep TOML (see warpvol.tools.sweep)")
    sw.add_argument("-o", "--output", required=True, help="output folder (tasks/, references/, table, plots, HTML)")
    sw.add_argument("--scheduler", help="tcp://HOST:PORT of a running Dask scheduler (default: a local cluster)")
    sw.add_argument("--workers", type=int, default=2, help="worker processes of the local cluster")
    sw.add_argument("--serial", action="store_true", help="run the tasks one after another in this process")
    sw.add_argument("--quiet", action="store_true", help="no progress output on stderr")
    sw.add_argument("--progress", action="store_true", help="progress on stderr also when it is not a "
                    "terminal (lines for a log; --quiet wins)")
    sw.set_defaults(func=cmd_sweep, device="cpu")
    from warpvol.cli_data import add_data_parser

    add_data_parser(sub)  # warpvol data [list] | fetch NAME...|all
    return p


def main(argv: list[str] | None = None) -> int:
    # the start on the perf_counter clock: as a command (argv None), the process's own start, so that wall_s
    # is what the user waited, imports included; called from Python, this call's
    t_start = time.perf_counter() - ((process_age_s() or 0.0) if argv is None else 0.0)
    args = build_parser().parse_args(argv)
    args.t_start = t_start
    args.command_line = shlex.join(["warpvol", *(sys.argv[1:] if argv is None else argv)])
    return _run(args, as_command=argv is None)


#: top-level modules built with nanobind, which reports at exit each of its objects not freed by then: they
#: must stay collectable (:func:`skip_final_collection` is skipped once one is loaded)
NANOBIND_MODULES = ("OpenImageIO",)


def skip_final_collection() -> bool:
    """Leave the objects alive now out of the interpreter's garbage collections (:func:`gc.freeze`), so
    that its shutdown does not traverse them; ``True`` when done. Warp's import and start-up leave a graph
    of objects whose collections at exit took 0.5-1 s under load (``python -c "import warp; warp.init()"``
    0.99 s from its last statement to the process's exit; ``warpvol render`` of a 32 x 32 sphere 0.85 s
    after its wall line). The command line calls this right after Warp's start-up: the objects made later
    (kernels, meshes, images, OpenImageIO's) are collected at exit as usual, and frozen objects are still
    freed when their last reference goes; only reference cycles alive at the freeze are left to the
    operating system, which takes the whole process back. Skipped when a module of
    :data:`NANOBIND_MODULES` is already loaded (its leak report would list every object frozen)."""
    import gc

    if any(m.partition(".")[0] in NANOBIND_MODULES for m in sys.modules):
        return False
    gc.freeze()
    return True


def _run(args, as_command: bool = False) -> int:
    """Run the subcommand; ``as_command``: this process ends after it (see :func:`skip_final_collection`)."""
    try:
        if args.cmd in ("render", "reference", "demo", "bench", "plan", "stress", "sweep"):
            from warpvol.pipeline import quiet_warp

            # the CLI keeps stdout for its summary and reports progress on stderr itself
            quiet_warp(cuda=str(getattr(args, "device", "cpu")).startswith("cuda"))
            if as_command:  # the process ends after the command: no collection at exit of Warp's objects
                skip_final_collection()
        return args.func(args)
    except (WarpvolError, OSError) as e:
        print(f"warpvol: error: {e}", file=sys.stderr)
        return 2
    except MemoryError:
        print("warpvol: error: out of memory: the mesh, the tables built from it or the image do not fit in the "
              "memory available; a smaller mesh or image (--width/--height) needs less", file=sys.stderr)
        return 2
    except RecursionError:
        print("warpvol: error: an input is nested too deeply (arrays or tables inside each other) to be read",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # Ctrl-C: queued work is cancelled (warpvol.parallel), staged outputs removed (warpvol.io.Outputs)
        print("warpvol: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
