"""Espinha & Celes 2005, hardware-assisted ray casting (paper figures, transfer functions, views, modelled
times); the command line is ``scripts/reproduce_espinha2005.py``."""

from __future__ import annotations

import numpy as np

from warpvol.io import write_png
from warpvol.metrics import image_error
from warpvol.model import load_profile, model_report
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.reproduce.common import calibrations, table
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.scene_file import load_scene
from warpvol.scene.transfer import TransferFunction


def resampled_tf(tf, segments: int):
    """The TF sampled at ``segments + 1`` uniformly spaced control points over its range (piecewise
    linear with ``segments`` segments, as the paper approximates its TFs)."""

    lo, hi = tf.srange
    s = np.linspace(lo, hi, segments + 1)
    return TransferFunction.from_table(tf.evaluate(s), (lo, hi), emission=tf.emission)


# -- Tables 2 and 3, Fig. 8 ---------------------------------------------------------------------------
PROFILE = "geforce6800gt"
#: the paper's Tables 2 and 3 (GeForce 6800 GT, 512x512): (min, max) tets/s
PAPER = {
    "bluntfin": {"VICP": (283e3, 306e3), "HARC-Full": (1.37e6, 1.97e6), "HARC-Partial-10": (787e3, 1.60e6),
                 "HARC-Partial-255": (670e3, 1.13e6)},
    "loxpost": {"VICP": (283e3, 290e3), "HARC-Full": (2.09e6, 3.64e6), "HARC-Partial-10": (1.43e6, 2.59e6),
                "HARC-Partial-255": (752e3, 1.47e6)},
}
METHODS = (("VICP", "weiler2003_vicp", None), ("HARC-Full", "espinha2005_full", None),
           ("HARC-Partial-10", "espinha2005_partial", 10), ("HARC-Partial-255", "espinha2005_partial", 255))
#: Table 2: ((min fps, max fps), (min tets/s, max tets/s)), GeForce 6800 GT, 512x512
VICP_PAPER = {
    "bluntfin": {"VICP": ((1.26, 1.36), (283e3, 306e3)), "VICP-GPU": ((3.09, 3.50), (695e3, 787e3))},
    "loxpost": {"VICP": ((0.46, 0.47), (283e3, 290e3)), "VICP-GPU": ((0.98, 1.21), (604e3, 745e3))},
}
#: rows the GeForce 6800 GT profile is calibrated on (its host cell_sort_rate on VICP Oxygen, its
#: cell_step_rate on HARC Blunt Fin): shown, never compared
CALIBRATION_ROWS = {("loxpost", "VICP"), ("bluntfin", "HARC-Full")}

T2_COLUMNS = ["data set", "method", "role", "emulated tets/s", "modelled fps", "modelled tets/s", "paper fps",
              "paper tets/s", "modelled / paper (tets/s)"]
T3_COLUMNS = ["data set", "method", "role", "emulated tets/s", "emulated rel", "modelled tets/s", "modelled rel",
              "paper tets/s", "paper rel", "modelled / paper (tets/s)"]
F8_COLUMNS = ["preset", "RMSE", "max abs"]


def views(camera, n: int):
    """``n`` cameras turned about the target around the up vector (the first is the scene's)."""
    eye, tgt, up = (np.asarray(x, float) for x in (camera.eye, camera.target, camera.true_up))
    r = eye - tgt
    out = []
    for k in range(n):
        a = 2 * np.pi * k / n
        par = up * (r @ up)
        perp = r - par
        rot = perp * np.cos(a) + np.cross(up, perp) * np.sin(a) + par
        out.append(camera.replace(eye=tuple(tgt + rot)))
    return out


def paper_scene(name: str, size: int):
    """``scenes/NAME.toml`` at ``size`` x ``size``."""
    import dataclasses
    from pathlib import Path


    sc = load_scene(Path(__file__).resolve().parents[2] / "scenes" / f"{name}.toml")
    return dataclasses.replace(sc, camera=sc.camera.replace(width_px=size, height_px=size))


def _span(v, scale=None, unit=None):
    if scale is None:
        scale, unit = (1e6, "M") if v and max(v) >= 1e6 else (1e3, "K")
    return f"{min(v) / scale:.1f}{unit}-{max(v) / scale:.1f}{unit}" if v else "-"


def method_runs(scenes: dict, n_views: int = 3, *, methods=METHODS, device="cpu", log=None) -> dict:
    """Each method on each scene from ``n_views`` viewpoints: emulated seconds (a redraw after a
    warm-up render that builds tables, per-mesh textures and sort structures) and the redraw's
    counters modelled on the GeForce 6800 GT profile. ``scenes``: name -> scene."""
    import dataclasses
    import time


    profile = load_profile(PROFILE)
    result = {}
    for name, sc in scenes.items():
        m = sc.mesh.n_tets
        rows = {}
        for label, preset, seg in methods:
            tf = sc.transfer if seg is None else resampled_tf(sc.transfer, seg)
            pipe = Pipeline.load(preset, device=device)
            runs = []
            for k, cam in enumerate(views(sc.camera, n_views)):
                s = dataclasses.replace(sc, transfer=tf, camera=cam)
                pipe.render(s, quiet=True)
                t0 = time.perf_counter()
                res = pipe.render(s, quiet=True)
                dt = time.perf_counter() - t0
                mr = model_report(res.report["counters"], profile)
                ms = mr["total"]
                runs.append({"view": k, "seconds": dt, "tets_per_s": m / dt, "modelled_s": ms,
                             "modelled_tets_per_s": None if ms is None else m / ms, "unmodelled": mr["unmodelled"],
                             "counters": res.report.get("counters"),
                             "stats": {key: res.report["stats"].get(key) for key in
                                       ("harc", "harc_peel", "harc_raster", "harc_mesh", "sort", "pt")}})
                if log:
                    log(f"  {name} {label} view {k}: {dt:.2f} s emulated, modelled {ms} s")
            rows[label] = runs
        result[name] = {"tets": m, "rows": rows}
    return result


def vicp_runs(scenes: dict, n_views: int = 3, *, device="cpu", log=None) -> dict:
    """Modelled VICP (cell data sent each frame) and VICP-GPU (the same counters without that upload:
    stage ``vicp`` with ``geometry = "resident"`` counts no ``bytes_up``) per viewpoint, from a redraw
    of ``weiler2003_vicp`` (the table already built)."""
    import dataclasses


    profile = load_profile(PROFILE)
    out = {}
    for name, sc in scenes.items():
        m = sc.mesh.n_tets
        pipe = Pipeline.load("weiler2003_vicp", device=device)
        pipe.render(sc, quiet=True)  # builds the table; the per-mesh cell constants are made resident
        runs = []
        for k, cam in enumerate(views(sc.camera, n_views)):
            res = pipe.render(dataclasses.replace(sc, camera=cam), quiet=True, gpu=PROFILE)
            c = res.report["counters"]
            up = model_report(c, profile)
            gpu_c = {key: ({kk: vv for kk, vv in v.items() if kk != "bytes_up"} if key == "vicp" else v)
                     for key, v in c.items()}
            resident = model_report(gpu_c, profile)
            runs.append({"view": k, "tets": m, "VICP": up["total"], "VICP-GPU": resident["total"],
                         "stages": up["stages"], "fragments": c["vicp"]["fragments"],
                         "exit_unresolved": res.report["stats"]["vicp"]["exit_unresolved"]})
            if log:
                log(f"  {name} view {k}: VICP {up['total']:.3f} s, VICP-GPU {resident['total']:.3f} s modelled")
        out[name] = runs
    return out


def _role(name, method):
    if (name, method) in CALIBRATION_ROWS:
        return "calibration"
    return "prediction" if PAPER.get(name, {}).get(method) or VICP_PAPER.get(name, {}).get(method) else "-"


def table2(runs: dict, vicp: dict, size: int = 512) -> dict:
    """Table 2: VICP, VICP-GPU (modelled) and HARC-Full per data set, min-max over the viewpoints."""

    rows = []
    for name in runs.keys() | vicp.keys():
        emul = {lab: [x["tets_per_s"] for x in r] for lab, r in runs.get(name, {}).get("rows", {}).items()}
        for method in ("VICP", "VICP-GPU", "HARC-Full"):
            if method == "HARC-Full":
                rr = runs.get(name, {}).get("rows", {}).get(method, [])
                tps = [x["modelled_tets_per_s"] for x in rr if x["modelled_tets_per_s"]]
                fps = [1.0 / x["modelled_s"] for x in rr if x["modelled_s"]]
                p = PAPER.get(name, {}).get(method)
                paper = (None, p) if p else None
            else:
                vr = [r for r in vicp.get(name, []) if r[method]]
                tps = [r["tets"] / r[method] for r in vr]
                fps = [1.0 / r[method] for r in vr]
                paper = VICP_PAPER.get(name, {}).get(method)
            if not tps and not emul.get(method):
                continue
            role = _role(name, method)
            ratio = "-" if not paper or not tps or role == "calibration" else \
                f"{min(tps) / paper[1][0]:.2f}-{max(tps) / paper[1][1]:.2f}"
            rows.append([name, method, role, _span(emul.get(method, [])),
                         f"{min(fps):.2f}-{max(fps):.2f}" if fps else "-", _span(tps),
                         f"{paper[0][0]:.2f}-{paper[0][1]:.2f}" if paper and paper[0] else "-",
                         _span(list(paper[1])) if paper else "-", ratio])
    rows.sort(key=lambda r: (r[0], ("VICP", "VICP-GPU", "HARC-Full").index(r[1])))
    return table(f"Table 2 at {size}x{size}: VICP against HARC, min-max over viewpoints",
                 T2_COLUMNS, rows,
                 "Emulated: tets / wall time of the CPU emulation on this machine. Modelled: the redraw's counters on "
                 f"the {PROFILE} profile (warpvol.model). VICP-GPU: the VICP counters without the per-frame cell "
                 "upload. Rows marked calibration are where the profile's constants were fitted and are not "
                 "compared. " + calibrations(PROFILE))


def table3(runs: dict, size: int = 512) -> dict:
    """Table 3: HARC with full and with partial pre-integration (TF of 10 and 255 segments), speeds
    relative to HARC-Full, min-max over the viewpoints."""

    rows = []
    for name, r in runs.items():
        if "HARC-Full" not in r["rows"]:
            continue
        full = [x["tets_per_s"] for x in r["rows"]["HARC-Full"]]
        mfull = [x["modelled_tets_per_s"] for x in r["rows"]["HARC-Full"] if x["modelled_tets_per_s"]]
        pf = PAPER.get(name, {}).get("HARC-Full")
        for label, rr in r["rows"].items():
            if not label.startswith("HARC"):
                continue
            t = [x["tets_per_s"] for x in rr]
            mt = [x["modelled_tets_per_s"] for x in rr if x["modelled_tets_per_s"]]
            p = PAPER.get(name, {}).get(label)
            role = _role(name, label)
            rows.append([name, label, role, _span(t), f"{min(t) / min(full):.2f}-{max(t) / max(full):.2f}",
                         _span(mt, 1e6, "M") if mt else "unmodelled",
                         f"{min(mt) / min(mfull):.2f}-{max(mt) / max(mfull):.2f}" if mt and mfull else "-",
                         _span(list(p), 1e6, "M") if p else "-",
                         f"{p[0] / pf[0]:.2f}-{p[1] / pf[1]:.2f}" if p and pf else "-",
                         f"{min(mt) / p[0]:.2f}-{max(mt) / p[1]:.2f}" if p and mt and role != "calibration" else "-"])
    return table(f"Table 3 at {size}x{size}: HARC with full and partial pre-integration, min-max over viewpoints",
                 T3_COLUMNS, rows,
                 "rel = speed / HARC-Full. Emulated: the CPU emulation's wall time on this machine. Modelled: "
                 f"the {PROFILE} profile: each pass's fragment-program loop priced per issue slot from its "
                 "instruction listing (warpvol.gpu.programs: the shared plane walk, + one 3D lookup and 4 "
                 "instructions for the full table, + the TF, psi and iso lookups and 37 instructions per partial "
                 "sub-step; a TF of N segments splits rays at all its N - 1 inner control points), each 32 x 32 "
                 "pixel batch running in lock-step until its longest ray is done, so modelled partial/full ratios "
                 "follow the instructions and fetches issued. "
                 + calibrations(PROFILE))


def fig8(size: int = 256, *, out=None, device="cpu") -> dict:
    """Fig. 8: full vs partial pre-integration (and harc_best) on the built-in ``stiff`` mesh, whose
    cells differ in size by a factor ~6e4: RMSE and max |error| against the exact reference; images
    in ``out`` when given."""
    from pathlib import Path


    sc = builtin_scene("stiff").with_camera(width_px=size, height_px=size)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        write_png(out / "fig8_reference.png", ref)
    rows = []
    for preset in ("espinha2005_full", "espinha2005_partial", "harc_best"):
        img = Pipeline.load(preset, device=device).render(sc, quiet=True).image
        if out is not None:
            write_png(out / f"fig8_{preset}.png", img)
            write_png(out / f"fig8_{preset}_error.png", np.clip(np.abs(img - ref) * 10, 0, 1))
        e = image_error(img, ref)
        rows.append([preset, float(e["rmse"]), float(e["max_abs"])])
    return table(f"Fig. 8: built-in stiff mesh (longest / shortest edge {sc.mesh.edge_ratio:.3g}), {size}x{size}: "
                 "error against the exact reference", F8_COLUMNS, rows,
                 "No timing and no model: each preset's image against warpvol's exact float64 reference.")
