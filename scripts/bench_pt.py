"""Benchmark: warpvol's projected-tetrahedra presets vs VTK's ``vtkProjectedTetrahedraMapper``.

Renders a scene (default: NASA Blunt Fin, perspective, 512x512, ``scenes/bluntfin.toml``) with each
PT preset (``pt_vertex_color``, ``roettger2000_3d``, ``roettger2002_hw``, ``pt_best`` by default) and with VTK's
projected-tetrahedra mapper (OpenGL, offscreen; on a machine without a GPU that is Mesa's software
rasteriser) in one run (PNGs of each, and ``side_by_side_pt_vertex_color_vtk.png``: reference, warpvol
``pt_vertex_color``, VTK, 4x their difference); prints times (median of ``--repeat`` rounds, interleaved: one render of each renderer per round,
after a first round that includes kernel compilation, table builds and mesh derived data), the ratio to VTK and the errors
against the exact reference (cached in ``--out``). VTK's transfer function gets the same control
points, colour and extinction (scalar opacity unit distance 1), as in ``scripts/bench_raycast.py``.

``--variant PRESET:STAGE.PARAM=VALUE`` (repeatable) adds a preset with one stage parameter replaced to the
same interleaved rounds, e.g. ``pt_best:pt_integrate.walk=pixel`` (pt_best on the emulated per-pixel
fragment walk) for an A/B against ``pt_best`` (its fused draw, ``walk = "fused"``).

``--fill`` runs only the views where the data fills the image (``scenes/bluntfin_close.toml``,
``scenes/spx_fill.toml``): ``pt_best`` against VTK's projected-tetrahedra mapper, printing ``VTK PT time /
pt_best time`` (``bench_raycast.fill_vs_vtk_pt``).

``--spans`` compares ``pt_best`` one fragment at a time and in SIMD spans with VTK's mapper
(``scripts/bench_pt_spans.py``: ns per fragment, us per cell, VTK PT / this, load average; ``--json``).

Usage::

    ./run.sh python scripts/bench_pt.py [--scene scenes/bluntfin.toml] [--size 512] [--repeat 1]
        [--presets pt_best] [--variant pt_best:pt_integrate.walk=pixel] [--fill]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_raycast import interleaved_times, scene_and_reference, vtk_renderer, warpvol_renderer  # noqa: E402

PRESETS = ("pt_vertex_color", "roettger2000_3d", "roettger2002_hw", "pt_best")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "bluntfin.toml"))
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--presets", default=",".join(PRESETS), help="comma-separated PT presets")
    ap.add_argument("--variant", action="append", default=[],
                    help="PRESET:STAGE.PARAM=VALUE, a preset with one stage parameter replaced (TOML value or a bare word)")
    ap.add_argument("--out", default=str(ROOT / "out" / "bench_pt"))
    ap.add_argument("--fill", action="store_true",
                    help="only the views filling the image (scenes/bluntfin_close.toml, scenes/spx_fill.toml): "
                         "VTK PT time / pt_best time, medians over interleaved rounds (--repeat, at least 5), errors, load")
    from bench_pt_spans import add_arguments

    add_arguments(ap)
    args = ap.parse_args(argv)
    if args.spans:
        from bench_pt_spans import main as spans

        return spans(args)
    if args.fill:
        from bench_raycast import fill_vs_vtk_pt

        fill_vs_vtk_pt(["pt_best"], size=args.size, repeat=max(args.repeat, 5))
        return 0

    from warpvol.io import write_png
    from warpvol.metrics import image_error
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    out = Path(args.out)
    scene, ref = scene_and_reference(args.scene, args.size, out)
    write_png(out / "reference.png", ref)
    renderers = [("VTK vtkProjectedTetrahedraMapper", *vtk_renderer(scene, "projected_tetrahedra"))]
    results = {}
    for name in args.presets.split(","):
        render, image, result = warpvol_renderer(scene, args.device, preset=name)
        renderers.append((f"warpvol {name}", render, image))
        results[f"warpvol {name}"] = result
    for spec in args.variant:
        render, image, result = variant_renderer(scene, args.device, spec)
        renderers.append((f"warpvol {spec}", render, image))
        results[f"warpvol {spec}"] = result
    times = interleaved_times(renderers, args.repeat)  # renders interleaved per round, first is a warm-up
    vtk_t = statistics.median(times[renderers[0][0]][1:])
    rows = []
    theirs = renderers[0][2]()
    write_png(out / "vtk_pt.png", theirs)
    for label, _, image in renderers:
        img = image()
        row = {"renderer": label, "time_s": statistics.median(times[label][1:]), "first_s": times[label][0],
               "error": image_error(img, ref)}
        if label in results:
            res, name = results[label](), label.split(" ", 1)[1]
            write_png(out / f"{name.replace(':', '_').replace('=', '_')}.png", img)
            if name == "pt_vertex_color":  # reference | warpvol | VTK | 4 x |warpvol - VTK| (RGBA)
                diff = 4.0 * np.abs(img - theirs).max(axis=-1)
                write_png(out / "side_by_side_pt_vertex_color_vtk.png",
                          np.concatenate([ref[..., :3], img[..., :3], theirs[..., :3],
                                          np.repeat(diff[..., None], 3, axis=-1)], axis=1))
            row.update(stages=res.report["stages"], counters=res.report["counters"], stats=res.report.get("stats", {}))
        rows.append(row)
    (out / "result.json").write_text(json.dumps({"scene": scene.name, "tets": scene.mesh.n_tets, "size": args.size,
                                                 "rows": rows}, indent=2))
    print(f"{scene.name}: {scene.mesh.n_tets} tets, {args.size}x{args.size}, device {args.device}")
    w = max(36, *(len(r["renderer"]) + 2 for r in rows))
    print(f"{'renderer':<{w}}{'time [s]':>10}{'first [s]':>11}{'/ VTK':>8}{'rmse':>12}{'max_abs':>12}{'psnr':>8}")
    for r in rows:
        e = r["error"]
        print(f"{r['renderer']:<{w}}{r['time_s']:>10.3f}{r['first_s']:>11.3f}{r['time_s'] / vtk_t:>8.2f}"
              f"{e['rmse']:>12.3e}{e['max_abs']:>12.3e}{e['psnr']:>8.1f}")
    return 0


def variant_renderer(scene, device: str, spec: str):
    """``(render, image, result)`` for ``PRESET:STAGE.PARAM=VALUE`` (the value parsed as TOML)."""
    import tomllib

    from warpvol.pipeline import Pipeline, _read_pipeline_text

    try:
        name, rest = spec.split(":", 1)
        key, text = rest.split("=", 1)
        stage, param = key.split(".", 1)
    except ValueError:
        raise SystemExit(f"--variant: expected PRESET:STAGE.PARAM=VALUE, got {spec!r}")
    cfg = tomllib.loads(_read_pipeline_text(name)[0])
    hit = [st for st in cfg["stages"] if st["stage"] == stage]
    if not hit:
        raise SystemExit(f"--variant: preset {name!r} has no stage {stage!r}")
    for st in hit:
        try:
            st[param] = tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:  # a bare word: a string
            st[param] = text
    pipe = Pipeline.from_config(cfg, device=device)
    last = {}

    def render():
        last["res"] = pipe.render(scene, quiet=True)

    return render, lambda: last["res"].image, lambda: last["res"]


if __name__ == "__main__":
    sys.exit(main())
