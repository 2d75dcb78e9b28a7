"""Every preset on ``cuda:0`` next to the CPU: images compared, warm frames timed.

    ./run.sh python scripts/check_cuda.py [-o out/check_cuda] [--budget-s 210] [--scene scenes/bluntfin.toml]

1. Self-check, on any machine: every preset renders the two small scenes twice on the CPU and the
   comparison below finds the two images equal (the comparison, the tolerance rows and the report
   are exercised without a GPU). A failure exits 1.
2. Without a CUDA device it says so and exits 0 after the self-check (nothing else is run or written
   as if measured).
3. With one: first every kernel module is compiled for ``cuda:0`` and the CPU at once (host threads;
   Warp's kernel cache is a folder under the output, so a second run compiles nothing); after the
   self-check every preset renders the two small scenes (48^2) and the Blunt Fin at 512^2 and
   1024^2 on both devices. Each
   image pair is compared with the preset's row of ``tests/tolerances.py`` (max |GPU - CPU| and the
   RMSE of the difference, the bounds the CPU tests hold against the reference), and warm frames are
   timed (after one untimed frame: kernels compiled, tables built): 3 on the GPU, 1 on the CPU.
   ``pt_best`` is timed with the fused draw's bins chosen by the device (8 px on CUDA) and with 4-
   and 64-pixel bins (64: the CPU's). Rows that would run past ``--budget-s`` are listed as skipped.

Writes ``check_cuda.json`` and ``check_cuda.md`` (the table) into the output folder.
"""

from __future__ import annotations

import argparse
import ctypes.util
import json
import os
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the tolerance table the CPU tests use

SMALL = (("concave", 48), ("sphere", 48))
SELF_SIZE = 24
BIG_SIZES = (512, 1024)
# Blunt Fin order: the exact presets first, the slow sweep last
BIG_ORDER = ("raycast", "harc_best", "pt_best", "pt_vertex_color", "kraus2004_full", "kraus2004_basic",
             "roettger2000_3d", "weiler2003_vicp", "espinha2005_full", "espinha2005_partial", "guthe2002_linear",
             "guthe2002_quadratic_gf4", "guthe2002_quartic_radeon", "roettger2002_cylindrical", "roettger2002_hw",
             "westermann1997", "vsbuffer_best")
# pt_best's fused draw on the GPU: one thread per bin of 8 px (its default there), 4 px, or 64 px (the CPU's)
TILE_VARIANTS = tuple((f"pt_best [{t}-px bins]", (("pt_integrate.fused_tile", t),)) for t in (4, 64))


def cuda_driver_present() -> bool:
    """A CUDA driver library or device node is here (decides where the kernel cache goes, before Warp starts)."""
    return ctypes.util.find_library("cuda") is not None or Path("/dev/nvidiactl").exists()


def preset_names() -> list[str]:
    from warpvol.pipeline import list_presets

    return [n for n, _ in list_presets()]


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
    """Render ``cfg`` on both devices; the difference against the tolerance row ``tol``."""
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
        d = np.abs(imgs[0].astype(np.float64) - imgs[1])
        row.update(max_abs=float(d.max()), rmse=float(np.sqrt(np.mean(d * d))), identical=bool((d == 0).all()),
                   tol_max_abs=tol["max_abs"], tol_rmse=tol["rmse"],
                   time_s=[float(np.median(t)) if t else None for t in times])
        row["status"] = "ok" if row["max_abs"] <= tol["max_abs"] and row["rmse"] <= tol["rmse"] else "DIFFERS"
    except ConfigError as e:  # the preset declines the scene in words (on every device alike)
        row.update(status="declined", error=str(e)[:300])
    except Exception as e:  # noqa: BLE001 - a preset that fails on a device is a row, not the end of the run
        row.update(status="ERROR", error=f"{type(e).__name__}: {e}"[:500])
    return row


def small_scenes(size: int) -> list:
    from warpvol.scene.builtin import builtin_scene

    return [builtin_scene(name).with_camera(width_px=size, height_px=size) for name, _ in SMALL]


def self_check(log) -> list[dict]:
    """Every preset twice on the CPU: the comparison must find equal images."""
    from tolerances import preset_tolerance

    rows = []
    for sc in small_scenes(SELF_SIZE):
        for name in preset_names():
            r = compare(name, name, sc, preset_tolerance(name), ("cpu", "cpu"), (0, 0))
            if r["status"] == "ok" and not r["identical"]:
                r["status"] = "DIFFERS"  # the same code on the same device: the same bits
            rows.append(r)
            log(f"self-check {sc.name} {name}: {r['status']}")
    return rows


def compile_all(devices: list[str]) -> dict:
    """Load every kernel module on every device from host threads (Warp compiles modules concurrently)."""
    import warp as wp

    from warpvol.kernels import kernel_modules

    mods = kernel_modules()
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 4) as pool:
        list(pool.map(lambda md: wp.load_module(md[0], device=md[1]), [(m, d) for m in mods for d in devices]))
    return {"modules": len(mods), "devices": devices, "seconds": time.perf_counter() - t0}


def gpu_rows(args, t_start: float, log) -> list[dict]:
    from tolerances import preset_tolerance

    from warpvol.scene.scene_file import load_scene
    from warpvol.tools.sweep import pipeline_config

    rows = []
    devs = ("cuda:0", "cpu")
    for sc in small_scenes(SMALL[0][1]):
        for name in preset_names():
            rows.append(compare(name, name, sc, preset_tolerance(name), devs, (3, 1)))
            log(f"{sc.name} {name}: {rows[-1]['status']}")
    scene_path = Path(args.scene)
    try:
        big = load_scene(scene_path)
    except Exception as e:  # noqa: BLE001 - the data set may not be on this machine
        rows.append({"preset": "*", "scene": str(scene_path), "status": "SKIPPED",
                     "error": f"scene not loaded ({type(e).__name__}: {e})"[:500]})
        return rows
    for size in BIG_SIZES:
        sc = big.with_camera(width_px=size, height_px=size)
        jobs = [(n, n) for n in BIG_ORDER if n in preset_names()]
        jobs[3:3] = [(label, pipeline_config("pt_best", ov)) for label, ov in TILE_VARIANTS]
        for label, cfg in jobs:
            if time.perf_counter() - t_start > args.budget_s:
                rows.append({"preset": label, "scene": sc.name, "size": size, "status": "SKIPPED",
                             "error": f"time budget of {args.budget_s:.0f} s spent"})
                continue
            rows.append(compare(label, cfg, sc, preset_tolerance(label.split(" ")[0]), devs, (3, 1)))
            log(f"{sc.name} {size} {label}: {rows[-1]['status']}")
    return rows


def table(rows: list[dict]) -> str:
    out = ["| preset | scene | size | devices | status | max abs diff (tol) | rmse diff (tol) | time s (A / B) | reads/frame |",
           "|---|---|---:|---|---|---|---|---|---:|"]
    for r in rows:
        if "max_abs" in r:
            t = " / ".join("-" if x is None else f"{x:.4f}" for x in r["time_s"])
            out.append(f"| {r['preset']} | {r['scene']} | {r['size']} | {' vs '.join(r['devices'])} | {r['status']} | "
                       f"{r['max_abs']:.2e} ({r['tol_max_abs']:.0e}) | {r['rmse']:.2e} ({r['tol_rmse']:.0e}) | {t} | "
                       f"{r.get('reads_per_frame') if r.get('reads_per_frame') is not None else '-'} |")
        else:
            out.append(f"| {r['preset']} | {r['scene']} | {r.get('size', '')} | | {r['status']} | {r.get('error', '')} | | | |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--out", default="out/check_cuda", help="output folder (JSON, table, kernel cache)")
    ap.add_argument("--budget-s", type=float, default=210.0,
                    help="rows that would start after this many seconds (from the start) are listed as skipped")
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "bluntfin.toml"), help="the large scene (Blunt Fin)")
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    import warp as wp

    if cuda_driver_present():  # compile once per output folder: a rerun compiles nothing
        wp.config.kernel_cache_dir = str((out / "warp-cache").resolve())
    wp.config.quiet = True
    wp.init()

    def log(msg: str) -> None:
        print(f"[{time.perf_counter() - t_start:6.1f} s] {msg}", flush=True)

    result: dict = {"warp": wp.config.version, "kernel_cache": wp.config.kernel_cache_dir}
    cuda = wp.is_cuda_available()
    if cuda:  # every module at once for both devices (host threads) before anything renders
        result["compile"] = compile_all(["cuda:0", "cpu"])
        log(f"compiled {result['compile']['modules']} modules for cuda:0 and cpu in {result['compile']['seconds']:.1f} s")
    result["self_check"] = self_check(log)
    bad = [r for r in result["self_check"] if r["status"] not in ("ok", "declined")]
    n_dec = sum(r["status"] == "declined" for r in result["self_check"])
    print(table(result["self_check"]) if bad else
          f"self-check passed: {len(result['self_check']) - n_dec} CPU-vs-CPU image pairs bit-identical, "
          f"{n_dec} scenes declined in words by the preset on both runs")
    if bad:
        (out / "check_cuda.json").write_text(json.dumps(result, indent=1))
        print(f"self-check FAILED: {len(bad)} pairs differ", file=sys.stderr)
        return 1
    if not cuda:
        print("no CUDA device: Warp finds no CUDA driver or GPU here; the GPU comparison and timing did not run")
        return 0
    dev = wp.get_device("cuda:0")
    result["device"] = {"name": dev.name, "arch": dev.arch, "cpu_threads": os.cpu_count()}
    result["rows"] = gpu_rows(args, t_start, log)
    result["total_s"] = time.perf_counter() - t_start
    (out / "check_cuda.json").write_text(json.dumps(result, indent=1))
    md = (f"{dev.name} (sm_{dev.arch}), warp {wp.config.version}; A = cuda:0 (median of 3 warm frames), "
          f"B = cpu ({os.cpu_count()} threads, 1 warm frame); compile {result['compile']['seconds']:.1f} s, "
          f"total {result['total_s']:.0f} s\n\n" + table(result["rows"]))
    (out / "check_cuda.md").write_text(md + "\n")
    print(md)
    return 1 if any(r["status"] in ("DIFFERS", "ERROR") for r in result["rows"]) else 0


if __name__ == "__main__":
    sys.exit(main())
