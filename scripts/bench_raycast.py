"""Benchmark: warpvol ``raycast`` vs VTK's unstructured-grid ray caster on the same view.

Renders a scene (default: NASA Blunt Fin, perspective, 512x512, from ``scenes/bluntfin.toml``) with

* warpvol's ``raycast`` preset (float32 Warp kernel, CPU), and
* VTK's ``vtkUnstructuredGridVolumeRayCastMapper`` + ``vtkUnstructuredGridLinearRayIntegrator``
  (image sample distance 1, auto-adjust off; VTK's linear integrator samples opacity only at colour
  control points, so both of its functions get the same points, and its "opacity" is an attenuation
  coefficient divided by the unit distance, set to 1),

in one run, and prints both times, their ratio and both errors against the exact reference
(``warpvol.reference``, cached in ``--out``). Times are the median of ``--repeat`` renders after one
warm-up render each (Warp kernels compiled, VTK ray-cast structures built). VTK's mapper keeps its
image in 8-bit RGBA, so its error includes 8-bit quantisation: that is what it produces.

Usage::

    ./run.sh python scripts/bench_raycast.py [--scene scenes/bluntfin.toml] [--size 512] [--repeat 3]
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


def vtk_render(scene, repeat: int, mapper=None):
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

    if mapper is None:  # default: the unstructured-grid ray caster (scripts/bench_pt.py passes its PT mapper)
        mapper = vtk.vtkUnstructuredGridVolumeRayCastMapper()
        mapper.SetRayIntegrator(vtk.vtkUnstructuredGridLinearRayIntegrator())
        mapper.SetAutoAdjustSampleDistances(0)
        mapper.SetImageSampleDistance(1.0)
        mapper.SetNumberOfThreads(len(__import__("os").sched_getaffinity(0)))
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
        c.SetParallelScale(cam.height / 2)
    near, far = cam.depth_range(*mesh.bounds)
    c.SetClippingRange(near * 0.5, far * 2)

    times = []
    for k in range(repeat + 1):
        t0 = time.perf_counter()
        win.Render()
        times.append(time.perf_counter() - t0)
    w2i = vtk.vtkWindowToImageFilter()
    w2i.SetInput(win)
    w2i.SetInputBufferTypeToRGBA()
    w2i.ReadFrontBufferOff()
    w2i.Update()
    from vtk.util.numpy_support import vtk_to_numpy

    img = vtk_to_numpy(w2i.GetOutput().GetPointData().GetScalars()).reshape(cam.height_px, cam.width_px, 4)
    img = img[::-1].astype(np.float32) / 255.0  # VTK row 0 is the bottom
    return img, times[0], statistics.median(times[1:])


def warpvol_render(scene, repeat: int, device: str, preset: str = "raycast"):
    from warpvol.pipeline import Pipeline

    pipe = Pipeline.load(preset, device=device)
    times, res = [], None
    for k in range(repeat + 1):
        t0 = time.perf_counter()
        res = pipe.render(scene, quiet=True)
        times.append(time.perf_counter() - t0)
    return res, times[0], statistics.median(times[1:])


def scene_and_reference(scene_path: str, size: int, out: Path):
    """The scene (file or ``builtin:NAME``) at ``size`` x ``size`` and its exact reference (cached as
    EXR in ``out``)."""
    from warpvol.builtin import builtin_scene
    from warpvol.io import read_exr, write_exr
    from warpvol.reference import render_reference
    from warpvol.scene import load_scene

    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    scene = builtin_scene(scene_path[8:]) if scene_path.startswith("builtin:") else load_scene(scene_path)
    scene.camera = scene.camera.replace(width_px=size, height_px=size)
    print(f"scene {scene.name}: {scene.mesh.n_tets} tets, {size}x{size}, loaded in "
          f"{time.perf_counter() - t0:.1f} s", file=sys.stderr)
    ref_path = out / f"reference_{scene.name}_{size}.exr"
    if ref_path.exists():
        return scene, read_exr(ref_path)
    t0 = time.perf_counter()
    ref = render_reference(scene.mesh, scene.transfer, scene.camera).astype(np.float32)
    print(f"reference: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    write_exr(ref_path, ref)
    return scene, ref


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "bluntfin.toml"))
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--out", default=str(ROOT / "out" / "bench_raycast"))
    args = ap.parse_args(argv)

    from warpvol.io import write_png
    from warpvol.metrics import image_error

    out = Path(args.out)
    scene, ref = scene_and_reference(args.scene, args.size, out)
    ours, ours_first, ours_t = warpvol_render(scene, args.repeat, args.device)
    theirs, vtk_first, vtk_t = vtk_render(scene, args.repeat)
    e_ours = image_error(ours.image, ref)
    e_vtk = image_error(theirs, ref)
    write_png(out / "warpvol.png", ours.image)
    write_png(out / "vtk.png", theirs)
    write_png(out / "reference.png", ref)
    result = {
        "scene": scene.name, "tets": scene.mesh.n_tets, "size": args.size, "threads_note": "both use all cores",
        "warpvol_raycast_s": ours_t, "warpvol_first_s": ours_first, "warpvol_stages": ours.report["stages"],
        "vtk_raycast_s": vtk_t, "vtk_first_s": vtk_first,
        "time_ratio_vtk_over_warpvol": vtk_t / ours_t,
        "warpvol_error": e_ours, "vtk_error": e_vtk,
        "error_ratio_vtk_over_warpvol": e_vtk["rmse"] / max(e_ours["rmse"], 1e-30),
    }
    (out / "result.json").write_text(json.dumps(result, indent=2))
    print(f"{'':<18}{'time [s]':>10}{'first [s]':>11}{'rmse':>12}{'max_abs':>12}{'psnr [dB]':>11}")
    print(f"{'warpvol raycast':<18}{ours_t:>10.3f}{ours_first:>11.3f}{e_ours['rmse']:>12.3e}{e_ours['max_abs']:>12.3e}{e_ours['psnr']:>11.1f}")
    print(f"{'VTK ray caster':<18}{vtk_t:>10.3f}{vtk_first:>11.3f}{e_vtk['rmse']:>12.3e}{e_vtk['max_abs']:>12.3e}{e_vtk['psnr']:>11.1f}")
    print(f"time ratio VTK / warpvol = {result['time_ratio_vtk_over_warpvol']:.2f}   "
          f"error ratio (rmse) VTK / warpvol = {result['error_ratio_vtk_over_warpvol']:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
