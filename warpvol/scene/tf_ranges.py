"""Ranges of a transfer function: its largest density and its steepest slopes over scalar intervals
(host, float64), for the checks that decide whether float32 or a table's resolution can draw a cell
right."""

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
    out[has] = np.maximum(out[has], _range_max(dens, lo[has], hi[has]))
    return out


def _range_max(values: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``max(values[a[i]:b[i]])`` for each ``i`` (``b > a``), by a sparse table (log K levels)."""
    levels = [values]
    while 2 ** len(levels) <= len(values):
        prev, w = levels[-1], 2 ** (len(levels) - 1)
        levels.append(np.maximum(prev[:-w], prev[w:]))
    k = np.floor(np.log2(b - a)).astype(np.int64)
    m = np.empty(len(a))
    for lv in np.unique(k):
        sel = k == lv
        tab = levels[lv]
        m[sel] = np.maximum(tab[a[sel]], tab[b[sel] - 2 ** lv])
    return m


def slope_max(tf, smin: np.ndarray, smax: np.ndarray, relative: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Largest rates of change of ``tf`` per unit scalar over each range ``[smin, smax]``: of its
    colour (the largest channel) and of its extinction, over the segments between control points
    the range overlaps (0 beyond the transfer function's ends, where it is constant), float64.
    ``relative``: per unit of the scalar's size instead (each segment's rate times its far end's
    |s|: what a relative rounding of the scalar there moves the value by)."""
    p = np.asarray(tf.points, dtype=np.float64)
    smin, smax = np.asarray(smin, dtype=np.float64), np.asarray(smax, dtype=np.float64)
    if len(p) < 2:
        return np.zeros(len(smin)), np.zeros(len(smin))
    gap = np.diff(p[:, 0])
    if relative:
        gap = gap / np.maximum(np.abs(p[:-1, 0]), np.abs(p[1:, 0]))
    colour = np.abs(np.diff(p[:, 1:4], axis=0)).max(axis=1) / gap
    ext = np.abs(np.diff(p[:, 4])) / gap
    a = np.clip(np.searchsorted(p[:, 0], smin, side="right") - 1, 0, len(gap))  # segments a .. b-1
    b = np.clip(np.searchsorted(p[:, 0], smax, side="left"), 0, len(gap))
    out_c, out_e = np.zeros(len(smin)), np.zeros(len(smin))
    has = b > a
    if has.any():
        out_c[has] = _range_max(colour, a[has], b[has])
        out_e[has] = _range_max(ext, a[has], b[has])
    return out_c, out_e
