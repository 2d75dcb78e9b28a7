"""Benchmark: warpvol ``raycast`` vs VTK's unstructured-grid volume mappers on the same view.

Renders a scene (default: NASA Blunt Fin, perspective, 512x512, from ``scenes/bluntfin.toml``) with

* warpvol's ``raycast`` preset (float32 Warp kernel, CPU),
* VTK's ``vtkUnstructuredGridVolumeRayCastMapper`` + ``vtkUnstructuredGridLinearRayIntegrator``
  (image sample distance 1, auto-adjust off; VTK's linear integrator samples opacity only at colour
  control points, so both of its functions get the same points, and its "opacity" is an attenuation
  coefficient divided by the unit distance, set to 1), and
* VTK's ``vtkProjectedTetrahedraMapper`` (Shirley-Tuchman projected tetrahedra, OpenGL; offscreen
  through Mesa llvmpipe here), the fastest unstructured-grid mapper a pyvista user has,

in one run, and prints all times, the ratios VTK / warpvol and all errors against the exact
reference (``warpvol.reference.numpy_render``, cached in ``--out``). Times are the median (and minimum) of
``--repeat`` rounds after one warm-up round (Warp kernels compiled, per-mesh cell data built, VTK
structures built); each round renders once with every renderer in turn, so load from other
processes on a shared machine hits all of them alike. VTK's mappers keep their image in 8-bit RGBA, so their errors include 8-bit quantisation:
that is what they produce.

``--fill`` runs only the views where the data fills the image (``scenes/bluntfin_close.toml``,
``scenes/spx_fill.toml``) against VTK's projected-tetrahedra mapper and prints ``VTK PT time / raycast
time`` (:func:`fill_vs_vtk_pt`, shared with ``bench_pt.py --fill`` and ``bench_harc.py --fill``).

Usage::

    ./run.sh python scripts/bench_raycast.py [--scene scenes/bluntfin.toml] [--size 512] [--repeat 5] [--fill]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def vtk_renderer(scene, mapper_name: str = "raycast"):
    """``(render, image)`` callables for a VTK mapper set up on ``scene``."""
    import pyvista as pv
    import vtk

    mesh, tf, cam = scene.mesh, scene.transfer, scene.camera
    cells = np.hstack([np.full((mesh.n_tets, 1), 4), mesh.tets]).ravel()
    grid = pv.UnstructuredGrid(cells, np.full(mesh.n_tets, pv.CellType.TETRA, dtype=np.uint8), mesh.points)
    grid.point_data["s"] = mesh.scalars
    grid.set_active_scalars("s")

    ctf = vtk.vtkColorTransferFunction()
    otf = vtk.vtkPiecewiseFunction()
    for s, r, g, b, ext in tf.points:
        ctf.AddRGBPoint(s, r, g, b)
        otf.AddPoint(s, ext)
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetScalarOpacityUnitDistance(1.0)
    prop.ShadeOff()
    prop.SetInterpolationTypeToLinear()

    if mapper_name == "raycast":
        mapper = vtk.vtkUnstructuredGridVolumeRayCastMapper()
        mapper.SetRayIntegrator(vtk.vtkUnstructuredGridLinearRayIntegrator())
        mapper.SetAutoAdjustSampleDistances(0)
        mapper.SetImageSampleDistance(1.0)
        mapper.SetNumberOfThreads(len(__import__("os").sched_getaffinity(0)))
    else:
        mapper = vtk.vtkProjectedTetrahedraMapper()
    mapper.SetInputData(grid)
    vol = vtk.vtkVolume()
    vol.SetMapper(mapper)
    vol.SetProperty(prop)

    ren = vtk.vtkRenderer()
    ren.SetBackground(0, 0, 0)
    ren.SetBackgroundAlpha(0.0)
    ren.AddVolume(vol)
    win = vtk.vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.SetAlphaBitPlanes(1)
    win.SetMultiSamples(0)
    win.AddRenderer(ren)
    win.SetSize(cam.width_px, cam.height_px)
    c = ren.GetActiveCamera()
    c.SetPosition(*cam.eye)
    c.SetFocalPoint(*cam.target)
    c.SetViewUp(*cam.true_up)
    if cam.projection == "perspective":
        c.SetViewAngle(cam.fov_y_deg)
    else:
        c.ParallelProjectionOn()
        c.SetParallelScale(cam.ortho_height / 2)
    near, far = cam.depth_range(*mesh.bounds)
    c.SetClippingRange(near * 0.5, far * 2)

    def image():
        from vtk.util.numpy_support import vtk_to_numpy

        w2i = vtk.vtkWindowToImageFilter()
        w2i.SetInput(win)
        w2i.SetInputBufferTypeToRGBA()
        w2i.ReadFrontBufferOff()
        w2i.Update()
        img = vtk_to_numpy(w2i.GetOutput().GetPointData().GetScalars()).reshape(cam.height_px, cam.width_px, 4)
        return img[::-1].astype(np.float32) / 255.0  # VTK row 0 is the bottom

    return win.Render, image


def warpvol_renderer(scene, device: str, preset: str = "raycast"):
    """``(render, image, result)``: a preset (default ``raycast``); ``result()`` is the last render's result."""
    from warpvol.pipeline import Pipeline

    pipe = Pipeline.load(preset, device=device)
    last = {}

    def render():
        last["res"] = pipe.render(scene, quiet=True)

    return render, lambda: last["res"].image, lambda: last["res"]


def interleaved_times(renderers, repeat: int) -> dict[str, list[float]]:
    """Seconds per render of every ``(name, render, image)`` renderer: ``repeat + 1`` rounds (the first
    a warm-up), each round rendering once with every renderer in turn, so that load from other
    processes on a shared machine hits all of them alike."""
    times = {name: [] for name, _, _ in renderers}
    for _ in range(repeat + 1):
        for name, render, _ in renderers:
            t0 = time.perf_counter()
            render()
            times[name].append(time.perf_counter() - t0)
    return times


def scene_and_reference(scene_path: str, size: int, out: Path):
    """The scene (file or ``builtin:NAME``) at ``size`` x ``size`` and its exact reference (cached as
    EXR in ``out``)."""
    from warpvol.scene.builtin import builtin_scene
    from warpvol.scene.scene_file import load_scene

    t0 = time.perf_counter()
    scene = builtin_scene(scene_path[8:]) if scene_path.startswith("builtin:") else load_scene(scene_path)
    scene.camera = scene.camera.replace(width_px=size, height_px=size)
    print(f"scene {scene.name}: {scene.mesh.n_tets} tets, {size}x{size}, loaded in "
          f"{time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return scene, cached_reference(scene, out)


def cached_reference(scene, out: Path) -> np.ndarray:
    """The scene's exact reference, cached as EXR in ``out`` by scene name and image size."""
    from warpvol.io import read_exr, write_exr
    from warpvol.reference.numpy_render import render_reference

    out.mkdir(parents=True, exist_ok=True)
    ref_path = out / f"reference_{scene.name}_{scene.camera.width_px}.exr"
    if ref_path.exists():
        return read_exr(ref_path)
    t0 = time.perf_counter()
    ref = render_reference(scene.mesh, scene.transfer, scene.camera).astype(np.float32)
    print(f"reference {scene.name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    write_exr(ref_path, ref)
    return ref


FILL_SCENES = (str(ROOT / "scenes" / "bluntfin_close.toml"), str(ROOT / "scenes" / "spx_fill.toml"))
TOLERANCE_KEYS = {"raycast": "raycast/fp32", "harc_best": "harc_best", "pt_best": "pt_best"}


def load_average() -> str:
    """The machine's 1/5/15-minute load averages, for the line printed with every time."""
    import os

    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def tolerance_row(preset: str):
    """``tests/tolerances.py``'s row for ``preset`` (None where it has none or the file is absent)."""
    import importlib.util

    path = ROOT / "tests" / "tolerances.py"
    if not path.exists():
        return None
    spec = importlib.util.spec_from_file_location("_bench_tolerances", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.TOLERANCES.get(TOLERANCE_KEYS.get(preset, preset))


def fill_vs_vtk_pt(presets, scenes=FILL_SCENES, size: int = 512, repeat: int = 5, device: str = "cpu",
                   out: Path | None = None) -> dict:
    """VTK's projected-tetrahedra time / preset time on views where the data fills the image.

    For each scene, every preset and ``vtkProjectedTetrahedraMapper`` render interleaved (one render of
    each per round, ``repeat`` rounds after a warm-up round: kernels compiled, per-mesh data built); prints
    per renderer the median and minimum time, the ratio ``VTK PT median / preset median`` (> 1: the
    preset is faster), the error against the exact reference and the preset's tolerance row
    (``tests/tolerances.py``), with the machine's load average. Returns the rows (also written to
    ``out/fill_result.json``)."""
    from warpvol.metrics import image_error

    out = Path(out) if out is not None else ROOT / "out" / "bench_fill"
    result = {}
    for path in scenes:
        scene, ref = scene_and_reference(path, size, out)
        renderers = [("VTK PT", *vtk_renderer(scene, "projected_tetrahedra"))]
        results = {}
        for name in presets:
            render, image, res = warpvol_renderer(scene, device, preset=name)
            renderers.append((name, render, image))
            results[name] = res
        load0 = load_average()
        times = interleaved_times(renderers, repeat)
        load1 = load_average()
        vtk_t = statistics.median(times["VTK PT"][1:])
        print(f"\n{scene.name}: {scene.mesh.n_tets} tets, {size}x{size}, {repeat} interleaved rounds after a "
              f"warm-up; {load0} (start), {load1} (end)")
        print(f"{'renderer':<12}{'median [s]':>11}{'min [s]':>9}{'VTK PT / this':>15}{'rmse':>11}{'max_abs':>11}"
              f"{'tolerance (rmse, max_abs)':>28}  cell steps / fragments")
        rows = {}
        for name, _, image in renderers:
            img = image()
            e = image_error(img, ref)
            t = statistics.median(times[name][1:])
            row = {"median_s": t, "min_s": min(times[name][1:]), "times_s": times[name], "error": e,
                   "vtk_pt_over_this": vtk_t / t, "load": [load0, load1]}
            tol, work = "", ""
            if name in results:
                rep = results[name]().report
                row["stages"], row["counters"] = rep["stages"], rep.get("counters")
                tr = tolerance_row(name)
                if tr is not None:
                    ok = e["rmse"] <= tr["rmse"] and e["max_abs"] <= tr["max_abs"]
                    row["tolerance"], row["within_tolerance"] = tr, ok
                    tol = f"{tr['rmse']:.0e}, {tr['max_abs']:.0e} {'ok' if ok else 'EXCEEDED'}"
                steps = sum(c.get("cell_steps", 0) for c in (rep.get("counters") or {}).values() if isinstance(c, dict))
                frags = sum(c.get("fragments", 0) for c in (rep.get("counters") or {}).values() if isinstance(c, dict))
                work = f"{steps / 1e6:.2f} M" if steps else (f"{frags / 1e6:.2f} M frags" if frags else "")
            rows[name] = row
            print(f"{name:<12}{t:>11.3f}{row['min_s']:>9.3f}{vtk_t / t:>15.2f}{e['rmse']:>11.3e}{e['max_abs']:>11.3e}"
                  f"{tol:>28}  {work}")
        result[scene.name] = {"tets": scene.mesh.n_tets, "size": size, "rows": rows}
    out.mkdir(parents=True, exist_ok=True)
    (out / "fill_result.json").write_text(json.dumps(result, indent=2, default=float))
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "bluntfin.toml"))
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--out", default=str(ROOT / "out" / "bench_raycast"))
    ap.add_argument("--fill", action="store_true",
                    help="only the views filling the image (scenes/bluntfin_close.toml, scenes/spx_fill.toml): "
                         "VTK PT time / raycast time, medians over interleaved rounds, errors, load average")
    args = ap.parse_args(argv)
    if args.fill:
        fill_vs_vtk_pt(["raycast"], size=args.size, repeat=args.repeat, device=args.device)
        return 0

    from warpvol.io import write_png
    from warpvol.metrics import image_error

    out = Path(args.out)
    scene, ref = scene_and_reference(args.scene, args.size, out)

    # renders are interleaved (one of each per round, after a warm-up round) so that load from other
    # processes on a shared machine hits every renderer alike
    w_render, w_image, w_result = warpvol_renderer(scene, args.device)
    renderers = [("warpvol raycast", w_render, w_image)]
    for name, key in (("VTK ray caster", "raycast"), ("VTK proj. tetra", "projected_tetrahedra")):
        renderers.append((name, *vtk_renderer(scene, key)))
    times = interleaved_times(renderers, args.repeat)
    ours = w_result()
    ours_t = statistics.median(times["warpvol raycast"][1:])
    ours_min = min(times["warpvol raycast"][1:])
    rows = [(name, image(), times[name][0], statistics.median(times[name][1:]), min(times[name][1:]))
            for name, _, image in renderers]
    write_png(out / "reference.png", ref)
    result = {"scene": scene.name, "tets": scene.mesh.n_tets, "size": args.size,
              "threads_note": "all renderers use all cores", "warpvol_stages": ours.report["stages"],
              "warpvol_counters": ours.report.get("counters"), "renderers": {}}
    print(f"{'':<18}{'median [s]':>11}{'min [s]':>9}{'first [s]':>10}{'rmse':>11}{'max_abs':>11}{'psnr [dB]':>10}"
          f"{'time / warpvol (median, min)':>30}{'rmse / warpvol':>16}")
    e0 = image_error(ours.image, ref)
    for name, img, first, t, tmin in rows:
        e = image_error(img, ref)
        write_png(out / (name.replace(" ", "_").replace(".", "") + ".png"), img)
        result["renderers"][name] = {"median_s": t, "min_s": tmin, "first_s": first, "times_s": times[name],
                                     "error": e, "time_ratio_over_warpvol": t / ours_t,
                                     "min_time_ratio_over_warpvol": tmin / ours_min,
                                     "rmse_ratio_over_warpvol": e["rmse"] / max(e0["rmse"], 1e-30)}
        ratio = f"{t / ours_t:.2f}, {tmin / ours_min:.2f}"
        print(f"{name:<18}{t:>11.3f}{tmin:>9.3f}{first:>10.3f}{e['rmse']:>11.3e}{e['max_abs']:>11.3e}{e['psnr']:>10.1f}"
              f"{ratio:>30}{e['rmse'] / max(e0['rmse'], 1e-30):>16.1f}")
    print(f"warpvol counters: {ours.report.get('counters')}")
    (out / "result.json").write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
