"""Figures of the Python API: a rendering beside its error map (:meth:`warpvol.Rendering.plot`), and
:func:`warpvol.compare`'s figure, one row per pipeline, where a pipeline that declined the scene or
failed keeps its row as a labelled empty panel with the reason in words."""

from __future__ import annotations

import textwrap
from typing import Any

import numpy as np

from warpvol.io import composite_over

#: characters per line of a declined pipeline's reason in its empty panel
REASON_WIDTH = 70


def rgb(image: np.ndarray, background=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The premultiplied RGBA ``image`` composited over ``background``, clipped to [0, 1]."""

    return np.clip(composite_over(np.asarray(image, np.float64), background), 0.0, 1.0)


def draw_pair(ax_img, ax_err, res: Any, title: str, norm=None) -> None:
    """One panel pair: the image of ``res`` (a :class:`~warpvol.Rendering`; title: time and RMSE) and its
    error map against the reference on the logarithmic colour scale ``norm``
    (:func:`warpvol.metrics.error_norm`; one per figure)."""
    from warpvol.metrics import draw_error, error_norm

    ax_img.imshow(rgb(res.image), interpolation="nearest")
    t = res.report.get("median_s", res.report.get("render_s", res.report["total_s"]))
    err = res.error
    ax_img.set_title(f"{title}\n{t:.3f} s" + (f", RMSE {err['rmse']:.2e}" if err else ""), fontsize=9)
    ax_img.set_axis_off()
    if ax_err is not None:
        emap = res.error_image
        draw_error(ax_err, emap, error_norm(emap) if norm is None else norm)
        ax_err.set_title(f"|error|, log scale (max {err['max_abs']:.2e})", fontsize=9)


def draw_declined(ax, name: str, status: str, reason: str) -> None:
    """An empty panel spanning a row: the pipeline's name, ``declined`` or ``failed``, and the reason."""
    from matplotlib.patches import Rectangle

    ax.set_axis_off()
    ax.set_title(f"{name}: {status}", fontsize=9)
    ax.add_patch(Rectangle((0, 0), 1, 1, transform=ax.transAxes, fill=False, linestyle="--", edgecolor="0.6"))
    ax.text(0.5, 0.5, textwrap.fill(str(reason or "(no reason given)"), REASON_WIDTH), transform=ax.transAxes,
            ha="center", va="center", fontsize=8, wrap=True)


def comparison_figure(results: dict, table: list[dict], title: str | None = None):
    """:func:`warpvol.compare`'s figure: one row per row of ``table``, in its order; a rendered pipeline
    (in ``results``) as image and error map on one shared logarithmic colour scale, any other as a
    labelled empty panel with its ``status`` and ``reason``. ``None`` for an empty table."""
    from matplotlib.figure import Figure

    from warpvol.metrics import error_norm

    if not table:
        return None
    norm = error_norm(*(r.error_image for r in results.values())) if results else None
    heights = [4.0 if row["pipeline"] in results else 1.4 for row in table]
    fig = Figure(figsize=(8.4, sum(heights) + (0.4 if title else 0.0)), layout="constrained")
    grid = fig.add_gridspec(len(table), 2, height_ratios=heights)
    for k, row in enumerate(table):
        if row["pipeline"] in results:
            draw_pair(fig.add_subplot(grid[k, 0]), fig.add_subplot(grid[k, 1]), results[row["pipeline"]],
                      row["pipeline"], norm)
        else:
            draw_declined(fig.add_subplot(grid[k, :]), row["pipeline"], row["status"], row["reason"])
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
