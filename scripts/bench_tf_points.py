"""Render time with a densely sampled transfer function (not a test): time(20,000 points) / time(8 points)
for the exact presets on Blunt Fin (target <= 2) and for the table presets at a small image (table
build and whole render). The dense TF samples the 8-point one uniformly plus its own control points
(the same function); each render's TF is new, so no table comes from the cache, and a warm-up render
with another TF compiles the kernels first.

    ./run.sh python scripts/bench_tf_points.py [--device cpu] [--size 256] [--points 20000] [--only raycast,...]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

EXACT = ("raycast", "harc_best", "pt_best")
TABLES = ("weiler2003_vicp", "espinha2005_full", "roettger2000_3d", "roettger2002_cylindrical", "kraus2004_basic",
          "kraus2004_full", "guthe2002_linear", "guthe2002_quartic_radeon", "espinha2005_partial")
TABLE_STAGES = ("table_",)


def smooth8(tf, seed):
    from warpvol.scene.transfer import TransferFunction

    lo, hi = tf.srange
    rng = np.random.default_rng(seed)
    s = np.linspace(lo, hi, 8)
    ext = tf.extinction.max() * (0.2 + 0.8 * rng.random(8))
    return TransferFunction(np.column_stack([s, 0.2 + 0.8 * rng.random((8, 3)), ext]), tf.emission)


def dense(tf8, n):
    from warpvol.scene.transfer import TransferFunction

    lo, hi = tf8.srange
    s = np.union1d(np.linspace(lo, hi, n - len(tf8.s)), tf8.s)
    return TransferFunction(np.column_stack([s, tf8.evaluate(s)]), tf8.emission)


def timed_render(scene, tf, pipeline, device):
    import warpvol

    t0 = time.perf_counter()
    r = warpvol.render(scene, transfer=tf, pipeline=pipeline, device=device)
    total = time.perf_counter() - t0
    st = r.report.get("stages", {})
    table = sum(float(v.get("time_s", 0.0)) if isinstance(v, dict) else float(v)
                for k, v in st.items() if k.startswith(TABLE_STAGES))
    return total, table, r.image


def run(scene, pipelines, n_points, device, seed):
    rows = []
    for i, p in enumerate(pipelines):
        timed_render(scene, smooth8(scene.transfer, seed + 1000 + i), p, device)  # compile, warm caches
        tf8 = smooth8(scene.transfer, seed + i)
        t8, b8, im8 = timed_render(scene, tf8, p, device)
        tfn = dense(smooth8(scene.transfer, seed + i), n_points)  # a new object: no cached table
        tn, bn, imn = timed_render(scene, tfn, p, device)
        diff = float(np.abs(im8.astype(np.float64) - imn).max())
        rows.append((p, t8, tn, b8, bn, diff))
        tab = f"  table {b8:.3f} -> {bn:.3f} s" if b8 or bn else ""
        print(f"{p:26s} 8 pts {t8:7.3f} s  {n_points} pts {tn:7.3f} s  ratio {tn / t8:5.2f}{tab}  "
              f"max |image diff| {diff:.2e}", flush=True)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--size", type=int, default=256, help="Blunt Fin image size (exact presets)")
    ap.add_argument("--table-size", type=int, default=32, help="image size of the table presets (built-in concave)")
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--only", default="", help="comma-separated presets")
    a = ap.parse_args()
    import warp as wp

    wp.config.quiet = True
    from warpvol.scene.builtin import builtin_scene
    from warpvol.scene.scene_file import load_scene

    only = [x for x in a.only.split(",") if x]
    exact = [p for p in EXACT if not only or p in only]
    tables = [p for p in TABLES if not only or p in only]
    if exact:
        here = os.path.dirname(os.path.abspath(__file__))
        scene = load_scene(os.path.join(here, "..", "scenes", "bluntfin.toml")).with_camera(width_px=a.size,
                                                                                             height_px=a.size)
        print(f"Blunt Fin {a.size}^2, {a.device}")
        run(scene, exact, a.points, a.device, 0)
    if tables:
        scene = builtin_scene("concave").with_camera(width_px=a.table_size, height_px=a.table_size)
        print(f"built-in concave {a.table_size}^2 (table presets), {a.device}")
        run(scene, tables, a.points, a.device, 0)


if __name__ == "__main__":
    main()
