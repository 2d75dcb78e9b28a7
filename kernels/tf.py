"""Transfer-function evaluation on the device (``@wp.func`` only; shared by every kernel module).

A transfer function is two arrays: ``tf_s`` (float32[K], strictly ascending control-point scalars)
and ``tf_v`` (vec4[K]: r, g, b, extinction). Values are linear between control points and clamped
outside, exactly like :meth:`warpvol.scene.transfer.TransferFunction.evaluate`.

Searches are binary (O(log K)) and a segment walks only the control points it crosses, so the cost
of a segment is O(log K + pieces crossed). :func:`device_points` (host side) prepares the device
arrays: control points that lie on the line through their kept neighbours to within float32
rounding of the largest value of each channel (:data:`MERGE_REL`) are dropped, so a TF sampled
densely from a few linear pieces (a ParaView TF exported at 4,096 or 20,000 points) is integrated
as those few pieces, and a curved one as the pieces its curvature needs at float32 precision.
"""

from collections import OrderedDict

import numpy as np
import warp as wp

wp.set_module_options({"enable_backward": False})  # functions only: they take the calling kernel's options

#: merge tolerance of :func:`device_points`, relative to each channel's largest |value|: 2^-22,
#: two float32 units in the last place at the top of the channel (the upload to float32 itself moves
#: values by up to half of one)
MERGE_REL = 2.0 ** -22
_MERGED: "OrderedDict[bytes, np.ndarray]" = OrderedDict()


def merge_collinear(s, v, tol) -> np.ndarray:
    """Indices of the control points kept when every dropped point lies within ``tol`` (per channel)
    of the line through the kept points around it (so the piecewise-linear function moves by at most
    ``tol`` anywhere: its largest deviation from a chord is at a control point).

    ``s``: ascending scalars (K,), ``v``: values (K, C), ``tol``: (C,) >= 0. One pass, O(K): from an
    anchor the chord's slope must stay inside the intersection of the slope intervals that pass each
    point in between within ``tol``; the first point whose chord leaves it ends the run at the point
    before. The first and last points are always kept; a jump (two points very close in ``s``) keeps
    both, since no chord across it passes near both sides.
    """
    s = np.asarray(s, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64).reshape(len(s), -1)
    tol = np.asarray(tol, dtype=np.float64)
    k = len(s)
    if k <= 2:
        return np.arange(k)
    keep = [0]
    a = 0
    w = 16
    while a < k - 1:
        b = min(k - 1, a + w)
        ds = (s[a + 1:b + 1] - s[a])[:, None]
        dv = v[a + 1:b + 1] - v[a]
        m = dv / ds  # chord slopes from the anchor
        lo = np.maximum.accumulate((dv - tol) / ds, axis=0)
        hi = np.minimum.accumulate((dv + tol) / ds, axis=0)
        # chord to a + 1 + j must pass the points a + 1 .. a + j within tol: bounds up to row j - 1
        ok = np.ones(len(m), dtype=bool)
        ok[1:] = ((m[1:] >= lo[:-1]) & (m[1:] <= hi[:-1])).all(axis=1)
        bad = np.flatnonzero(~ok)
        if len(bad) == 0 and b < k - 1:
            w *= 2  # the run goes on past the window
            continue
        end = b if len(bad) == 0 else a + bad[0]  # the last point the run reaches
        keep.append(end)
        w = max(16, 2 * (end - a))
        a = end
    return np.asarray(keep, dtype=np.int64)


def device_points(points) -> np.ndarray:
    """The control points ``[s, r, g, b, extinction]`` (K, 5) a kernel should see: collinear runs
    merged (:func:`merge_collinear` with :data:`MERGE_REL` of each channel's largest |value|), float64.
    Results are memoised by content (a TF is uploaded by every render)."""
    p = np.ascontiguousarray(points, dtype=np.float64)
    if p.shape[0] <= 2:
        return p
    key = p.tobytes()
    hit = _MERGED.get(key)
    if hit is not None:
        _MERGED.move_to_end(key)
        return hit
    tol = MERGE_REL * np.abs(p[:, 1:]).max(axis=0)
    out = p[merge_collinear(p[:, 0], p[:, 1:], tol)]
    out.setflags(write=False)
    _MERGED[key] = out
    while len(_MERGED) > 16:
        _MERGED.popitem(last=False)
    return out


@wp.func
def tf_upper(s: float, tf_s: wp.array(dtype=float)) -> int:
    """Smallest index k with ``tf_s[k] > s`` (K if none)."""
    lo = int(0)
    hi = tf_s.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if tf_s[mid] > s:
            hi = mid
        else:
            lo = mid + 1
    return lo


@wp.func
def tf_lower(s: float, tf_s: wp.array(dtype=float)) -> int:
    """Smallest index k with ``tf_s[k] >= s`` (K if none)."""
    lo = int(0)
    hi = tf_s.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if tf_s[mid] >= s:
            hi = mid
        else:
            lo = mid + 1
    return lo


@wp.func
def tf_first_break(sf: float, sb: float, tf_s: wp.array(dtype=float)) -> int:
    """Index of the first control point strictly between ``sf`` and ``sb``, walking from ``sf``
    towards ``sb`` (either direction); -1 if the segment crosses none."""
    n = tf_s.shape[0]
    if sb > sf:
        k = tf_upper(sf, tf_s)
        if k < n:
            if tf_s[k] < sb:
                return k
    elif sb < sf:
        k = tf_lower(sf, tf_s) - 1
        if k >= 0:
            if tf_s[k] > sb:
                return k
    return -1


@wp.func
def tf_first_break_upper(ku: int, sf: float, sb: float, tf_s: wp.array(dtype=float)) -> int:
    """:func:`tf_first_break` given ``ku = tf_upper(sf, tf_s)`` (no second search: ``tf_lower(sf)`` is
    ``ku - 1`` when ``sf`` is the control point below ``ku``, else ``ku``)."""
    n = tf_s.shape[0]
    if sb > sf:
        if ku < n:
            if tf_s[ku] < sb:
                return ku
    elif sb < sf:
        k = ku - 1
        if k >= 0:
            if tf_s[k] == sf:
                k = k - 1
        if k >= 0:
            if tf_s[k] > sb:
                return k
    return -1


@wp.func
def tf_next_break(k: int, sf: float, sb: float, tf_s: wp.array(dtype=float)) -> int:
    """The control point after ``k`` on the walk from ``sf`` to ``sb``; -1 past ``sb``."""
    if sb > sf:
        if k + 1 < tf_s.shape[0]:
            if tf_s[k + 1] < sb:
                return k + 1
    else:
        if k - 1 >= 0:
            if tf_s[k - 1] > sb:
                return k - 1
    return -1


@wp.func
def tf_eval(s: float, tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4)) -> wp.vec4:
    """(r, g, b, extinction) at scalar ``s``; clamped to the end values outside the range."""
    return tf_eval_upper(s, tf_upper(s, tf_s), tf_s, tf_v)


@wp.func
def tf_eval_upper(s: float, k: int, tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4)) -> wp.vec4:
    """:func:`tf_eval` given ``k = tf_upper(s, tf_s)`` (a walker keeping ``k`` knows whether a
    segment crosses a control point: it does iff ``k`` differs at its ends)."""
    n = tf_s.shape[0]
    if k == 0:
        return tf_v[0]
    if k >= n:
        return tf_v[n - 1]
    s0 = tf_s[k - 1]
    s1 = tf_s[k]
    w = (s - s0) / (s1 - s0)
    w = wp.clamp(w, 0.0, 1.0)
    return tf_v[k - 1] * (1.0 - w) + tf_v[k] * w


@wp.func
def tf_upper_from(s: float, k: int, tf_s: wp.array(dtype=float)) -> int:
    """:func:`tf_upper` found by stepping from a nearby index ``k`` (a walker's previous value): the
    same result (NaN included: ``K``), in O(control points crossed) instead of a binary search."""
    n = tf_s.shape[0]
    while k < n:
        if tf_s[k] > s:
            break
        k += 1
    while k > 0:
        if not (tf_s[k - 1] > s):
            break
        k -= 1
    return k
