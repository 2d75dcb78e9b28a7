"""Guthe et al. 2002, pre-integration tables in hardware (transfer function and the model of its Table 4);
the command line is ``scripts/reproduce_guthe2002.py``."""

from __future__ import annotations

import numpy as np

from warpvol.model import load_profile, model_counters
from warpvol.pipeline import Pipeline
from warpvol.reproduce.common import calibrations, counted, modelled_seconds, table
from warpvol.scene.camera import Camera
from warpvol.scene.loaders import load_mesh
from warpvol.scene.scene import Scene
from warpvol.scene.scene_file import scene_from_config
from warpvol.scene.transfer import TransferFunction
from warpvol.tables.exact import build_exact3d
from warpvol.tables.guthe2d import build_guthe2d, reconstruct
from warpvol.tables.pingpong import build_pingpong
from warpvol.tables.roettger_sw import build_roettger_sw


def guthe_tf(m=128):
    """m entries, colour times extinction, with steep gradients (what the polynomial is for)."""

    x = np.linspace(0, 1, m)
    r = 0.5 + 0.5 * np.sin(9 * x)
    g = np.clip(np.exp(-((x - 0.55) / 0.05) ** 2) + 0.2, 0, 1)
    b = np.clip(1 - x, 0, 1)
    rho = 0.5 + 6.0 * np.exp(-((x - 0.55) / 0.04) ** 2) + 2.0 * (x > 0.8)
    return TransferFunction.from_table(np.column_stack([r, g, b, rho]), (0.0, 1.0), "color_extinction")


GUTHE_T4 = {1: (4.4, 0.6), 2: (6.6, 1.0), 4: (11.0, 1.7)}


def guthe_t4_model(degree: int, device: str = "cpu", gpu: str = "radeon8500") -> float:
    """Modelled Table 4 hardware row (512^2, m = 128, ping-pong slices + host coefficient fit)."""

    c = counted(build_guthe2d, guthe_tf(), n_s=512, degree=degree, lmax=1.0, slices="pingpong", m=128,
                emulate=False, device=device)
    return model_counters(c, load_profile(gpu))["s"]



def guthe_steps_per_pass_speedup(device: str = "cpu") -> float:
    """Radeon 8500: modelled GPU time of 1 over 4 integration steps per pass (one channel slice)."""

    p = load_profile("radeon8500")
    t = [model_counters(counted(build_pingpong, guthe_tf(), n_s=512, lengths=(1.0,), m=128, per_pass=k,
                                emulate=False, device=device), p)["gpu_s"] for k in (1, 4)]
    return t[0] / t[1]


# -- Figs. 6 and 4/7 as numbers, Tables 4 and 5 ----------------------------------------------------------
#: Table 5, fps: card -> data set -> (numeric, MPVO, XMPVO)
PAPER_T5 = {"geforce4": {"Blunt Fin": (3.18, 2.64, 2.35), "Bucky Ball": (2.46, 2.19, 2.05)},
            "radeon8500": {"Blunt Fin": (2.51, 2.20, 1.99), "Bucky Ball": (2.09, 1.98, 1.87)}}
SORTS = (("numeric", "centroid"), ("MPVO", "mpvo"), ("XMPVO", "xmpvo"))
PROFILES = {"geforce4": "geforce4_ti4600", "radeon8500": "radeon8500"}

F6_COLUMNS = ["hardware", "RMS vs software", "max vs software", "RMS vs exact", "max vs exact"]
F7_COLUMNS = ["degree", "card arithmetic", "RMS fp32 shader", "max fp32 shader", "RMS card", "max card", "card / fp32",
              "RMS fp32 tables", "max fp32 tables", "coefficient scales (card)", "saturated"]
T4_COLUMNS = ["n", "paper software [s]", "paper hardware [s]", "paper ratio", "ours software (exact) [s]",
              "ours hardware emulated (ping-pong) [s]", "ours ratio", "modelled hardware [s]",
              "modelled hardware / paper", "paper software / modelled hardware", "ping-pong passes", "role"]
T5_COLUMNS = ["card", "data set", "tets", "sort", "paper fps", "emulated fps", "emulated / paper", "modelled fps",
              "modelled / paper", "sort exact", "role"]


def _save(out, name, img):
    if out is None:
        return
    import os

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(out, exist_ok=True)
    plt.imsave(os.path.join(out, name), np.clip(img, 0, 1)[::-1], origin="upper")


def fig6(tf=None, N: int = 512, m: int = 128, *, device="cpu", out=None) -> dict:
    """Fig. 6: the ping-pong hardware slice at l = lmax (12-bit hi/lo, per card) against software
    pre-integration with ``m`` steps and against the exact integral."""

    tf = tf or guthe_tf()
    soft = build_roettger_sw(tf, n_s=N, n_l=2, lmax=1.0, m=1, oversampling=1e-9, n_min=m, l_axis="endpoint",
                             device=device).data[1]
    exact = build_exact3d(tf, n_s=N, n_l=2, lmax=1.0, l_axis="endpoint", device=device).data[1]
    rows = []
    for gpu in ("radeon8500", "geforce4"):
        pp = build_pingpong(tf, n_s=N, lengths=[1.0], lmax=1.0, m=m, gpu=gpu, device=device).data[0]
        d = np.abs(pp[..., :3] - soft[..., :3])
        de = np.abs(pp[..., :3] - exact[..., :3])
        rows.append([f"{gpu} ping-pong", float(np.sqrt((d ** 2).mean())), float(d.max()),
                     float(np.sqrt((de ** 2).mean())), float(de.max())])
        _save(out, f"guthe2002_fig6_{gpu}_hw.png", pp[..., :3])
        _save(out, f"guthe2002_fig6_{gpu}_error_x8_inverted.png", 1 - 8 * d)
    ds = np.abs(soft[..., :3] - exact[..., :3])
    rows.append([f"software (m = {m})", 0.0, 0.0, float(np.sqrt((ds ** 2).mean())), float(ds.max())])
    _save(out, "guthe2002_fig6_software.png", soft[..., :3])
    return table(f"Fig. 6: ping-pong (12-bit hi/lo) vs software pre-integration, m = {m}, {N}^2 slice at l = lmax",
                 F6_COLUMNS, rows, "Colour error of the slice; no timing and no model.")


def fig7(tf=None, N: int = 512, E: int = 64, *, device="cpu", out=None) -> dict:
    """Figs. 4/7 as numbers: linear, degree-2 and degree-4 colour reconstruction error against the
    exact integral over an ``E``^3 grid of (sf, sb, l), textures ``N``^2."""

    tf = tf or guthe_tf()
    ref = build_exact3d(tf, n_s=E, n_l=E, lmax=1.0, device=device)
    x = ref.axes[2].nodes
    L, B, F = np.meshgrid(ref.axes[0].nodes, x, x, indexing="ij")
    cards = {1: ("nv_combiner", "ati_fs"), 2: ("nv_combiner", "ati_fs"), 4: ("ati_fs",)}
    rows = []

    def err(g, **kw):
        d = np.abs(reconstruct(g, F, B, L, device=device, **kw) - ref.data)
        return float(np.sqrt((d ** 2).mean())), float(d.max()), d

    for deg in (1, 2, 4):
        flt = err(build_guthe2d(tf, n_s=N, degree=deg, lmax=1.0, format="fp32", alpha_format="fp32", device=device),
                  via="float")
        fp = err(build_guthe2d(tf, n_s=N, degree=deg, lmax=1.0, device=device))
        for arith in cards[deg]:
            g = build_guthe2d(tf, n_s=N, degree=deg, lmax=1.0, scales=arith, device=device)
            hw = err(g)
            _save(out, f"guthe2002_fig7_degree{deg}_{arith}_error_x8_inverted.png", 1 - 8 * hw[2][E // 2, ..., :3])
            rows.append([deg, arith, fp[0], fp[1], hw[0], hw[1], hw[0] / fp[0], flt[0], flt[1],
                         [float(v[0]) for v in g.meta["coef_scale"]], str(g.meta["coef_saturated"])])
    _save(out, "guthe2002_fig7_exact_mid_l.png", ref.data[E // 2, ..., :3])
    return table(f"Figs. 4/7: colour reconstruction error against the exact integral over an {E}^3 grid of "
                 f"(sf, sb, l), textures {N}^2", F7_COLUMNS, rows,
                 "8-bit signed coefficients and 16-bit A/L alpha through the emulated texture unit; shader "
                 "arithmetic in fp32 with free per-channel scales ('fp32 shader'), in the card's fixed-point "
                 "registers with the scales its scale ops offer ('card'), and fp32 tables with float64 filtering "
                 "('fp32 tables') to isolate the polynomial. No timing and no model.")


def table4(tf=None, N: int = 512, m: int = 128, *, device="cpu", model_device=None) -> dict:
    """Table 4: texture set-up time for n = 1, 2, 4: the exact software build and the emulated
    ping-pong (warm kernels, this CPU), and the counted ping-pong work at 512^2 modelled on the
    radeon8500 profile (:func:`guthe_t4_model`), the paper's P4 / Radeon 8500 times beside."""
    import time


    tf = tf or guthe_tf()
    build_guthe2d(tf, n_s=8, degree=1, slices="pingpong", m=4, device=device)  # warm-up
    rows = []
    for deg in (1, 2, 4):
        t0 = time.perf_counter()
        build_guthe2d(tf, n_s=N, degree=deg, lmax=1.0, device=device)
        tsw = time.perf_counter() - t0
        t0 = time.perf_counter()
        g = build_guthe2d(tf, n_s=N, degree=deg, lmax=1.0, slices="pingpong", m=m, device=device)
        thw = time.perf_counter() - t0
        tm = guthe_t4_model(deg, model_device or device)
        p = GUTHE_T4[deg]
        rows.append([deg, p[0], p[1], p[0] / p[1], tsw, thw, tsw / thw, tm, tm / p[1], p[0] / tm,
                     g.meta["pingpong_passes"], "calibration" if deg == 1 else "prediction"])
    return table(f"Table 4: texture set-up time at {N}^2, m = {m}; paper: Pentium 4 2 GHz software vs Radeon 8500",
                 T4_COLUMNS, rows,
                 "'ours software' is the exact piecewise-linear integrator (Warp kernel, all CPU cores), much faster "
                 "than 2002's numerical integration; the emulated ping-pong runs every shader step on the CPU, so its "
                 "ratio measures emulation cost. Modelled: the counted ping-pong work at 512^2 on the radeon8500 "
                 "profile. Our build integrates 3n channel slices (C0 from the exact moments); the paper runs "
                 "3(n + 1) ('9 pre-integration cycles for degree 2'). " + calibrations("radeon8500"))


def table5_scenes(width=1280, height=960):
    """Blunt Fin (5-tet split, 187,318 tets, scenes/bluntfin.toml's TF and view) and the Bucky Ball
    (bucky.raw, 6-tet split, 178,746 tets) at width x height."""
    import tomllib
    import warnings
    from pathlib import Path


    root = Path(__file__).resolve().parents[2]
    p = root / "scenes" / "bluntfin.toml"
    cfg = tomllib.loads(p.read_text())
    cfg["mesh"]["split"] = 5
    cfg["name"] = "Blunt Fin"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # 77 zero-volume tets of the collapsed wall rows
        bf = scene_from_config(cfg, p.parent)
    bf.camera = bf.camera.replace(width_px=width, height_px=height)
    mesh = load_mesh({"raw": {"path": str(root.parent / "shared" / "data" / "bucky.raw"), "dims": [32, 32, 32],
                              "dtype": "uint8", "spacing": [1, 1, 1]}, "split": 6})
    tf = TransferFunction([[0, 0.0, 0.0, 0.0, 0.0], [60, 0.2, 0.4, 1.0, 0.02], [120, 0.3, 1.0, 0.4, 0.08],
                           [200, 1.0, 0.8, 0.2, 0.3], [255, 1.0, 0.2, 0.1, 0.6]], "color_extinction")
    cam = Camera(eye=(62.0, 48.0, 70.0), target=(15.5, 15.5, 15.5), fov_y_deg=40.0, width_px=width, height_px=height)
    return [bf, Scene(mesh=mesh, transfer=tf, camera=cam, name="Bucky Ball")]


#: Table 5 rows a host sort rate is calibrated on (the others are predictions)
CALIBRATED_T5 = {("geforce4", "Blunt Fin", "MPVO"): "calibration (host cell_sort_rate)",
                 ("geforce4", "Blunt Fin", "numeric"): "calibration (host numeric_sort_rate)"}


def table5(scenes, *, res: int = 512, device="cpu", log=None) -> dict:
    """Table 5: frames per second with numeric (centroid), MPVO and XMPVO sorting, degree 2, per card:
    emulated on this CPU (the same emulated work for both cards) and modelled per card profile.
    ``scenes``: named scenes (``Blunt Fin``, ``Bucky Ball`` have paper rows)."""
    import time


    rows, size = [], ""
    for sc in scenes:
        size = f"{sc.camera.width_px}x{sc.camera.height_px}"
        for label, method in SORTS:
            times, results = {}, {}
            for card in ("geforce4", "radeon8500"):
                cfg = {"name": f"guthe2002_table5_{card}", "stages": [
                    {"stage": "vertex"}, {"stage": "sort", "method": method},
                    {"stage": "table_guthe", "n_s": res, "degree": 2, "alpha_format": "al16"},
                    {"stage": "pt_project"}, {"stage": "pt_guthe", "gpu": card, "format": "unorm8"}]}
                pipe = Pipeline.from_config(cfg, device=device)
                pipe.render(sc, quiet=True)  # compile, build the tables
                t0 = time.perf_counter()
                results[card] = pipe.render(sc, quiet=True)
                times[card] = time.perf_counter() - t0
            exact = (results["geforce4"].report.get("stats", {}).get("sort", {}) or {}).get("exact")
            for card in ("geforce4", "radeon8500"):
                paper = PAPER_T5[card].get(sc.name)
                paper = None if paper is None else paper[[mm for _, mm in SORTS].index(method)]
                fps = 1.0 / times[card]
                m = modelled_seconds(results[card].report, PROFILES[card])
                mfps = None if m is None else 1.0 / m
                role = "-" if paper is None else CALIBRATED_T5.get((card, sc.name, label), "prediction")
                rows.append([card, sc.name, int(sc.mesh.n_tets), label, paper, fps,
                             None if paper is None else fps / paper, mfps,
                             None if (mfps is None or paper is None) else mfps / paper, exact, role])
                if log:
                    log(f"  {card} {sc.name} {label}: {times[card]:.2f} s emulated, modelled {m} s")
    return table(f"Table 5: display times including visibility sorting, degree 2, {size}, 2D textures {res}^2: fps",
                 T5_COLUMNS, rows,
                 "Emulated: this CPU, the same emulated work for both cards. Modelled: warpvol.model on "
                 "geforce4_ti4600 / radeon8500; the host sorts are priced by algorithm, their rates calibrated on "
                 "the text's 'half of the time is spent by sorting' (GeForce4 Blunt Fin: MPVO's graph sort on the "
                 "MPVO row, the numeric sort on the numeric row); XMPVO adds its boundary-fragment sort. The texture "
                 "memory each triangle's lookups read (warpvol.reproduce.texcache) is priced by "
                 "scripts/validate_model.py, not in this table. " + calibrations("geforce4_ti4600", "radeon8500"))
