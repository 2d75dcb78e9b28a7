#!/usr/bin/env python
"""Benchmark of the emulated GPU units: rasterise + blend a large triangle soup into an RGBA8 buffer.

Runs the same work twice — the Warp rasteriser/blending unit (``Rasterizer.draw`` with
``BlendUnit.over()``, triangle setup and binning included) and a plain NumPy implementation (one
vectorised step per triangle over its bounding box: snapped int64 edge functions with the top-left
rule, fp32 screen-space colour interpolation, 8-bit integer "over" blending) — checks that both
frame buffers agree, and prints fragments per second and the speed ratio.

    ./run.sh python scripts/bench_units.py [--device cpu] [--tris 20000] [--size 512]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import warp as wp

from warpvol.gpu.blend import BlendUnit, FrameBuffer
from warpvol.gpu.raster import Rasterizer
from warpvol.pipeline import quiet_warp


def make_soup(n_tris: int, width: int, height: int, seed: int = 0, size: float = 24.0):
    rng = np.random.default_rng(seed)
    centre = rng.uniform([0, 0], [width, height], (n_tris, 1, 2))
    xy = centre + rng.uniform(-size / 2, size / 2, (n_tris, 3, 2))
    pos = np.concatenate([xy, rng.uniform(0, 1, (n_tris, 3, 1)), np.ones((n_tris, 3, 1))], -1)
    pos = pos.reshape(-1, 4).astype(np.float32)
    cols = rng.uniform(0, 1, (3 * n_tris, 4)).astype(np.float32)
    cols[:, 3] *= 0.5
    cols[:, :3] *= cols[:, 3:4]  # premultiplied
    return pos, np.arange(3 * n_tris, dtype=np.int32).reshape(-1, 3), cols


def numpy_reference(pos, tris, cols, width, height):
    """Plain NumPy: per triangle, all pixels of its bounding box at once. Returns (codes, fragments)."""
    sub = 256
    buf = np.zeros((height, width, 4), np.int64)
    n = 255
    snap = np.sign(pos[:, :2].astype(np.float64) * sub) * np.floor(np.abs((pos[:, :2] * np.float32(sub)).astype(np.float64)) + 0.5)
    snap = snap.astype(np.int64)
    frags = 0
    for t in range(tris.shape[0]):
        v = tris[t].copy()
        X, Y = snap[v, 0].copy(), snap[v, 1].copy()
        area = (X[1] - X[0]) * (Y[2] - Y[0]) - (Y[1] - Y[0]) * (X[2] - X[0])
        if area == 0:
            continue
        if area < 0:
            v[[1, 2]], X[[1, 2]], Y[[1, 2]] = v[[2, 1]], X[[2, 1]], Y[[2, 1]]
        j0 = max(-((-(X.min() - 128)) // sub), 0)
        j1 = min((X.max() - 128) // sub, width - 1)
        i0 = max(-((-(Y.min() - 128)) // sub), 0)
        i1 = min((Y.max() - 128) // sub, height - 1)
        if j0 > j1 or i0 > i1:
            continue
        jj, ii = np.meshgrid(np.arange(j0, j1 + 1), np.arange(i0, i1 + 1))
        px, py = jj * sub + 128, ii * sub + 128
        inside = np.ones(jj.shape, bool)
        for a, b in ((1, 2), (2, 0), (0, 1)):
            dx, dy = X[b] - X[a], Y[b] - Y[a]
            e = dx * (py - Y[a]) - dy * (px - X[a])
            top_left = dy < 0 or (dy == 0 and dx > 0)
            inside &= (e >= 0) if top_left else (e > 0)
        if not inside.any():
            continue
        jj, ii = jj[inside], ii[inside]
        frags += jj.size
        fx, fy = (jj + np.float32(0.5)).astype(np.float32), (ii + np.float32(0.5)).astype(np.float32)
        p = pos[v]
        l0 = (p[2, 0] - p[1, 0]) * (fy - p[1, 1]) - (p[2, 1] - p[1, 1]) * (fx - p[1, 0])
        l1 = (p[0, 0] - p[2, 0]) * (fy - p[2, 1]) - (p[0, 1] - p[2, 1]) * (fx - p[2, 0])
        l2 = (p[1, 0] - p[0, 0]) * (fy - p[0, 1]) - (p[1, 1] - p[0, 1]) * (fx - p[0, 0])
        s = l0 + l1 + l2
        w0, w1, w2 = (l0 / s)[:, None], (l1 / s)[:, None], (l2 / s)[:, None]
        c = w0 * cols[v[0]] + w1 * cols[v[1]] + w2 * cols[v[2]]
        x = np.clip(c, 0, 1) * np.float32(n)
        src = np.floor(x.astype(np.float64) + 0.5).astype(np.int64)
        dst = buf[ii, jj]
        num = src * n + dst * (n - src[:, 3:4])
        buf[ii, jj] = np.minimum((2 * num + n) // (2 * n), n)
    return buf, frags


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--tris", type=int, default=20000)
    ap.add_argument("--size", type=int, default=512, help="frame buffer width = height")
    ap.add_argument("--tri-size", type=float, default=24.0, help="triangle extent in pixels")
    ap.add_argument("--tile", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    quiet_warp()
    W = H = args.size
    pos, tris, cols = make_soup(args.tris, W, H, size=args.tri_size)

    fb = FrameBuffer(W, H, "unorm8", args.device)
    rast = Rasterizer(W, H, device=args.device, tile_size=args.tile,
                      fill_rule="top_left", snap_ties="away")  # the NumPy reference's rules
    blend = BlendUnit.over()

    def warp_run():
        fb.clear((0, 0, 0, 0))
        rast.draw(pos, tris, cols, fb, blend, interpolation="linear")
        wp.synchronize_device(args.device)

    warp_run()  # compile / warm up
    times = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        warp_run()
        times.append(time.perf_counter() - t0)
    t_warp = min(times)
    codes = fb.codes()

    t0 = time.perf_counter()
    ref, frags = numpy_reference(pos, tris, cols, W, H)
    t_np = time.perf_counter() - t0

    mismatch = int((codes != ref).any(-1).sum())
    print(f"triangle soup: {args.tris} triangles (~{args.tri_size:g} px), {W}x{H} RGBA8 buffer, "
          f"{frags} fragments, blend over, device {args.device}")
    print(f"warp  : {t_warp * 1e3:9.1f} ms  {frags / t_warp / 1e6:8.2f} Mfragments/s  (setup + binning + draw)")
    print(f"numpy : {t_np * 1e3:9.1f} ms  {frags / t_np / 1e6:8.2f} Mfragments/s")
    print(f"ratio : {t_np / t_warp:.1f}x  (target >= 20x)")
    print(f"pixels differing between the two paths: {mismatch} of {W * H}")


if __name__ == "__main__":
    main()
