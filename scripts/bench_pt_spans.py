"""Benchmark: ``pt_best``'s fused draw one fragment at a time (``pt_integrate.lanes = 1``) and in SIMD spans
(``lanes = 16``, the CPU's default) against VTK's ``vtkProjectedTetrahedraMapper``, interleaved in one process.

For each view (``--scenes`` x ``--tfs``: the transfer functions of ``scripts/bench_skip.py``, dense, sparse
and opaque), the three renderers render once per round, ``--repeat`` rounds after a warm-up round (kernels
compiled, per-mesh data built). Per renderer: the median frame time and ``VTK PT / this``; for the two
``pt_best`` paths also the fused draw's time (:func:`warpvol.projection.pt._draw_fused`, wall and CPU of
this process), its fragments (integrated and blended) and ``ns per fragment`` (draw wall time / fragments;
the draw includes the rasteriser's triangle set-up and binning), and ``us per cell`` of the per-cell work
before the draw (the ``pt_project`` stage: classification, decomposition, projection; its time over the
cells drawn), and the median time of each pipeline stage. ``--corner`` adds, per view, its corner view
(``scripts/bench_skip.py``'s ``corner_view``: the mesh in a corner of the image, the rest empty; what a small
frame costs). Both
paths must give the same image bits (checked; a difference is an error). The load
average is printed and written with every view. ``--json`` writes the rows with the commit, the command
and the date.

Usage::

    ./run.sh python scripts/bench_pt.py --spans [--scenes scenes/bluntfin_close.toml scenes/spx_fill.toml]
        [--tfs dense sparse opaque] [--size 512] [--repeat 3] [--corner] [--json docs/data/pt_spans.json]
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

from bench_raycast import FILL_SCENES, load_average, vtk_renderer  # noqa: E402

LANES = (1, 16)


class DrawClock:
    """Wraps :func:`warpvol.projection.pt._draw_fused`: wall and CPU seconds and fragments of the draws since
    :meth:`reset`."""

    def __init__(self):
        from warpvol.projection import pt as ppt

        self.ppt, self.orig = ppt, ppt._draw_fused
        self.reset()

        def timed(*a, **k):
            t0, c0 = time.perf_counter(), time.process_time()
            info = self.orig(*a, **k)
            self.wall += time.perf_counter() - t0
            self.cpu += time.process_time() - c0
            self.fragments += info["fragments"]
            return info

        ppt._draw_fused = timed

    def reset(self):
        self.wall = self.cpu = 0.0
        self.fragments = 0


def pt_best_renderer(scene, lanes: int, clock: DrawClock, stats: list):
    """``(render, image)`` of pt_best with ``pt_integrate.lanes``; each render appends its draw numbers to ``stats``."""
    from warpvol.pipeline import Pipeline
    from warpvol.tools.sweep import pipeline_config

    pipe = Pipeline.from_config(pipeline_config("pt_best", (("pt_integrate.lanes", lanes),)))
    last = {}

    def render():
        clock.reset()
        last["res"] = res = pipe.render(scene, quiet=True)
        st = res.report["stage_timing"]
        stats.append({"draw_wall_s": clock.wall, "draw_cpu_s": clock.cpu, "fragments": clock.fragments,
                      "pt_project_s": st["pt_project"]["s"], "stages_s": {k: v["s"] for k, v in st.items()}})

    return render, lambda: last["res"]


def run_view(path: str, tf_name: str, size: int, repeat: int, corner: bool = False) -> dict:
    from bench_skip import corner_view, variant

    from warpvol.scene.scene_file import load_scene

    base = load_scene(path)
    base.camera = base.camera.replace(width_px=size, height_px=size)
    scene, frac = variant(base, tf_name)
    if corner:
        scene = corner_view(scene)
    clock = DrawClock()
    stats = {n: [] for n in LANES}
    vtk_render, vtk_image = vtk_renderer(scene, "projected_tetrahedra")
    renderers = [("VTK PT", vtk_render)]
    results = {}
    for n in LANES:
        render, result = pt_best_renderer(scene, n, clock, stats[n])
        renderers.append((f"pt_best lanes={n}", render))
        results[n] = result
    load0 = load_average()
    times = {name: [] for name, _ in renderers}
    for _ in range(repeat + 1):
        for name, render in renderers:
            t0 = time.perf_counter()
            render()
            times[name].append(time.perf_counter() - t0)
    load1 = load_average()
    a, b = results[LANES[0]](), results[LANES[1]]()
    if not np.array_equal(a.image.view(np.uint32), b.image.view(np.uint32)):
        raise SystemExit(f"{scene.name} {tf_name}: lanes={LANES[0]} and lanes={LANES[1]} draw different images")
    if a.report["counters"] != b.report["counters"]:
        raise SystemExit(f"{scene.name} {tf_name}: the two paths count differently")
    cells = int(a.report["counters"]["pt_project"]["tets_projected"])
    vtk_t = statistics.median(times["VTK PT"][1:])
    row = {"scene": path, "view": "corner" if corner else "scene", "tf": tf_name, "visible_fraction": frac,
           "tets": scene.mesh.n_tets, "cells_drawn": cells,
           "size": size, "repeat": repeat, "load": [load0, load1], "renderers": {}}
    print(f"\n{scene.name} {tf_name} ({scene.mesh.n_tets} tets, {cells} drawn, {size}x{size}), {repeat} interleaved "
          f"rounds after a warm-up; {load0} (start), {load1} (end)")
    print(f"{'renderer':<18}{'median [s]':>11}{'VTK PT / this':>15}{'draw [s]':>10}{'draw CPU [s]':>13}"
          f"{'fragments':>12}{'ns / fragment':>15}{'us / cell (pt_project)':>24}")
    for name, _ in renderers:
        t = statistics.median(times[name][1:])
        r = {"median_s": t, "times_s": times[name], "vtk_pt_over_this": vtk_t / t}
        line = f"{name:<18}{t:>11.4f}{vtk_t / t:>15.2f}"
        if name != "VTK PT":
            st = stats[int(name.split("=")[1])][1:]
            dw = statistics.median(s["draw_wall_s"] for s in st)
            dc = statistics.median(s["draw_cpu_s"] for s in st)
            pp = statistics.median(s["pt_project_s"] for s in st)
            nf = st[-1]["fragments"]
            r.update(draw_wall_s=dw, draw_cpu_s=dc, fragments=nf, ns_per_fragment=dw / max(nf, 1) * 1e9,
                     cpu_ns_per_fragment=dc / max(nf, 1) * 1e9, pt_project_s=pp,
                     us_per_cell=pp / max(cells, 1) * 1e6)
            line += (f"{dw:>10.4f}{dc:>13.4f}{nf:>12,}{r['ns_per_fragment']:>15.1f}{r['us_per_cell']:>24.2f}")
            r["stages_ms"] = {k: statistics.median(s["stages_s"][k] for s in st) * 1e3 for k in st[-1]["stages_s"]}
            line += "\n    stages [ms]: " + ", ".join(f"{k} {v:.1f}" for k, v in r["stages_ms"].items())
        print(line)
        row["renderers"][name] = r
    return row


COLUMNS = ["view", "TF", "size", "renderer", "median [s]", "VTK PT / this", "draw [s]", "draw CPU [s]", "fragments",
           "ns / fragment", "CPU ns / fragment", "us / cell", "load (1 min)"]


def rows_table(views: list[dict]) -> dict:
    """The views as one table (``docs/hooks.py``'s value markers quote it): a row per view and renderer."""
    out = []
    for v in views:
        view = Path(v["scene"]).stem + ("_corner" if v.get("view") == "corner" else "")
        load = float(v["load"][0].split()[2])
        for name, r in v["renderers"].items():
            d = lambda k: round(r[k], 4) if k in r else "-"  # noqa: E731
            out.append([view, v["tf"], v["size"], name, round(r["median_s"], 4), round(r["vtk_pt_over_this"], 3),
                        d("draw_wall_s"), d("draw_cpu_s"), r.get("fragments", "-"), d("ns_per_fragment"),
                        d("cpu_ns_per_fragment"), d("us_per_cell"), load])
    return {"title": "pt_best one fragment at a time (lanes=1) and in SIMD spans (lanes=16) against VTK's PT mapper, "
                     "interleaved in one process", "columns": COLUMNS, "rows": out}


def main(args) -> int:
    from warpvol.pipeline import quiet_warp
    from warpvol.tools import provenance

    quiet_warp()
    block = provenance.start(provenance.command_line("scripts/bench_pt.py"), timing=True,
                             note="pt_best lanes=1 vs lanes=16 vs VTK's projected-tetrahedra mapper, interleaved in "
                                  "one process (scripts/bench_pt_spans.py)")
    rows = [run_view(p, tf, args.size, args.repeat, corner) for p in args.scenes for tf in args.tfs
            for corner in ((False, True) if args.corner else (False,))]
    if args.json:
        loads = [float(r["load"][k].split()[2]) for r in rows for k in (0, 1)]
        doc = {"tables": {"rows": rows_table(rows)}, "views": rows}
        provenance.write_json(args.json, doc, provenance.with_loads(block, loads))
        print(f"\nwrote {args.json}")
    return 0


def add_arguments(ap) -> None:
    ap.add_argument("--spans", action="store_true", help="pt_best lanes=1 vs lanes=16 vs VTK PT (scripts/bench_pt_spans.py)")
    ap.add_argument("--scenes", nargs="+", default=list(FILL_SCENES))
    ap.add_argument("--tfs", nargs="+", default=["dense", "sparse", "opaque"])
    ap.add_argument("--json", default=None, help="write the rows here (e.g. docs/data/pt_spans.json)")
    ap.add_argument("--corner", action="store_true",
                    help="each view also as its corner view (bench_skip.corner_view: the mesh in a corner of the "
                         "image; a small frame's fixed costs)")
