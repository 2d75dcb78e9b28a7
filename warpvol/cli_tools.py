"""Command line for the measuring tools (:mod:`warpvol.tools`): ``bench``, ``plan``, ``stress`` and ``sweep``.

Imported by :func:`warpvol.cli.build_parser` when the command line starts.
"""

from __future__ import annotations

import sys
from pathlib import Path

from warpvol.cli_checks import (
    check_image_memory,
    check_sizes,
    folder_outputs,
    load_scene,
    output_folder,
    pipeline_inputs,
    scene_inputs,
)
from warpvol.errors import ConfigError, check_number
from warpvol.io import check_inputs


def _available_memory() -> int | None:
    """Bytes of memory available to this process now (:func:`warpvol.io.available_memory`)."""
    from warpvol.io import available_memory

    return available_memory()


def _note(quiet: bool):
    return lambda text: None if quiet else print(f"warpvol: {text}", file=sys.stderr)


def cmd_bench(args) -> int:
    from warpvol.tools.bench import check_gpu, gpu_support, load_pipelines, resolve_pipelines, run_bench, write_bench
    from warpvol.tools.report_html import table_markdown

    check_sizes(args)
    check_number("--repeats", args.repeats, lo=1, integer=True)
    names = resolve_pipelines(args.pipelines)
    pipes = load_pipelines(names, args.device, quick=args.quick)  # bad names fail first
    plan_pipes = dict(zip(names, pipes))
    check_gpu(args.gpu)
    from warpvol.io import OwnedFiles
    from warpvol.tools.bench import (
        BENCH_FILES,
        BENCH_MODELLED_FILES,
        ROW_DIR,
        pipeline_digest,
        pipeline_keys,
        row_stem,
        row_store,
    )

    keys = pipeline_keys(pipes)
    rels = [f"{ROW_DIR}/{row_stem(k)}{ext}" for k in keys for ext in (".json", ".npy")] + list(BENCH_FILES) \
        + (list(BENCH_MODELLED_FILES) if args.gpu else [])
    check_inputs(scene_inputs(args.scene) + pipeline_inputs(names), folder_outputs(Path(args.output), rels))
    scene = load_scene(args.scene, args)
    check_image_memory(scene.camera, ["render", "png", "reference", "error_image"], _available_memory())
    outdir = output_folder(args.output)
    cache_dir = output_folder(args.cache_dir, "--cache-dir") if args.cache_dir else outdir / "reference-cache"
    if args.gpu and gpu_support(args.gpu):
        print(f"warpvol: {gpu_support(args.gpu)}", file=sys.stderr)
    # only files bench wrote and that are still as written (-o's record) are replaced or deleted, nothing
    # before all is checked; each file is recorded once written
    owned = OwnedFiles(outdir, "bench")
    owned.check(rels)
    if not args.resume:
        owned.remove(owned.owned_in(ROW_DIR))
    # each pipeline's row and image are saved as it finishes: an interrupted bench loses nothing
    saved, save = row_store(outdir, scene, repeats=args.repeats, gpu=args.gpu, quick=args.quick,
                            audit=args.audit, skip=not args.no_skip, owned=owned, note=_note(args.quiet),
                            digests={k: pipeline_digest(n) for k, n in zip(keys, names)})
    if saved and not args.quiet:
        print(f"warpvol: bench: resuming, {len(saved)} pipeline(s) read from {outdir / ROW_DIR}", file=sys.stderr)
    try:
        res = run_bench(scene, names, repeats=args.repeats, gpu=args.gpu, device=args.device, quiet=args.quiet,
                        progress=args.progress, cache_dir=cache_dir,
                        audit=args.audit, quick=args.quick, done=saved, on_row=save, skip=not args.no_skip,
                        command=getattr(args, "command_line", None))
    except KeyboardInterrupt:
        print(f"warpvol: bench: the finished pipelines are saved in {outdir / ROW_DIR}; run the same command with "
              "--resume to go on", file=sys.stderr)
        raise
    write_bench(res, outdir, plan={n: p.plan(scene, skip=not args.no_skip) for n, p in plan_pipes.items()},
                owned=owned)
    print(table_markdown(res.rows))
    print(f"wrote {outdir}/index.html, table.csv, table.json, table.md, pareto.png, pareto.svg")
    return 0


def cmd_plan(args) -> int:
    from warpvol.tools.bench import load_pipelines
    from warpvol.tools.plan import run_plan

    check_sizes(args)
    check_number("--repeats", args.repeats, lo=1, integer=True)
    pipes = load_pipelines(args.pipeline, args.device, flag="--pipeline")
    scenes = [load_scene(s, args) for s in args.scene]
    for scene in scenes:
        check_image_memory(scene.camera, ["render"], _available_memory())
    # one preset that declines the scene ends with the error; with several the declines are listed
    run_plan(pipes, scenes, repeats=args.repeats, measure=not args.no_measure, skip=not args.no_skip,
             note=_note(args.quiet))
    return 0


def cmd_stress(args) -> int:
    from warpvol.io import Outputs, OwnedFiles
    from warpvol.pipeline import report_json
    from warpvol.tools.bench import load_pipelines, pipeline_digest, resolve_pipelines
    from warpvol.tools.report_html import table_csv
    from warpvol.tools.stress import (
        CASE_DIR,
        STRESS_FILES,
        case_store,
        check_case_names,
        run_stress,
        stress_markdown,
        stress_matrix,
        stress_page,
    )

    if args.resume and not args.output:
        raise ConfigError("--resume: needs -o, the folder of the run to resume")
    # every argument is checked before any file is touched
    names = check_case_names(args.cases)
    pipe_names = resolve_pipelines(args.pipelines)
    load_pipelines(pipe_names, args.device, quick=args.quick)
    saved, save = {}, None
    if args.output:  # each case's rows are saved as it finishes: an interrupted suite loses nothing
        rels = [f"{CASE_DIR}/{n}.json" for n in names] + list(STRESS_FILES)
        check_inputs(pipeline_inputs(pipe_names), folder_outputs(Path(args.output), rels))
        outdir = output_folder(args.output)
        # only files stress wrote and that are still as written (-o's record) are replaced or deleted
        owned = OwnedFiles(outdir, "stress")
        owned.check(rels)
        if not args.resume:
            owned.remove(owned.owned_in(CASE_DIR))
        saved, save = case_store(outdir, args.quick, pipe_names, skip=not args.no_skip, owned=owned,
                                 note=_note(args.quiet),
                                 digests={n: pipeline_digest(n) for n in pipe_names})
    else:
        outdir = None
        if saved and not args.quiet:
            print(f"warpvol: stress: resuming, {len(saved)} case(s) read from {outdir / CASE_DIR}", file=sys.stderr)
    try:
        rows = run_stress(quick=args.quick, cases=names, pipelines=pipe_names, device=args.device,
                          quiet=args.quiet, done=saved, on_case=save, progress=args.progress,
                          skip=not args.no_skip)
    except KeyboardInterrupt:
        if outdir is not None:
            print(f"warpvol: stress: the finished cases are saved in {outdir / CASE_DIR}; run the same command "
                  "with --resume to go on", file=sys.stderr)
        raise
    md = stress_markdown(rows) + "\n\n" + stress_matrix(rows)
    if outdir is not None:
        with Outputs(owned) as out:
            out.text(outdir / "stress.json", report_json({"quick": args.quick, "rows": rows}))
            out.text(outdir / "stress.csv", table_csv(rows))
            out.text(outdir / "stress.md", md + "\n")
            out.text(outdir / "stress.html", stress_page(rows, args.quick))
    print(md)
    failed = [r for r in rows if r["status"] == "failed"]
    for r in failed:
        print(f"warpvol: stress: {r['case']} / {r['pipeline']} failed: {r['message']}", file=sys.stderr)
    return 1 if failed else 0


def cmd_sweep(args) -> int:
    from warpvol.io import OwnedFiles
    from warpvol.tools.report_html import table_markdown
    from warpvol.tools.sweep import SWEEP_FILES, load_config, plan_tasks, run_sweep, write_sweep

    check_number("--workers", args.workers, lo=1, integer=True)
    if args.scheduler is not None and not args.scheduler.startswith(("tcp://", "tls://", "inproc://")):
        raise ConfigError(f"--scheduler: expected tcp://HOST:PORT, got {args.scheduler!r}")
    if args.scheduler and args.serial:
        raise ConfigError("--serial: give either it or --scheduler, not both")
    cfg = load_config(args.config)
    rels = [f"tasks/{t.key}{ext}" for t in plan_tasks(cfg)[0] for ext in (".json", ".npy")] + list(SWEEP_FILES)
    inputs = [(Path(args.config), "sweep config")] + [f for sc in cfg.scenes for f in scene_inputs(sc)] \
        + pipeline_inputs(cfg.presets)
    check_inputs(inputs, folder_outputs(Path(args.output), rels))
    outdir = output_folder(args.output)
    owned = OwnedFiles(outdir, "sweep")
    owned.check(rels)  # only files sweep wrote and that are still as written are replaced

    def done(row: dict, _client) -> None:  # a task's files are recorded once written
        if row.get("status") == "ok":
            owned.wrote([f"tasks/{row['task']}{ext}" for ext in (".json", ".npy")])

    res = run_sweep(cfg, outdir, scheduler=args.scheduler, workers=args.workers, serial=args.serial, quiet=args.quiet,
                    progress=args.progress, on_result=done)
    write_sweep(res, outdir, owned=owned)
    failed = [r for r in res.rows if r["status"] == "failed"]
    print(table_markdown([{**r, "pipeline": f"{r['scene']} {r['view']} {r['pipeline']} [{r['options']}]"}
                          for r in res.rows]))
    print(f"{len(res.rows)} rows ({res.skipped_done} done before, {len(failed)} failed) in {res.wall_s:.1f} s; "
          f"wrote {outdir}/index.html, table.csv, table.json, table.md, pareto.png, pareto.svg")
    for r in failed:
        print(f"warpvol: sweep: {r['task']} failed: {r['message']}", file=sys.stderr)
    return 1 if failed else 0
