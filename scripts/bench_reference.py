"""Benchmark: the exact reference (Warp kernels) against ``raycast``'s warm frame, interleaved in one process.

On each ``--scenes`` (default the dense views ``scenes/bluntfin_close.toml`` and ``scenes/spx_fill.toml``) at
each ``--sizes``: one ``raycast`` frame and one reference (:func:`warpvol.reference.warp_render.render_reference_warp`,
what ``warpvol reference`` and ``--compute-reference`` run) to warm up (kernels compiled or loaded, per-mesh
data built: reported apart as *first*), then ``--rounds`` rounds of one ``raycast`` frame and one reference each,
alternating, so that load from other processes hits both alike. Warm = the second call and later. Prints, per
scene and size, the median warm seconds of each, the median per-round ratio reference / raycast (with its
range) and that of their CPU seconds (this process's, all threads: less sensitive to load from other
processes than the wall-clock ratio), the reference's own split (set-up on the host before the walk, the
walk's launches), its segments and tet steps, and the 1-minute load average before and after. With
``--numpy-sizes`` the NumPy oracle (:mod:`warpvol.reference.numpy_render`) runs once at those sizes, for its
time and its largest difference from the Warp reference. ``--docs`` writes the rows to
``docs/data/reference_pace.json`` (stamped: :mod:`warpvol.tools.provenance`), which the performance page
quotes.

Usage::

    ./run.sh python scripts/bench_reference.py [--scenes scenes/bluntfin_close.toml ...] [--sizes 512]
        [--rounds 3] [--numpy-sizes] [--device cpu] [--json out.json] [--docs]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DOCS_JSON = ROOT / "docs" / "data" / "reference_pace.json"
DEFAULT_SCENES = [str(ROOT / "scenes" / "bluntfin_close.toml"), str(ROOT / "scenes" / "spx_fill.toml")]


def _load(path: str):
    from warpvol.scene.builtin import builtin_scene
    from warpvol.scene.scene_file import load_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return builtin_scene(path[8:]) if path.startswith("builtin:") else load_scene(path)


def bench_scene(path: str, sizes: list[int], rounds: int, numpy_sizes: list[int], device: str) -> list[dict]:
    from warpvol.pipeline import Pipeline
    from warpvol.reference.numpy_render import render_reference
    from warpvol.reference.warp_render import render_reference_warp

    scene = _load(path)
    print(f"scene {scene.name}: {scene.mesh.n_tets} tets, device {device}", file=sys.stderr)
    base_cam = scene.camera
    pipe = Pipeline.load("raycast", device=device)
    rows = []
    for size in sizes:
        scene.camera = cam = base_cam.replace(width_px=size, height_px=size)

        def ref(st):
            return render_reference_warp(scene.mesh, scene.transfer, cam, device=device, stats=st,
                                         show_progress=False)

        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        pipe.render(scene, quiet=True)
        first_ray = time.perf_counter() - t0
        t0 = time.perf_counter()
        ref({})
        first_ref = time.perf_counter() - t0
        t_ray, t_ref, c_ray, c_ref, st_all, img = [], [], [], [], [], None
        for _ in range(rounds):
            c0, t0 = time.process_time(), time.perf_counter()
            pipe.render(scene, quiet=True)
            t_ray.append(time.perf_counter() - t0)
            c_ray.append(time.process_time() - c0)
            st = {}
            c0, t0 = time.process_time(), time.perf_counter()
            img = ref(st)
            t_ref.append(time.perf_counter() - t0)
            c_ref.append(time.process_time() - c0)
            st_all.append(st)
        ratios = [b / a for a, b in zip(t_ray, t_ref)]
        cpu_ratios = [b / a for a, b in zip(c_ray, c_ref)]
        row = dict(scene=scene.name, size=size, raycast=statistics.median(t_ray), reference=statistics.median(t_ref),
                   ratio=statistics.median(ratios), ratio_lo=min(ratios), ratio_hi=max(ratios),
                   cpu_raycast=statistics.median(c_ray), cpu_reference=statistics.median(c_ref),
                   cpu_ratio=statistics.median(cpu_ratios),
                   ref_setup=statistics.median(s["setup_s"] for s in st_all),
                   ref_walk=statistics.median(s["render_s"] for s in st_all),
                   first_raycast=first_ray, first_reference=first_ref, segments=st_all[-1]["n_segments"],
                   steps=st_all[-1]["n_steps"], failed=st_all[-1]["n_failed"], rounds=rounds,
                   load=(load0, os.getloadavg()[0]), numpy=None, diff=None)
        if size in numpy_sizes:
            t0 = time.perf_counter()
            ref_np = render_reference(scene.mesh, scene.transfer, cam, method="numpy")
            row["numpy"] = time.perf_counter() - t0
            row["diff"] = float(np.abs(img - ref_np).max())
        rows.append(row)
        print(f"  {size}^2 done", file=sys.stderr)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=DEFAULT_SCENES)
    ap.add_argument("--sizes", type=int, nargs="+", default=[512])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--numpy-sizes", type=int, nargs="*", default=[])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--json", default=None, help="also write the rows to this JSON file")
    ap.add_argument("--docs", action="store_true", help=f"write the table to {DOCS_JSON.relative_to(ROOT)}")
    args = ap.parse_args(argv)
    from warpvol.tools import provenance

    block = provenance.start(provenance.command_line("scripts/bench_reference.py", argv), timing=True,
                             note="raycast and the reference alternating in one process, warm against warm")

    rows = []
    for path in args.scenes:
        rows += bench_scene(path, args.sizes, max(1, args.rounds), args.numpy_sizes, args.device)

    print("| scene | size | raycast warm (s) | reference warm (s) [set-up + walk] | reference / raycast "
          "[range] | CPU s raycast / reference (ratio) | first raycast / reference (s) | segments | tet steps | failed | NumPy (s) | max abs Warp - "
          "NumPy | load |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        np_s = "-" if r["numpy"] is None else f"{r['numpy']:.1f}"
        diff = "-" if r["diff"] is None else f"{r['diff']:.2g}"
        print(f"| {r['scene']} | {r['size']}^2 | {r['raycast']:.3f} | {r['reference']:.3f} "
              f"[{r['ref_setup']:.3f} + {r['ref_walk']:.3f}] | {r['ratio']:.2f}x [{r['ratio_lo']:.2f}-"
              f"{r['ratio_hi']:.2f}] | {r['cpu_raycast']:.2f} / {r['cpu_reference']:.2f} ({r['cpu_ratio']:.2f}x) | "
              f"{r['first_raycast']:.2f} / {r['first_reference']:.2f} | {r['segments']:,} | "
              f"{r['steps']:,} | {r['failed']} | {np_s} | {diff} | {r['load'][0]:.1f}-{r['load'][1]:.1f} |")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    if args.docs:
        write_docs(rows, block)
    return 0


COLUMNS = ["scene", "size", "raycast_s", "reference_s", "ratio", "ratio_lo", "ratio_hi", "cpu_ratio", "setup_s",
           "walk_s", "segments", "rounds", "load_start", "load_end"]


def write_docs(rows: list[dict], block: dict) -> None:
    """The rows as table ``reference_pace`` of :data:`DOCS_JSON`, stamped."""
    from warpvol.tools import provenance

    out = [[r["scene"], r["size"], round(r["raycast"], 3), round(r["reference"], 3), round(r["ratio"], 2),
            round(r["ratio_lo"], 2), round(r["ratio_hi"], 2), round(r["cpu_ratio"], 2), round(r["ref_setup"], 3),
            round(r["ref_walk"], 3), int(r["segments"]), r["rounds"], round(r["load"][0], 2), round(r["load"][1], 2)]
           for r in rows]
    table = {"title": "the exact reference (warpvol reference, --compute-reference) against raycast's warm frame: "
                      "median seconds of rounds alternating in one process after one warm-up call each, the "
                      "median per-round ratio reference / raycast (wall clock, its range, and of CPU seconds)",
             "columns": COLUMNS, "rows": out}
    provenance.write_json(DOCS_JSON, {"tables": {"reference_pace": table}},
                          provenance.with_loads(block, [round(x, 2) for r in rows for x in r["load"]]))
    print(f"  wrote {DOCS_JSON}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
