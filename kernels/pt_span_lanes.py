"""The scalar helper functions of :mod:`warpvol.kernels.pt_span`'s span draw (``@wp.func``, inlined into
its kernels): the attribute plane, clamp and "moved" test of one lane value, the segment bounds of a
clamped triangle, the bin entry order, the exact int64 row stepping of each edge's run
(:func:`edge_start` / :func:`edge_next`, :func:`edge_lo` / :func:`edge_hi`: the runs of
:func:`~warpvol.kernels.raster.row_span`), the blend's fp32 short cuts (:func:`blend_kind` /
:func:`blend_by`) and a rare lane's TF value (:func:`tf_lane_value`). Each does the same float32 operations
in the same order as the scalar function it stands for (``fuse_fp`` off in the kernels' modules).
"""

import warp as wp

from .blend import ONE, ONE_MINUS_DST_ALPHA, ONE_MINUS_SRC_ALPHA, BlendState, blend
from .pt import CLAMP_ABS, PERSP_OFF, vec8f

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.func
def exp_neg_thin(x: float) -> float:
    """:func:`~warpvol.kernels.integrate.exp_neg`'s polynomial (``x <= THIN_DEPTH``), same operations."""
    x2 = x * x
    return (1.0 - x) + x2 * ((0.5 - x * (1.0 / 6.0)) + x2 * (1.0 / 24.0))


@wp.func
def plane1(a0: float, g: float, t: float, ry: float) -> float:
    """One attribute from its plane, as the draw's ``a0 + gx * t + ry`` rounds it."""
    return a0 + g * t + ry


@wp.func
def clamp1(x: float, lo: float, hi: float) -> float:
    """:func:`~warpvol.kernels.pt_draw.clamp8`'s clamp of one attribute."""
    return wp.min(wp.max(lo, x), hi)


@wp.func
def moved1(x: float, y: float, tol: float) -> int:
    """:func:`~warpvol.kernels.pt_draw.clamp8`'s test of one attribute (0 where ``y == x``)."""
    return wp.where(wp.abs(y - x) > tol + CLAMP_ABS, 1, 0)


@wp.func
def segment_bounds(lo: vec8f, hi: vec8f, mode: int) -> wp.vec4:
    """``(min sf, max sf, min sb, max sb)`` over the fragments of a triangle whose attributes are clamped into
    ``[lo, hi]`` (:func:`~warpvol.kernels.pt_draw.zero_segments`' corners: the rounded products are monotone in
    each factor); all NaN where there is no such bound (``1 / w`` not positive or not finite)."""
    if mode == PERSP_OFF:
        return wp.vec4(lo[0], hi[0], lo[1], hi[1])
    if not (lo[2] > 0.0 and lo[3] > 0.0):
        nan = wp.nan
        return wp.vec4(nan, nan, nan, nan)
    wf0 = 1.0 / hi[2]
    wf1 = 1.0 / lo[2]
    wb0 = 1.0 / hi[3]
    wb1 = 1.0 / lo[3]
    if not (wf1 < 3.4e38 and wb1 < 3.4e38):  # an infinite reciprocal: 0 * inf would be NaN, which min / max drop
        nan = wp.nan
        return wp.vec4(nan, nan, nan, nan)
    return wp.vec4(wp.min(wp.min(lo[0] * wf0, lo[0] * wf1), wp.min(hi[0] * wf0, hi[0] * wf1)),
                   wp.max(wp.max(lo[0] * wf0, lo[0] * wf1), wp.max(hi[0] * wf0, hi[0] * wf1)),
                   wp.min(wp.min(lo[1] * wb0, lo[1] * wb1), wp.min(hi[1] * wb0, hi[1] * wb1)),
                   wp.max(wp.max(lo[1] * wb0, lo[1] * wb1), wp.max(hi[1] * wb0, hi[1] * wb1)))


@wp.func
def bin_entry(e0: int, ne: int, q: int, back: bool) -> int:
    """The index in ``tri_of`` of a tile's ``q``-th bin entry (``e0``, ``ne`` entries; in reverse for ``back``, front
    to back), ``q`` past the last taken as the last."""
    k = wp.min(q, ne - 1)
    return wp.where(back, e0 + ne - 1 - k, e0 + k)


@wp.func
def edge_floor(e: wp.int64, d: wp.int64) -> wp.int64:
    """``floor(e / d)`` for ``d > 0`` (exact, int64)."""
    q = e / d
    return wp.where(q * d > e, q - wp.int64(1), q)


@wp.func
def edge_start(e: wp.int64, sj: wp.int64, si: wp.int64):
    """One edge's row stepper: for an edge function ``e`` at a row's first pixel, ``sj`` per pixel and ``si``
    per row, ``(F, R, d, dq, dr)`` with ``d = |sj|`` (1 for ``sj = 0``), ``e = F d + R``, ``0 <= R < d`` and
    ``si = dq d + dr``, ``0 <= dr < d``: :func:`edge_next` steps ``F`` and ``R`` to the next row with adds."""
    d = wp.where(sj == wp.int64(0), wp.int64(1), wp.abs(sj))
    f = edge_floor(e, d)
    dq = edge_floor(si, d)
    return f, e - f * d, d, dq, si - dq * d


@wp.func
def edge_next(f: wp.int64, r: wp.int64, dq: wp.int64, dr: wp.int64, d: wp.int64):
    """:func:`edge_start`'s ``(F, R)`` one row down (``e + si``), exact."""
    x = r + dr
    c = x >= d
    return f + dq + wp.where(c, wp.int64(1), wp.int64(0)), x - wp.where(c, d, wp.int64(0))


@wp.func
def edge_lo(f: wp.int64, sj: wp.int64, n: int) -> int:
    """The first covered pixel of a row of ``n`` as one edge bounds it (``F = floor(e / |sj|)``): for
    ``sj > 0`` :func:`~warpvol.kernels.raster.first_nonneg` (``-F`` clamped into ``[0, n]``), else 0."""
    return wp.where(sj > wp.int64(0), int(wp.clamp(-f, wp.int64(0), wp.int64(n))), 0)


@wp.func
def edge_hi(f: wp.int64, sj: wp.int64, n: int) -> int:
    """The last covered pixel of a row of ``n`` as one edge bounds it: for ``sj < 0``
    :func:`~warpvol.kernels.raster.last_nonneg` (``F`` clamped into ``[-1, n - 1]``); for ``sj = 0`` -1 where
    ``e < 0`` (``F = e``); else ``n - 1``."""
    hz = wp.where(sj == wp.int64(0) and f < wp.int64(0), -1, n - 1)
    return wp.where(sj < wp.int64(0), int(wp.clamp(f, wp.int64(-1), wp.int64(n - 1))), hz)


@wp.func
def blend_kind(bs: BlendState) -> int:
    """Which of :func:`~warpvol.kernels.blend.blend_float`'s fp32 short cuts ``bs`` takes: 1 "under", 2 "over",
    0 neither (then :func:`~warpvol.kernels.blend.blend`); once per kernel."""
    if bs.fmt.kind == 0 or bs.fmt.kind == 2:
        return 0
    if bs.src_rgb == ONE_MINUS_DST_ALPHA and bs.src_a == ONE_MINUS_DST_ALPHA and bs.dst_rgb == ONE and bs.dst_a == ONE:
        return 1
    if bs.src_rgb == ONE and bs.src_a == ONE and bs.dst_rgb == ONE_MINUS_SRC_ALPHA and bs.dst_a == ONE_MINUS_SRC_ALPHA:
        return 2
    return 0


@wp.func
def blend_by(kind: int, bs: BlendState, src: wp.vec4, dst: wp.vec4, x: int, y: int, prim: int) -> wp.vec4:
    """:func:`~warpvol.kernels.blend.blend` given :func:`blend_kind` (the same operations: no state read per
    fragment on the fp32 paths)."""
    if kind == 1:
        g = 1.0 - dst[3]
        return wp.vec4(src[0] * g + dst[0], src[1] * g + dst[1], src[2] * g + dst[2], src[3] * g + dst[3])
    if kind == 2:
        f = 1.0 - src[3]
        return wp.vec4(src[0] + dst[0] * f, src[1] + dst[1] * f, src[2] + dst[2] * f, src[3] + dst[3] * f)
    return blend(bs, src, dst, x, y, prim)


@wp.func
def tf_lane_value(s: float, k: int, ntf: int, s0: float, s1: float, r0: float, g0: float, b0: float, a0: float,
                  r1: float, g1: float, b1: float, a1: float) -> wp.vec4:
    """The TF value at ``s`` from its interval ``k = tf_upper(s)`` and the control points around it as a lane
    selected them (``k - 1`` and ``k``, clamped): the lane loop's operations (those of
    :func:`~warpvol.kernels.tf.tf_eval_upper`), for a rare lane."""
    e = k == 0 or k >= ntf  # tf_eval_upper's ends: the end point's value
    w = wp.clamp((s - s0) / (s1 - s0), 0.0, 1.0)
    return wp.vec4(wp.where(e, r1, r0 * (1.0 - w) + r1 * w), wp.where(e, g1, g0 * (1.0 - w) + g1 * w),
                   wp.where(e, b1, b0 * (1.0 - w) + b1 * w), wp.where(e, a1, a0 * (1.0 - w) + a1 * w))
