"""Micro-benchmark: a ray caster's first-pass march kernel alone, this tree's kernels against a git ref's.

Renders the view once with ``--preset`` (``raycast``: :func:`warpvol.kernels.raycast.march_kernel`; ``harc_best``:
HARC's march kernel, :func:`warpvol.kernels.harc.march_kernel`; both walk in
:func:`warpvol.kernels.cellwalk.make_walk`'s walk) and records the first pass's launches
with their inputs (cells, entry search data, the rays marked for float64 before the walk), then replays them
one after the other on one host thread, for this tree's ``kernels/`` and for a copy of ``--base``'s
(``git archive``, imported as a package of its own, so both are compiled side by side; inputs matched by
argument name, Warp structs converted field by field or taken apart into their fields for a kernel that takes
them one by one), interleaved round by round in one process so load from
other processes hits both alike. Prints per kernel set the median time, the cell steps and the nanoseconds per
step (one thread), and whether the two produce the same pass bit for bit (colour, transmittance, ray
parameter, status, counters: the same float64 redo counts).

With ``--lanes N`` (0: the CPU's lane count, :func:`warpvol.kernels.lanes.device_lanes`) it compares
this tree's march with one ray per thread and with ``N`` rays per thread (:mod:`warpvol.kernels.lanes_march`)
instead of a base ref, and ``--json`` adds the view's ns per ray-step to a stamped JSON file
(``docs/data/march_lanes.json``); with ``--lanes-base REF`` too, it compares ``REF``'s lane march with this tree's
(both ``N`` rays per thread; this tree's kernels compile first).

Usage::

    ./run.sh python scripts/bench_march.py scenes/bluntfin_close.toml --tf opaque [--size 512] [--repeat 5]
        [--base main] [--preset raycast|harc_best] [--lanes 0 [--json docs/data/march_lanes.json | --lanes-base REF]]
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


def capture(scene, preset: str) -> list:
    """Render ``scene`` with ``preset`` (``raycast`` or ``harc_best``) once; the first pass's launches of its
    march kernel (``raycast``: the one-ray march), each ``(kernel, dim, inputs)`` with the arrays as they were
    before the launch."""
    import warp as wp

    from warpvol.pipeline import Pipeline

    if preset == "raycast":
        from warpvol.raycasting.stages import raycast as where
    else:
        from warpvol.raycasting import harc as where
    rec, on = [], {"now": False, "done": False}
    orig_pass, orig_launch = where.march_pass, wp.launch

    def launch(kernel, *a, **kw):
        if on["now"]:
            rec.append((kernel, kw["dim"], [wp.clone(x) if isinstance(x, wp.array) else x for x in kw["inputs"]]))
        return orig_launch(kernel, *a, **kw)

    def first_pass(*a, **kw):
        on["now"] = not on["done"]
        try:
            return orig_pass(*a, **kw)
        finally:
            on["now"], on["done"] = False, True

    from warpvol.raycasting.stages import raycast as stage

    lanes = stage.MARCH_LANES
    stage.MARCH_LANES = 1  # (the one-ray launches: one thread per ray, the other kernels take their inputs)
    where.march_pass, wp.launch = first_pass, launch
    try:
        Pipeline.load(preset, device="cpu").render(scene, quiet=True)
    finally:
        where.march_pass, wp.launch = orig_pass, orig_launch
        stage.MARCH_LANES = lanes
    return rec


def as_package(x, pkg: str):
    """A Warp struct value of ``warpvol.kernels`` as the same struct of the kernel package ``pkg`` (field by
    field); anything else as it is."""
    if not hasattr(x, "_cls"):
        return x
    try:
        mod = importlib.import_module(x._cls.module.name.replace("warpvol.kernels", pkg, 1))
    except ModuleNotFoundError:
        mod = None
    if mod is None or not hasattr(mod, x._cls.key):  # a struct defined elsewhere in pkg (moved between modules)
        import pkgutil

        base = importlib.import_module(pkg)
        mod = next(m for m in (importlib.import_module(f"{pkg}.{i.name}") for i in pkgutil.iter_modules(base.__path__))
                   if hasattr(m, x._cls.key))
    out = getattr(mod, x._cls.key)()
    for name in x._cls.vars:
        setattr(out, name, as_package(getattr(x, name), pkg))
    return out


def kernel_of(pkg: str, kernel):
    """``kernel`` (a march kernel of ``warpvol.kernels``) in the kernel package ``pkg``."""
    new = importlib.import_module("warpvol.kernels.harc")
    if "harc_march" not in kernel.key:  # raycast's pass kernel
        rc = importlib.import_module(f"{pkg}.raycast")
        return rc.march_kernel() if hasattr(rc, "march_kernel") else rc.march
    mod = importlib.import_module(f"{pkg}.harc")
    for walk in (new.WALK_PLANES, new.WALK_PLUCKER):
        for setup in (new.SETUP_ROBUST, new.SETUP_PAPER):
            for mode in (0, 1, 2):
                try:
                    if new.march_kernel(walk, setup, mode) is kernel:
                        return mod.march_kernel(walk, setup, mode)
                except ValueError:
                    pass
    raise LookupError(kernel.key)


def run_pass(pkg: str, launches: list, reentries: int = 0, lanes: int = 1):
    """The recorded launches with ``pkg``'s kernels, one after the other on this thread, each on fresh copies of
    its arrays, its inputs taken by argument name (a kernel of another signature takes what it names);
    ``(seconds, outputs)``: the arrays after the launches and the counters summed. A kernel that takes
    ``reentries`` (raycast's re-entries in a ray's thread) gets ``reentries``. ``lanes`` > 1 (this tree): the pass
    kernel with that many rays per thread (:mod:`warpvol.kernels.lanes_march`, raycast's or harc_best's) instead."""
    import warp as wp

    total, outs = 0.0, []
    for kernel, dim, inputs in launches:
        k = kernel if pkg == "warpvol.kernels" else kernel_of(pkg, kernel)
        n_threads = dim
        alias = {}  # the lane kernel's ray start and write-back inputs: their names in the recorded kernel
        if lanes > 1:
            lane_mod = importlib.import_module(f"{pkg}.lanes")
            LaneState, flat_mesh = lane_mod.LaneState, lane_mod.flat_mesh
            lane_scratch, lane_threads = lane_mod.lane_scratch, lane_mod.lane_threads
            harc = "harc_march" in kernel.key
            k = importlib.import_module(f"{pkg}.lanes_march").march_lanes_kernel(lanes, False, harc)
            n_threads = lane_threads(dim, lanes)
            alias = ({"starts": "lists", "col": "rgba", "aux": "px_work", "more": "fb"} if harc else
                     {"starts": "bins", "col": "rgb", "aux": "trans", "more": "reentries"})
        named = {a.label: x for a, x in zip(kernel.adj.args, inputs)}
        for x in list(named.values()):  # a struct's fields by name, for a kernel that takes them one by one
            if hasattr(x, "_cls"):
                for f in x._cls.vars:
                    named.setdefault(f, getattr(x, f))
        if "t_stop" in named:
            named.setdefault("t_min", named["t_stop"])  # (raycast's name of it before the walk options)
        named["reentries"] = reentries
        if lanes > 1:
            for name, was in alias.items():
                named[name] = named[was]
            named["count"] = dim
            named["scratch"] = wp.empty(lane_scratch(named["first"] + dim, named["chunk"] + 1, lanes), dtype=LaneState,
                                        device="cpu")
            named["fm"] = flat_mesh(as_package(named["mesh"], pkg), named["ig"].tf_v)
        args = [wp.clone(named[a.label]) if isinstance(named[a.label], wp.array) else as_package(named[a.label], pkg)
                for a in k.adj.args]
        wp.synchronize_device("cpu")
        t0 = time.perf_counter()
        wp.launch(k, dim=n_threads, device="cpu", inputs=args)
        wp.synchronize_device("cpu")
        total += time.perf_counter() - t0
        outs.append({alias.get(a.label, a.label): x.numpy() for a, x in zip(k.adj.args, args)
                     if isinstance(x, wp.array) and a.label != "scratch"})
        outs[-1]["counters"] = outs[-1]["counters"][named["chunk"]]  # this launch's row
    keys = ("rgb", "rgba", "trans", "tcur", "status", "last", "px_work")
    out = {key: np.concatenate([o[key].ravel() for o in outs]) for key in keys if key in outs[0]}
    out["counters"] = sum(o["counters"] for o in outs)
    return total, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--tf", default="opaque", choices=("dense", "sparse", "opaque"))
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--base", default="main", help="git ref whose kernels/ to compare against ('' : none)")
    ap.add_argument("--preset", default="raycast", choices=("raycast", "harc_best"))
    ap.add_argument("--reentries", type=int, default=0, help="raycast: re-entries per ray in the pass's threads "
                    "(0: one entry per ray, as kernels without them)")
    ap.add_argument("--lanes", type=int, default=None,
                    help="compare this tree's march with one ray per thread (LANES=1) and with this many "
                         "(0: the device's, warpvol.kernels.lanes.device_lanes) instead of a base ref")
    ap.add_argument("--lanes-base", default=None, help="with --lanes: compare this git ref's lane march with this "
                    "tree's instead of LANES=1")
    ap.add_argument("--json", default=None, help="with --lanes: add this view's ns per ray-step to this JSON file")
    a = ap.parse_args(argv)
    if a.lanes_base and (a.lanes is None or a.json):
        ap.error("--lanes-base: with --lanes, without --json")
    if a.json and a.preset != "raycast":
        ap.error("--json: the table holds raycast's march (--preset raycast)")

    from bench_raycast import load_average
    from bench_skip import variant

    from warpvol.pipeline import quiet_warp
    from warpvol.scene.scene_file import load_scene

    quiet_warp()
    base = load_scene(a.scene)
    base.camera = base.camera.replace(width_px=a.size, height_px=a.size)
    scene, _ = variant(base, a.tf)
    launches = capture(scene, a.preset)
    kinds = {"this tree": ("warpvol.kernels", 1)}
    if a.lanes is not None:
        from warpvol.kernels.lanes import device_lanes

        n = a.lanes or device_lanes("cpu")
        kinds = {"LANES=1": ("warpvol.kernels", 1), f"LANES={n}": ("warpvol.kernels", n)}
    with tempfile.TemporaryDirectory() as tmp:
        if a.base and a.lanes is None:
            base_kernels(a.base, Path(tmp))
            kinds = {f"base {a.base}": ("base_kernels", 1), **kinds}
        elif a.lanes_base:
            base_kernels(a.lanes_base, Path(tmp))
            kinds = {f"this tree L{n}": ("warpvol.kernels", n), f"{a.lanes_base} L{n}": ("base_kernels", n)}
        times = {name: [] for name in kinds}
        outs = {}
        load0 = load_average()
        for r in range(a.repeat + 1):  # round 0: compile and warm up
            for name, (pkg, lanes) in kinds.items():
                dt, outs[name] = run_pass(pkg, launches, a.reentries, lanes)
                if r:
                    times[name].append(dt)
        load1 = load_average()
    print(f"{scene.name} {a.size}^2, {a.preset}: the first pass's march launches on one host thread, {a.repeat} "
          f"interleaved rounds; {load0} (start), {load1} (end)")
    # counter columns (kernels/raycast.py, warpvol/raycasting/harc.py COUNTER_NAMES): steps, failed, thin, terminated
    col = (1, 3, 5, 6) if a.preset == "raycast" else (2, 3, 8, 11)
    for name in kinds:
        c = [int(outs[name]["counters"][i]) for i in col]
        t = statistics.median(times[name])
        print(f"  {name:<14} {t:8.4f} s  (min {min(times[name]):.4f})  steps {c[0]:,}  {1e9 * t / max(1, c[0]):6.1f} "
              f"ns/step  failed {c[1]:,} (thin {c[2]:,})  terminated {c[3]:,}")
    if len(kinds) == 2:
        o_base, o_new = outs.values()
        same = {key: bool(np.array_equal(o_base[key], o_new[key])) for key in o_base}
        print("  identical to base:", ", ".join(f"{key} {'yes' if v else 'NO'}" for key, v in same.items()))
        colour = "rgb" if "rgb" in o_base else "rgba"
        if not same[colour]:
            print(f"  largest colour difference {np.abs(o_base[colour] - o_new[colour]).max():.3e}")
        tb, tn = times.values()
        if a.lanes_base:  # (this tree's kernels first: they compile before the base's)
            tb, tn = tn, tb
        print(f"  base / this tree: {statistics.median(tb) / statistics.median(tn):.3f}")
    if a.json and a.lanes is not None and not a.lanes_base:
        write_lanes_json(a, scene, kinds, times, outs, load0, load1)
    return 0


def write_lanes_json(a, scene, kinds, times, outs, load0: str, load1: str) -> None:
    """Add this view's row (ns per ray-step with one ray per thread and with the lanes, their ratio, whether
    the passes are identical, the load average) to ``a.json`` (stamped: :mod:`warpvol.tools.provenance`)."""
    import json

    from warpvol.tools import provenance

    path = Path(a.json)
    doc = json.loads(path.read_text()) if path.exists() else {}
    rows = {f"{r[0]}/{r[1]}/{r[2]}": r for r in (doc.get("tables", {}).get("march_lanes", {}).get("rows") or [])}
    (n1, one), (nl, lanes) = kinds.items()
    steps = int(outs[n1]["counters"][1])
    t1, tl = statistics.median(times[n1]), statistics.median(times[nl])
    same = all(np.array_equal(outs[n1][k], outs[nl][k]) for k in outs[n1])
    lanes_n = lanes[1]
    rows[f"{a.scene}/{a.tf}/{a.size}"] = [a.scene, a.tf, a.size, steps, round(1e9 * t1 / max(1, steps), 1), lanes_n,
                                          round(1e9 * tl / max(1, steps), 1), round(t1 / tl, 3), same,
                                          float(load0.split()[2]), float(load1.split()[2])]
    table = {"title": "raycast's first-pass march on one host thread: ns per ray-step with one ray per thread "
                      "(LANES=1) and with the CPU's lanes, interleaved in one process",
             "columns": ["scene", "tf", "size", "steps", "ns_per_step_lanes1", "lanes", "ns_per_step_lanes",
                         "speedup", "identical", "load_start", "load_end"],
             "rows": sorted(rows.values())}
    block = provenance.start(provenance.command_line("scripts/bench_march.py"), timing=True,
                             note="scripts/bench_march.py --lanes 0, one command per view")
    loads = [float(load0.split()[2]), float(load1.split()[2])]
    provenance.write_json(path, {"tables": {"march_lanes": table}}, provenance.with_loads(block, loads))
    print(f"  wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
