"""Image error metrics over premultiplied RGBA images."""

from __future__ import annotations

import math

import numpy as np

from warpvol.io import Outputs


def image_error(image: np.ndarray, reference: np.ndarray) -> dict:
    """RMSE, max absolute error and PSNR (peak 1.0) over all RGBA values.

    The result goes into strict JSON reports (no ``Infinity``/``NaN``), so the PSNR of an exact match
    (``rmse == 0``, unbounded) is ``None`` (JSON ``null``) and ``psnr_note`` says why.

    Examples
    --------
    >>> a = np.zeros((2, 2, 4)); b = a.copy(); b[0, 0, 0] = 0.1
    >>> e = image_error(a, b); round(e["rmse"], 4), e["max_abs"], round(e["psnr"], 2)
    (0.025, 0.1, 32.04)
    >>> image_error(a, a)
    {'rmse': 0.0, 'max_abs': 0.0, 'psnr': None, 'psnr_note': 'exact match (rmse = 0): PSNR is unbounded, reported as null'}
    """
    a = np.asarray(image, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"image shape {a.shape} differs from reference shape {b.shape}")
    d = a - b
    rmse = float(np.sqrt(np.mean(d * d)))
    out = {"rmse": rmse, "max_abs": float(np.abs(d).max()),
           "psnr": None if rmse == 0 else 20.0 * math.log10(1.0 / rmse)}
    if rmse == 0:
        out["psnr_note"] = "exact match (rmse = 0): PSNR is unbounded, reported as null"
    return out


def error_image(image: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Per-pixel max absolute error over the RGBA channels, (H, W)."""
    return np.abs(np.asarray(image, np.float64) - np.asarray(reference, np.float64)).max(axis=-1)


#: lowest error an error map's logarithmic colour scale shows (smaller errors, exact zeros included, take
#: its colour): about a tenth of float32's resolution at 1
ERROR_FLOOR = 1e-8
#: colour map of the error maps
ERROR_CMAP = "magma"
#: what an error map shows (its colour bar's label)
ERROR_LABEL = "max |image - reference| over RGBA (log scale)"


def error_norm(*maps: np.ndarray, floor: float = ERROR_FLOOR):
    """One logarithmic colour scale (matplotlib ``LogNorm``) for all of ``maps``: from ``floor`` to
    their largest value (at least ten times ``floor``), so maps drawn with it compare by colour.

    Examples
    --------
    >>> n = error_norm(np.array([[0.0, 1e-3]]), np.array([[2e-2]]))
    >>> n.vmin, n.vmax, type(n).__name__
    (1e-08, 0.02, 'LogNorm')
    """
    from matplotlib.colors import LogNorm

    top = max([float(np.max(m)) for m in maps if np.size(m)] + [0.0])
    return LogNorm(vmin=floor, vmax=max(top, 10.0 * floor), clip=True)


def draw_error(ax, err: np.ndarray, norm, *, colorbar: bool = True):
    """Draw error map ``err`` on matplotlib axes ``ax`` with ``norm`` (:func:`error_norm`); values below
    the floor take its colour. With ``colorbar``, a colour bar labelled :data:`ERROR_LABEL`. Returns
    the image."""
    im = ax.imshow(np.maximum(np.asarray(err, np.float64), norm.vmin), cmap=ERROR_CMAP, norm=norm,
                   interpolation="nearest")
    ax.set_axis_off()
    if colorbar:
        cb = ax.figure.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
        cb.set_label(ERROR_LABEL, fontsize=8)
        cb.ax.tick_params(labelsize=7)
    return im


#: height in pixels of the text (title, colour-bar ticks and label) in :func:`error_png_bytes`'s PNG
ERROR_PNG_TEXT_PX = 13


def error_png_bytes(err: np.ndarray, *, title: str | None = None, norm=None) -> bytes:
    """A PNG of error map ``err`` (H, W) on a logarithmic colour scale with its colour bar (the scale
    written beside it), the map drawn at least 256 pixels high (each error pixel a block of pixels) and its
    text :data:`ERROR_PNG_TEXT_PX` pixels high, legible when the PNG is shown at its own size."""
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    err = np.asarray(err, np.float64)
    norm = error_norm(err) if norm is None else norm
    h, w = err.shape
    s = max(1, int(np.ceil(256 / max(h, 1))))
    dpi = 100
    pt = ERROR_PNG_TEXT_PX * 72 / dpi  # font size in points for text that many pixels high
    W, H, left, bottom, _top = w * s + 110, h * s + 80, 10, 16, 64  # figure and margins in pixels
    fig = Figure(figsize=(W / dpi, H / dpi), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((left / W, bottom / H, w * s / W, h * s / H))
    draw_error(ax, err, norm, colorbar=False)
    cax = fig.add_axes(((left + w * s + 14) / W, bottom / H, 12 / W, h * s / H))
    cb = fig.colorbar(ax.images[0], cax=cax)
    cb.ax.tick_params(labelsize=pt)  # what the colours mean is the title's first line (a vertical label would not fit)
    text = title if title is not None else ("max |image - reference| over RGBA\n"
                                            f"log scale {norm.vmin:.0e} .. {norm.vmax:.1e}, max {float(err.max()):.2e}\n"
                                            f"(below {norm.vmin:.0e}, exact too: the lowest colour)")
    fig.text(left / W, 1 - 4 / H, text, fontsize=pt, va="top")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def write_error_png(path, image: np.ndarray, reference: np.ndarray, outputs=None) -> float:
    """PNG of :func:`error_image` on a logarithmic colour scale (:data:`ERROR_FLOOR` to the maximum)
    with a colour bar and the scale written on it; returns the maximum.

    With ``outputs`` (a :class:`warpvol.io.Outputs`) the file is staged there instead of written now.
    """

    err = error_image(image, reference)
    data = error_png_bytes(err)
    if outputs is None:
        with Outputs() as out:
            out.bytes(path, data)
    else:
        outputs.bytes(path, data)
    return float(err.max())
