"""Transfer-function evaluation on the device (``@wp.func`` only; shared by every kernel module).

A transfer function is two arrays: ``tf_s`` (float32[K], strictly ascending control-point scalars)
and ``tf_v`` (vec4[K]: r, g, b, extinction). Values are linear between control points and clamped
outside, exactly like :meth:`warpvol.transfer.TransferFunction.evaluate`.
"""

import warp as wp

wp.set_module_options({"enable_backward": False})


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
