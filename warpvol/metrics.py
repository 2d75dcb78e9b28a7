"""Image error metrics over premultiplied RGBA images."""

from __future__ import annotations

import math

import numpy as np


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


def write_error_png(path, image: np.ndarray, reference: np.ndarray, outputs=None) -> float:
    """PNG of :func:`error_image` scaled so its maximum is white; returns that maximum.

    With ``outputs`` (a :class:`warpvol.io.Outputs`) the file is staged there instead of written now.
    """
    from warpvol.io import Outputs

    err = error_image(image, reference)
    scale = float(err.max())
    if outputs is None:
        with Outputs() as out:
            out.png(path, err / max(scale, 1e-30))
    else:
        outputs.png(path, err / max(scale, 1e-30))
    return scale
