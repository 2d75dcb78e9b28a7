"""Pixel marks of :mod:`warpvol.shared.pixel_marks` as Warp kernels on the CPU.

``k_near_segments``: one thread per window-space segment ``a b``, stepped along its major axis as
:func:`warpvol.shared.pixel_marks.near_segment_pixels` steps it (the same float64 operations in the same
order, no fused multiply-adds): per pixel column (row) of its span the one row (column) whose centre is
nearest the segment. A centre inside the window whose squared distance to the segment is within the
bound is appended (pixel, segment and the distance's two components, for the host's ``np.hypot`` test:
the exact decision of the NumPy function); ``n[0]`` counts them all, also past ``pix``'s length (the host
then runs it again with room for them). Atomics: one launch on the CPU.
"""

import warp as wp

wp.set_module_options({"enable_backward": False, "fuse_fp": False})  # NumPy's roundings, no contraction


@wp.func
def clip64(x: wp.float64, lo: wp.float64, hi: wp.float64) -> wp.float64:
    return wp.min(wp.max(x, lo), hi)


@wp.kernel
def k_near_segments(ax: wp.array(dtype=wp.float64), ay: wp.array(dtype=wp.float64), bx: wp.array(dtype=wp.float64),
                    by: wp.array(dtype=wp.float64), w: int, h: int, delta: wp.float64, bound2: wp.float64,
                    n: wp.array(dtype=wp.int32), pix: wp.array(dtype=wp.int64), seg: wp.array(dtype=wp.int32),
                    qx: wp.array(dtype=wp.float64), qy: wp.array(dtype=wp.float64)):
    s = wp.tid()
    px = ax[s]
    py = ay[s]
    dx = bx[s] - px
    dy = by[s] - py
    flat = wp.abs(dx) >= wp.abs(dy)
    pm = px  # major axis x (flat): a column per step, the nearest row found
    dm = dx
    pn = py
    dn = dy
    lim = w
    limn = h
    if not flat:
        pm = py
        dm = dy
        pn = px
        dn = dx
        lim = h
        limn = w
    half = wp.float64(0.5)
    one = wp.float64(1.0)
    zero = wp.float64(0.0)
    lo = clip64(wp.min(pm, pm + dm) - delta - half, -one, wp.float64(lim))
    hi = clip64(wp.max(pm, pm + dm) + delta - half, -one, wp.float64(lim))
    c0 = int(wp.ceil(lo))
    cnt = int(wp.floor(hi)) - c0 + 1
    den = dm
    if dm == zero:
        den = one
    ee = wp.max(dx * dx + dy * dy, wp.float64(1e-300))
    for k in range(cnt):
        c = c0 + k
        m = wp.float64(c) + half
        u = clip64((m - pm) / den, zero, one)
        of = wp.rint(pn + u * dn - half)
        if c >= 0 and c < lim and of >= zero and of < wp.float64(limn):
            o = wp.float64(int(of)) + half
            rx = m - px
            ry = o - py
            if not flat:
                rx = o - px
                ry = m - py
            t = clip64((rx * dx + ry * dy) / ee, zero, one)
            ex = rx - t * dx
            ey = ry - t * dy
            if ex * ex + ey * ey <= bound2:
                slot = wp.atomic_add(n, 0, 1)
                if slot < pix.shape[0]:
                    jj = c
                    ii = int(of)
                    if not flat:
                        jj = int(of)
                        ii = c
                    pix[slot] = wp.int64(ii) * wp.int64(w) + wp.int64(jj)
                    seg[slot] = s
                    qx[slot] = ex
                    qy[slot] = ey
