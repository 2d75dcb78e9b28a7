"""Validate the throughput model (warpvol.model) against every paper timing the stages cover.

Two tables. **Absolute rows**, grouped by paper: the paper's figure, the modelled one, modelled / paper,
and the row's role -- ``prediction``, or ``calibration on ROW`` when a profile constant was fitted to
that row (its ratio is near 1 by construction and never counts as agreement) or to ROW and makes most of
this row's time (VICP-GPU on the LOX Post: the host sort fitted to the VICP LOX Post row). The GeForce4
of Guthe et al. is modelled as the Ti 4600, an assumption its rows' names carry. **Relative rows**: method A
over method B on the same card and data (speed of A / speed of B), paper and modelled, and their ratio;
these test what the model says about the hardware rather than one fitted rate. A relative row agrees
when the modelled relation has the paper's sign (which method is faster) and modelled / paper is within
[0.5, 2]. Each relative row takes its role from its two absolute rows: ``prediction`` when both are
predictions (only these make the count), ``one calibration row`` when one of them was fitted (its ratio
is the predicted row's modelled / paper over the calibration row's, 1 only where the fit is exact;
counted apart), ``calibration only`` when both were (not a prediction, not counted). The counts, agree /
predicted by role, are printed and written to the JSON (table ``counts``), with how many independent
ratios the relative rows rest on (a relative ratio is its A row's over its B row's: at most the absolute
rows they use less the groups of rows they link; ``counts.independent``).
Rows whose agreement rests on one estimated constant (the texture-cache block edge of Roettger's Fig. 8,
Kraus' fp16 rebind time, VICP's host upload rate) carry the ratio at half and double that constant in
their notes, and so do the relative rows built on them.

Counters come from one redraw of each of 29 configurations at the paper's image size
(:mod:`warpvol.reproduce.model_rows`), cached under ``out/validate_model/counters`` and keyed by the code
that counts (:func:`warpvol.reproduce.model_rows.code_key`: a change to any counting module or preset
recounts, so a stale cache cannot hide it; ``--refresh`` recounts everything). What the cache lacks is
counted first, in this process, with a progress bar weighted by each configuration's last count time;
the script prints each count's time, and the JSON's ``cost`` table keeps what each count took (wall, CPU,
load) as recorded when it was counted. A fresh run (empty cache) takes tens of minutes on a 2-core
machine, most of it the four Guthe Table 5 renders at 1280x960: the shipped JSON's ``cost`` table (shown on
the performance page) gives what its run took, group by group, with the load. With every counter cached the run takes seconds. The table builds (Roettger Table 2, Guthe Table 4) are counted in counting mode on every run.
Configurations whose data are absent are listed as skipped.

    .venv/bin/python scripts/validate_model.py [--refresh] [--json docs/data/validate_model.json]
    .venv/bin/python scripts/validate_model.py --absolute-from docs/data/validate_model.json --json ...

``--absolute-from`` takes the absolute rows (values, roles, notes) from an earlier JSON instead of counting
them and rebuilds the relative rows and the counts from those rows alone (no renders): what the relative
rows and counts say follows from the absolute rows, which tests/test_model.py checks on the shipped JSON.
With ``--sensitivity`` it adds the sensitivity notes from the counter cache, for each row whose cached
counters give its own modelled value again.
"""

from __future__ import annotations

import argparse
import math
import sys

from warpvol.reproduce.agreement import (  # noqa: F401
    NOTES_ABS,
    REL_CAL_ONLY,
    REL_ONE_CAL,
    REL_PREDICTION,
    absolute_counts,
    absolute_from,
    count_lines,
    counts_table,
    independent_ratios,
    relative_counts,
    relative_role,
    sensitivity,
    to_json,
)
from warpvol.reproduce.agreement import fmt_ratio as _r
from warpvol.reproduce.guthe2002 import GUTHE_T4, guthe_steps_per_pass_speedup, guthe_t4_model
from warpvol.reproduce.roettger2002 import ROETTGER_T2, roettger_combiner_speedup, roettger_t2_model
from warpvol.reproduce.westermann1997 import PAPER as WESTERMANN
from warpvol.tools import provenance


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
#: Guthe et al. 2002 name their card "GeForce4" only; the profile models the Ti 4600 (the fastest GeForce4 of
#: 2002): an assumption, and the rows say so
GF4 = "GeForce4 (Ti 4600 assumed)"
#: Roettger & Ertl 2002 Fig. 8, fps (3D texture, 2D multi-texturing) at 512x384
ROETTGER_F8 = {"geforce3": (47.6, 79.0), "radeon8500": (33.8, 38.2), "octane_mxi": (8.5, 12.7)}
CARD = {"geforce3": "GeForce3", "radeon8500": "Radeon 8500", "octane_mxi": "Octane MXI",
        "geforce4": GF4, "geforce6800gt": "GeForce 6800 GT", "quadro_fx3000": "Quadro FX 3000"}
DATA = {"bluntfin": "Blunt Fin", "loxpost": "LOX Post", "bucky": "Bucky Ball"}


#: the counted configurations the tables use (warpvol.reproduce.model_rows.CONFIGS keys)
MODEL_KEYS = (*(f"roettger/sphere/{k}" for k in ("3d", "2d", "2d_sgi")),
              *(f"guthe/{d}/{x}" for d in ("bluntfin", "bucky")
                for x in ("geforce4", "radeon8500", "sort_centroid", "sort_mpvo", "sort_xmpvo")),
              *(f"kraus/bluntfin/{k}" for k in KRAUS), "westermann/bluntfin", "westermann/fe",
              *(f"espinha/{d}/{k}" for d in ("bluntfin", "loxpost") for k in ("full", "partial10", "partial255", "vicp")))


class Model:
    """Modelled seconds of cached configurations (``None`` with the reason when not modelled)."""

    def __init__(self, device: str, refresh: bool, cached_only: bool = False):
        self.device, self.refresh, self.cached_only = device, refresh, cached_only
        self.skipped: dict[str, str] = {}

    def counters(self, key: str) -> dict | None:
        from warpvol.reproduce.model_rows import counters, is_cached

        if self.cached_only and not is_cached(key):
            self.skipped[key] = "not in the counter cache (--cached-only)"
            return None
        try:
            return counters(key, self.device, self.refresh)
        except Exception as e:  # noqa: BLE001 - data absent or a stage failed: the rows are skipped
            self.skipped[key] = f"{type(e).__name__}: {e}"
            return None

    def seconds(self, c: dict | None, profile: str, skip=(), scale: dict | None = None) -> tuple[float | None, str]:
        """Modelled seconds of counters ``c`` on ``profile``; ``scale``: {(section, key): factor} multiplies
        those profile constants (the sensitivity notes)."""
        import copy

        from warpvol.model import check_caps, counter_needs, load_profile, model_counters

        if c is None:
            return None, "skipped (data or configuration unavailable)"
        p = load_profile(profile)
        if scale:
            p = copy.deepcopy(p)
            for (section, key), f in scale.items():
                getattr(p, section)[key]["value"] = float(getattr(p, section)[key]["value"]) * f
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

    def row(paper, name, pv, mv, role, note="", at=None):
        """``at``: (constant, modelled at half it, modelled at double it) where the row rests on one estimate."""
        rows.append({"paper": paper, "row": name, "paper_value": pv, "modelled": mv,
                     "ratio": None if pv is None or mv is None else mv / pv, "role": role, "note": note,
                     "at": None if at is None or mv is None else {"constant": at[0], "half": at[1], "double": at[2]}})

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
            key = f"roettger/sphere/{cfg}"
            c = m.counters(key)
            if c and kind == "3d":
                fragments = c["pt_table3d"]["fragments"]
            s, why = m.seconds(c, prof, skip=("sort",))
            at = fig8_at(m, key, c, prof) if s else None
            row("Roettger 2002", f"Fig. 8 {CARD[prof]} {'3D texture' if kind == '3d' else '2D planes'} [fps]", pv,
                None if s is None else 1.0 / s, "prediction" if s else "-", why or "our view of the sphere, 512x384",
                at)
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
        c = m.counters(f"kraus/bluntfin/{k}")
        s, why = m.seconds(c, "quadro_fx3000")
        at = kraus_fp16_at(m, c) if (k == "fp16" and s) else None
        row("Kraus 2004", f"T1 {KRAUS_LABEL[k]} [s]", pv, s, "prediction" if s else "-",
            why or (kraus_dither_note() if k == "dither" else ""), at)
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
            at = vicp_at(m, data) if (kind == "vicp" and s) else None
            role = "calibration on this row" if cal else "prediction"
            why = note[kind] if cal else "our viewpoint (the paper's are not given); paper: geometric mean of min-max"
            if kind == "vicp_gpu" and s:  # no upload: the host sort is most of its time
                share = 1.0 - espinha_seconds(m, data, kind, skip=("sort",)) / s
                why = (f"{share:.0%} of the modelled time is the host sort at cell_sort_rate, fitted to the VICP LOX "
                       f"Post row; {why}")
                if data == "loxpost":  # the same cells at the fitted rate: the fit again, not a prediction
                    role = f"calibration on {VICP_LOX}"
            row("Espinha 2005", f"T2/T3 {ESPINHA_LABEL[kind]} {DATA[data]} [fps]", _mid(lo, hi),
                None if s is None else 1.0 / s, role, why, at)
    for r in rows:  # last in the note: what the agreement rests on
        if r["at"]:
            r["note"] = "; ".join(x for x in (r["note"], sensitivity(r["paper_value"], (r["at"]["half"],
                                                                                         r["at"]["double"]),
                                                                       r["at"]["constant"])) if x)
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


def espinha_seconds(m: Model, data: str, kind: str, scale: dict | None = None, skip=()) -> float | None:
    c = m.counters(f"espinha/{data}/{'vicp' if kind.startswith('vicp') else kind}")
    if c is None:
        return None
    if kind == "vicp_gpu":  # VICP-GPU: the cell data resident on the card (no per-frame upload)
        c = {k: ({kk: vv for kk, vv in v.items() if kk != "bytes_up"} if k == "vicp" else v) for k, v in c.items()}
    return m.seconds(c, "geforce6800gt", skip=skip, scale=scale)[0]


#: the row the geforce6800gt host's cell_sort_rate was fitted to (VICP-GPU on the same data rests on it)
VICP_LOX = "T2/T3 VICP LOX Post [fps]"


#: the estimated constants single agreements rest on (their rows show the ratio at half and double them)
FB_REBIND = "fb_rebind_s (10 us per fp16 buffer rebind, an estimate)"
UPLOAD = "host upload_rate (694 MB/s, derived from Kraus et al. 2004)"
BLOCK_EDGE = "texture-cache block edge (4 texels, an estimate: 2 and 8)"


def _inv(t: float | None) -> float | None:
    return None if t is None else 1.0 / t


def fig8_at(m: Model, key: str, c: dict, prof: str) -> tuple | None:
    """Roettger Fig. 8 on ``prof``: fps at block edges 2 and 8 (None where the profile does not price the
    cache term: no memory bandwidth)."""
    from warpvol.model import load_profile
    from warpvol.reproduce.model_rows import texcache_at
    from warpvol.reproduce.texcache import SENSITIVITY_BLOCKS

    if not load_profile(prof).rate("memory_bandwidth"):
        return None
    return (BLOCK_EDGE, *(_inv(m.seconds(texcache_at(key, c, b), prof, skip=("sort",))[0]) for b in SENSITIVITY_BLOCKS))


def kraus_fp16_at(m: Model, c: dict) -> tuple:
    """Kraus Table 1's fp16 read-back total (s) at half and double ``fb_rebind_s``."""
    return (FB_REBIND, *(m.seconds(c, "quadro_fx3000", scale={("rates", "fb_rebind_s"): f})[0] for f in (0.5, 2.0)))


def vicp_at(m: Model, data: str) -> tuple:
    """Espinha's VICP fps at half and double the host's ``upload_rate``."""
    return (UPLOAD, *(_inv(espinha_seconds(m, data, "vicp", scale={("host", "upload_rate"): f})) for f in (0.5, 2.0)))


def sensitivity_from_counters(m: Model, absolute: list[dict]) -> None:
    """Give the rows that rest on one estimated constant (``fig8_at``, ``kraus_fp16_at``, ``vicp_at``) their
    sensitivities from counted configurations, for rows taken from an earlier JSON (``--absolute-from``):
    only where the counters give the row's own modelled value (else the note says so)."""
    jobs = {f"Fig. 8 {CARD[p]} {'3D texture' if k == '3d' else '2D planes'} [fps]":
            (f"roettger/sphere/{k}", lambda c, p=p, k=k: fig8_at(m, f"roettger/sphere/{k}", c, p), p, 1)
            for p in ("geforce3", "radeon8500") for k in ("3d", "2d")}
    jobs[f"T1 {KRAUS_LABEL['fp16']} [s]"] = ("kraus/bluntfin/fp16", lambda c: kraus_fp16_at(m, c), "quadro_fx3000", 0)
    for d in ("bluntfin", "loxpost"):
        jobs[f"T2/T3 VICP {DATA[d]} [fps]"] = (f"espinha/{d}/vicp", lambda c, d=d: vicp_at(m, d), None, 1)
    for r in absolute:
        if r["row"] not in jobs or r["modelled"] is None:
            continue
        if "sensitivity: " in r["note"]:  # from a rerun on its own output: the note ends with it
            r["note"] = r["note"][:r["note"].index("sensitivity: ")].rstrip("; ")
        key, make, prof, inverse = jobs[r["row"]]
        c = m.counters(key)
        base = None
        if c is not None:
            base = (espinha_seconds(m, key.split("/")[1], "vicp") if prof is None
                    else m.seconds(c, prof, skip=("sort",) if key.startswith("roettger") else ())[0])
        base = _inv(base) if inverse else base
        if base is None or abs(base - r["modelled"]) > 1e-9 * abs(r["modelled"]):
            r["note"] = "; ".join(x for x in (r["note"], "sensitivity not computed: the counters at hand do not give "
                                              "this row's modelled value") if x)
            continue
        at = make(c)
        r["at"] = {"constant": at[0], "half": at[1], "double": at[2]}
        r["note"] = "; ".join(x for x in (r["note"], sensitivity(r["paper_value"], at[1:], at[0])) if x)


def relative_rows(m: Model | None, absolute: list[dict], view_note: str = "") -> list[dict]:
    """Speed of A over speed of B (= time B / time A), paper and modelled: two methods on one card and data
    set, one method on two data sets, two table sizes or two cards. Built from the absolute rows alone (their
    values and roles); ``m`` only adds the Espinha view note from the counters (None: ``view_note``)."""
    fps = {(r["paper"], r["row"]): r for r in absolute}
    rows = []

    def rel(paper, what, card, data, a_key, b_key, time_rows=False, note=""):
        ra, rb = fps.get((paper, a_key)), fps.get((paper, b_key))
        if ra is None or rb is None:  # a table without that paper's rows (tests build partial tables)
            return
        (pa, ma), (pb, mb) = (ra["paper_value"], ra["modelled"]), (rb["paper_value"], rb["modelled"])
        if time_rows:  # seconds: speed ratio = time B / time A
            pa, pb, ma, mb = pb, pa, mb, ma
        p_rel = None if None in (pa, pb) else pa / pb
        m_rel = None if None in (ma, mb) else ma / mb
        role = relative_role(ra["role"], rb["role"])
        ok = None
        if p_rel is not None and m_rel is not None and role is not None:
            ok = ((p_rel > 1) == (m_rel > 1)) and 0.5 <= m_rel / p_rel <= 2.0
        cal = [k for k, r in ((a_key, ra), (b_key, rb)) if r["role"].startswith("calibration")]
        if cal:
            note = "; ".join(x for x in (f"calibration: {', '.join(cal)}", note) if x)
        consts = {r["at"]["constant"] for r in (ra, rb) if r.get("at")}
        if len(consts) == 1 and ok is not None:  # the relation rests on one estimate: at half and double it
            const = consts.pop()
            alt = []
            for h in ("half", "double"):
                va, vb = ((r["at"][h] if r.get("at") and r["at"]["constant"] == const else r["modelled"])
                          for r in (ra, rb))
                alt.append(None if None in (va, vb) else (vb / va if time_rows else va / vb))
            note = "; ".join(x for x in (note, sensitivity(p_rel, alt, const)) if x)
        rows.append({"paper": paper, "row": what, "card": card, "data": data, "paper_rel": p_rel, "modelled_rel": m_rel,
                     "ratio": None if ok is None else m_rel / p_rel, "agrees": ok, "role": role or "-",
                     "note": note, "a": (paper, a_key), "b": (paper, b_key)})

    E, G6 = "Espinha 2005", CARD["geforce6800gt"]

    def esp(kind, data):
        return f"T2/T3 {ESPINHA_LABEL[kind]} {DATA[data]} [fps]"

    for data in ("bluntfin", "loxpost"):
        for k in ("partial10", "partial255", "vicp", "vicp_gpu"):
            rel(E, f"{ESPINHA_LABEL[k]} over full pre-integration", G6, DATA[data], esp(k, data), esp("full", data))
        rel(E, "VICP-GPU over VICP", G6, DATA[data], esp("vicp_gpu", data), esp("vicp", data))
        # the iso-surface sub-steps: a TF of 255 segments splits rays at 255 control points, 10 segments at 10
        rel(E, "HARC partial, 255 over 10 TF segments", G6, DATA[data], esp("partial255", data),
            esp("partial10", data))
    for k in ESPINHA:  # one method, the two data sets (the paper gives no viewpoints: see the note)
        rel(E, f"{ESPINHA_LABEL[k]}, LOX Post over Blunt Fin", G6, "both", esp(k, "loxpost"), esp(k, "bluntfin"),
            note=(espinha_view_note(m) if m is not None else view_note) if k == "full" else "")
    K = "Kraus 2004"
    keys = {k: f"T1 {v} [s]" for k, v in KRAUS_LABEL.items()}
    for a, b, what in (("ii", "i", "perspective interpolation (ii): (i) over (i)+(ii)"),
                       ("iii", "ii", "HILO table cost (iii): without over with"),
                       ("iv", "iii", "logarithmic axis (iv): without over with"),
                       ("dither", "iv", "alpha dithering: without over with"),
                       ("fp16", "iv", "fp16 read-back buffer: 8-bit over fp16")):
        # speed of the configuration without the enhancement over the one with it (>1: the enhancement costs)
        rel(K, what, CARD["quadro_fx3000"], "Blunt Fin", keys[b], keys[a], time_rows=True,
            note=overhead_note(*((fps.get((K, keys[x]), {}).get("paper_value"), fps.get((K, keys[x]), {}).get("modelled"))
                                 for x in (a, b))))
    R = "Roettger 2002"
    for N_a, N_b in ((64, 128), (128, 256)):  # Table 2: one build, two table sizes (time ratio)
        for kind, host in (("software", "R10K"), ("hardware", "Octane MXI")):
            rel(R, f"T2 {kind} build: {N_a}x{N_a}x{N_a // 2} over {N_b}x{N_b}x{N_b // 2}", host, "table build", f"T2 {kind} {N_a}x{N_a}x{N_a // 2} [s] ({host})",
                f"T2 {kind} {N_b}x{N_b}x{N_b // 2} [s] ({host})", time_rows=True)
    for N in (64, 128, 256):  # Table 2's speed-up column: hardware over software build
        rel(R, f"T2 hardware over software build, {N}x{N}x{N // 2}", "Octane MXI / R10K", "table build",
            f"T2 hardware {N}x{N}x{N // 2} [s] (Octane MXI)", f"T2 software {N}x{N}x{N // 2} [s] (R10K)",
            time_rows=True)
    for prof in ROETTGER_F8:
        rel(R, "Fig. 8: 2D planes over 3D texture", CARD[prof], "sphere (2,560 tets)",
            f"Fig. 8 {CARD[prof]} 2D planes [fps]", f"Fig. 8 {CARD[prof]} 3D texture [fps]")
    for prof in ("radeon8500", "octane_mxi"):  # one path, two cards of the same figure
        for kind in ("3D texture", "2D planes"):
            rel(R, f"Fig. 8 {kind}: {CARD[prof]} over GeForce3", f"{CARD[prof]} / GeForce3", "sphere (2,560 tets)",
                f"Fig. 8 {CARD[prof]} {kind} [fps]", f"Fig. 8 GeForce3 {kind} [fps]")
    G = "Guthe 2002"
    rel(G, "T4 set-up: n = 1 over n = 2", CARD["radeon8500"], "table build", "T4 Radeon 8500 set-up n = 1 [s]",
        "T4 Radeon 8500 set-up n = 2 [s]", time_rows=True)
    rel(G, "T4 set-up: n = 2 over n = 4", CARD["radeon8500"], "table build", "T4 Radeon 8500 set-up n = 2 [s]",
        "T4 Radeon 8500 set-up n = 4 [s]", time_rows=True)
    for card in GUTHE_T5:
        for la, _ in SORTS:
            rel(G, f"T5 Blunt Fin over Bucky Ball ({la})", CARD[card], "both",
                f"T5 {CARD[card]} Blunt Fin {la} [fps]", f"T5 {CARD[card]} Bucky Ball {la} [fps]")
        for data in ("bluntfin", "bucky"):
            for (la, _), (lb, _) in ((SORTS[0], SORTS[1]), (SORTS[1], SORTS[2])):
                rel(G, f"T5 {la} over {lb}", CARD[card], DATA[data], f"T5 {CARD[card]} {DATA[data]} {la} [fps]",
                    f"T5 {CARD[card]} {DATA[data]} {lb} [fps]")
    for data in ("bluntfin", "bucky"):  # one method and data set, the two cards
        for la, _ in SORTS:
            rel(G, f"T5 {la}: Radeon 8500 over GeForce4", f"Radeon 8500 / {GF4}", DATA[data],
                f"T5 Radeon 8500 {DATA[data]} {la} [fps]", f"T5 {GF4} {DATA[data]} {la} [fps]")
    W = "Westermann 1997"
    for data, what in (("bluntfin", "Blunt Fin"), ("fe", "fedata (FE-like stand-in mesh)")):
        rel(W, "T1 GrOps over Int (Int time / GrOps time)", "Indigo2 IMPACT / R4400",
            what, f"T1 {what} GrOps [s] (Indigo2 IMPACT)", f"T1 {what} Int [s] (R4400)", time_rows=True)
    for part, host in (("GrOps", "Indigo2 IMPACT"), ("Int", "R4400")):
        rel(W, f"T1 {part}: Blunt Fin over fedata", host, "both", f"T1 Blunt Fin {part} [s] ({host})",
            f"T1 fedata (FE-like stand-in mesh) {part} [s] ({host})", time_rows=True,
            note="fedata: a stand-in mesh of the paper's FE data set's size")
    return rows


#: the cost table's groups of configurations (MODEL_KEYS prefixes)
COST_GROUPS = (("Roettger Fig. 8 renders (512x384)", "roettger/"), ("Guthe Table 5 renders (1280x960)",
               ("guthe/bluntfin/geforce4", "guthe/bluntfin/radeon8500", "guthe/bucky/geforce4",
                "guthe/bucky/radeon8500")),
               ("Guthe Table 5 sorts alone", "guthe/"), ("Kraus Table 1 renders (800x600)", "kraus/"),
               ("Westermann Table 1 sweeps", "westermann/"), ("Espinha Tables 2/3 renders (512^2)", "espinha/"))


def cost_table(counted: dict) -> dict | None:
    """What counting the configurations took, as each cache file recorded when it was counted
    (:func:`warpvol.reproduce.model_rows.count_cost`), by group; ``counted``: the keys this run counted.
    ``None`` when a configuration's cost is not recorded."""
    from warpvol.reproduce.model_rows import count_cost

    cost = {k: count_cost(k) for k in MODEL_KEYS}
    if any(v is None for v in cost.values()):
        return None
    rows, left = [], list(MODEL_KEYS)
    for label, match in COST_GROUPS:
        keys = [k for k in left if (k in match if isinstance(match, tuple) else k.startswith(match))]
        left = [k for k in left if k not in keys]
        loads = [x for k in keys for x in cost[k]["load"]]
        rows.append([label, len(keys), round(sum(cost[k]["seconds"] for k in keys)),
                     round(sum(cost[k]["cpu_s"] for k in keys)), f"{min(loads):.1f}-{max(loads):.1f}"])
    loads = [x for v in cost.values() for x in v["load"]]
    wall, cpu = sum(v["seconds"] for v in cost.values()), sum(v["cpu_s"] for v in cost.values())
    rows.append(["all", len(MODEL_KEYS), round(wall), round(cpu), f"{min(loads):.1f}-{max(loads):.1f}"])
    return {"title": "Throughput model: what counting its configurations took",
            "columns": ["configurations", "count", "wall [s]", "CPU [s]", "load (1 min)"], "rows": rows,
            "notes": (f"Each configuration's count (two renders at the paper's size: the first builds the tables, "
                      f"the redraw is counted) as its cache file recorded it when counted, in one process; this "
                      f"run counted {len(counted)} of {len(MODEL_KEYS)} and took the rest from the cache (keyed by "
                      f"the code that counts). Load: the 1-minute load average at each count's start and end (other "
                      f"jobs beside it on the shared 2-core machine of the provenance line). A fresh run "
                      f"(empty cache) costs the 'all' row, {wall / 60:.0f} min here; with every counter cached the "
                      f"run takes seconds.")}


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
    print(f"\nRelative rows (speed of A over speed of B):\n{'paper':<16} {'row':<52} "
          f"{'card':<16} {'data':<12} {'paper':>6} {'model':>6} {'ratio':>6}  agrees  role")
    for r in relative:
        print(f"{r['paper']:<16} {r['row']:<52} {r['card']:<16} {r['data']:<12} {_f(r['paper_rel'], 3):>6} "
              f"{_f(r['modelled_rel'], 3):>6} {_r(r['ratio']):>6}"
              f"  {'-' if r['agrees'] is None else ('yes' if r['agrees'] else 'NO'):<6}  {r['role']}"
              f"{'; ' + r['note'] if r['note'] else ''}")
    print("\n" + "\n".join(count_lines(absolute, relative)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--refresh", action="store_true", help="re-render every configuration (minutes)")
    ap.add_argument("--cached-only", action="store_true", help="skip configurations not yet counted (no renders)")
    ap.add_argument("--absolute-from", metavar="JSON", help="take the absolute rows from an earlier --json output "
                    "(no counting) and rebuild the relative rows and counts from them")
    ap.add_argument("--sensitivity", action="store_true", help="with --absolute-from: add the sensitivity notes of "
                    "the rows resting on one estimated constant from the counter cache (no renders)")
    ap.add_argument("--json", metavar="PATH", help="write the tables as JSON (docs/hooks.py renders it)")
    a = ap.parse_args(argv)
    import time

    t_start = time.perf_counter()
    prov = provenance.start(provenance.command_line("scripts/validate_model.py", argv))
    if a.absolute_from:
        absolute, notes_abs, src, view = absolute_from(a.absolute_from)
        if a.sensitivity:
            from warpvol.pipeline import quiet_warp

            quiet_warp()
            sensitivity_from_counters(Model(a.device, False, cached_only=True), absolute)
        relative = relative_rows(None, absolute, view)
        out = to_json(absolute, relative, {}, notes_abs,
                      f"python scripts/validate_model.py --absolute-from {a.absolute_from}"
                      f"{' --sensitivity' if a.sensitivity else ''} --json {a.json}")
        out["absolute_source"] = src
    else:
        from warpvol.pipeline import quiet_warp

        quiet_warp()
        m = Model(a.device, False, a.cached_only)
        got = {"counted": {}}
        if not a.cached_only:  # every configuration the cache lacks (or all: --refresh), counted first
            from warpvol.reproduce.model_rows import fill

            t0 = time.perf_counter()
            got = fill(MODEL_KEYS, a.device, a.refresh)
            print(f"counters: {len(got['counted'])} configuration(s) counted in {time.perf_counter() - t0:.0f} s, "
                  f"{got['cached']} from the cache (keyed by the code that counts)"
                  + "".join(f"\n  {k}: {v:.0f} s" for k, v in got["counted"].items()), file=sys.stderr)
        absolute = absolute_rows(m)
        relative = relative_rows(m, absolute)
        out = to_json(absolute, relative, m.skipped)
        cost = cost_table(got["counted"])
        if cost:
            out["tables"]["cost"] = cost
            print("\n" + cost["title"] + "\n" + "\n".join(f"  {r[0]:<40} {r[1]:>3} {r[2]:>6} s wall {r[3]:>6} s CPU "
                                                        f" load {r[4]}" for r in cost["rows"]))
    print_tables(absolute, relative)
    if a.json:
        provenance.write_json(a.json, out, prov)
        print(f"wrote {a.json}", file=sys.stderr)
    print(f"validate_model: {time.perf_counter() - t_start:.0f} s in all", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
