"""Benchmark: warpvol ``harc_best`` vs VTK's ray caster with partial pre-integration, and the cost of a TF edit.

For each scene (default: Blunt Fin and LOX Post, 512x512) renders, in one run and interleaved (one
render of each renderer per round, after a warm-up round; :func:`bench_raycast.interleaved_times`):

* warpvol ``harc_best`` (rasterised ray start, consistent Plücker walk, exact segment integrals, CPU),
* warpvol ``espinha2005_partial`` (the paper's HARC with partial pre-integration, emulated),
* VTK's ``vtkUnstructuredGridVolumeRayCastMapper`` with ``vtkUnstructuredGridPartialPreIntegration``
  (Moreland & Angel's integrator; set up as in ``bench_raycast.py``, all cores),

and prints median / min times, ratios VTK / harc_best, errors against the exact reference and the
error ratio. Then a TF edit: colours changed with the control points kept, and control points moved;
for each preset it reports which stages ran again (tables rebuilt or reused, per-mesh data reused)
and the time of the first render after the edit.

``--fill`` runs only the views where the data fills the image (``scenes/bluntfin_close.toml``,
``scenes/spx_fill.toml``): ``harc_best`` against VTK's projected-tetrahedra mapper, printing ``VTK PT time /
harc_best time`` (``bench_raycast.fill_vs_vtk_pt``).

Usage::

    ./run.sh python scripts/bench_harc.py [--scenes scenes/bluntfin.toml scenes/loxpost.toml] [--size 512] [--repeat 3] [--fill]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_raycast import interleaved_times, scene_and_reference, vtk_renderer, warpvol_renderer  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def vtk_partial_renderer(scene):
    """VTK's unstructured ray caster with the partial pre-integration integrator."""
    import vtk

    render, image = vtk_renderer(scene, "raycast")
    win = render.__self__
    vol = win.GetRenderers().GetFirstRenderer().GetVolumes().GetLastProp()
    vol.GetMapper().SetRayIntegrator(vtk.vtkUnstructuredGridPartialPreIntegration())
    return render, image


def tf_edit(scene, preset: str) -> dict:
    """Render, edit the TF (colours only; then control points moved), render again: what ran, and times."""
    from warpvol.pipeline import Pipeline
    from warpvol.scene.transfer import TransferFunction

    pipe = Pipeline.load(preset)
    pipe.render(scene, quiet=True)
    t0 = time.perf_counter()
    pipe.render(scene, quiet=True)
    same = time.perf_counter() - t0
    out = {"unchanged_s": same}
    pts = scene.transfer.points.copy()
    pts[:, 1:4] = pts[::-1, 1:4]  # colours edited, control points kept
    moved = scene.transfer.points.copy()
    lo, hi = scene.transfer.srange
    moved[1:-1, 0] = moved[1:-1, 0] + 0.01 * (hi - lo)  # interior control points moved
    for label, p in (("colours", pts), ("control_points", moved)):
        sc = dataclasses.replace(scene, transfer=TransferFunction(p, emission=scene.transfer.emission))
        t0 = time.perf_counter()
        res = pipe.render(sc, quiet=True)
        dt = time.perf_counter() - t0
        tabs = res.report["stats"].get("tables", {})
        out[label] = {"first_render_s": dt, "stage_s": res.report["stages"],
                      "skipped": [f"{s['stage']}: {s['reason']}" for s in res.report["skipped"]],
                      "tables_built": {k: v.get("build_s") for k, v in tabs.items() if v.get("built")}}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=[str(ROOT / "scenes" / "bluntfin.toml"),
                                                    str(ROOT / "scenes" / "loxpost.toml")])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "out" / "bench_harc"))
    ap.add_argument("--fill", action="store_true",
                    help="only the views filling the image (scenes/bluntfin_close.toml, scenes/spx_fill.toml): "
                         "VTK PT time / harc_best time, medians over interleaved rounds (--repeat, at least 5), errors, load")
    args = ap.parse_args(argv)
    if args.fill:
        from bench_raycast import fill_vs_vtk_pt

        fill_vs_vtk_pt(["harc_best"], size=args.size, repeat=max(args.repeat, 5))
        return 0

    from warpvol.metrics import image_error

    out = Path(args.out)
    result = {}
    for path in args.scenes:
        scene, ref = scene_and_reference(path, args.size, out)
        best_r, best_i, best_res = warpvol_renderer(scene, "cpu", "harc_best")
        part_r, part_i, _ = warpvol_renderer(scene, "cpu", "espinha2005_partial")
        renderers = [("harc_best", best_r, best_i), ("espinha2005_partial", part_r, part_i),
                     ("VTK ray caster + partial pre-int.", *vtk_partial_renderer(scene))]
        times = interleaved_times(renderers, args.repeat)
        t0 = statistics.median(times["harc_best"][1:])
        e0 = image_error(best_i(), ref)
        rows = {}
        print(f"\n{scene.name}: {scene.mesh.n_tets} tets, {args.size}x{args.size}, {args.repeat} rounds after a warm-up")
        print("| renderer | median [s] | min [s] | time / harc_best | rmse | max_abs | rmse / harc_best rmse |")
        print("| --- | --- | --- | --- | --- | --- | --- |")
        for name, _, image in renderers:
            e = image_error(image(), ref)
            t = statistics.median(times[name][1:])
            rows[name] = {"median_s": t, "min_s": min(times[name][1:]), "times_s": times[name], "error": e,
                          "time_ratio_over_harc_best": t / t0,
                          "rmse_ratio_over_harc_best": e["rmse"] / max(e0["rmse"], 1e-30)}
            print(f"| {name} | {t:.3f} | {min(times[name][1:]):.3f} | {t / t0:.2f} | {e['rmse']:.3e} | "
                  f"{e['max_abs']:.3e} | {e['rmse'] / max(e0['rmse'], 1e-30):.1f} |")
        res = best_res()
        rows["harc_best_stats"] = {k: res.report["stats"].get(k) for k in ("harc", "harc_peel", "harc_raster")}
        edits = {p: tf_edit(scene, p) for p in ("harc_best", "espinha2005_partial", "espinha2005_full")}
        print("TF edit (first render after the edit; what ran again):")
        for p, e in edits.items():
            for label in ("colours", "control_points"):
                d = e[label]
                print(f"  {p:<20} {label:<15} {d['first_render_s']:.3f} s (unchanged TF {e['unchanged_s']:.3f} s); "
                      f"tables built: {d['tables_built'] or 'none'}; reused/skipped: {d['skipped']}")
        result[scene.name] = {"rows": rows, "tf_edit": edits}
    (out / "result.json").write_text(json.dumps(result, indent=2, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
