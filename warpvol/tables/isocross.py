"""Iso-crossing table (Espinha & Celes 2005 §4.2) for partial pre-integration.

A 2D table over normalised ``(sf, sb)`` storing ``(s_iso, next_s_iso)``: the first TF control point
at or beyond ``sf`` in the direction of ``sb``, and the one after it (``-1`` where there is none).
The ray step (the paper's Fig. 6, :func:`split_segment`) looks it up with nearest sampling, steps to
``next_s_iso`` when ``sf`` already equals ``s_iso`` (that rule stops the infinite loop when ``sf`` sits
on an iso-surface) and splits the segment only if ``|sb - sf| > |s_iso - sf|``.

``limit="segment"`` (default) reports ``s_iso`` only if it lies within ``sb`` plus one texel (the
paper's "-1: no iso-surface between sf and sb"; the texel of slack covers nearest sampling of sb);
``limit="direction"`` reports the first control point in the direction of ``sb`` regardless of
``sb`` (so that, as in the paper's worked example, the lookup at (0.5, 0.7) yields 0.75 and the ray
step rejects it). Both give the same segments. ``next_s_iso`` is never limited by ``sb``.

``anchor="centre"`` (default, the paper's table) searches from each texel's centre, so a control
point between ``sf`` and its texel's centre is missed by a nearest lookup; ``anchor="edge"`` searches
from the texel's edge behind ``sf`` and the ray step takes ``next_s_iso`` when ``s_iso`` lies behind
``sf`` -- exact splits whenever control points are more than one texel apart.

The table depends only on the TF's control-point positions (normalised over the TF range), so its
cache key omits colours and extinctions: editing those does not rebuild it. Stored as fp32 (the
default: the ray step compares ``sf == s_iso`` exactly) or fp16.
"""

from __future__ import annotations

import hashlib

import numpy as np

from warpvol.tables.base import Axis, Table
from warpvol.tables.common import check_choice, check_res, check_tf, farr, finish, kernels, table_key, timed

LIMITS = {"segment": 1, "direction": 0}


def iso_values(tf) -> np.ndarray:
    """The TF's control points normalised to [0, 1] over its range (float32, ascending): every point
    as given, collinear runs included. The paper decomposes the TF into linear segments and splits a
    ray at every segment boundary, so a TF of 255 segments costs 255 iso-surfaces even where
    neighbouring segments are collinear (the partial pre-integration walk reads the same unmerged points:
    :func:`warpvol.shared.integration.integ_setup`)."""
    lo, hi = tf.srange
    return ((np.asarray(tf.points, dtype=np.float64)[:, 0] - lo) / (hi - lo)).astype(np.float32)


def iso_hash(tf) -> str:
    return "iso:" + hashlib.sha256(np.ascontiguousarray(iso_values(tf)).tobytes()).hexdigest()[:16]


def build_isocross(tf=None, *, n: int = 256, limit: str = "segment", iso=None, format: str = "fp32",
                   anchor: str = "centre", device: str = "cpu") -> Table:
    """Iso-crossing table ``data[sb, sf] = (s_iso, next_s_iso)``.

    Parameters
    ----------
    tf : TransferFunction, optional
        Control points taken from it (normalised); or give ``iso`` directly.
    n : int
        Resolution of both axes (texel centres ``(k + 0.5) / n``).
    limit : str
        ``"segment"`` or ``"direction"`` (see the module docstring).
    iso : array_like, optional
        Normalised iso values (ascending) instead of ``tf``.
    format : str
        ``fp32`` or ``fp16``.
    anchor : str
        ``centre`` or ``edge`` (see the module docstring).
    device : str
    """
    n = check_res("n", n, 2)
    check_choice("limit", limit, tuple(LIMITS))
    check_choice("anchor", anchor, ("centre", "edge"))
    check_choice("format", format, ("fp32", "fp16"))
    if iso is None:
        check_tf(tf)
        iv = iso_values(tf)
        h = iso_hash(tf)
    else:
        iv = np.asarray(iso, dtype=np.float32).ravel()
        if iv.size == 0 or np.any(np.diff(iv) <= 0) or not np.isfinite(iv).all():
            raise ValueError("iso: expected finite, strictly ascending values")
        h = "iso:" + hashlib.sha256(iv.tobytes()).hexdigest()[:16]
    import warp as wp

    k = kernels()
    ax = Axis("sf", n), Axis("sb", n)
    key = table_key("isocross", h, n=n, limit=limit, format=format,
                    **({"anchor": anchor} if anchor != "centre" else {}))
    meta = {"builder": "isocross", "n_iso": int(iv.size), "limit": limit, "anchor": anchor}
    out = wp.zeros((n, n), dtype=wp.vec2, device=device)
    x = farr(ax[0].nodes, device)
    with timed(meta, device=device):
        wp.launch(k.iso_table, dim=(n, n), device=device,
                  inputs=[x, farr(iv, device), LIMITS[limit], 1.0 / n, 0.5 / n + 2.0 ** -20 if anchor == "edge" else 0.0, out])
    return finish("isocross", out.numpy(), (ax[1], ax[0]), ("s_iso", "next_s_iso"), format, key, meta)


def lookup_nearest(table: Table, sf: float, sb: float) -> tuple[float, float]:
    """Nearest-texel lookup (GL_NEAREST: texel ``floor(x n)`` clamped)."""
    n = table.data.shape[0]
    i = min(max(int(np.floor(sf * n)), 0), n - 1)
    j = min(max(int(np.floor(sb * n)), 0), n - 1)
    v = table.data[j, i]
    return float(v[0]), float(v[1])


def split_segment(table: Table, sf: float, sb: float, max_steps: int = 100000) -> list[tuple[float, float]]:
    """The sub-segments ``[(sf, s1), (s1, s2), ..., (sk, sb)]`` a ray step produces (paper's Fig. 6)."""
    segs = []
    for _ in range(max_steps):
        s_iso, nxt = lookup_nearest(table, sf, sb)
        end = sb
        if s_iso != -1.0:
            if sf == s_iso:
                s_iso = nxt
            if abs(sb - sf) > abs(s_iso - sf):
                end = s_iso
        segs.append((sf, end))
        if end == sb:
            return segs
        sf = end
    raise RuntimeError("split_segment: no progress")
