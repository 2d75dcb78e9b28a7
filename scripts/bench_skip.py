"""Benchmark: what leaving out invisible cells, empty space and occluded depth buys the exact presets,
against VTK's projected-tetrahedra mapper, on views whose data fills the image.

For each view (default ``scenes/bluntfin_close.toml``, the NASA Blunt Fin from close by, and
``scenes/spx_fill.toml``, the SPX mesh filling the image) and three transfer functions:

* ``dense``: the scene's own (a faint background everywhere plus its peaks);
* ``sparse``: one iso-like shell, a hat around the median scalar whose half-width is chosen so that
  5-10 % of the cells can be visible (:func:`warpvol.conditioning.visibility.cell_visibility`; the
  fraction is printed);
* ``opaque``: the scene's colours with a constant extinction of 100 over the mesh's diagonal, so a ray
  is opaque (transmittance 1e-6) within 14 % of the diagonal,

it renders with ``vtkProjectedTetrahedraMapper`` (pyvista/VTK, offscreen, set up as in
``scripts/bench_raycast.py``) and every exact preset (``raycast``, ``harc_best``, ``pt_best``,
``vsbuffer_best``), and each preset also with ``skip=False`` (all the work, for comparison; not
``vsbuffer_best`` unless ``--no-skip-vsbuffer``), interleaved in one process: each round renders once
with every renderer in turn, after a warm-up round (kernels compiled, per-mesh data built, VTK's
structures built), so load from other processes on a shared machine hits all of them alike.
``vsbuffer_best`` (its sweep emulated plane by plane: minutes per frame at 512^2 on two cores) runs
on the same views at ``--slow-size`` (default 128^2), interleaved with VTK at that size,
``--slow-repeat`` timed rounds.

Prints per renderer the median time, ``VTK PT median / this median`` (> 1: faster than VTK), the error
against the exact reference (cached in ``--out``) with the preset's tolerance row, and what the render
left out (``report["left_out"]``: cells culled, fragments, steps and rays left), with the machine's load
average; writes ``--out/skip_result.json`` and, with ``--docs``, ``docs/data/skip.json`` (tables ``summary``
and ``rows`` for the performance page's ``<!-- table: skip/... -->`` markers; ``--docs-from JSON`` writes
them from an earlier run's ``skip_result.json`` without rendering).

``--small``: sparse views of a small mesh, where a frame is mostly fixed cost: SPX (12,936 tets) seen from
far off (``scenes/spx.toml``) and filling the image (``scenes/spx_fill.toml``), each also as its ``corner``
view (``--corner``: the camera turned half way to the corner of the mesh's bounding box farthest along the
view's right, up and forward axes, so the mesh fills a corner of the image), with the sparse TF, ``raycast`` and
``harc_best`` with skipping on only (``--skip-only``); it prints each ratio beside its target (:data:`TARGETS`)
and writes ``--out`` (default ``out/bench_skip_small``) and, with ``--docs``, ``docs/data/skip_small.json``.

Usage::

    ./run.sh python scripts/bench_skip.py [--size 512] [--repeat 3] [--slow-repeat 1] [--presets ...]
        [--tfs dense sparse opaque] [--scenes scenes/bluntfin_close.toml scenes/spx_fill.toml] [--corner]
        [--skip-only] [--small]
"""

from __future__ import annotations

import argparse
import copy
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

from bench_raycast import FILL_SCENES, cached_reference, load_average, tolerance_row, vtk_renderer  # noqa: E402

from warpvol.tools import provenance  # noqa: E402

PRESETS = ("raycast", "harc_best", "pt_best", "vsbuffer_best")
TFS = ("dense", "sparse", "opaque")
SLOW = ("vsbuffer_best",)
TOLERANCE_KEYS = {"vsbuffer_best": "vsbuffer/vsbuffer_best"}
#: visible fraction the sparse TF's shell aims at (accepted within 5-10 %)
SPARSE_TARGET = 0.075
#: ``--small``: the scenes, and VTK PT's time over the preset's that the sparse views of a small mesh aim at
SMALL_SCENES = (str(ROOT / "scenes" / "spx.toml"), str(ROOT / "scenes" / "spx_fill.toml"))
TARGETS = {"raycast": 2.0, "harc_best": 1.5}


def corner_view(scene):
    """``scene`` seen from the same eye turned half way from its target to the corner of the mesh's bounding box
    that lies farthest along its camera's right, up and forward axes (named ``NAME_corner``): the mesh moves
    towards a corner of the image, part of it out of the window, the rest of the window sees nothing."""
    cam = scene.camera
    lo, hi = (np.asarray(b, np.float64) for b in scene.mesh.bounds)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    axes = np.asarray(cam.right, np.float64) + np.asarray(cam.true_up, np.float64) + np.asarray(cam.forward, np.float64)
    out = copy.copy(scene)
    target = np.asarray(cam.target, np.float64)
    out.camera = cam.replace(target=tuple(float(v) for v in target + 0.5 * (corners[int(np.argmax(corners @ axes))] - target)))
    out.name = f"{scene.name}_corner"
    return out


def sparse_tf(scene):
    """One iso-like shell: a hat around the scalar quantile nearest the median (0.5, 0.6, ... 0.95) whose
    iso-surface crosses under :data:`SPARSE_TARGET` of the cells, its half-width bisected so that about
    that fraction of the cells can be visible; ``(tf, visible fraction)``."""
    from warpvol.conditioning.visibility import cell_scalar_range, cell_visibility
    from warpvol.scene.transfer import TransferFunction

    mesh, tf = scene.mesh, scene.transfer
    s = np.asarray(mesh.scalars, np.float64)
    lo, hi = float(s.min()), float(s.max())
    clo, chi = cell_scalar_range(mesh.tets, s)
    cands = [float(np.quantile(s, q)) for q in (0.5, 0.6, 0.7, 0.8, 0.9, 0.95)]
    crossing = [float(((clo <= c) & (chi >= c)).mean()) for c in cands]
    s0 = next((c for c, f in zip(cands, crossing) if f < 0.9 * SPARSE_TARGET), cands[int(np.argmin(crossing))])
    colour = tf.evaluate(s0)[:3]
    ext = 3.0 * float(tf.extinction.max())

    def make(w):
        pts = [[lo - 1.0, *colour, 0.0], [s0 - w, *colour, 0.0], [s0, *colour, ext], [s0 + w, *colour, 0.0],
               [hi + 1.0, *colour, 0.0]]
        return TransferFunction(pts, tf.emission)

    a, b = 1e-9 * (hi - lo), 0.5 * (hi - lo)
    for _ in range(40):
        w = 0.5 * (a + b)
        frac = float(cell_visibility(mesh, make(w)).mean())
        if frac < SPARSE_TARGET:
            a = w
        else:
            b = w
    w = 0.5 * (a + b)
    return make(w), float(cell_visibility(mesh, make(w)).mean())


def opaque_tf(scene):
    """The scene's colours with a constant extinction of 100 over the mesh's diagonal."""
    from warpvol.scene.transfer import TransferFunction

    lo, hi = (np.asarray(b, np.float64) for b in scene.mesh.bounds)
    pts = np.array(scene.transfer.points, np.float64)
    pts[:, 4] = 100.0 / float(np.linalg.norm(hi - lo))
    return TransferFunction(pts, scene.transfer.emission)


def variant(scene, name):
    """The scene with transfer function ``name`` (``dense``, ``sparse``, ``opaque``) and its visible fraction."""
    from warpvol.conditioning.visibility import cell_visibility

    out = copy.copy(scene)
    if name == "sparse":
        out.transfer, frac = sparse_tf(scene)
    else:
        if name == "opaque":
            out.transfer = opaque_tf(scene)
        frac = float(cell_visibility(scene.mesh, out.transfer).mean())
    out.name = f"{scene.name}_{name}"
    return out, frac


def preset_renderer(scene, name: str, skip: bool, device: str = "cpu"):
    from warpvol.pipeline import Pipeline

    pipe = Pipeline.load(name, device=device)
    last = {}

    def render():
        last["res"] = pipe.render(scene, quiet=True, skip=skip)

    return render, lambda: last["res"]


def left_out_summary(report: dict) -> str:
    """``report["left_out"]``'s counts in one short line."""
    parts = []
    for stage, d in (report.get("left_out") or {}).items():
        counts = ", ".join(f"{k} {v:,}" for k, v in d.items() if k != "why" and v)
        if counts:
            parts.append(f"{stage}: {counts}")
    return "; ".join(parts) or "-"


def run_view(path: str, tf_name: str, presets, size: int, repeat: int, slow_repeat: int, no_skip_slow: bool,
             out: Path, corner: bool = False, skip_only: bool = False, small: bool = False) -> dict:
    from warpvol.metrics import image_error
    from warpvol.scene.scene_file import load_scene

    base = load_scene(path)
    base.camera = base.camera.replace(width_px=size, height_px=size)
    if corner:
        base = corner_view(base)
    scene, frac = variant(base, tf_name)
    ref = cached_reference(scene, out)
    rows = [("VTK PT", *vtk_renderer(scene, "projected_tetrahedra"), None, repeat)]  # (label, render, image, result, rounds)
    for name in presets:
        n = slow_repeat if name in SLOW else repeat
        r, res = preset_renderer(scene, name, True)
        rows.append((name, r, None, res, n))
        if not skip_only and (name not in SLOW or no_skip_slow):
            r, res = preset_renderer(scene, name, False)
            rows.append((f"{name} no-skip", r, None, res, n))
    times = {row[0]: [] for row in rows}
    load0 = load_average()
    for k in range(repeat + 1):  # round 0: warm-up
        for label, render, _, _, n in rows:
            if k > n:
                continue
            t0 = time.perf_counter()
            render()
            times[label].append(time.perf_counter() - t0)
    load1 = load_average()
    vtk_t = statistics.median(times["VTK PT"][1:])
    print(f"\n{scene.name}: {scene.mesh.n_tets:,} tets, {size}x{size}, visible cells {100 * frac:.1f} %, "
          f"{repeat} interleaved rounds after a warm-up; {load0} (start), {load1} (end)")
    print(f"{'renderer':<24}{'median [s]':>11}{'VTK PT / this':>15}{'rmse':>11}{'max_abs':>11}{'tolerance':>11}  left out")
    result = {"tets": int(scene.mesh.n_tets), "size": size, "visible_fraction": frac, "load": [load0, load1],
              "rows": {}}
    for label, render, image, res, _ in rows:
        t = statistics.median(times[label][1:])
        row = {"median_s": t, "times_s": times[label], "vtk_pt_over_this": vtk_t / t}
        if res is None:  # VTK: its 8-bit image
            e = image_error(image(), ref)
            lo, tol = "-", ""
        else:
            rep = res().report
            e = image_error(res().image, ref)
            lo = left_out_summary(rep)
            row["left_out"] = rep.get("left_out")
            tr = tolerance_row(TOLERANCE_KEYS.get(label.split()[0], label.split()[0]))
            tol = ""
            if tr is not None:
                ok = e["rmse"] <= tr["rmse"] and e["max_abs"] <= tr["max_abs"]
                row["within_tolerance"] = ok
                tol = "ok" if ok else "EXCEEDED"
        row["error"] = e
        result["rows"][label] = row
        target = TARGETS.get(label) if small else None
        aim = "" if target is None else f"  (target {target:.1f}x: {'met' if vtk_t / t >= target else 'NOT met'})"
        print(f"{label:<24}{t:>11.3f}{vtk_t / t:>15.2f}{e['rmse']:>11.3e}{e['max_abs']:>11.3e}{tol:>11}  {lo}{aim}",
              flush=True)
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=list(FILL_SCENES))
    ap.add_argument("--tfs", nargs="+", default=list(TFS), choices=TFS)
    ap.add_argument("--presets", nargs="+", default=list(PRESETS), choices=PRESETS)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=3, help="timed rounds after the warm-up round")
    ap.add_argument("--slow-repeat", type=int, default=1, help="timed rounds of vsbuffer_best")
    ap.add_argument("--slow-size", type=int, default=128, help="image size of vsbuffer_best (and VTK beside it)")
    ap.add_argument("--no-skip-vsbuffer", action="store_true", help="also vsbuffer_best with skip=False")
    ap.add_argument("--out", default=str(ROOT / "out" / "bench_skip"))
    ap.add_argument("--docs", action="store_true", help="also write docs/data/skip.json")
    ap.add_argument("--docs-from", help="write docs/data/skip.json (skip_small.json from a --small run) from this "
                                        "skip_result.json, render nothing")
    ap.add_argument("--corner", action="store_true", help="also each scene's corner view (see corner_view)")
    ap.add_argument("--skip-only", action="store_true", help="the presets with skipping on only (no skip=False rows)")
    ap.add_argument("--small", action="store_true",
                    help="sparse views of a small mesh: SPX far and filling, each with its corner view, sparse TF, "
                         "raycast and harc_best with skipping on, ratios beside their targets")
    args = ap.parse_args(argv)
    if args.small and not args.docs_from:
        args.scenes, args.tfs, args.presets = list(SMALL_SCENES), ["sparse"], list(TARGETS)
        args.corner = args.skip_only = True
        if args.out == str(ROOT / "out" / "bench_skip"):
            args.out = str(ROOT / "out" / "bench_skip_small")
    if args.docs_from:
        saved = json.loads(Path(args.docs_from).read_text())
        prov = provenance.of(saved)
        if prov is None:  # a result written before runs were stamped: say what is not known
            prov = dict(provenance.start(saved["source"], timing=True), commit="unknown", dirty=None, load=None,
                        date="unknown", note=f"Written by --docs-from {args.docs_from}, a run that recorded no "
                                             "commit, date or machine load of its own.")
        write_docs(saved["views"], saved["source"], prov, "skip_small.json" if "--small" in saved["source"] else "skip.json")
        return 0
    prov = provenance.start(provenance.command_line("scripts/bench_skip.py", argv), timing=True)
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    out = Path(args.out)
    result = {}
    t0 = time.perf_counter()
    fast = [p for p in args.presets if p not in SLOW]
    slow = [p for p in args.presets if p in SLOW]
    views = [(path, corner) for path in args.scenes for corner in ((False, True) if args.corner else (False,))]
    for path, corner in views:
        stem = Path(path).stem + ("_corner" if corner else "")
        opts = dict(corner=corner, skip_only=args.skip_only, small=args.small)
        for tf_name in args.tfs:
            if fast:
                result[f"{stem}/{tf_name}/{args.size}"] = run_view(
                    path, tf_name, fast, args.size, args.repeat, args.slow_repeat, args.no_skip_vsbuffer, out, **opts)
            if slow:
                result[f"{stem}/{tf_name}/{args.slow_size}"] = run_view(
                    path, tf_name, slow, args.slow_size, args.slow_repeat, args.slow_repeat, args.no_skip_vsbuffer, out,
                    **opts)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s; {load_average()}")
    out.mkdir(parents=True, exist_ok=True)
    source = "python scripts/bench_skip.py " + " ".join(argv if argv is not None else sys.argv[1:])
    prov = provenance.finish(prov)
    provenance.write_json(out / "skip_result.json", {"source": source, "views": result}, prov)
    print(f"wrote {out / 'skip_result.json'}")
    if args.docs:
        write_docs(result, source, prov, "skip_small.json" if args.small else "skip.json")
    return 0


def write_docs(views: dict, source: str, prov: dict, file_name: str = "skip.json") -> None:
    """``docs/data/skip.json``: ``summary`` (per view and TF, VTK PT's median over each preset's, with
    skipping and, in parentheses, without) and ``rows`` (every renderer: time, ratio, error, left out)."""
    import os

    summary, rows = {}, []
    for key, v in views.items():
        view, tf, size = key.split("/")
        s = summary.setdefault((view, tf), {"visible": v["visible_fraction"], "vtk": {}, "cells": {},
                                            "load": v["load"][0].split()[-3]})
        vtk = v["rows"]["VTK PT"]["median_s"]
        s["vtk"][size] = vtk
        for label, r in v["rows"].items():
            err = r["error"]
            rows.append([view, tf, int(size), label, round(r["median_s"], 3), round(r["vtk_pt_over_this"], 2),
                         float(f"{err['rmse']:.3g}"), float(f"{err['max_abs']:.3g}"),
                         {True: "ok", False: "exceeded", None: "-"}[r.get("within_tolerance")],
                         left_out_summary({"left_out": r.get("left_out")})])
            name = label.split()[0]
            if name == "VTK":
                continue
            cell = s["cells"].setdefault(name, ["", ""])
            cell[1 if label.endswith("no-skip") else 0] = f"{r['vtk_pt_over_this']:.2f}"
    present = [p for p in PRESETS if any(p in s["cells"] for s in summary.values())]  # (--small: two)
    columns = ["view", "TF", "visible cells", "load (1 min)", "VTK PT [s]"] + [p + (" (128^2)" if p in SLOW else "") for p in present]
    srows = []
    for (view, tf), s in summary.items():
        vtk = ", ".join(f"{t:.3f} ({size}^2)" for size, t in s["vtk"].items())
        vals = []
        for p in present:
            c = s["cells"].get(p)
            vals.append("-" if c is None else (c[0] + (f" ({c[1]})" if c[1] else "")))
        srows.append([view, tf, f"{100 * s['visible']:.1f} %", s["load"], vtk] + vals)
    doc = {"source": source, "tables": {
        "summary": {"title": "VTK PT's median time over each exact preset's (> 1: the preset is faster); in "
                             "parentheses the same preset with skip=False",
                    "columns": columns, "rows": srows,
                    "notes": f"Interleaved in one process on a shared {os.cpu_count()}-core machine (load: the 1-minute "
                             "load average when the view started). " + (
                                 "The presets with skipping on only; a _corner view is its scene's camera turned half way "
                                 "to a corner of the mesh's bounding box (bench_skip.corner_view)."
                                 if file_name == "skip_small.json" else
                                 "vsbuffer_best at 128^2 beside VTK at 128^2 (its sweep is emulated plane by plane), "
                                 "without skip=False.")},
        "rows": {"title": "Every renderer: median time, VTK PT / this, error against the exact reference, "
                          "tolerance row, what the render left out",
                 "columns": ["view", "TF", "size", "renderer", "median [s]", "VTK PT / this", "RMSE", "max abs",
                             "tolerance", "left out"], "rows": rows}}}
    path = ROOT / "docs" / "data" / file_name
    provenance.write_json(path, doc, provenance.with_loads(prov, [float(s["load"]) for s in summary.values()]))
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
