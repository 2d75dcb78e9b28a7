"""Benchmark the table builders (not a test): exact 256x256x128 table (target < 10 s), the per-TF-edit
cost of partial pre-integration (iso-crossing table only; target < 50 ms), and the cost of counting
(warpvol.gpu.counters) in a hardware build, a render and a rasteriser draw: the same work with and
without active counters, interleaved, median of ``--repeat`` runs (target: counting < 5 %).

    ./run.sh python scripts/bench_tables.py [--device cpu] [--repeat 3] [--only counting]
"""

from __future__ import annotations

import argparse
import contextlib
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


@contextlib.contextmanager
def counting_off():
    """No counting anywhere: Counters never become active (also inside Pipeline.render), ctx.count is a no-op."""
    from warpvol.gpu.counters import Counters
    from warpvol.stage import Context

    saved = Counters.__enter__, Counters.__exit__, Context.count
    Counters.__enter__ = lambda self: self
    Counters.__exit__ = lambda self, *e: None
    Context.count = lambda self, **kw: None
    try:
        yield
    finally:
        Counters.__enter__, Counters.__exit__, Context.count = saved


def paired(fn, repeat):
    """Best-of seconds of ``fn`` with and without counting, runs interleaved after a warm-up (the minimum
    is the figure least disturbed by other processes on a shared machine)."""
    from warpvol.gpu.counters import Counters

    fn()
    on, off = [], []
    for _ in range(repeat):
        for ctx, ts in ((Counters, on), (counting_off, off)):
            with ctx():
                t0 = time.perf_counter()
                fn()
                ts.append(time.perf_counter() - t0)
    return min(on), min(off)


def bench_counting(device, repeat):
    import os

    from warpvol.gpu.blend import BlendUnit, FrameBuffer
    from warpvol.gpu.raster import Rasterizer
    from warpvol.pipeline import Pipeline
    from warpvol.scene.transfer import TransferFunction
    from warpvol.tables.roettger_hw import build_roettger_hw

    tf = TransferFunction.from_table(np.random.default_rng(1).random((64, 4)), (0.0, 1.0), "emission_density")
    cases = [("roettger_hw 128x128x64, 64 steps, 12 bit",
              lambda: build_roettger_hw(tf, n_s=128, n_l=64, steps=64, bits=12, device=device))]
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        from warpvol.scene.scene_file import load_scene

        scene = load_scene(os.path.join(here, "..", "scenes", "bluntfin.toml"))
        pipe = Pipeline.load("raycast", device=device)
        cases.append(("raycast render, Blunt Fin 512^2", lambda: pipe.render(scene, quiet=True)))
        hw = Pipeline.from_config({"stages": [{"stage": "table_roettger_hw", "n_s": 64, "n_l": 32, "steps": 32,
                                               "lmax": 1.0}, {"stage": "cell_setup"}, {"stage": "entry_bins"},
                                              {"stage": "raycast"}]}, device=device)

        def table_render():
            hw.persistent.clear()  # rebuild the table every time
            hw.render(scene, quiet=True)

        cases.append(("table_roettger_hw 64x64x32 + raycast render, Blunt Fin", table_render))
    except Exception as e:  # data absent
        print(f"raycast render: skipped ({e})")
    rng = np.random.default_rng(0)
    n = 20000
    xy = rng.uniform(0, 512, (n, 1, 2)) + rng.uniform(-12, 12, (n, 3, 2))
    pos = np.concatenate([xy, rng.uniform(0, 1, (n, 3, 1)), np.ones((n, 3, 1))], -1).reshape(-1, 4).astype(np.float32)
    tris = np.arange(3 * n).reshape(-1, 3)
    cols = np.full((3 * n, 4), 0.1, np.float32)
    fb = FrameBuffer(512, 512, "unorm8", device)
    r = Rasterizer(512, 512, device=device)
    cases.append(("Rasterizer.draw 20,000 triangles 512^2 (fused raster+blend)",
                  lambda: r.draw(pos, tris, cols, fb, BlendUnit.over())))
    colours = np.full((r.fragments(pos, tris).count, 4), 0.1, np.float32)
    cases.append(("Rasterizer.fragments + BlendUnit.blend_fragments, same soup",
                  lambda: BlendUnit.over().blend_fragments(fb, r.fragments(pos, tris), colours)))
    print("counting overhead (best of paired runs, counters on / off):")
    for name, fn in cases:
        on, off = paired(fn, repeat)
        print(f"  {name:<62} on {on:.4f} s  off {off:.4f} s  overhead {100 * (on / off - 1):+.1f} %")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=("tables", "counting"), help="run one part")
    a = ap.parse_args(argv)
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    if a.only != "tables":
        bench_counting(a.device, max(a.repeat, 5))
    if a.only == "counting":
        return
    from warpvol.scene.transfer import TransferFunction
    from warpvol.tables.exact import build_exact3d
    from warpvol.tables.isocross import build_isocross
    from warpvol.tables.psi import build_psi

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
