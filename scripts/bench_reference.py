"""Benchmark: the exact reference (Warp kernels and NumPy) against ``raycast``'s warm frame time.

One run on a scene (default NASA Blunt Fin, ``scenes/bluntfin.toml``) at each ``--sizes``: the Warp
reference (:mod:`warpvol.reference.warp_render`; its kernels compiled beforehand on a tiny image, per-mesh
set-up included since the reference keeps no cache), ``raycast``'s warm frame (one render to warm
up, then the median of ``--repeat``), and the NumPy reference (:mod:`warpvol.reference.numpy_render`, the
oracle) at the sizes in ``--numpy-sizes`` (it takes minutes at 1024^2). Rounds are interleaved so
load from other processes hits all alike. Prints a table with the ratio reference / raycast and,
where both references ran, their largest difference.

Usage::

    ./run.sh python scripts/bench_reference.py [--scene scenes/bluntfin.toml] [--sizes 512 1024]
        [--numpy-sizes 512] [--repeat 3] [--device cpu]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "bluntfin.toml"))
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024])
    ap.add_argument("--numpy-sizes", type=int, nargs="*", default=[512])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--device", default="cpu")
    args = ap.parse_args(argv)

    from warpvol.pipeline import Pipeline
    from warpvol.reference.numpy_render import render_reference
    from warpvol.reference.warp_render import render_reference_warp
    from warpvol.scene.builtin import builtin_scene
    from warpvol.scene.scene_file import load_scene

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = builtin_scene(args.scene[8:]) if args.scene.startswith("builtin:") else load_scene(args.scene)
    print(f"scene {scene.name}: {scene.mesh.n_tets} tets, device {args.device}", file=sys.stderr)
    base_cam = scene.camera
    # compile / load the kernels once
    render_reference_warp(scene.mesh, scene.transfer, base_cam.replace(width_px=8, height_px=8), device=args.device,
                          show_progress=False)
    pipe = Pipeline.load("raycast", device=args.device)
    rows = []
    for size in args.sizes:
        scene.camera = base_cam.replace(width_px=size, height_px=size)
        pipe.render(scene, quiet=True)  # warm: kernels, per-mesh data
        t_ray, t_ref, st = [], [], {}
        img = None
        for k in range(args.repeat):
            t0 = time.perf_counter()
            pipe.render(scene, quiet=True)
            t_ray.append(time.perf_counter() - t0)
            if k < 2:  # the reference is long: two rounds at most
                st = {}
                t0 = time.perf_counter()
                img = render_reference_warp(scene.mesh, scene.transfer, scene.camera, device=args.device,
                                            stats=st, show_progress=False)
                t_ref.append(time.perf_counter() - t0)
        row = dict(size=size, raycast=statistics.median(t_ray), warp=statistics.median(t_ref),
                   setup=st["setup_s"], segments=st["n_segments"], failed=st["n_failed"], numpy=None, diff=None)
        if size in args.numpy_sizes:
            t0 = time.perf_counter()
            ref_np = render_reference(scene.mesh, scene.transfer, scene.camera, method="numpy")
            row["numpy"] = time.perf_counter() - t0
            row["diff"] = float(np.abs(img - ref_np).max())
        rows.append(row)
        print(f"  {size}^2 done", file=sys.stderr)

    print("| size | raycast warm frame (s) | Warp reference (s) [set-up] | Warp ref / raycast | "
          "NumPy reference (s) | NumPy ref / raycast | max abs Warp - NumPy | segments | failed walks |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        np_s = "not run" if r["numpy"] is None else f"{r['numpy']:.1f}"
        np_x = "-" if r["numpy"] is None else f"{r['numpy'] / r['raycast']:.1f}x"
        diff = "-" if r["diff"] is None else f"{r['diff']:.2g}"
        print(f"| {r['size']}^2 | {r['raycast']:.3f} | {r['warp']:.3f} [{r['setup']:.2f}] | "
              f"{r['warp'] / r['raycast']:.2f}x | {np_s} | {np_x} | {diff} | {r['segments']} | {r['failed']} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
