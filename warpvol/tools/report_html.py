"""Tables, error-vs-time plots and self-contained HTML pages for ``bench``, ``sweep`` and ``stress``.

Everything here turns rows (dicts, see :data:`warpvol.tools.bench.ROW_FIELDS`) into text or bytes; nothing
renders. The pages are Jinja2 templates (``warpvol/tools/templates/*.html.j2``); a page embeds its images
as ``data:`` URIs and its plots as inline SVG drawn by matplotlib, one per clock (emulated time;
modelled GPU time), each point with a ``<title>`` shown on hover, so one file carries everything and
opens without a network.
"""

from __future__ import annotations

import base64
import csv
import io
import math
import re
from typing import Any

import numpy as np

from warpvol.io import composite_over
from warpvol.metrics import error_image
from warpvol.tools.machine import timer_resolution

#: time column -> the row flag marking its Pareto front (time against error)
FRONTS = {"total_s": "pareto", "modelled_s": "pareto_modelled"}

#: leading CSV / Markdown columns, in this order, where rows have them
LEAD = ("case", "scene", "view", "options", "pipeline", "status", "finite", "time_s", "total_s", "min_s", "max_s",
        "first_s", "repeats", "modelled_s", "rmse",
        "max_abs", "psnr", "table_bytes", "pareto", "gpu_note", "message")


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.3e}" if (v != 0 and (abs(v) < 1e-2 or abs(v) >= 1e5)) else f"{v:.4g}"
    if isinstance(v, dict):
        return ", ".join(f"{k}={_fmt(x)}" for k, x in v.items())
    return str(v)


def flat_row(r: dict) -> dict:
    """One row as flat ``column -> value``: stage times as ``stage_s.KEY``, modelled ones as
    ``modelled_s.KEY``, counters as ``count.STAGE.NAME``, planner savings as ``saved_s.STAGE``."""
    out = {k: (_fmt(r[k]) if isinstance(r[k], dict) else r[k]) for k in LEAD if k in r}
    out.update({f"stage_s.{k}": v for k, v in (r.get("stages_s") or {}).items()})
    out.update({f"modelled_s.{k}": v for k, v in (r.get("modelled_stages_s") or {}).items()})
    out.update({f"count.{st}.{k}": v for st, c in (r.get("counters") or {}).items() for k, v in c.items()})
    if r.get("skipped"):
        out["skipped"] = "; ".join(f"{s['stage']}: {s['reason']}" for s in r["skipped"])
    out.update({f"saved_s.{a['stage']}": a.get("saved_s") for a in r.get("planner") or []})
    return out


def _columns(flat: list[dict]) -> list[str]:
    cols: list[str] = []
    for f in flat:
        cols += [k for k in f if k not in cols]
    lead = [c for c in LEAD if c in cols]
    return lead + [c for c in cols if c not in lead]


def table_csv(rows: list[dict]) -> str:
    """Rows as CSV (one column per field, stage time and counter; empty where a row lacks it)."""
    flat = [flat_row(r) for r in rows]
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=_columns(flat), lineterminator="\n")
    w.writeheader()
    for f in flat:
        w.writerow({k: ("" if v is None else v) for k, v in f.items()})
    return buf.getvalue()


def _md_cells(r: dict) -> list[str]:
    stages = ", ".join(f"{k} {v:.3g}" for k, v in (r.get("stages_s") or {}).items())
    skipped = ", ".join(s["stage"] for s in r.get("skipped") or []) or "-"
    mib = r.get("table_bytes")
    return [str(r.get("pipeline")), str(r.get("status")), _fmt(r.get("total_s")), _fmt(r.get("min_s")),
            _fmt(r.get("max_s")), stages or "-",
            _fmt(r.get("modelled_s")), _fmt(r.get("rmse")), _fmt(r.get("max_abs")), _fmt(r.get("psnr")),
            "-" if mib is None else f"{mib / 2**20:.2f}", _fmt(r.get("pareto")), skipped,
            (r.get("message") or r.get("gpu_note") or "").replace("|", "/")]


MD_HEAD = ("pipeline", "status", "time [s]", "min [s]", "max [s]", "stages [s]", "modelled [s]", "RMSE", "max abs", "PSNR [dB]",
           "tables [MiB]", "Pareto", "skipped", "note")


def table_markdown(rows: list[dict]) -> str:
    """The main columns as a Markdown table (counters and stage columns are in the CSV/JSON).

    Examples
    --------
    >>> print(table_markdown([{"pipeline": "p", "status": "ok", "total_s": 0.5, "rmse": 1e-7, "pareto": True}]))
    | pipeline | status | time [s] | min [s] | max [s] | stages [s] | modelled [s] | RMSE | max abs | PSNR [dB] | tables [MiB] | Pareto | skipped | note |
    | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |
    | p | ok | 0.5 | - | - | - | - | 1.000e-07 | - | - | - | yes | - |  |
    """
    lines = ["| " + " | ".join(MD_HEAD) + " |", "|" + " --- |" * len(MD_HEAD)]
    lines += ["| " + " | ".join(_md_cells(r)) + " |" for r in rows]
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------------
# plots: one matplotlib figure per clock, written as SVG (hover titles) or PNG
# ------------------------------------------------------------------------------------------------
#: time column -> (plot title, axis label, id prefix of the points in the SVG)
CLOCKS = {"total_s": ("RMSE against emulated run time", "median run time of the emulation on this CPU [s]",
                      "pareto-emulated-"),
          "modelled_s": ("RMSE against modelled GPU time", "modelled GPU time [s]", "pareto-modelled-")}


def _plot_points(rows: list[dict], tk: str) -> tuple[list[tuple[int, dict]], float]:
    """``(row number from 1, row)`` of the rows with a time and an error on the clock ``tk``, and the
    floor an exact match (RMSE 0) is drawn at."""
    pts = [(k, r) for k, r in enumerate(rows, 1)
           if r.get("status") == "ok" and r.get("rmse") is not None and r.get(tk)]
    pos = [r["rmse"] for _, r in pts if r["rmse"] > 0]
    floor = (min(pos) / 10.0) if pos else 1e-12
    return pts, floor


def _label(r: dict) -> str:
    extra = [str(r[k]) for k in ("scene", "view", "options") if r.get(k)]
    return " ".join([str(r["pipeline"])] + extra)


def unplotted(rows: list[dict], tk: str) -> list[tuple[str, str]]:
    """``(name, why)`` of the rows missing from the plot of clock ``tk``.

    Examples
    --------
    >>> unplotted([{"pipeline": "a", "status": "ok", "rmse": 1e-3, "modelled_s": None,
    ...             "gpu_note": "not modelled: sort: cells_sorted"},
    ...            {"pipeline": "b", "status": "failed", "message": "boom"}], "modelled_s")
    [('a', 'not modelled: sort: cells_sorted'), ('b', 'failed: boom')]
    """
    out = []
    for r in rows:
        if r.get("status") != "ok":
            out.append((_label(r), f"{r.get('status')}: {r.get('message') or ''}".rstrip(": ")))
        elif r.get("rmse") is None:
            out.append((_label(r), "no error: the reference is missing"))
        elif not r.get(tk):
            why = r.get("gpu_note") if tk == "modelled_s" else None
            out.append((_label(r), why or ("no modelled time" if tk == "modelled_s" else "no time")))
    return out


def _decades(values: list[float]) -> tuple[float, float]:
    """Axis limits on whole decades around ``values`` (at least one decade): points differing in
    their rounding (two exact presets) do not stretch an axis of their own."""
    lo, hi = math.log10(min(values)), math.log10(max(values))
    return 10.0 ** math.floor(lo - 0.05), 10.0 ** math.ceil(hi + 0.05)


def pareto_figure(rows: list[dict], tk: str = "total_s", gpu: str | None = None):
    """``(figure, tips)``: log-log RMSE against the time ``tk`` (``"total_s"`` emulated, ``"modelled_s"``
    modelled on ``gpu``); the Pareto front red and joined; each point labelled with its row number (and
    its name on the front); ``tips``: point id -> hover text."""
    from matplotlib.figure import Figure

    title, xlabel, prefix = CLOCKS[tk]
    if tk == "modelled_s" and gpu:
        title += f" ({gpu})"
    flag = FRONTS[tk]
    pts, floor = _plot_points(rows, tk)
    fig = Figure(figsize=(6.4, 4.4), layout="constrained")
    ax = fig.subplots()
    tips = {}
    for k, r in pts:
        x, y, front = r[tk], max(r["rmse"], floor), bool(r.get(flag))
        sc = ax.scatter([x], [y], s=36, color="tab:red" if front else "tab:blue", zorder=3)
        sc.set_gid(f"{prefix}{k}")
        spread = (f" (min {_fmt(r['min_s'])}, max {_fmt(r['max_s'])})"
                  if tk == "total_s" and r.get("min_s") is not None else "")
        tips[f"{prefix}{k}"] = (f"{k}. {_label(r)}: {r[tk]:.4g} s{spread}, RMSE {r['rmse']:.3e}, "
                                f"max {_fmt(r.get('max_abs'))}, PSNR {_fmt(r.get('psnr'))}"
                                + (" (Pareto front)" if front else ""))
        ax.annotate(f"{k} {_label(r)}" if front else str(k), (x, y), textcoords="offset points", xytext=(5, 3),
                    fontsize=7, color="0.15")
    front = sorted((r[tk], max(r["rmse"], floor)) for _, r in pts if r.get(flag))
    if len(front) > 1:
        ax.plot(*zip(*front), color="tab:red", lw=1.2, label="Pareto front", drawstyle="steps-post", zorder=2)
        ax.legend(fontsize=8, loc="best")
    if pts:
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(*_decades([r[tk] for _, r in pts]))
        ax.set_ylim(*_decades([max(r["rmse"], floor) for _, r in pts]))
    else:
        ax.text(0.5, 0.5, "no preset on this clock", ha="center", transform=ax.transAxes)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("RMSE against the exact reference")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="major", alpha=0.35)
    ax.grid(True, which="minor", alpha=0.12)
    return fig, tips


#: design size of :func:`error_time_figure` in inches at 100 dpi (900 x 560 px), its text size in points
ERROR_TIME_SIZE = (9.0, 5.6)
ERROR_TIME_FONT = 10


def error_time_figure(rows: list[dict], title: str = "RMSE against run time, every preset"):
    """Log-log RMSE against the median run time of every preset that rendered, each point labelled with its
    preset's name; a horizontal bar spans the fastest to the slowest timed render where the rows record it
    (``min_s``, ``max_s``); the Pareto front is red. An exact match (RMSE 0) is drawn at a tenth of the
    smallest RMSE. Sized :data:`ERROR_TIME_SIZE` with :data:`ERROR_TIME_FONT`-point text, legible at 900 px.

    Examples
    --------
    >>> fig = error_time_figure([{"pipeline": "a", "status": "ok", "total_s": 0.1, "min_s": 0.09, "max_s": 0.2,
    ...                           "rmse": 1e-7, "pareto": True},
    ...                          {"pipeline": "b", "status": "ok", "total_s": 1.0, "rmse": 1e-3}])
    >>> sorted(t.get_text() for t in fig.axes[0].texts if t.get_text())  # the names (and empty leader lines)
    ['a', 'b']
    """
    from matplotlib.figure import Figure

    pts, floor = _plot_points(rows, "total_s")
    fig = Figure(figsize=ERROR_TIME_SIZE, dpi=100, layout="constrained")
    ax = fig.subplots()
    spread = False
    for k, (_, r) in enumerate(sorted(pts, key=lambda p: (p[1]["total_s"], p[1]["rmse"]))):
        x, y, front = r["total_s"], max(r["rmse"], floor), bool(r.get("pareto"))
        color = "tab:red" if front else "tab:blue"
        if r.get("min_s") is not None and r.get("max_s") is not None:
            ax.errorbar([x], [y], xerr=[[max(0.0, x - r["min_s"])], [max(0.0, r["max_s"] - x)]], fmt="none",
                        ecolor=color, elinewidth=1.2, capsize=3, alpha=0.8, zorder=2)
            spread = True
        ax.scatter([x], [y], s=40, color=color, zorder=3)
    front = sorted((r["total_s"], max(r["rmse"], floor)) for _, r in pts if r.get("pareto"))
    if len(front) > 1:
        ax.plot(*zip(*front), color="tab:red", lw=1.2, label="Pareto front", drawstyle="steps-post", zorder=1)
    if pts:
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(*_decades([r.get("min_s") or r["total_s"] for _, r in pts] + [r.get("max_s") or r["total_s"]
                                                                                for _, r in pts]))
        ax.set_ylim(*_decades([max(r["rmse"], floor) for _, r in pts]))
    if spread:
        ax.plot([], [], color="0.4", lw=1.2, label="fastest to slowest timed render")
    if len(front) > 1 or spread:
        ax.legend(fontsize=ERROR_TIME_FONT - 1, loc="center right")
    ax.set_xlabel("median run time on this CPU [s] (log)", fontsize=ERROR_TIME_FONT)
    ax.set_ylabel("RMSE against the exact reference (log)", fontsize=ERROR_TIME_FONT)
    ax.tick_params(labelsize=ERROR_TIME_FONT - 1)
    ax.set_title(title, fontsize=ERROR_TIME_FONT + 1)
    ax.grid(True, which="major", alpha=0.35)
    ax.grid(True, which="minor", alpha=0.12)
    _place_labels(fig, ax, [(str(r["pipeline"]), r["total_s"], max(r["rmse"], floor)) for _, r in pts])
    return fig


#: label positions tried around a point, in points: right, left, then further above and below
_LABEL_OFFSETS = [(dx, dy) for dy in (4, -13, 15, -24, 26, -35, 37, -46) for dx in (7, -7)]


def _place_labels(fig, ax, labels: list[tuple[str, float, float]]) -> None:
    """Name every point: each label takes the first position around its point (:data:`_LABEL_OFFSETS`)
    where it overlaps no point and no label placed before and stays inside the axes, with a thin leader
    line to its point."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    fig.draw_without_rendering()
    renderer = canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    from matplotlib.transforms import Bbox

    r = 5.0 * fig.dpi / 72.0  # a marker's half size in pixels: labels keep off every point
    placed = [Bbox.from_extents(px - r, py - r, px + r, py + r)
              for px, py in (ax.transData.transform((x, y)) for _, x, y in labels)]
    if ax.get_legend() is not None:  # labels keep off the legend too
        placed.append(ax.get_legend().get_window_extent(renderer))
    for name, x, y in sorted(labels, key=lambda t: (t[2], t[1])):
        best = None
        for dx, dy in _LABEL_OFFSETS:
            t = ax.annotate(name, (x, y), textcoords="offset points", xytext=(dx, dy), ha="left" if dx > 0 else "right",
                            fontsize=ERROR_TIME_FONT - 1, color="0.1", zorder=4)
            box = t.get_window_extent(renderer).expanded(1.04, 1.1)
            inside = frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1)
            if inside and not any(box.overlaps(b) for b in placed):
                best = (t, box, True)
                break
            t.remove()
        if best is None:  # nowhere free: the first position, overlapping
            dx, dy = _LABEL_OFFSETS[0]
            t = ax.annotate(name, (x, y), textcoords="offset points", xytext=(dx, dy), fontsize=ERROR_TIME_FONT - 1,
                            color="0.1", zorder=4)
            best = (t, t.get_window_extent(renderer), False)
        t, box, far = best
        if far:  # a leader line from the label to its point says whose it is
            t.arrow_patch = None
            t.set_annotation_clip(False)
            ax.annotate("", (x, y), xytext=t.get_position(), textcoords="offset points",
                        arrowprops=dict(arrowstyle="-", color="0.55", lw=0.6, shrinkA=0, shrinkB=3))
        placed.append(box)


def pareto_svg(rows: list[dict], tk: str = "total_s", gpu: str | None = None) -> str:
    """:func:`pareto_figure` as SVG text (text kept as text), a ``<title>`` (hover text) in each point's
    group."""
    import matplotlib

    fig, tips = pareto_figure(rows, tk, gpu)
    buf = io.StringIO()
    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": "warpvol"}):
        fig.savefig(buf, format="svg")
    svg = buf.getvalue()

    def add_title(m: re.Match) -> str:
        tip = tips.get(m.group(1))
        return m.group(0) if tip is None else f'{m.group(0)}\n   <title>{_escape(tip)}</title>'

    return re.sub(r'<g id="([^"]+)"[^>]*>', add_title, svg)


def pareto_png(rows: list[dict], tk: str = "total_s", gpu: str | None = None) -> bytes:
    """:func:`pareto_figure` as PNG (the same plot, for documents)."""
    fig, _ = pareto_figure(rows, tk, gpu)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _inline_svg(svg: str) -> str:
    """An SVG file's text without its XML declaration and DOCTYPE, for a page."""
    return svg[svg.index("<svg"):]


# ------------------------------------------------------------------------------------------------
# images and pages (Jinja2 templates)
# ------------------------------------------------------------------------------------------------
def _escape(text: str) -> str:
    from markupsafe import escape

    return str(escape(text))


_ENV = None


def templates():
    """The Jinja2 environment of ``warpvol/tools/templates`` (autoescaped; an undefined name is an error)."""
    global _ENV
    if _ENV is None:
        from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

        _ENV = Environment(loader=PackageLoader("warpvol.tools", "templates"),
                           autoescape=select_autoescape(["html.j2"]), undefined=StrictUndefined,
                           trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True)
    return _ENV


def png_data_uri(rgb: np.ndarray) -> str:
    """``data:image/png;base64,...`` of an (H, W, 3|4) float image in [0, 1]."""
    from matplotlib.image import imsave

    buf = io.BytesIO()
    imsave(buf, np.clip(np.asarray(rgb, np.float64), 0.0, 1.0), format="png")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def image_uri(image: np.ndarray) -> str:
    return png_data_uri(composite_over(np.asarray(image, np.float64), (0.0, 0.0, 0.0)))


def error_uri(image: np.ndarray, reference: np.ndarray) -> tuple[str, float]:
    """Per-pixel max |error| through the ``magma`` colour map, scaled to its maximum."""
    from matplotlib import colormaps


    err = error_image(image, reference)
    scale = float(err.max())
    return png_data_uri(colormaps["magma"](err / scale if scale > 0 else err)), scale


def html_table(head: list[str], body: list[list[Any]], classes: str = "") -> str:
    """An HTML table (cells formatted with the tables' number format, text escaped)."""
    cells = [[c if isinstance(c, str) else _fmt(c) for c in r] for r in body]
    return templates().get_template("table.html.j2").render(head=list(head), body=cells, classes=classes)


def page(title: str, sections: list[str]) -> str:
    """A self-contained page: ``title`` and the sections (HTML) in order."""
    return templates().get_template("page.html.j2").render(title=title, sections=sections)


def below_noise(diff: float | None, noise: float, resolution: float) -> str | None:
    """``diff`` in words when it is noise: ``"< timer resolution"`` or ``"within the repeats' spread
    (±x s)"``; ``None`` when it is a measured difference.

    Examples
    --------
    >>> below_noise(-2e-4, 5e-4, 1e-9), below_noise(3e-10, 0.0, 1e-9), below_noise(0.01, 5e-4, 1e-9)
    ("within the repeats' spread (±5e-04 s)", '< timer resolution', None)
    """
    if diff is None:
        return None
    if abs(diff) < resolution:
        return "< timer resolution"
    if abs(diff) <= noise:
        return f"within the repeats' spread (±{noise:.0e} s)"
    return None


def _audit_rows(rows: list[dict], resolution: float) -> tuple[bool, list[list[str]]]:
    body, audited = [], False
    for r in rows:
        spread = (r.get("max_s") or 0.0) - (r.get("min_s") or 0.0)
        for a in r.get("planner") or []:
            audited = True
            saved = below_noise(a.get("saved_s"), 0.0, resolution) or _fmt(a.get("saved_s"))
            noise = max(spread, (a.get("forced_max_s") or 0.0) - (a.get("forced_min_s") or 0.0))
            diff = a.get("total_diff_s")
            diff_text = below_noise(diff, noise, resolution) or (f"{diff:+.3e}" if diff is not None else "-")
            body.append([r["pipeline"], a["stage"], a["reason"], saved, _fmt(a.get("warmup_stage_s")),
                         _fmt(a.get("forced_total_s")), diff_text, _fmt(a.get("diff_max_abs")), a.get("note", "")])
        if r.get("status") == "ok" and not r.get("planner"):
            for sk in r.get("skipped") or []:
                body.append([r["pipeline"], sk["stage"], sk["reason"], "-", "-", "-", "-", "-",
                             "not measured (run with --audit)"])
            if not r.get("skipped"):
                body.append([r["pipeline"], "-", "no stage left out for this scene", "-", "-", "-", "-", "-", ""])
    return audited, body


AUDIT_HEAD = ["pipeline", "stage left out", "why", "time saved [s]", "in the warm-up [s]", "render with it [s]",
              "render difference [s]", "max |difference|", "note"]

PAGE_HEAD = ["#", "pipeline", "status", "time [s] (median)", "min [s]", "max [s]", "first [s]", "modelled [s]",
             "RMSE", "max abs", "PSNR [dB]", "tables [MiB]", "Pareto", "Pareto (modelled)", "stages [s] (median)",
             "skipped", "note"]


def _page_row(k: int, r: dict) -> dict:
    def num(v: Any) -> dict:
        return {"text": _fmt(v), "num": True}

    def txt(v: str) -> dict:
        return {"text": v, "num": False}

    mib = r.get("table_bytes")
    cells = [num(k), txt(str(r.get("pipeline"))), txt(str(r.get("status"))), num(r.get("total_s")), num(r.get("min_s")),
             num(r.get("max_s")), num(r.get("first_s")), num(r.get("modelled_s")), num(r.get("rmse")),
             num(r.get("max_abs")), num(r.get("psnr")), num(None if mib is None else mib / 2**20),
             txt(_fmt(r.get("pareto"))), txt(_fmt(r.get("pareto_modelled")) if r.get("modelled_s") else "-"),
             txt(", ".join(f"{s} {v:.3g}" for s, v in (r.get("stages_s") or {}).items()) or "-"),
             txt(", ".join(s["stage"] for s in r.get("skipped") or []) or "-"),
             txt(r.get("message") or r.get("gpu_note") or "")]
    return {"cells": cells, "failed": r.get("status") == "failed"}


def bench_section(result: Any, plan: dict | None = None, title: str | None = None) -> str:
    """One scene's section: metadata, description, table with the spread of the repeats, one Pareto plot
    per clock (the presets not on it listed with the reason), images and error maps, planner audit."""

    sc = result.scene
    gpu = getattr(result, "gpu", None)
    meta = [[k, str(v)] for k, v in (getattr(result, "meta", None) or {}).items()]
    plots = []
    for tk in ("total_s", "modelled_s"):
        if tk == "modelled_s" and not gpu and not any(r.get(tk) for r in result.rows):
            continue
        has = any(r.get("status") == "ok" and r.get("rmse") is not None and r.get(tk) for r in result.rows)
        name = CLOCKS[tk][0] + (f" ({gpu})" if tk == "modelled_s" and gpu else "")
        plots.append({"title": name, "modelled": tk == "modelled_s",
                      "svg": _inline_svg(pareto_svg(result.rows, tk=tk, gpu=gpu)) if has else "",
                      "empty": "No preset has a time on this clock.", "missing": unplotted(result.rows, tk)})
    cards = []
    for r in result.rows:
        img = result.images.get(r["pipeline"])
        if img is None:
            cards.append({"name": r["pipeline"], "image": None, "caption": r.get("message", "")})
            continue
        card = {"name": r["pipeline"], "image": image_uri(img), "error": None,
                "caption": f"{_fmt(r.get('total_s'))} s, RMSE {_fmt(r.get('rmse'))}"}
        if result.reference is not None:
            card["error"], scale = error_uri(img, result.reference)
            card["caption"] += f"; right: |error|, white = {scale:.2e}"
        cards.append(card)
    audited, audit_body = _audit_rows(result.rows, timer_resolution())
    plan_rows = [[p, s["stage"], {True: "runs", False: "skipped", None: "at render time"}[s["run"]], s["reason"] or ""]
                 for p, stages in (plan or {}).items() for s in stages]
    ref_text = ("read from the cache" if result.reference_cached
                else f"computed in {_fmt(result.reference_s)} s")
    return templates().get_template("bench_section.html.j2").render(
        title=title or sc["name"], meta=meta, gpu=gpu, notes=list(result.notes),
        scene_text=", ".join(f"{k}: {_fmt(v)}" for k, v in sc.items() if v is not None), reference_text=ref_text,
        head=PAGE_HEAD, rows=[_page_row(k, r) for k, r in enumerate(result.rows, 1)], plots=plots,
        reference_uri=image_uri(result.reference) if result.reference is not None else None, cards=cards,
        audited=audited, audit_head=AUDIT_HEAD, audit_body=audit_body, plan=plan_rows)


def bench_page(result: Any, plan: dict | None = None) -> str:
    """The bench's self-contained HTML page."""
    return page(f"warpvol bench: {result.scene['name']}", [bench_section(result, plan)])
