"""Tables, error-vs-time plots and self-contained HTML pages for ``bench``, ``sweep`` and ``stress``.

Everything here turns rows (dicts, see :data:`warpvol.tools.bench.ROW_FIELDS`) into text or bytes; nothing
renders. The HTML page embeds its images as ``data:`` URIs and its interactive plot as inline SVG
(hover a point for its numbers), so one file carries everything and opens without a network.
"""

from __future__ import annotations

import base64
import csv
import html
import io
import math
from typing import Any

import numpy as np

#: time column -> the row flag marking its Pareto front (time against error)
FRONTS = {"total_s": "pareto", "modelled_s": "pareto_modelled"}

#: leading CSV / Markdown columns, in this order, where rows have them
LEAD = ("case", "scene", "view", "options", "pipeline", "status", "finite", "time_s", "total_s", "first_s", "repeats", "modelled_s", "rmse",
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
    return [str(r.get("pipeline")), str(r.get("status")), _fmt(r.get("total_s")), stages or "-",
            _fmt(r.get("modelled_s")), _fmt(r.get("rmse")), _fmt(r.get("max_abs")), _fmt(r.get("psnr")),
            "-" if mib is None else f"{mib / 2**20:.2f}", _fmt(r.get("pareto")), skipped,
            (r.get("message") or r.get("gpu_note") or "").replace("|", "/")]


MD_HEAD = ("pipeline", "status", "time [s]", "stages [s]", "modelled [s]", "RMSE", "max abs", "PSNR [dB]",
           "tables [MiB]", "Pareto", "skipped", "note")


def table_markdown(rows: list[dict]) -> str:
    """The main columns as a Markdown table (counters and stage columns are in the CSV/JSON).

    Examples
    --------
    >>> print(table_markdown([{"pipeline": "p", "status": "ok", "total_s": 0.5, "rmse": 1e-7, "pareto": True}]))
    | pipeline | status | time [s] | stages [s] | modelled [s] | RMSE | max abs | PSNR [dB] | tables [MiB] | Pareto | skipped | note |
    | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |
    | p | ok | 0.5 | - | - | 1.000e-07 | - | - | - | yes | - |  |
    """
    lines = ["| " + " | ".join(MD_HEAD) + " |", "|" + " --- |" * len(MD_HEAD)]
    lines += ["| " + " | ".join(_md_cells(r)) + " |" for r in rows]
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------------
# plots
# ------------------------------------------------------------------------------------------------
def _plot_points(rows: list[dict], tk: str) -> tuple[list[dict], float]:
    pts = [r for r in rows if r.get("status") == "ok" and r.get("rmse") is not None and r.get(tk)]
    pos = [r["rmse"] for r in pts if r["rmse"] > 0]
    floor = (min(pos) / 10.0) if pos else 1e-12  # an exact match (rmse 0) is drawn at this floor
    return pts, floor


def _label(r: dict) -> str:
    extra = [str(r[k]) for k in ("scene", "view", "options") if r.get(k)]
    return " ".join([str(r["pipeline"])] + extra)


def label_offsets(points: list[tuple[float, float, float, float]], area: tuple[float, float, float, float],
                  step: float = 11.0, gap: float = 4.0, marker: float = 0.0) -> list[tuple[float, float]]:
    """Offsets ``(dx, dy)`` placing a ``w x h`` label by each point ``(x, y, w, h)`` (in the order given:
    the first ones get the best places) so that no two labels overlap and each stays inside ``area``
    ``(x0, y0, x1, y1)``: the first free place of right of the point, then left of it, at vertical offsets
    ``gap``, then +-``step``, +-2 ``step``, ... (any y direction: the boxes are compared, not drawn);
    a label with no free place keeps ``(gap, gap)``. ``marker``: half-size of the points' markers, which
    labels keep clear of too."""
    placed = [(x - marker, y - marker, x + marker, y + marker) for x, y, _, _ in points] if marker else []
    out = []
    tries = [gap] + [sgn * step * k for k in range(1, 12) for sgn in (1.0, -1.0)]
    for x, y, w, h in points:
        choice = None
        for dy in tries:
            for dx in (gap, -gap - w):  # right of the point, else left of it
                box = (x + dx, y + dy, x + dx + w, y + dy + h)
                inside = box[0] >= area[0] and box[2] <= area[2] and box[1] >= area[1] and box[3] <= area[3]
                if inside and not any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3]
                                      for b in placed):
                    choice = (dx, dy, box)
                    break
            if choice:
                break
        dx, dy, box = choice or (gap, gap, (x + gap, y + gap, x + gap + w, y + gap + h))
        placed.append(box)
        out.append((dx, dy))
    return out


def _place_labels(fig, ax, pts: list[tuple], fontsize: float = 7.0) -> None:
    """Annotate ``(x, y, label, on_front)`` points with :func:`label_offsets` (front points first, in
    display points of the laid-out axes); a label moved away from its point gets a thin leader line."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig).draw()  # lay out: axis limits and the data -> display transform
    scale = fig.dpi / 72.0
    area = tuple(v / scale for v in ax.get_window_extent().extents)
    pts = sorted(pts, key=lambda p: not p[3])
    boxes = []
    for x, y, text, _ in pts:
        px, py = (v / scale for v in ax.transData.transform((x, y)))
        boxes.append((px, py, 0.62 * fontsize * len(text), 1.3 * fontsize))
    for (x, y, text, _), (dx, dy) in zip(pts, label_offsets(boxes, area, marker=3.0)):
        far = abs(dy) > 5.0 or dx < 0
        ax.annotate(text, (x, y), textcoords="offset points", xytext=(dx, dy), fontsize=fontsize,
                    va="bottom", arrowprops=dict(arrowstyle="-", lw=0.4, color="0.5") if far else None)


def pareto_png(rows: list[dict], title: str = "error against run time", tk: str = "total_s") -> bytes:
    """Log-log PNG of RMSE against median run time (``tk="modelled_s"``: modelled GPU time); the
    Pareto front is joined and red."""
    from matplotlib.figure import Figure

    flag = FRONTS[tk]
    pts, floor = _plot_points(rows, tk)
    fig = Figure(figsize=(6.4, 4.4), layout="constrained")
    ax = fig.subplots()
    for r in pts:
        ax.scatter([r[tk]], [max(r["rmse"], floor)], s=40, color="tab:red" if r.get(flag) else "tab:blue", zorder=3)
    if pts:
        ax.set_xscale("log")
        ax.set_yscale("log")
        _place_labels(fig, ax, [(r[tk], max(r["rmse"], floor), _label(r), bool(r.get(flag))) for r in pts])
    front = sorted((r[tk], max(r["rmse"], floor)) for r in pts if r.get(flag))
    if front:
        ax.plot(*zip(*front), color="tab:red", lw=1.2, label="Pareto front", drawstyle="steps-post")
        ax.legend(fontsize=8)
    if not pts:
        ax.text(0.5, 0.5, "no pipeline rendered", ha="center", transform=ax.transAxes)
    ax.set_xlabel("median run time [s] (emulated)" if tk == "total_s" else "modelled GPU time [s]")
    ax.set_ylabel("RMSE against the exact reference")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def pareto_svg(rows: list[dict], width: int = 640, height: int = 420, tk: str = "total_s") -> str:
    """The same plot as self-contained SVG; each point has a ``<title>`` shown on hover."""
    flag = FRONTS[tk]
    pts, floor = _plot_points(rows, tk)
    ml, mr, mt, mb = 70, 20, 20, 50
    head = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="11">'
            f'<rect width="{width}" height="{height}" fill="white"/>')
    if not pts:
        return head + f'<text x="{width / 2}" y="{height / 2}" text-anchor="middle">no pipeline rendered</text></svg>\n'
    xs = [math.log10(r[tk]) for r in pts]
    ys = [math.log10(max(r["rmse"], floor)) for r in pts]
    x0, x1 = math.floor(min(xs) - 0.05), math.ceil(max(xs) + 0.05)
    y0, y1 = math.floor(min(ys) - 0.05), math.ceil(max(ys) + 0.05)

    def px(x: float) -> float:
        return ml + (x - x0) / (x1 - x0) * (width - ml - mr)

    def py(y: float) -> float:
        return height - mb - (y - y0) / (y1 - y0) * (height - mt - mb)

    parts = [head, f'<rect x="{ml}" y="{mt}" width="{width - ml - mr}" height="{height - mt - mb}" fill="none" stroke="#888"/>']
    for d in range(x0, x1 + 1):
        parts.append(f'<line x1="{px(d):.1f}" x2="{px(d):.1f}" y1="{mt}" y2="{height - mb}" stroke="#ddd"/>'
                     f'<text x="{px(d):.1f}" y="{height - mb + 15}" text-anchor="middle">1e{d}</text>')
    for d in range(y0, y1 + 1):
        parts.append(f'<line x1="{ml}" x2="{width - mr}" y1="{py(d):.1f}" y2="{py(d):.1f}" stroke="#ddd"/>'
                     f'<text x="{ml - 5}" y="{py(d) + 4:.1f}" text-anchor="end">1e{d}</text>')
    parts.append(f'<text x="{(width + ml) / 2}" y="{height - 12}" text-anchor="middle">'
                 f'{"median run time" if tk == "total_s" else "modelled GPU time"} [s]</text>'
                 f'<text transform="translate(16 {(height - mb + mt) / 2}) rotate(-90)" text-anchor="middle">RMSE</text>')
    front = sorted((px(x), py(y)) for x, y, r in zip(xs, ys, pts) if r.get(flag))
    if len(front) > 1:
        path = " ".join(f"{a:.1f},{b:.1f}" for a, b in front)
        parts.append(f'<polyline points="{path}" fill="none" stroke="#c0392b" stroke-width="1.5"/>')
    order = sorted(range(len(pts)), key=lambda k: not pts[k].get(flag))  # front labels placed first
    # label boxes in SVG units (y down) from the point: text of 11 px, ~6.2 px per character, 12 px high
    offs = dict(zip(order, label_offsets([(px(xs[k]), py(ys[k]), 6.2 * len(_label(pts[k])), 12.0) for k in order],
                                         (ml, mt, width - mr, height - mb), step=12.0, gap=7.0, marker=6.0)))
    for k, (x, y, r) in enumerate(zip(xs, ys, pts)):
        tip = (f"{_label(r)}: {r[tk]:.4g} s, RMSE {r['rmse']:.3e}, max {_fmt(r.get('max_abs'))}, "
               f"PSNR {_fmt(r.get('psnr'))}" + (" (Pareto front)" if r.get(flag) else ""))
        colour = "#c0392b" if r.get(flag) else "#2e6fb0"
        dx, dy = offs[k]
        tx, ty = px(x) + dx, py(y) + dy + 10.0  # text baseline
        lead = (f'<line x1="{px(x):.1f}" y1="{py(y):.1f}" x2="{tx + (0 if dx > 0 else 6.2 * len(_label(r))):.1f}" '
                f'y2="{ty - 4:.1f}" stroke="#999" stroke-width="0.5"/>') if abs(dy) > 7.5 or dx < 0 else ""
        parts.append(f'<g class="pt">{lead}<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="6" fill="{colour}">'
                     f'<title>{html.escape(tip)}</title></circle>'
                     f'<text x="{tx:.1f}" y="{ty:.1f}">{html.escape(_label(r))}</text></g>')
    return "".join(parts) + "</svg>\n"


# ------------------------------------------------------------------------------------------------
# images and pages
# ------------------------------------------------------------------------------------------------
def png_data_uri(rgb: np.ndarray) -> str:
    """``data:image/png;base64,...`` of an (H, W, 3|4) float image in [0, 1]."""
    from matplotlib.image import imsave

    buf = io.BytesIO()
    imsave(buf, np.clip(np.asarray(rgb, np.float64), 0.0, 1.0), format="png")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def image_uri(image: np.ndarray) -> str:
    from warpvol.io import composite_over

    return png_data_uri(composite_over(np.asarray(image, np.float64), (0.0, 0.0, 0.0)))


def error_uri(image: np.ndarray, reference: np.ndarray) -> tuple[str, float]:
    """Per-pixel max |error| through the ``magma`` colour map, scaled to its maximum."""
    from matplotlib import colormaps

    from warpvol.metrics import error_image

    err = error_image(image, reference)
    scale = float(err.max())
    return png_data_uri(colormaps["magma"](err / scale if scale > 0 else err)), scale


CSS = """body{font-family:sans-serif;margin:1.5em;color:#222}table{border-collapse:collapse;font-size:12px}
td,th{border:1px solid #ccc;padding:3px 6px;text-align:left}th{background:#f0f0f0}
.grid{display:flex;flex-wrap:wrap;gap:12px}.card{border:1px solid #ddd;padding:6px;font-size:12px}
.card img{width:220px;image-rendering:pixelated;display:block}.pair{display:flex;gap:4px}.fail{color:#b00}.ok{color:#070}
.plots{display:flex;flex-wrap:wrap;gap:16px;align-items:flex-start}.plots img{width:560px}"""


def html_table(head: list[str], body: list[list[Any]]) -> str:
    h = "".join(f"<th>{html.escape(str(c))}</th>" for c in head)
    rows = "".join("<tr>" + "".join(f"<td>{html.escape(_fmt(c) if not isinstance(c, str) else c)}</td>" for c in r)
                   + "</tr>" for r in body)
    return f"<table><tr>{h}</tr>{rows}</table>"


def _planner_html(rows: list[dict], plan: dict | None) -> str:
    body = []
    for r in rows:
        for a in r.get("planner") or []:
            body.append([r["pipeline"], a["stage"], a["reason"], a.get("saved_s"), a.get("warmup_stage_s"),
                         a.get("forced_total_s"), a.get("total_diff_s"), a.get("diff_max_abs"), a.get("note", "")])
        if r.get("status") == "ok" and not r.get("planner"):
            for sk in r.get("skipped") or []:
                body.append([r["pipeline"], sk["stage"], sk["reason"], None, None, None, None, None, "not measured (no audit run)"])
            if not r.get("skipped"):
                body.append([r["pipeline"], "-", "no stage left out for this scene", None, None, None, None, None, ""])
    out = ("<p>Stages each preset left out for this scene (the stages' <code>skip_reason</code>), and what "
           "forcing each back on costs: the stage's own time (what leaving it out saves), the whole render's "
           "time with it and the difference to the render without it (medians of the same repeats; the "
           "difference also carries the other stages' timing noise), and the largest pixel difference. A "
           "stage left out only on re-renders (a table found in the pipeline's cache) ran in the warm-up "
           "render: its time there is the work each later render avoids.</p>")
    out += html_table(["pipeline", "stage left out", "why", "time saved [s]", "in the warm-up [s]",
                       "render with it [s]", "render difference [s]", "max |difference|", "note"], body)
    if plan:
        plan_rows = [[p, s["stage"], {True: "runs", False: "skipped", None: "at render time"}[s["run"]], s["reason"] or ""]
                     for p, stages in plan.items() for s in stages]
        out += "<h3>Dry-run plan of every preset</h3>" + html_table(["pipeline", "stage", "plan", "reason"], plan_rows)
    return out


def bench_section(result: Any, plan: dict | None = None, title: str | None = None) -> str:
    """One scene's section: description, table, plots, images and error maps, planner audit."""
    sc = result.scene
    parts = [f"<h2>{html.escape(title or sc['name'])}</h2>",
             "<p>" + html.escape(", ".join(f"{k}: {_fmt(v)}" for k, v in sc.items() if v is not None)) + "</p>"]
    ref_s = "read from the cache" if result.reference_cached else f"computed in {_fmt(result.reference_s)} s"
    parts.append(f"<p>Exact float64 reference {ref_s}. Times are medians of the repeated renders after a "
                 "warm-up (emulated on this machine" + (f"; modelled for GPU {html.escape(result.gpu)}" if result.gpu else "")
                 + ").</p>")
    parts += [f"<p><b>Note:</b> {html.escape(n)}</p>" for n in result.notes]
    parts.append(html_table(list(MD_HEAD), [_md_cells(r) for r in result.rows]))
    for tk in ("total_s", "modelled_s"):
        if tk == "modelled_s" and not any(r.get(tk) for r in result.rows):
            continue
        png = base64.b64encode(pareto_png(result.rows, tk=tk)).decode()
        parts.append(f'<div class="plots"><div><img alt="error against {tk}" src="data:image/png;base64,{png}"/>'
                     f'</div><div>{pareto_svg(result.rows, tk=tk)}<br/><small>interactive: hover a point</small></div></div>')
    cards = []
    if result.reference is not None:
        cards.append(f'<div class="card"><img alt="reference" src="{image_uri(result.reference)}"/>exact reference</div>')
    for r in result.rows:
        img = result.images.get(r["pipeline"])
        if img is None:
            cards.append(f'<div class="card fail"><b>{html.escape(r["pipeline"])}</b><br/>'
                         f'{html.escape(r.get("message", ""))}</div>')
            continue
        pair = f'<img alt="{html.escape(r["pipeline"])}" src="{image_uri(img)}"/>'
        caption = f'<b>{html.escape(r["pipeline"])}</b> {_fmt(r.get("total_s"))} s, RMSE {_fmt(r.get("rmse"))}'
        if result.reference is not None:
            uri, scale = error_uri(img, result.reference)
            pair += f'<img alt="error {html.escape(r["pipeline"])}" src="{uri}"/>'
            caption += f"; right: |error|, white = {scale:.2e}"
        cards.append(f'<div class="card"><div class="pair">{pair}</div>{caption}</div>')
    parts.append('<div class="grid">' + "".join(cards) + "</div>")
    parts.append("<h3>Planner audit</h3>" + _planner_html(result.rows, plan))
    return "\n".join(parts)


def page(title: str, sections: list[str]) -> str:
    return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"/><title>{html.escape(title)}</title>"
            f"<style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>\n" + "\n".join(sections) + "\n</body></html>\n")


def bench_page(result: Any, plan: dict | None = None) -> str:
    """The bench's self-contained HTML page."""
    return page(f"warpvol bench: {result.scene['name']}", [bench_section(result, plan)])
