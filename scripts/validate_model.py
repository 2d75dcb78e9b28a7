"""Validate the throughput model (warpvol.model) against every paper timing the stages cover.

Two tables. **Absolute rows**, grouped by paper: the paper's figure, the modelled one, modelled / paper,
and the row's role -- ``prediction``, or ``calibration on ROW`` when a profile constant was fitted to
that row (its ratio is 1 by construction and never counts as agreement). **Relative rows**: method A
over method B on the same card and data (speed of A / speed of B), paper and modelled, and their ratio;
these test what the model says about the hardware rather than one fitted rate. A relative row agrees
when the modelled relation has the paper's sign (which method is faster) and modelled / paper is within
[0.5, 2].

Counters come from one redraw of each configuration at the paper's image size
(:mod:`warpvol.reproduce.model_rows`, cached under ``out/validate_model/counters``; ``--refresh``
re-renders, which takes a few minutes on two CPU cores); the table builds (Roettger Table 2, Guthe
Table 4) are counted in counting mode. Configurations whose data are absent are listed as skipped.

    .venv/bin/python scripts/validate_model.py [--refresh] [--json docs/data/validate_model.json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from warpvol.reproduce.guthe2002 import GUTHE_T4, guthe_steps_per_pass_speedup, guthe_t4_model
from warpvol.reproduce.roettger2002 import ROETTGER_T2, roettger_combiner_speedup, roettger_t2_model
from warpvol.reproduce.westermann1997 import PAPER as WESTERMANN

def _mid(lo: float, hi: float) -> float:
    return math.sqrt(lo * hi)


#: Espinha & Celes 2005 Tables 2/3, fps (min, max) on the GeForce 6800 GT at 512^2
ESPINHA = {"full": {"bluntfin": (6.09, 8.76), "loxpost": (3.40, 5.91)},
           "partial10": {"bluntfin": (3.50, 7.11), "loxpost": (2.32, 4.21)},
           "partial255": {"bluntfin": (2.98, 5.04), "loxpost": (1.22, 2.38)},
           "vicp": {"bluntfin": (1.26, 1.36), "loxpost": (0.46, 0.47)},
           "vicp_gpu": {"bluntfin": (3.09, 3.50), "loxpost": (0.98, 1.21)}}
ESPINHA_LABEL = {"full": "HARC full pre-integration", "partial10": "HARC partial, 10 TF segments",
                 "partial255": "HARC partial, 255 TF segments", "vicp": "VICP", "vicp_gpu": "VICP-GPU"}
#: Kraus et al. 2004 Table 1 (Blunt Fin 187,318 tets, 800x600, Quadro FX 3000): total seconds per configuration
KRAUS = {"i": 0.195, "ii": 0.243, "iii": 0.274, "iv": 0.314, "dither": 0.621, "fp16": 1.781}
KRAUS_LABEL = {"i": "basic pre-integrated PT (i)", "ii": "+ perspective interpolation (ii)",
               "iii": "+ HILO lookup textures (iii)", "iv": "+ logarithmic lookup (iv) = frame buffer total",
               "dither": "total with alpha dithering", "fp16": "total floating-point colour buffer (read-back)"}
#: Guthe et al. 2002 Table 5, fps: card -> data -> (numeric, MPVO, XMPVO)
GUTHE_T5 = {"geforce4": {"bluntfin": (3.18, 2.64, 2.35), "bucky": (2.46, 2.19, 2.05)},
            "radeon8500": {"bluntfin": (2.51, 2.20, 1.99), "bucky": (2.09, 1.98, 1.87)}}
GUTHE_PROFILE = {"geforce4": "geforce4_ti4600", "radeon8500": "radeon8500"}
SORTS = (("numeric", "centroid"), ("MPVO", "mpvo"), ("XMPVO", "xmpvo"))
#: Roettger & Ertl 2002 Fig. 8, fps (3D texture, 2D multi-texturing) at 512x384
ROETTGER_F8 = {"geforce3": (47.6, 79.0), "radeon8500": (33.8, 38.2), "octane_mxi": (8.5, 12.7)}
CARD = {"geforce3": "GeForce3", "radeon8500": "Radeon 8500", "octane_mxi": "Octane MXI",
        "geforce4": "GeForce4 Ti 4600", "geforce6800gt": "GeForce 6800 GT", "quadro_fx3000": "Quadro FX 3000"}
DATA = {"bluntfin": "Blunt Fin", "loxpost": "LOX Post", "bucky": "Bucky Ball"}


class Model:
    """Modelled seconds of cached configurations (``None`` with the reason when not modelled)."""

    def __init__(self, device: str, refresh: bool, cached_only: bool = False):
        self.device, self.refresh, self.cached_only = device, refresh, cached_only
        self.skipped: dict[str, str] = {}

    def counters(self, key: str) -> dict | None:
        from warpvol.reproduce.model_rows import CACHE, counters

        if self.cached_only and not (CACHE / (key.replace("/", "__") + ".json")).is_file():
            self.skipped[key] = "not in the counter cache (--cached-only)"
            return None
        try:
            return counters(key, self.device, self.refresh)
        except Exception as e:  # noqa: BLE001 - data absent or a stage failed: the rows are skipped
            self.skipped[key] = f"{type(e).__name__}: {e}"
            return None

    def seconds(self, c: dict | None, profile: str, skip=()) -> tuple[float | None, str]:
        from warpvol.model import check_caps, counter_needs, load_profile, model_counters

        if c is None:
            return None, "skipped (data or configuration unavailable)"
        p = load_profile(profile)
        total = 0.0
        for key, cc in c.items():
            if key.startswith(tuple(skip)):
                continue
            try:
                check_caps(p, key, counter_needs(cc))
            except Exception as e:  # noqa: BLE001 - a capability the card lacks
                return None, f"not modelled: {e}"
            r = model_counters(cc, p)
            if r["s"] is None:
                return None, f"not modelled: {key}: {', '.join(r['unmodelled'])}"
            total += r["s"]
        return total, ""


def absolute_rows(m: Model) -> list[dict]:
    rows = []

    def row(paper, name, pv, mv, role, note=""):
        rows.append({"paper": paper, "row": name, "paper_value": pv, "modelled": mv,
                     "ratio": None if pv is None or mv is None else mv / pv, "role": role, "note": note})

    # Roettger & Ertl 2002 Table 2 and §3 (table builds, counting mode)
    for N in (64, 128, 256):
        t = roettger_t2_model(N, m.device)
        psw, phw, pspd = ROETTGER_T2[N]
        row("Roettger 2002", f"T2 software {N}x{N}x{N // 2} [s] (R10K)", psw, t["sw"],
            "calibration on this row" if N == 64 else "prediction")
        row("Roettger 2002", f"T2 hardware {N}x{N}x{N // 2} [s] (Octane MXI)", phw, t["hw"],
            "calibration on this row" if N == 64 else "prediction")
    row("Roettger 2002", "§3 GeForce3: 4 combiner steps vs single texturing [x]", 2.0,
        roettger_combiner_speedup(256, m.device), "prediction", "the text's 'approximately twice as fast'")
    # Roettger & Ertl 2002 Fig. 8 (rendering, host sort left out: the paper's are rasterisation rates)
    fig8, fragments = {}, None
    for prof, (p3, p2) in ROETTGER_F8.items():
        for kind, pv in (("3d", p3), ("2d", p2)):
            cfg = "2d_sgi" if (kind, prof) == ("2d", "octane_mxi") else kind  # single texture, nearest
            c = m.counters(f"roettger/sphere/{cfg}")
            if c and kind == "3d":
                fragments = c["pt_table3d"]["fragments"]
            s, why = m.seconds(c, prof, skip=("sort",))
            row("Roettger 2002", f"Fig. 8 {CARD[prof]} {'3D texture' if kind == '3d' else '2D planes'} [fps]", pv,
                None if s is None else 1.0 / s, "prediction" if s else "-", why or "our view of the sphere, 512x384")
            fig8[(prof, kind)] = rows[-1]
    roettger_f8_notes(fig8, fragments)
    # Guthe et al. 2002 §4, Table 4 (builds, counting mode), Table 5 (rendering)
    row("Guthe 2002", "§4 Radeon 8500: 4 vs 1 steps per pass [x]", 2.0, guthe_steps_per_pass_speedup(m.device),
        "calibration on this row", "pass_overhead_s of radeon8500 ('a speedup of nearly two')")
    for deg in (1, 2, 4):
        psw, phw = GUTHE_T4[deg]
        row("Guthe 2002", f"T4 Radeon 8500 set-up n = {deg} [s]", phw, guthe_t4_model(deg, m.device),
            "calibration on this row" if deg == 1 else "prediction")
    for card, per in GUTHE_T5.items():
        for data, fps in per.items():
            base = m.counters(f"guthe/{data}/{card}")
            for (label, method), pv in zip(SORTS, fps):
                sc = m.counters(f"guthe/{data}/sort_{method}")
                c = None if base is None or sc is None else {**base, "sort": sc["sort"]}
                s, why = m.seconds(c, GUTHE_PROFILE[card])
                cal = card == "geforce4" and data == "bluntfin" and method in ("mpvo", "centroid")
                rate = "cell_sort_rate (MPVO)" if method == "mpvo" else "numeric_sort_rate"
                row("Guthe 2002", f"T5 {CARD[card]} {DATA[data]} {label} [fps]", pv, None if s is None else 1.0 / s,
                    "calibration on this row" if cal else ("prediction" if s else "-"),
                    why or (f"host {rate}: 'half of the time is spent by sorting'" if cal else ""))
    # Kraus et al. 2004 Table 1
    for k, pv in KRAUS.items():
        s, why = m.seconds(m.counters(f"kraus/bluntfin/{k}"), "quadro_fx3000")
        row("Kraus 2004", f"T1 {KRAUS_LABEL[k]} [s]", pv, s, "prediction" if s else "-",
            why or (kraus_dither_note() if k == "dither" else ""))
    # Westermann & Ertl 1997 Table 1
    for data, pname in (("bluntfin", "bluntfin"), ("fe", "fedata")):
        c = m.counters(f"westermann/{data}")
        _, _, gr, it, _ = WESTERMANN[pname]
        what = "Blunt Fin" if data == "bluntfin" else "fedata (FE-like stand-in mesh)"
        r, note = None, ""
        if c is not None:
            from warpvol.model import load_profile, model_counters

            prof = load_profile("indigo2_impact")
            r = model_counters(c["vsb_sweep"], prof)
            drawn, paper_drawn = c["vsb_sweep"].get("drawn_cells", 0), WESTERMANN[pname][1]
            if drawn:  # the geometry work scales with the drawn tets; read-backs and clears do not
                f = paper_drawn / drawn
                at = model_counters({k: (round(v * f) if k in ("vertices", "primitives", "fragments",
                                                                "writes_rgb8") else v)
                                     for k, v in c["vsb_sweep"].items()}, prof)["gpu_s"]
                note = (f"the sweep draws {drawn / 1e6:.2f} M tets, the paper {paper_drawn / 1e6:.2f} M (Table 1); "
                        f"at the paper's count {at:.1f} s (ratio {at / gr:.2f})")
        row("Westermann 1997", f"T1 {what} GrOps [s] (Indigo2 IMPACT)", gr, r and r["gpu_s"],
            "prediction" if r else "-", note)
        row("Westermann 1997", f"T1 {what} Int [s] (R4400)", it, r and r["host_s"],
            "calibration on this row" if data == "bluntfin" else ("prediction" if r else "-"))
    # Espinha & Celes 2005 Tables 2/3
    for kind, per in ESPINHA.items():
        for data, (lo, hi) in per.items():
            s = espinha_seconds(m, data, kind)
            cal = (kind, data) in (("full", "bluntfin"), ("vicp", "loxpost"))
            note = {"full": "loop_issue_rate of geforce6800gt", "vicp": "host cell_sort_rate of geforce6800gt"}
            row("Espinha 2005", f"T2/T3 {ESPINHA_LABEL[kind]} {DATA[data]} [fps]", _mid(lo, hi),
                None if s is None else 1.0 / s, "calibration on this row" if cal else "prediction",
                note[kind] if cal else "our viewpoint (the paper's are not given); paper: geometric mean of min-max")
    return rows


def roettger_f8_notes(fig8: dict, fragments: int | None) -> None:
    """Notes on Fig. 8's Radeon 8500 and Octane MXI rows (``fig8``: (profile, "3d" / "2d") -> row) from the
    paper's own figures: the Radeon 8500 against the GeForce3 in the same figure (vendor figures have it
    faster, the paper slower), and the lookup rate the Octane's 3D row implies for the ``fragments`` our
    view draws (None: not counted, no note)."""
    from warpvol.model import load_profile

    gp, rp = load_profile("geforce3"), load_profile("radeon8500")
    spec = ", ".join(f"{rp.rate(k) / gp.rate(k):.2f}x its {what}" for k, what in
                     (("pixel_fill", "fill rate"), ("tex_2d_linear", "bilinear texel rate"),
                      ("memory_bandwidth", "memory bandwidth")))
    for kind in ("3d", "2d"):
        gf, ra = fig8.get(("geforce3", kind)), fig8.get(("radeon8500", kind))
        if gf and ra and gf["modelled"] and ra["modelled"]:
            ra["note"] += (f"; paper: {ra['paper_value'] / gf['paper_value']:.2f}x the GeForce3's fps, modelled "
                           f"{ra['modelled'] / gf['modelled']:.2f}x (profiles: {spec})")
    oc = fig8.get(("octane_mxi", "3d"))
    if fragments and oc and oc["modelled"]:
        oc["note"] += (f"; both paths blend-bound at the Table 2 blend rate; the paper's 3D rate is "
                       f"{oc['paper_value'] * fragments / 1e6:.1f} M trilinear lookups/s for our "
                       f"{fragments / 1e6:.2f} M fragments (no source gives the texture memory's rate)")


def kraus_dither_note() -> str:
    """What the paper's own increments in Table 1 give for alpha dithering's ten instructions and two fetches
    (Kraus et al. 2004 §5): per instruction from (ii) (eleven) and (iv) (seven), per fetch from (iii) (one
    more 3D fetch)."""
    per_op = sorted(((KRAUS["ii"] - KRAUS["i"]) / 11, (KRAUS["iv"] - KRAUS["iii"]) / 7))
    fetch = KRAUS["iii"] - KRAUS["ii"]
    lo, hi = (10 * k + 2 * fetch for k in per_op)
    return (f"the paper's own increments ((ii) 11 instructions, (iv) 7, (iii) one fetch) give dithering's 10 "
            f"instructions and 2 fetches {lo:+.3f} to {hi:+.3f} s; the paper has {KRAUS['dither'] - KRAUS['iv']:+.3f} s")


def espinha_seconds(m: Model, data: str, kind: str) -> float | None:
    c = m.counters(f"espinha/{data}/{'vicp' if kind.startswith('vicp') else kind}")
    if c is None:
        return None
    if kind == "vicp_gpu":  # VICP-GPU: the cell data resident on the card (no per-frame upload)
        c = {k: ({kk: vv for kk, vv in v.items() if kk != "bytes_up"} if k == "vicp" else v) for k, v in c.items()}
    return m.seconds(c, "geforce6800gt")[0]


def relative_rows(m: Model, absolute: list[dict]) -> list[dict]:
    """Speed of A over speed of B (= time B / time A) on one card and data set, paper and modelled."""
    fps = {(r["paper"], r["row"]): (r["paper_value"], r["modelled"]) for r in absolute}
    rows = []

    def rel(paper, what, card, data, a_key, b_key, time_rows=False, note=""):
        pa, ma = fps[(paper, a_key)]
        pb, mb = fps[(paper, b_key)]
        if time_rows:  # seconds: speed ratio = time B / time A
            p_rel = None if None in (pa, pb) else pb / pa
            m_rel = None if None in (ma, mb) else mb / ma
        else:
            p_rel = None if None in (pa, pb) else pa / pb
            m_rel = None if None in (ma, mb) else ma / mb
        ok = None
        if p_rel is not None and m_rel is not None:
            ok = ((p_rel > 1) == (m_rel > 1)) and 0.5 <= m_rel / p_rel <= 2.0
        rows.append({"paper": paper, "row": what, "card": card, "data": data, "paper_rel": p_rel, "modelled_rel": m_rel,
                     "ratio": None if ok is None else m_rel / p_rel, "agrees": ok, "note": note})

    E = "Espinha 2005"
    for data in ("bluntfin", "loxpost"):
        f = f"T2/T3 {ESPINHA_LABEL['full']} {DATA[data]} [fps]"
        for k in ("partial10", "partial255", "vicp"):
            rel(E, f"{ESPINHA_LABEL[k]} over full pre-integration", CARD["geforce6800gt"], DATA[data],
                f"T2/T3 {ESPINHA_LABEL[k]} {DATA[data]} [fps]", f)
        rel(E, "VICP-GPU over VICP", CARD["geforce6800gt"], DATA[data],
            f"T2/T3 VICP-GPU {DATA[data]} [fps]", f"T2/T3 VICP {DATA[data]} [fps]")
        # the iso-surface sub-steps: a TF of 255 segments splits rays at 255 control points, 10 segments at 10
        rel(E, "HARC partial, 255 over 10 TF segments", CARD["geforce6800gt"], DATA[data],
            f"T2/T3 {ESPINHA_LABEL['partial255']} {DATA[data]} [fps]",
            f"T2/T3 {ESPINHA_LABEL['partial10']} {DATA[data]} [fps]")
    rel(E, "HARC full pre-integration, LOX Post over Blunt Fin", CARD["geforce6800gt"], "both",
        f"T2/T3 {ESPINHA_LABEL['full']} LOX Post [fps]", f"T2/T3 {ESPINHA_LABEL['full']} Blunt Fin [fps]",
        note=espinha_view_note(m))
    K = "Kraus 2004"
    keys = {k: f"T1 {v} [s]" for k, v in KRAUS_LABEL.items()}
    for a, b, what in (("ii", "i", "perspective interpolation (ii): (i) over (i)+(ii)"),
                       ("iii", "ii", "HILO table cost (iii): without over with"),
                       ("iv", "iii", "logarithmic axis (iv): without over with"),
                       ("dither", "iv", "alpha dithering: without over with"),
                       ("fp16", "iv", "fp16 read-back buffer: 8-bit over fp16")):
        # speed of the configuration without the enhancement over the one with it (>1: the enhancement costs)
        rel(K, what, CARD["quadro_fx3000"], "Blunt Fin", keys[b], keys[a], time_rows=True,
            note=overhead_note(fps[(K, keys[a])], fps[(K, keys[b])]))
    R = "Roettger 2002"
    for prof in ROETTGER_F8:
        rel(R, "Fig. 8: 2D planes over 3D texture", CARD[prof], "sphere (2,560 tets)",
            f"Fig. 8 {CARD[prof]} 2D planes [fps]", f"Fig. 8 {CARD[prof]} 3D texture [fps]")
    G = "Guthe 2002"
    for card in GUTHE_T5:
        rel(G, "T5 Blunt Fin over Bucky Ball (numeric)", CARD[card], "both",
            f"T5 {CARD[card]} Blunt Fin numeric [fps]", f"T5 {CARD[card]} Bucky Ball numeric [fps]")
        for data in ("bluntfin", "bucky"):
            for (la, _), (lb, _) in ((SORTS[0], SORTS[1]), (SORTS[1], SORTS[2])):
                rel(G, f"T5 {la} over {lb}", CARD[card], DATA[data], f"T5 {CARD[card]} {DATA[data]} {la} [fps]",
                    f"T5 {CARD[card]} {DATA[data]} {lb} [fps]")
    return rows


def espinha_view_note(m: Model) -> str:
    """How many cells our two views walk, against what the paper's frame rates imply (the paper gives no
    viewpoints): the one input the LOX Post rows rest on that no paper number fixes."""
    c = {d: m.counters(f"espinha/{d}/full") for d in ("bluntfin", "loxpost")}
    if None in c.values():
        return ""
    steps = {d: sum(v.get("cell_steps", 0) for v in cc.values()) for d, cc in c.items()}
    (bl, bh), (ll, lh) = ESPINHA["full"]["bluntfin"], ESPINHA["full"]["loxpost"]
    return (f"cells walked: our LOX view {steps['loxpost'] / steps['bluntfin']:.2f}x our Blunt Fin view; the paper's "
            f"fps imply {_mid(bl, bh) / _mid(ll, lh):.2f}x at equal cost per cell (viewpoints not given)")


def overhead_note(with_, without) -> str:
    (pa, ma), (pb, mb) = with_, without
    if None in (pa, ma, pb, mb):
        return ""
    return f"overhead paper {pa - pb:+.3f} s, modelled {ma - mb:+.3f} s"


def _f(v, nd=4):
    return "-" if v is None else f"{v:.{nd}g}"


def _r(v) -> str:
    return "-" if v is None else f"{v:.2f}"


def print_tables(absolute: list[dict], relative: list[dict]) -> None:
    print(f"{'paper':<16} {'row':<58} {'paper':>8} {'modelled':>9} {'ratio':>6}  role")
    last = None
    for r in absolute:
        if r["paper"] != last:
            print()
            last = r["paper"]
        print(f"{r['paper']:<16} {r['row']:<58} {_f(r['paper_value']):>8} {_f(r['modelled']):>9} "
              f"{_r(r['ratio']):>6}"
              f"  {r['role']}{'; ' + r['note'] if r['note'] else ''}")
    print(f"\nRelative rows (speed of A over speed of B, same card and data):\n{'paper':<16} {'row':<52} "
          f"{'card':<16} {'data':<12} {'paper':>6} {'model':>6} {'ratio':>6}  agrees")
    for r in relative:
        print(f"{r['paper']:<16} {r['row']:<52} {r['card']:<16} {r['data']:<12} {_f(r['paper_rel'], 3):>6} "
              f"{_f(r['modelled_rel'], 3):>6} {_r(r['ratio']):>6}"
              f"  {'-' if r['agrees'] is None else ('yes' if r['agrees'] else 'NO')}{'; ' + r['note'] if r['note'] else ''}")
    pred = [r for r in absolute if r["role"] == "prediction" and r["ratio"] is not None]
    inside = [r for r in pred if 0.5 <= r["ratio"] <= 2.0]
    agree = [r for r in relative if r["agrees"]]
    print(f"\nAbsolute predictions within [0.5, 2]: {len(inside)} of {len(pred)} "
          f"({sum(r['role'].startswith('calibration') for r in absolute)} calibration rows not counted). "
          f"Relative rows with the paper's sign and ratio in [0.5, 2]: {len(agree)} of "
          f"{sum(r['agrees'] is not None for r in relative)}.")


def to_json(absolute: list[dict], relative: list[dict], skipped: dict) -> dict:
    notes_abs = ("ratio = modelled / paper. 'calibration on this row': a profile constant was fitted to it (the "
                 "profile file names the row), so its ratio is 1 by construction and is not counted as agreement. "
                 "Every profile number's source is in warpvol/profiles/*.toml.")
    notes_rel = ("speed of A over speed of B on the same card and data (>1: A faster); ratio = modelled / paper; "
                 "agrees: the paper's sign and ratio within [0.5, 2].")
    if skipped:
        notes_abs += " Skipped: " + "; ".join(f"{k} ({v})" for k, v in skipped.items())
    def tables(absolute, relative, what=""):
        return {"rows": {"title": f"Throughput model: absolute rows{what}",
                         "columns": ["paper", "row", "paper value", "modelled", "ratio", "role", "note"],
                         "rows": [[r["paper"], r["row"], r["paper_value"], r["modelled"], r["ratio"], r["role"],
                                   r["note"]] for r in absolute], "notes": notes_abs},
                "relative": {"title": f"Throughput model: relative rows (method A over method B){what}",
                             "columns": ["paper", "row", "card", "data", "paper", "modelled", "ratio", "agrees",
                                         "note"],
                             "rows": [[r["paper"], r["row"], r["card"], r["data"], r["paper_rel"], r["modelled_rel"],
                                       r["ratio"], r["agrees"], r["note"]] for r in relative], "notes": notes_rel}}

    out = tables(absolute, relative)
    for paper in dict.fromkeys(r["paper"] for r in absolute):  # each paper's page shows its own rows
        slug = paper.split()[0].lower() + paper.split()[-1]
        per = tables([r for r in absolute if r["paper"] == paper], [r for r in relative if r["paper"] == paper],
                     f", {paper}")
        out[f"rows_{slug}"], out[f"relative_{slug}"] = per["rows"], per["relative"]
    return {"source": "python scripts/validate_model.py --json docs/data/validate_model.json", "tables": out}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--refresh", action="store_true", help="re-render every configuration (minutes)")
    ap.add_argument("--cached-only", action="store_true", help="skip configurations not yet counted (no renders)")
    ap.add_argument("--json", metavar="PATH", help="write both tables as JSON (docs/hooks.py renders it)")
    a = ap.parse_args(argv)
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    m = Model(a.device, a.refresh, a.cached_only)
    absolute = absolute_rows(m)
    relative = relative_rows(m, absolute)
    print_tables(absolute, relative)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(to_json(absolute, relative, m.skipped), f, indent=1)
        print(f"wrote {a.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
