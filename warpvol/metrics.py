"""Image error metrics over premultiplied RGBA images."""

from __future__ import annotations

import math

import numpy as np


def image_error(image: np.ndarray, reference: np.ndarray) -> dict:
    """RMSE, max absolute error and PSNR (peak 1.0) over all RGBA values.

    Examples
    --------
    >>> a = np.zeros((2, 2, 4)); b = a.copy(); b[0, 0, 0] = 0.1
    >>> e = image_error(a, b); round(e["rmse"], 4), e["max_abs"]
    (0.025, 0.1)
    """
    a = np.asarray(image, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"image shape {a.shape} differs from reference shape {b.shape}")
    d = a - b
    rmse = float(np.sqrt(np.mean(d * d)))
    return {
        "rmse": rmse,
        "max_abs": float(np.abs(d).max()),
        "psnr": float("inf") if rmse == 0 else 20.0 * math.log10(1.0 / rmse),
    }


def error_image(image: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Per-pixel max absolute error over the RGBA channels, (H, W)."""
    return np.abs(np.asarray(image, np.float64) - np.asarray(reference, np.float64)).max(axis=-1)


def write_error_png(path, image: np.ndarray, reference: np.ndarray) -> float:
    """PNG of :func:`error_image` scaled so its maximum is white; returns that maximum."""
    from .io import write_png

    err = error_image(image, reference)
    scale = float(err.max())
    write_png(path, err / max(scale, 1e-30))
    return scale
