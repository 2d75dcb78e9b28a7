"""Benchmark the table builders (not a test): exact 256x256x128 table (target < 10 s) and the per-TF-edit
cost of partial pre-integration (iso-crossing table only; target < 50 ms).

    ./run.sh python scripts/bench_tables.py [--device cpu] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def bench(fn, repeat):
    fn()  # warm-up: kernel compilation / module load
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return min(ts), float(np.median(ts))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    from warpvol.tables.exact import build_exact3d
    from warpvol.tables.isocross import build_isocross
    from warpvol.tables.psi import build_psi
    from warpvol.transfer import TransferFunction

    rng = np.random.default_rng(0)
    for m in (16, 64, 256):
        tf = TransferFunction(np.column_stack([np.linspace(0, 1, m), rng.random((m, 3)), 3 * rng.random(m)]),
                              "color_extinction")
        best, med = bench(lambda: build_exact3d(tf, n_s=256, n_l=128, lmax=1.0, device=a.device), a.repeat)
        print(f"exact 256x256x128, TF of {m:>3} points: best {best:.2f} s, median {med:.2f} s  (target < 10 s)")
    tf = TransferFunction(np.column_stack([np.linspace(0, 1, 255), rng.random((255, 3)), 3 * rng.random(255)]))
    for n in (256, 512):
        best, med = bench(lambda: build_isocross(tf, n=n, device=a.device), max(a.repeat, 10))
        print(f"iso-crossing table {n}^2, 255 control points (per-TF-edit cost): best {best * 1e3:.2f} ms, "
              f"median {med * 1e3:.2f} ms  (target < 50 ms)")
    best, med = bench(lambda: build_psi(n=512, device=a.device), 1)
    print(f"psi table 512^2 (once, TF-free): {best:.3f} s")


if __name__ == "__main__":
    main()
