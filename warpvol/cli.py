"""Command line (Contract 3).

::

    warpvol render SCENE.toml --pipeline PRESET_OR_FILE -o OUT.exr [--reference REF.exr] [--report OUT.json]
    warpvol reference SCENE.toml -o REF.exr          # exact float64 ray integral
    warpvol pipelines                                 # list presets with one line each
    warpvol gpus                                      # GPU profiles for render --gpu NAME (modelled time)
    warpvol demo                                      # built-in scene, default pipeline, image + report

``SCENE`` is a scene file or ``builtin:NAME``. Bad input ends with ``warpvol: error: ...`` naming the
file / key / value, exit status 2, and no output file.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from .errors import ConfigError, WarpvolError


def _load_scene(spec: str, args) -> "object":
    from .builtin import builtin_scene
    from .scene import load_scene

    if spec.startswith("builtin:"):
        scene = builtin_scene(spec.split(":", 1)[1])
    else:
        scene = load_scene(spec, strict=getattr(args, "strict", False))
    over = {}
    if getattr(args, "width", None):
        over["width_px"] = args.width
    if getattr(args, "height", None):
        over["height_px"] = args.height
    if over:
        scene.camera = scene.camera.replace(**over)
    return scene


def _check_out(path: str, flag: str) -> Path:
    p = Path(path)
    if str(p.parent) not in ("", ".") and not p.parent.exists():
        raise ConfigError(f"{flag}: output folder does not exist: {p.parent}")
    return p


def _progress_printer(quiet: bool):
    state = {"last": -1.0}

    def cb(frac: float) -> None:
        if quiet:
            return
        pct = int(frac * 100)
        if pct >= state["last"] + 10 or frac >= 1.0:
            state["last"] = pct
            print(f"[warpvol] reference {pct:3d} %", file=sys.stderr, flush=True)

    return cb


def compute_reference(scene, quiet: bool = False) -> tuple[np.ndarray, float]:
    from .reference import render_reference

    t0 = time.perf_counter()
    img = render_reference(scene.mesh, scene.transfer, scene.camera, progress=_progress_printer(quiet))
    return img, time.perf_counter() - t0


def cmd_render(args) -> int:
    from .io import read_exr, write_exr, write_png
    from .pipeline import Pipeline

    out = _check_out(args.output, "-o")
    report_path = _check_out(args.report, "--report") if args.report else None
    png_path = _check_out(args.png, "--png") if args.png else None
    err_path = _check_out(args.error_image, "--error-image") if args.error_image else None
    if err_path and not (args.reference or args.compute_reference):
        raise ConfigError("--error-image: needs --reference or --compute-reference")
    scene = _load_scene(args.scene, args)
    ref = None
    if args.reference and args.compute_reference:
        raise ConfigError("--compute-reference: give either it or --reference, not both")
    if args.reference:
        ref = read_exr(args.reference)
        want = (scene.camera.height_px, scene.camera.width_px, 4)
        if ref.shape != want:
            raise ConfigError(f"--reference: {args.reference} has shape {ref.shape}, expected {want}")
    elif args.compute_reference:
        ref, ref_s = compute_reference(scene, args.quiet)
    pipe = Pipeline.load(args.pipeline, device=args.device)
    res = pipe.render(scene, reference=ref, quiet=args.quiet, gpu=args.gpu)
    if args.compute_reference:
        res.report["reference_s"] = ref_s
    write_exr(out, res.image)
    if png_path:
        write_png(png_path, res.image, background=args.background)
    if err_path:
        from .metrics import write_error_png

        res.report["error"]["error_image_scale"] = write_error_png(err_path, res.image, ref)
    if report_path:
        res.write_report(report_path)
    _summary(res.report)
    return 0


def _summary(report: dict) -> None:
    line = f"{report['pipeline']}: {report['total_s']:.3f} s"
    if "error" in report:
        e = report["error"]
        line += f"  rmse={e['rmse']:.3e} max_abs={e['max_abs']:.3e} psnr={e['psnr']:.1f} dB"
    if "modelled_s" in report:
        t = report["modelled_s"]["total"]
        line += f"  modelled on {report['gpu']}: " + ("-" if t is None else f"{t:.4f} s")
    print(line)


def cmd_gpus(args) -> int:
    from .model import list_profiles

    for name, title, host in list_profiles():
        print(f"{name:<16} {title}" + (f"; host: {host}" if host else ""))
    return 0


def cmd_reference(args) -> int:
    from .io import write_exr

    out = _check_out(args.output, "-o")
    scene = _load_scene(args.scene, args)
    img, dt = compute_reference(scene, args.quiet)
    write_exr(out, img.astype(np.float32))
    print(f"reference: {dt:.2f} s, {scene.camera.width_px}x{scene.camera.height_px}, {scene.mesh.n_tets} tets -> {out}")
    return 0


def cmd_pipelines(args) -> int:
    from .pipeline import STAGES, _load_builtin_stages, list_presets

    for name, desc in list_presets():
        print(f"{name:<24} {desc}")
    if args.stages:
        _load_builtin_stages()
        print()
        for n in sorted(STAGES):
            print(STAGES[n].doc_table())
    return 0


def cmd_demo(args) -> int:
    from .builtin import BUILTIN_SCENES, builtin_scene
    from .io import atomic_write_text, write_exr, write_png
    from .metrics import write_error_png
    from .pipeline import DEFAULT_PIPELINE, Pipeline

    if args.scene not in BUILTIN_SCENES:
        raise ConfigError(f"--scene: unknown built-in scene {args.scene!r}; allowed: {', '.join(BUILTIN_SCENES)}")
    outdir = Path(args.output)
    outdir.mkdir(parents=True, exist_ok=True)
    scene = builtin_scene(args.scene)
    scene.camera = scene.camera.replace(width_px=args.size, height_px=args.size)
    pipe = Pipeline.load(args.pipeline or DEFAULT_PIPELINE, device=args.device)
    print(f"demo: scene {args.scene!r} ({scene.mesh.n_tets} tets, {args.size}x{args.size}), "
          f"pipeline {pipe.name!r}", file=sys.stderr)
    ref, ref_s = compute_reference(scene, args.quiet)
    res = pipe.render(scene, reference=ref, quiet=args.quiet)
    res.report["reference_s"] = ref_s
    write_exr(outdir / "image.exr", res.image)
    write_exr(outdir / "reference.exr", ref.astype(np.float32))
    write_png(outdir / "image.png", res.image, background=(0.1, 0.1, 0.1))
    err_max = write_error_png(outdir / "error.png", res.image, ref)
    atomic_write_text(outdir / "report.json", json.dumps(res.report, indent=2) + "\n")
    _summary(res.report)
    print(f"wrote {outdir}/image.exr, image.png, reference.exr, error.png (scaled to max {err_max:.2e}), report.json")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="warpvol", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)

    def common(sp, device=True):
        sp.add_argument("--quiet", action="store_true", help="no progress output on stderr")
        if device:
            sp.add_argument("--device", default="cpu", help="Warp device (cpu, cuda:0)")

    r = sub.add_parser("render", help="render a scene with a pipeline")
    r.add_argument("scene", help="scene TOML file or builtin:NAME")
    r.add_argument("--pipeline", required=True, help="preset name or pipeline TOML file")
    r.add_argument("-o", "--output", required=True, help="output OpenEXR file")
    r.add_argument("--reference", help="reference EXR: adds the error to the report")
    r.add_argument("--compute-reference", action="store_true",
                   help="compute the exact reference in this run (instead of --reference) for the report's error")
    r.add_argument("--report", help="write the JSON report here")
    r.add_argument("--png", help="also write an 8-bit PNG preview")
    r.add_argument("--error-image", help="with --reference: PNG of the per-pixel max |error|, scaled to its maximum")
    r.add_argument("--background", type=float, nargs=3, default=(0.0, 0.0, 0.0), help="PNG background RGB")
    r.add_argument("--width", type=int, help="override camera.width_px")
    r.add_argument("--height", type=int, help="override camera.height_px")
    r.add_argument("--strict", action="store_true", help="zero-volume tets are an error")
    r.add_argument("--gpu", help="GPU profile (warpvol gpus): check capabilities, add modelled_s to the report")
    common(r)
    r.set_defaults(func=cmd_render)

    f = sub.add_parser("reference", help="exact float64 reference image")
    f.add_argument("scene")
    f.add_argument("-o", "--output", required=True)
    f.add_argument("--width", type=int)
    f.add_argument("--height", type=int)
    f.add_argument("--strict", action="store_true")
    common(f, device=False)
    f.set_defaults(func=cmd_reference)

    ls = sub.add_parser("pipelines", help="list presets")
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
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.cmd in ("render", "demo"):
        from .pipeline import quiet_warp

        # the CLI keeps stdout for its summary and reports progress on stderr itself
        quiet_warp()
    try:
        return args.func(args)
    except WarpvolError as e:
        print(f"warpvol: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"warpvol: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
