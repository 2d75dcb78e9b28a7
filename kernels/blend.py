"""Blending unit of the emulated GPU: blend factors, frame-buffer rounding, alpha dithering.

Frame buffers hold ``vec4`` float32 values that are always values of the frame-buffer format
(fixed-point codes decoded as ``c / (2^n - 1)``; fp16 values; fp32 values).

Arithmetic (``blend(bs, src, dst, x, y, prim)``):

* **fixed point** (UNORM n bits, N = 2^n - 1), integer arithmetic as blending hardware did:
  the fragment colour is clamped to [0, 1] and converted to n-bit codes S with the format's rounding
  (alpha optionally *dithered*, below); the destination codes D are exact; the constant colour K is
  converted like S; factors are codes (ONE = N, ONE_MINUS_X = N - X). Each channel
  ``R = round((S Fs + D Fd) / N)`` exactly in integers (int32 up to 14 bits, else int64; N is odd, so exact ties cannot occur; the
  ``truncate`` rounding mode floors instead), then the out-of-range policy: saturate ``min(R, N)`` or
  wrap ``R & N``. The buffer is thus re-quantised after every blend.
* **fixed point, llvmpipe arithmetic** (``BlendState.arith = ARITH_LLVMPIPE``): Mesa llvmpipe's
  integer blend. The fragment colour converts as llvmpipe's ``float -> unorm`` does
  (``rint(fp32(x (2^n - 1) / 2^n) 2^n)``: ties to even, after an fp32 product), each *product* is
  rounded on its own with llvmpipe's normalised multiply ``(ab + (ab >> n) + 2^(n-1)) >> n`` (which
  misses ``round(ab / N)`` for 24 of the 65,536 byte pairs at n = 8), and the two terms are added
  with saturation (or the wrap policy). Dithering, if on, still decides the alpha code.
* **fp16**: S, D, K are rounded to binary16 (fragment colours are not clamped, as with float buffers);
  ``S Fs`` and ``D Fd`` are exact in fp32 (11-bit x 11-bit significands); their fp32 sum is rounded
  to binary16 (round to nearest even).
* **fp16, program compositing** (``BlendState.arith = ARITH_PROGRAM``): the colour buffer read as a
  texture and composited in an fp32 fragment program (Kraus et al. 2004's Quadro FX 3000): S, K and
  the factors stay fp32, the fp32 result is rounded to binary16 when written.
* **fp32**: plain fp32 ``S Fs + D Fd`` (``fuse_fp=False``: no FMA contraction).

Alpha dithering (Kraus, Qiao & Ebert 2004, Sec. 4.2), fixed-point only: with ``v = 255 a`` (N a in
general) and ``q`` from a pseudo-random table, ``S_a = floor(v) + 1`` if ``v - floor(v) > q`` else
``floor(v)``. ``q = table[hash(x, y, prim, seed) & mask]`` (:func:`dither_index`), so the same
fragment of the same primitive always gets the same threshold, and E[S_a] = v (unbiased).
"""

import warp as wp

from .formats import NumFmt, fp16_round, unorm_encode

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

ZERO = wp.constant(0)
ONE = wp.constant(1)
SRC_COLOR = wp.constant(2)
ONE_MINUS_SRC_COLOR = wp.constant(3)
SRC_ALPHA = wp.constant(4)
ONE_MINUS_SRC_ALPHA = wp.constant(5)
DST_COLOR = wp.constant(6)
ONE_MINUS_DST_COLOR = wp.constant(7)
DST_ALPHA = wp.constant(8)
ONE_MINUS_DST_ALPHA = wp.constant(9)
CONSTANT_COLOR = wp.constant(10)
ONE_MINUS_CONSTANT_COLOR = wp.constant(11)
CONSTANT_ALPHA = wp.constant(12)
ONE_MINUS_CONSTANT_ALPHA = wp.constant(13)

ARITH_EXACT = wp.constant(0)
ARITH_LLVMPIPE = wp.constant(1)
ARITH_PROGRAM = wp.constant(2)


@wp.struct
class BlendState:
    fmt: NumFmt
    src_rgb: int
    dst_rgb: int
    src_a: int
    dst_a: int
    constant: wp.vec4
    dither: int  # 0 off, 1 alpha dithering
    dither_table: wp.array(dtype=wp.float32)
    dither_mask: int  # table size - 1 (power of two)
    dither_seed: int
    arith: int  # ARITH_EXACT (one rounding per channel) or ARITH_LLVMPIPE (one per product)


@wp.func
def llvmpipe_encode(x: float, bits: int) -> int:
    """llvmpipe's fp32 -> unorm conversion of ``x`` in [0, 1]: ``rint(fp32(x (2^n - 1) / 2^n) 2^n)``."""
    s = float(1 << bits)
    v = wp.clamp(x, 0.0, 1.0)
    if wp.isnan(x):
        v = 0.0
    return int(wp.rint((v * (float((1 << bits) - 1) / s)) * s))


@wp.func
def llvmpipe_mul(a: wp.int64, b: wp.int64, bits: int) -> wp.int64:
    """llvmpipe's normalised multiply ``a b / (2^n - 1) ~ (ab + (ab >> n) + 2^(n-1)) >> n``."""
    ab = a * b
    return (ab + (ab >> wp.int64(bits)) + (wp.int64(1) << wp.int64(bits - 1))) >> wp.int64(bits)


@wp.func
def dither_index(x: int, y: int, prim: int, seed: int, mask: int) -> int:
    """Reproducible table index for a fragment (integer hash in uint32 arithmetic)."""
    h = wp.uint32(x) * wp.uint32(73856093)
    h = h ^ (wp.uint32(y) * wp.uint32(19349663))
    h = h ^ (wp.uint32(prim) * wp.uint32(83492791))
    h = h ^ (wp.uint32(seed) * wp.uint32(1103515245))
    h = h ^ (h >> wp.uint32(16))
    h = h * wp.uint32(2146121005)
    h = h ^ (h >> wp.uint32(15))
    h = h * wp.uint32(739982445)
    h = h ^ (h >> wp.uint32(16))
    return int(h & wp.uint32(mask))


@wp.func
def dither_code(a: float, n: int, q: float) -> int:
    """Randomised rounding of ``a`` to a code of ``n = 2^bits - 1`` steps against threshold ``q``."""
    v = wp.clamp(a, 0.0, 1.0)
    if wp.isnan(a):
        v = 0.0
    v = v * float(n)
    f = wp.floor(v)
    c = int(f)
    if v - f > q:
        c = c + 1
    return wp.min(c, n)


@wp.func
def factor_i(mode: int, n: int, sc: int, sa: int, dc: int, da: int, kc: int, ka: int) -> int:
    r = 0
    if mode == ONE:
        r = n
    elif mode == SRC_COLOR:
        r = sc
    elif mode == ONE_MINUS_SRC_COLOR:
        r = n - sc
    elif mode == SRC_ALPHA:
        r = sa
    elif mode == ONE_MINUS_SRC_ALPHA:
        r = n - sa
    elif mode == DST_COLOR:
        r = dc
    elif mode == ONE_MINUS_DST_COLOR:
        r = n - dc
    elif mode == DST_ALPHA:
        r = da
    elif mode == ONE_MINUS_DST_ALPHA:
        r = n - da
    elif mode == CONSTANT_COLOR:
        r = kc
    elif mode == ONE_MINUS_CONSTANT_COLOR:
        r = n - kc
    elif mode == CONSTANT_ALPHA:
        r = ka
    elif mode == ONE_MINUS_CONSTANT_ALPHA:
        r = n - ka
    return r


@wp.func
def factor_f(mode: int, sc: float, sa: float, dc: float, da: float, kc: float, ka: float) -> float:
    r = 0.0
    if mode == ONE:
        r = 1.0
    elif mode == SRC_COLOR:
        r = sc
    elif mode == ONE_MINUS_SRC_COLOR:
        r = 1.0 - sc
    elif mode == SRC_ALPHA:
        r = sa
    elif mode == ONE_MINUS_SRC_ALPHA:
        r = 1.0 - sa
    elif mode == DST_COLOR:
        r = dc
    elif mode == ONE_MINUS_DST_COLOR:
        r = 1.0 - dc
    elif mode == DST_ALPHA:
        r = da
    elif mode == ONE_MINUS_DST_ALPHA:
        r = 1.0 - da
    elif mode == CONSTANT_COLOR:
        r = kc
    elif mode == ONE_MINUS_CONSTANT_COLOR:
        r = 1.0 - kc
    elif mode == CONSTANT_ALPHA:
        r = ka
    elif mode == ONE_MINUS_CONSTANT_ALPHA:
        r = 1.0 - ka
    return r


@wp.func
def blend_unorm(bs: BlendState, src: wp.vec4, dst: wp.vec4, q: float) -> wp.vec4:
    bits = bs.fmt.bits
    n = (1 << bits) - 1
    rnd = bs.fmt.rnd
    s0 = unorm_encode(wp.clamp(src[0], 0.0, 1.0), bits, rnd, 0)
    s1 = unorm_encode(wp.clamp(src[1], 0.0, 1.0), bits, rnd, 0)
    s2 = unorm_encode(wp.clamp(src[2], 0.0, 1.0), bits, rnd, 0)
    sa = unorm_encode(wp.clamp(src[3], 0.0, 1.0), bits, rnd, 0)
    if bs.arith == ARITH_LLVMPIPE:
        s0 = llvmpipe_encode(src[0], bits)
        s1 = llvmpipe_encode(src[1], bits)
        s2 = llvmpipe_encode(src[2], bits)
        sa = llvmpipe_encode(src[3], bits)
    if q >= 0.0:
        sa = dither_code(src[3], n, q)
    d0 = unorm_encode(dst[0], bits, 0, 0)
    d1 = unorm_encode(dst[1], bits, 0, 0)
    d2 = unorm_encode(dst[2], bits, 0, 0)
    da = unorm_encode(dst[3], bits, 0, 0)
    k0 = int(0)
    k1 = int(0)
    k2 = int(0)
    ka = int(0)
    if wp.max(wp.max(bs.src_rgb, bs.dst_rgb), wp.max(bs.src_a, bs.dst_a)) >= 10:  # constant factors in use
        k = bs.constant
        k0 = unorm_encode(wp.clamp(k[0], 0.0, 1.0), bits, rnd, 0)
        k1 = unorm_encode(wp.clamp(k[1], 0.0, 1.0), bits, rnd, 0)
        k2 = unorm_encode(wp.clamp(k[2], 0.0, 1.0), bits, rnd, 0)
        ka = unorm_encode(wp.clamp(k[3], 0.0, 1.0), bits, rnd, 0)
    out = wp.vec4()
    for c in range(4):
        sc = s0
        dc = d0
        kc = k0
        if c == 1:
            sc = s1
            dc = d1
            kc = k1
        elif c == 2:
            sc = s2
            dc = d2
            kc = k2
        elif c == 3:
            sc = sa
            dc = da
            kc = ka
        ms = bs.src_rgb
        md = bs.dst_rgb
        if c == 3:
            ms = bs.src_a
            md = bs.dst_a
        fs = factor_i(ms, n, sc, sa, dc, da, kc, ka)
        fd = factor_i(md, n, sc, sa, dc, da, kc, ka)
        ri = 0
        if bs.arith == ARITH_LLVMPIPE:
            r64 = llvmpipe_mul(wp.int64(sc), wp.int64(fs), bits) + llvmpipe_mul(wp.int64(dc), wp.int64(fd), bits)
            if bs.fmt.ovf == 1:
                ri = int(r64 & wp.int64(n))
            else:
                ri = int(wp.min(r64, wp.int64(n)))
        elif bits <= 14:
            # 2 (S Fs + D Fd) + N < 2^31: exact in int32 (faster division)
            num = sc * fs + dc * fd
            r = (2 * num + n) / (2 * n)
            if rnd == 2:
                r = num / n
            if bs.fmt.ovf == 1:
                ri = r & n
            else:
                ri = wp.min(r, n)
        else:
            num64 = wp.int64(sc) * wp.int64(fs) + wp.int64(dc) * wp.int64(fd)
            nn = wp.int64(n)
            r64 = (wp.int64(2) * num64 + nn) / (wp.int64(2) * nn)
            if rnd == 2:
                r64 = num64 / nn
            if bs.fmt.ovf == 1:
                ri = int(r64 & nn)
            else:
                ri = int(wp.min(r64, nn))
        out[c] = float(ri) / float(n)
    return out


@wp.func
def blend_float(bs: BlendState, src: wp.vec4, dst: wp.vec4) -> wp.vec4:
    half = bs.fmt.kind == 2
    if not half and bs.src_rgb == ONE and bs.src_a == ONE and bs.dst_rgb == ONE_MINUS_SRC_ALPHA and (
            bs.dst_a == ONE_MINUS_SRC_ALPHA):
        # fp32 "over" (premultiplied): the general path below with its factors 1 and 1 - src.a, the same
        # operations (s * 1 is s exactly), without the factor selection
        f = 1.0 - src[3]
        return wp.vec4(src[0] + dst[0] * f, src[1] + dst[1] * f, src[2] + dst[2] * f, src[3] + dst[3] * f)
    if not half and bs.src_rgb == ONE_MINUS_DST_ALPHA and bs.src_a == ONE_MINUS_DST_ALPHA and bs.dst_rgb == ONE and (
            bs.dst_a == ONE):
        # fp32 "under" (front to back): the general path's operations (s * (1 - d.a) + d * 1) without the
        # factor selection
        g = 1.0 - dst[3]
        return wp.vec4(src[0] * g + dst[0], src[1] * g + dst[1], src[2] * g + dst[2], src[3] * g + dst[3])
    s = src
    k = bs.constant
    prog = bs.arith == ARITH_PROGRAM  # composited in an fp32 fragment program: only the write rounds
    if half and not prog:
        s = wp.vec4(fp16_round(src[0]), fp16_round(src[1]), fp16_round(src[2]), fp16_round(src[3]))
        k = wp.vec4(fp16_round(k[0]), fp16_round(k[1]), fp16_round(k[2]), fp16_round(k[3]))
    out = wp.vec4()
    for c in range(4):
        ms = bs.src_rgb
        md = bs.dst_rgb
        if c == 3:
            ms = bs.src_a
            md = bs.dst_a
        fs = factor_f(ms, s[c], s[3], dst[c], dst[3], k[c], k[3])
        fd = factor_f(md, s[c], s[3], dst[c], dst[3], k[c], k[3])
        if half and not prog:
            fs = fp16_round(fs)
            fd = fp16_round(fd)
        a = s[c] * fs
        b = dst[c] * fd
        r = a + b
        if half:
            r = fp16_round(r)
        out[c] = r
    return out


@wp.func
def blend(bs: BlendState, src: wp.vec4, dst: wp.vec4, x: int, y: int, prim: int) -> wp.vec4:
    """One blend of fragment colour ``src`` onto buffer value ``dst`` at pixel (x, y) of primitive ``prim``.

    Returns the new buffer value (already a value of the buffer format).
    """
    if bs.fmt.kind == 0:
        q = -1.0
        if bs.dither != 0:
            q = bs.dither_table[dither_index(x, y, prim, bs.dither_seed, bs.dither_mask)]
        return blend_unorm(bs, src, dst, q)
    return blend_float(bs, src, dst)


# ------------------------------------------------------------------------------------------------
# frame-buffer kernels
# ------------------------------------------------------------------------------------------------


@wp.kernel
def k_fill(fb: wp.array2d(dtype=wp.vec4), value: wp.vec4):
    i, j = wp.tid()
    fb[i, j] = value


@wp.kernel
def k_blend_layers(bs: BlendState, fb: wp.array2d(dtype=wp.vec4), layers: wp.array3d(dtype=wp.vec4),
                   prim0: int):
    """Blend full-screen layers ``layers[k]`` (k = 0, 1, ... in order) into ``fb``; layer k is primitive prim0 + k."""
    i, j = wp.tid()
    d = fb[i, j]
    for k in range(layers.shape[0]):
        d = blend(bs, layers[k, i, j], d, j, i, prim0 + k)
    fb[i, j] = d


@wp.kernel
def k_blend_fragments(bs: BlendState, fb: wp.array2d(dtype=wp.vec4), offsets: wp.array(dtype=wp.int32),
                      colors: wp.array(dtype=wp.vec4), prims: wp.array(dtype=wp.int32)):
    """Per pixel, blend its fragments ``offsets[p] .. offsets[p+1]-1`` in order (p = row * W + column)."""
    i, j = wp.tid()
    p = i * fb.shape[1] + j
    d = fb[i, j]
    for f in range(offsets[p], offsets[p + 1]):
        d = blend(bs, colors[f], d, j, i, prims[f])
    fb[i, j] = d
