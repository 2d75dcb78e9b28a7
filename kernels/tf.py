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
def tf_eval(s: float, tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4)) -> wp.vec4:
    """(r, g, b, extinction) at scalar ``s``; clamped to the end values outside the range."""
    n = tf_s.shape[0]
    k = tf_upper(s, tf_s)
    if k == 0:
        return tf_v[0]
    if k >= n:
        return tf_v[n - 1]
    s0 = tf_s[k - 1]
    s1 = tf_s[k]
    w = (s - s0) / (s1 - s0)
    w = wp.clamp(w, 0.0, 1.0)
    return tf_v[k - 1] * (1.0 - w) + tf_v[k] * w
