"""Ranges of a transfer function: its largest density over scalar intervals (host, float64), for the
checks that decide whether float32 or a table's resolution can draw a cell right."""

from __future__ import annotations

import numpy as np


def _density_points(tf) -> tuple[np.ndarray, np.ndarray]:
    """Control-point scalars and densities (extinction, plus the largest colour channel for the
    emission-density model, which multiplies a segment's length as the extinction does)."""
    p = np.asarray(tf.points, dtype=np.float64)
    dens = p[:, 4] + (p[:, 1:4].max(axis=1) if tf.emission == "emission_density" else 0.0)
    return p[:, 0], dens


def density_bound(tf) -> float:
    """Largest density of ``tf`` anywhere (a bound for :func:`density_max` over any range)."""
    return float(_density_points(tf)[1].max(initial=0.0))


def density_max(tf, smin: np.ndarray, smax: np.ndarray) -> np.ndarray:
    """Largest density of ``tf`` over each scalar range ``[smin, smax]`` (piecewise linear: the ends
    and the control points between), float64."""
    s, dens = _density_points(tf)
    out = np.maximum(np.interp(smin, s, dens), np.interp(smax, s, dens))
    lo = np.searchsorted(s, smin, side="right")  # control points strictly inside: lo .. hi-1
    hi = np.searchsorted(s, smax, side="left")
    has = hi > lo
    if not has.any():
        return out
    # range maximum over control points by a sparse table (log K levels)
    levels = [dens]
    while 2 ** len(levels) <= len(dens):
        prev, w = levels[-1], 2 ** (len(levels) - 1)
        levels.append(np.maximum(prev[:-w], prev[w:]))
    a, b = lo[has], hi[has]
    k = np.floor(np.log2(b - a)).astype(np.int64)
    m = np.empty(len(a))
    for lv in np.unique(k):
        sel = k == lv
        tab = levels[lv]
        m[sel] = np.maximum(tab[a[sel]], tab[b[sel] - 2 ** lv])
    out[has] = np.maximum(out[has], m)
    return out
