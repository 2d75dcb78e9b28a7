"""Every preset on ``cuda:0`` next to the CPU, in one run that fits a time budget: images compared, warm
frames timed, each row written as it finishes.

    ./run.sh python scripts/check_cuda.py [-o out/check_cuda] [--budget 480] [--scene scenes/bluntfin.toml]
                                          [--data DIR] [--presets NAME...] [--sizes 512 1024]

Phases, in this order, each within the budget (``--budget`` seconds from the start; a row whose estimated
time does not fit what is left, of the budget or of its phase's share, is written as SKIPPED with the
estimate and what was left):

1. Driver: where a CUDA driver is present (``nvidia-smi -L`` lists a GPU, or ``libcuda`` loads) but Warp
   sees no CUDA device, the run says so and exits 3 at once. Without a driver or device it runs the
   self-check, says "no CUDA device" and exits 0.
2. Compile (at most 35 % of the budget): every kernel module for ``cuda:0`` and the CPU at once (host
   threads; Warp's kernel cache is a folder under the output, so a second run compiles nothing). Modules
   not started in time compile on first use.
3. Self-check (at most 15 %): every preset renders the two small scenes at 24^2 twice on the CPU and
   the comparison below must find the two images bit-identical.
4. Scenes: every preset renders the two small scenes (48^2) and ``--scene`` (the Blunt Fin) at each of
   ``--sizes`` on ``cuda:0`` and on the CPU. Each ``cuda:0`` image is compared with the CPU image
   directly: max |GPU - CPU| and the RMSE of the difference within the preset's row of
   ``tests/tolerances.py`` (the bounds the CPU tests hold against the reference), and the pixels more
   than 1e-5 apart in any channel, counted. Warm frames are timed after one untimed frame: 3 on the
   GPU, 1 on the CPU. ``pt_best`` is also timed with 4- and 64-pixel bins for its fused draw.

A row's estimate is its work (renders x (pixels x cube root of the tets + tets)) at the rate the same
preset's last row ran at (else the median rate so far; the first rows take a prior); it runs when 1.5
times the estimate fits. ``--device cpu``
runs phase 4 CPU-vs-CPU as a stand-in, without a GPU (the tests do).

Writes ``rows.jsonl`` (one JSON row per line, flushed and synced as each finishes; what a run killed
at its time limit leaves), then ``check_cuda.json`` and ``check_cuda.md`` (the table). Exit status: 0
all rows within their rows, 1 a row differs or failed, 3 a driver without a CUDA device for Warp.
"""

from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import json
import os
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the tolerance table the CPU tests use

SMALL = ("concave", "sphere")
SMALL_SIZE = 48
SELF_SIZE = 24
BIG_SIZES = (512, 1024)
# Blunt Fin order: the exact presets first, the slow sweep last
BIG_ORDER = ("raycast", "harc_best", "pt_best", "pt_vertex_color", "kraus2004_full", "kraus2004_basic",
             "roettger2000_3d", "weiler2003_vicp", "espinha2005_full", "espinha2005_partial", "guthe2002_linear",
             "guthe2002_quadratic_gf4", "guthe2002_quartic_radeon", "roettger2002_cylindrical", "roettger2002_hw",
             "westermann1997", "vsbuffer_best")
# pt_best's fused draw on the GPU: one thread per bin of 8 px (its default there), 4 px, or 64 px (the CPU's)
TILE_VARIANTS = tuple((f"pt_best [{t}-px bins]", (("pt_integrate.fused_tile", t),)) for t in (4, 64))
#: two pixels differ when a channel differs by more than this
DIFF_PX = 1e-5
#: the most of the budget the compile and the self-check may take; the scenes get the rest
SHARES = {"compile": 0.35, "self-check": 0.15}
#: seconds per unit of :meth:`Estimator.work` before any row has been measured
PRIOR_RATE = 2e-6
#: a row runs when this many times its estimate fits what is left
SAFETY = 1.5
EXIT_NO_DEVICE = 3


# -- the driver ---------------------------------------------------------------------------------------
def probe_driver() -> str | None:
    """Why a CUDA driver is here (``nvidia-smi -L`` lists a GPU, or ``libcuda`` loads), else ``None``."""
    smi = shutil.which("nvidia-smi")
    if smi:
        try:
            r = subprocess.run([smi, "-L"], capture_output=True, text=True, timeout=30)
            if r.returncode == 0 and r.stdout.strip():
                return f"nvidia-smi -L: {r.stdout.strip().splitlines()[0]}"
        except (OSError, subprocess.TimeoutExpired):
            pass
    for lib in ("libcuda.so.1", ctypes.util.find_library("cuda")):
        if lib:
            try:
                ctypes.CDLL(lib)
                return f"{lib} loads"
            except OSError:
                pass
    return None


# -- rows, written as they finish ------------------------------------------------------------------------
def row_line(r: dict) -> str:
    """One line for stdout."""
    head = f"{r.get('phase', '')} {r.get('scene', '')} {r.get('size', '')} {r.get('preset', '')}".split()
    text = " ".join(head) + f": {r['status']}"
    if "max_abs" in r:
        text += (f"  max {r['max_abs']:.1e} (tol {r['tol_max_abs']:.0e})  rmse {r['rmse']:.1e} (tol {r['tol_rmse']:.0e})"
                 f"  px>1e-5 {r['px_diff']}/{r['px_total']}  time "
                 + " / ".join("-" if t is None else f"{t:.4f}" for t in r["time_s"]) + " s")
    if r.get("reason"):
        text += f"  ({r['reason']})"
    return text


class Rows:
    """Each row appended to ``path`` as one JSON line (flushed and synced) and printed, as it finishes."""

    def __init__(self, path: Path, t0: float, clock=time.perf_counter):
        self.rows: list[dict] = []
        self.t0, self.clock = t0, clock
        self._f = open(path, "w", encoding="utf-8")

    def add(self, row: dict) -> dict:
        row = dict(row, t_s=round(self.clock() - self.t0, 3))
        self.rows.append(row)
        self._f.write(json.dumps(row) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())
        print(f"[{row['t_s']:6.1f} s] {row_line(row)}", flush=True)
        return row

    def close(self) -> None:
        self._f.close()


# -- the budget ---------------------------------------------------------------------------------------------
class Budget:
    """``seconds`` from ``t0`` on ``clock``; a phase may take at most its share of them."""

    def __init__(self, seconds: float, t0: float | None = None, clock=time.perf_counter):
        self.seconds, self.clock = float(seconds), clock
        self.t0 = clock() if t0 is None else t0
        self.phase, self.phase_end = "", None

    def left(self) -> float:
        return self.t0 + self.seconds - self.clock()

    def start_phase(self, name: str, share: float | None = None) -> None:
        self.phase = name
        self.phase_end = None if share is None else min(self.clock() + share * self.seconds, self.t0 + self.seconds)

    def phase_left(self) -> float:
        return self.left() if self.phase_end is None else self.phase_end - self.clock()

    def why_not(self, estimate: float) -> str | None:
        """``None`` if a step of ``estimate`` seconds fits, else the reason it is skipped."""
        if SAFETY * estimate <= min(self.left(), self.phase_left()):
            return None
        if self.phase_end is not None and self.phase_left() < self.left():
            return (f"needs ~{estimate:.1f} s, the {self.phase} phase has {max(self.phase_left(), 0):.1f} s left of "
                    f"its {SHARES.get(self.phase, 0) * self.seconds:.0f} s")
        return f"needs ~{estimate:.1f} s, {max(self.left(), 0):.1f} s of --budget {self.seconds:.0f} s left"


class Estimator:
    """Seconds a row will take: its work (:meth:`work`) at the rate of the same preset's last row, else at
    the median rate of every row so far, else at :data:`PRIOR_RATE`."""

    def __init__(self, prior: float = PRIOR_RATE):
        self.prior, self.rates = prior, {}

    @staticmethod
    def work(pixels: int, renders: int, tets: int) -> float:
        """A render's work: its rays' cell steps (pixels x cube root of the tets) plus its per-cell work."""
        return renders * (float(pixels) * max(tets, 1) ** (1 / 3) + tets)

    def estimate(self, preset: str, pixels: int, renders: int, tets: int) -> float:
        rate = self.rates.get(preset)
        if rate is None:
            rate = float(np.median(list(self.rates.values()))) if self.rates else self.prior
        return rate * self.work(pixels, renders, tets)

    def record(self, preset: str, pixels: int, renders: int, tets: int, seconds: float) -> None:
        self.rates[preset] = seconds / self.work(pixels, renders, tets)


# -- one image pair -----------------------------------------------------------------------------------------
def compare_images(a: np.ndarray, b: np.ndarray, tol: dict) -> dict:
    """``a`` against ``b`` (RGBA): max |a - b| and the RMSE of the difference against the tolerance row
    ``tol``, the pixels more than :data:`DIFF_PX` apart in any channel, and ``status`` ok / DIFFERS."""
    d = np.abs(np.asarray(a, np.float64) - np.asarray(b, np.float64))
    px = d.reshape(-1, d.shape[-1]).max(axis=1) if d.ndim == 3 else d.ravel()
    out = {"max_abs": float(d.max()), "rmse": float(np.sqrt(np.mean(d * d))), "identical": bool((d == 0).all()),
           "px_diff": int((px > DIFF_PX).sum()), "px_total": int(px.size),
           "tol_max_abs": tol["max_abs"], "tol_rmse": tol["rmse"]}
    out["status"] = "ok" if out["max_abs"] <= tol["max_abs"] and out["rmse"] <= tol["rmse"] else "DIFFERS"
    return out


def frames(pipe, scene, device: str, n: int) -> tuple[np.ndarray, list[float], dict]:
    """One untimed frame, then ``n`` timed ones (wall clock, device synchronised)."""
    import warp as wp

    res = pipe.render(scene, quiet=True)
    times = []
    for _ in range(n):
        wp.synchronize_device(device)
        t0 = time.perf_counter()
        res = pipe.render(scene, quiet=True)
        wp.synchronize_device(device)
        times.append(time.perf_counter() - t0)
    return res.image, times, res.report


def compare(label: str, cfg, scene, tol: dict, devices: tuple[str, str], n: tuple[int, int]) -> dict:
    """Render ``cfg`` on both devices; the first image against the second (:func:`compare_images`)."""
    from warpvol.errors import ConfigError
    from warpvol.pipeline import Pipeline

    row = {"preset": label, "scene": scene.name, "size": int(scene.camera.width_px), "devices": list(devices)}
    try:
        imgs, times = [], []
        for dev, k in zip(devices, n):
            p = Pipeline.from_config(cfg, device=dev) if isinstance(cfg, dict) else Pipeline.load(cfg, device=dev)
            img, t, rep = frames(p, scene, dev, k)
            imgs.append(img)
            times.append(t)
            row.setdefault("reads_per_frame", rep.get("device_reads", {}).get("total"))
        row.update(compare_images(imgs[0], imgs[1], tol), time_s=[float(np.median(t)) if t else None for t in times])
    except ConfigError as e:  # the preset declines the scene in words (on every device alike)
        row.update(status="declined", reason=str(e)[:300])
    except Exception as e:  # noqa: BLE001 - a preset that fails on a device is a row, not the end of the run
        row.update(status="ERROR", reason=f"{type(e).__name__}: {e}"[:500])
    return row


# -- the phases -----------------------------------------------------------------------------------------------
def compile_all(devices: list[str], budget: Budget) -> dict:
    """Load every kernel module on every device from host threads (Warp compiles modules concurrently); a
    module not started before the compile phase's share of the budget is spent compiles on first use."""
    import warp as wp

    from warpvol.kernels import kernel_modules

    mods = kernel_modules()
    t0 = time.perf_counter()

    def load(md) -> bool:
        if budget.phase_left() <= 0:
            return False
        wp.load_module(md[0], device=md[1])
        return True

    with ThreadPoolExecutor(max_workers=os.cpu_count() or 4) as pool:
        done = list(pool.map(load, [(m, d) for m in mods for d in devices]))
    row = {"phase": "compile", "modules": len(mods), "devices": devices, "loaded": sum(done),
           "seconds": round(time.perf_counter() - t0, 2), "status": "ok" if all(done) else "PARTIAL"}
    if not all(done):
        row["reason"] = (f"{len(done) - sum(done)} of {len(done)} module loads not started within the compile phase's "
                         f"{SHARES['compile'] * budget.seconds:.0f} s; they compile on first use")
    return row


def preset_tolerance_of(label: str) -> dict:
    from tolerances import preset_tolerance

    return preset_tolerance(label.split(" ")[0])


def run_jobs(jobs: list, rows: Rows, budget: Budget, est: Estimator, devices: tuple[str, str], n: tuple[int, int],
             phase: str, compare_fn=compare) -> None:
    """Each ``(label, cfg, scene)`` of ``jobs`` compared on ``devices`` if its estimate fits, else SKIPPED."""
    renders = sum(1 + k for k in n)
    for label, cfg, scene in jobs:
        pixels, tets = scene.camera.width_px * scene.camera.height_px, scene.mesh.n_tets
        base = label.split(" ")[0]
        e = est.estimate(base, pixels, renders, tets)
        why = budget.why_not(e)
        head = {"phase": phase, "preset": label, "scene": scene.name, "size": int(scene.camera.width_px)}
        if why is not None:
            rows.add(dict(head, status="SKIPPED", estimate_s=round(e, 2), reason=why))
            continue
        t0 = budget.clock()
        r = compare_fn(label, cfg, scene, preset_tolerance_of(label), devices, n)
        seconds = budget.clock() - t0
        est.record(base, pixels, renders, tets, seconds)
        if phase == "self-check" and r["status"] == "ok" and not r["identical"]:
            r["status"] = "DIFFERS"  # the same code on the same device: the same bits
        rows.add(dict(head, **r, seconds=round(seconds, 3), estimate_s=round(e, 2)))


def small_scenes(size: int) -> list:
    from warpvol.scene.builtin import builtin_scene

    return [builtin_scene(name).with_camera(width_px=size, height_px=size) for name in SMALL]


def scene_jobs(args, names: list[str], rows: Rows) -> list:
    """``(label, cfg, scene)`` for phase 4: the small scenes, then the large one at each size."""
    from warpvol.scene.scene_file import load_scene
    from warpvol.tools.sweep import pipeline_config

    jobs = [(n, n, sc) for sc in small_scenes(args.small_size) for n in names]
    try:
        big = load_scene(args.scene)
    except Exception as e:  # noqa: BLE001 - the data set may not be on this machine
        rows.add({"phase": "scenes", "preset": "*", "scene": str(args.scene), "status": "SKIPPED",
                  "reason": f"scene not loaded ({type(e).__name__}: {e})"[:500]})
        return jobs
    for size in args.sizes:
        sc = big.with_camera(width_px=size, height_px=size)
        order = [n for n in BIG_ORDER if n in names] + [n for n in names if n not in BIG_ORDER]
        big_jobs = [(n, n, sc) for n in order]
        if "pt_best" in names:
            at = order.index("pt_best") + 1
            big_jobs[at:at] = [(label, pipeline_config("pt_best", ov), sc) for label, ov in TILE_VARIANTS]
        jobs += big_jobs
    return jobs


def table(rows: list[dict]) -> str:
    out = ["| phase | preset | scene | size | status | max abs diff (tol) | rmse diff (tol) | px > 1e-5 | time s (A / B) "
           "| reads/frame |", "|---|---|---|---:|---|---|---|---:|---|---:|"]
    for r in rows:
        if "max_abs" in r:
            t = " / ".join("-" if x is None else f"{x:.4f}" for x in r["time_s"])
            out.append(f"| {r['phase']} | {r['preset']} | {r['scene']} | {r['size']} | {r['status']} | "
                       f"{r['max_abs']:.2e} ({r['tol_max_abs']:.0e}) | {r['rmse']:.2e} ({r['tol_rmse']:.0e}) | "
                       f"{r['px_diff']} / {r['px_total']} | {t} | "
                       f"{r.get('reads_per_frame') if r.get('reads_per_frame') is not None else '-'} |")
        else:
            out.append(f"| {r.get('phase', '')} | {r.get('preset', '')} | {r.get('scene', '')} | {r.get('size', '')} | "
                       f"{r['status']} | {r.get('reason', '')} | | | | |")
    return "\n".join(out)


def parse_args(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--out", default="out/check_cuda", help="output folder (rows, JSON, table, kernel cache)")
    ap.add_argument("--budget", "--budget-s", dest="budget", type=float, default=480.0,
                    help="seconds for the whole run from its start (default 480: a 10-minute call less the set-up); "
                    "a row whose estimate does not fit is written as skipped")
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "bluntfin.toml"), help="the large scene (Blunt Fin)")
    ap.add_argument("--data", help="folder with the scene's data files where ../shared/data lacks them "
                    "(sets $WARPVOL_DATA; the wheelhouse's data/ folder)")
    ap.add_argument("--sizes", type=int, nargs="+", default=list(BIG_SIZES), help="sizes of the large scene")
    ap.add_argument("--small-size", type=int, default=SMALL_SIZE, help="size of the two small scenes")
    ap.add_argument("--self-size", type=int, default=SELF_SIZE, help="size of the self-check's scenes")
    ap.add_argument("--presets", nargs="+", help="only these presets (default: all)")
    ap.add_argument("--device", default="cuda:0", help="the device compared with the CPU (cpu: a CPU-vs-CPU stand-in "
                    "for checking this script without a GPU)")
    return ap.parse_args(argv)


def main(argv=None) -> int:
    t_start = time.perf_counter()
    args = parse_args(argv)
    budget = Budget(args.budget, t_start)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.data:
        os.environ["WARPVOL_DATA"] = str(Path(args.data).resolve())
    rows = Rows(out / "rows.jsonl", t_start)
    try:
        return _run(args, budget, rows, out)
    finally:
        rows.close()


def _run(args, budget: Budget, rows: Rows, out: Path) -> int:
    driver = probe_driver() if args.device.startswith("cuda") else None

    import warp as wp

    from warpvol.pipeline import list_presets, quiet_warp

    quiet_warp(cuda=bool(driver))  # no banner or module-load lines between the rows
    wp.init()

    names = [n for n, _ in list_presets() if not args.presets or n in args.presets]
    unknown = sorted(set(args.presets or ()) - set(names))
    if unknown:
        print(f"check_cuda: unknown presets {unknown}", file=sys.stderr)
        return 2
    result: dict = {"warp": wp.config.version, "kernel_cache": wp.config.kernel_cache_dir, "budget_s": args.budget,
                    "driver": driver, "device_under_test": args.device}
    cuda = args.device.startswith("cuda") and wp.is_cuda_available()
    on_device = cuda or args.device == "cpu"
    if driver and not cuda:
        rows.add({"phase": "driver", "status": "NO DEVICE",
                  "reason": f"a CUDA driver is here ({driver}) but Warp {wp.config.version} sees no CUDA device "
                            "(Warp's start-up message says why: driver too old for its CUDA, no device visible)"})
        _write(result, rows, out, None)
        return EXIT_NO_DEVICE
    est = Estimator()
    if cuda:  # compile once per output folder: a rerun compiles nothing (Warp reads the folder at each load)
        (out / "warp-cache").mkdir(exist_ok=True)
        wp.config.kernel_cache_dir = result["kernel_cache"] = str((out / "warp-cache").resolve())
        budget.start_phase("compile", SHARES["compile"])
        rows.add(compile_all([args.device, "cpu"], budget))
    budget.start_phase("self-check", SHARES["self-check"])
    self_jobs = [(n, n, sc) for sc in small_scenes(args.self_size) for n in names]
    run_jobs(self_jobs, rows, budget, est, ("cpu", "cpu"), (0, 0), "self-check")
    if not on_device:
        _write(result, rows, out, None)
        print("no CUDA device: Warp finds no CUDA driver or GPU here; the GPU comparison and timing did not run")
        return 1 if _bad(rows.rows) else 0
    budget.start_phase("scenes")
    dev = wp.get_device(args.device)
    result["device"] = {"name": dev.name, "arch": getattr(dev, "arch", None), "cpu_threads": os.cpu_count()}
    run_jobs(scene_jobs(args, names, rows), rows, budget, est, (args.device, "cpu"), (3, 1), "scenes")
    result["total_s"] = round(time.perf_counter() - budget.t0, 1)
    _write(result, rows, out, dev)
    return 1 if _bad(rows.rows) else 0


def _bad(rows: list[dict]) -> bool:
    return any(r["status"] in ("DIFFERS", "ERROR") for r in rows)


def _write(result: dict, rows: Rows, out: Path, dev) -> None:
    import warp as wp

    result["rows"] = rows.rows
    (out / "check_cuda.json").write_text(json.dumps(result, indent=1))
    where = "no device under test" if dev is None else (
        f"{dev.name}" + (f" (sm_{dev.arch})" if getattr(dev, "arch", None) else ""))
    md = (f"{where}, warp {wp.config.version}; A = {result['device_under_test']} (median of 3 warm frames), "
          f"B = cpu ({os.cpu_count()} threads, 1 warm frame); budget {result['budget_s']:.0f} s"
          + (f", total {result['total_s']:.0f} s" if "total_s" in result else "") + "\n\n" + table(rows.rows))
    (out / "check_cuda.md").write_text(md + "\n")
    counts: dict[str, int] = {}
    for r in rows.rows:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    print(f"rows: {', '.join(f'{v} {k}' for k, v in sorted(counts.items()))}; written to {out / 'check_cuda.md'}",
          flush=True)


if __name__ == "__main__":
    sys.exit(main())
