"""Micro-benchmark: the ``raycast`` first pass's march kernel alone, this tree's kernels against a git ref's.

Renders the view once with the ``raycast`` preset to capture the first pass's inputs (cells, entry bins,
the rays marked for float64 before the walk), then times :func:`warpvol.kernels.raycast.march` over the whole
image in one launch on one host thread, for this tree's ``kernels/`` and for a copy of ``--base``'s
(``git archive``, imported as a package of its own, so both are compiled side by side), interleaved round by
round in one process so load from other processes hits both alike. Prints per kernel set the median time,
the cell steps and the nanoseconds per step (one thread), and whether the two produce the same pass
bit for bit (radiance, transmittance, ray parameter, status, counters: the same float64 redo counts).

Usage::

    ./run.sh python scripts/bench_march.py scenes/bluntfin_close.toml --tf opaque [--size 512] [--repeat 5]
        [--base main]
"""

from __future__ import annotations

import argparse
import importlib
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))


def base_kernels(ref: str, where: Path):
    """``ref``'s ``kernels/`` as the importable package ``base_kernels`` (its ``raycast`` module)."""
    blob = subprocess.run(["git", "-C", str(ROOT), "archive", ref, "kernels"], check=True, capture_output=True).stdout
    with tarfile.open(fileobj=BytesIO(blob)) as tar:
        tar.extractall(where, filter="data")
    (where / "kernels").rename(where / "base_kernels")
    sys.path.insert(0, str(where))
    return importlib.import_module("base_kernels.raycast")


def capture(scene):
    """Render ``scene`` with ``raycast`` once; the first pass's context, its status before the walk, its
    ``t_min`` and ``max_steps``."""
    from warpvol.pipeline import Pipeline
    from warpvol.raycasting.stages import raycast as stage

    got = {}
    orig = stage.march_pass

    def spy(ctx, state, **kw):
        if "ctx" not in got:
            got.update(ctx=ctx, status=state.status.numpy().copy(), kw=kw)
        return orig(ctx, state, **kw)

    stage.march_pass = spy
    try:
        Pipeline.load("raycast", device="cpu").render(scene, quiet=True)
    finally:
        stage.march_pass = orig
    return got


def run_pass(k, ctx, status0, kw):
    """One launch of ``k.march`` over the whole image; ``(seconds, outputs)``."""
    import warp as wp

    from warpvol.raycasting.stages.raycast import camera_launch_args

    cells, bins = ctx.buffers["cells"], ctx.buffers["entry_bins"]
    n = len(status0)
    dev = ctx.device
    rgb = wp.zeros(n, dtype=wp.vec3, device=dev)
    trans = wp.array(np.ones(n, np.float32), device=dev)
    tcur = wp.zeros(n, dtype=wp.float32, device=dev)
    status = wp.array(status0, dtype=wp.int32, device=dev)
    last = wp.array(np.full(n, -1, np.int32), device=dev)
    counters = wp.zeros((1, 7), dtype=wp.int32, device=dev)
    ids = wp.zeros(0, dtype=wp.int32, device=dev)
    # by argument name, so kernels of another signature (a git ref's) take what they name
    named = dict(zip(("width", "height", "eye", "fwd", "right", "up", "ortho", "half_h", "aspect", "radius"),
                     camera_launch_args(ctx)))
    named.update({name: cells[name] for name in ("verts", "tets", "nbr", "nbr_vertex", "tf_s", "tf_v", "model",
                                                 "scalar_check")})
    named.update({name: bins[name] for name in ("bface_tet", "bface_local", "bface_box", "tile_start", "tile_items",
                                                "tile", "tiles_x")})
    named.update(max_steps=kw["max_steps"], t_min=kw["t_min"], t_tol=1e-6 * cells["radius"], first=0, ids=ids, rgb=rgb,
                 trans=trans, tcur=tcur, status=status, last=last, counters=counters, chunk=0)
    inputs = [named[a.label] for a in k.march.adj.args]
    wp.synchronize_device(dev)
    t0 = time.perf_counter()
    wp.launch(k.march, dim=n, device=dev, inputs=inputs)
    wp.synchronize_device(dev)
    dt = time.perf_counter() - t0
    return dt, {"rgb": rgb.numpy(), "trans": trans.numpy(), "tcur": tcur.numpy(), "status": status.numpy(),
                "counters": counters.numpy()[0]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--tf", default="opaque", choices=("dense", "sparse", "opaque"))
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--base", default="main", help="git ref whose kernels/ to compare against ('' : none)")
    a = ap.parse_args(argv)

    from bench_raycast import load_average
    from bench_skip import variant

    from warpvol.kernels import raycast as k_new
    from warpvol.pipeline import quiet_warp
    from warpvol.scene.scene_file import load_scene

    quiet_warp()
    base = load_scene(a.scene)
    base.camera = base.camera.replace(width_px=a.size, height_px=a.size)
    scene, _ = variant(base, a.tf)
    got = capture(scene)
    kinds = {"this tree": k_new}
    with tempfile.TemporaryDirectory() as tmp:
        if a.base:
            kinds = {f"base {a.base}": base_kernels(a.base, Path(tmp)), **kinds}
        times = {name: [] for name in kinds}
        outs = {}
        load0 = load_average()
        for r in range(a.repeat + 1):  # round 0: compile and warm up
            for name, k in kinds.items():
                dt, outs[name] = run_pass(k, got["ctx"], got["status"], got["kw"])
                if r:
                    times[name].append(dt)
        load1 = load_average()
    print(f"{scene.name} {a.size}^2: march alone, one launch on one host thread, {a.repeat} interleaved rounds; "
          f"{load0} (start), {load1} (end)")
    for name in kinds:
        c = outs[name]["counters"]
        t = statistics.median(times[name])
        print(f"  {name:<14} {t:8.4f} s  (min {min(times[name]):.4f})  steps {int(c[1]):,}  {1e9 * t / max(1, c[1]):6.1f} "
              f"ns/step  failed {int(c[3]):,} (thin {int(c[5]):,})  terminated {int(c[6]):,}")
    if len(kinds) == 2:
        o_base, o_new = outs.values()
        same = {key: bool(np.array_equal(o_base[key], o_new[key])) for key in o_base}
        print("  identical to base:", ", ".join(f"{key} {'yes' if v else 'NO'}" for key, v in same.items()))
        if not same["rgb"]:
            print(f"  largest radiance difference {np.abs(o_base['rgb'] - o_new['rgb']).max():.3e}")
        tb, tn = times.values()
        print(f"  base / this tree: {statistics.median(tb) / statistics.median(tn):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
