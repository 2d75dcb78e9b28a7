"""Number formats of the emulated GPU, as Warp ``@wp.func`` s (host side: :mod:`warpvol.gpu.formats`).

A format reaches a kernel as a :class:`NumFmt` struct (build it with ``fmt.kernel_params()``):

====  ==========  ==========================================================================
kind  name        meaning of ``bits`` / ``rnd`` / ``ovf``
====  ==========  ==========================================================================
0     UNORM       unsigned normalised fixed point, code ``c`` in [0, 2^bits - 1], value c / (2^bits - 1)
1     SNORM       signed normalised, code in [-(2^(bits-1) - 1), 2^(bits-1) - 1], value max(c / M, -1)
2     FP16        IEEE binary16, round to nearest even (bits/rnd/ovf unused)
3     FP32        IEEE binary32 (identity)
====  ==========  ==========================================================================

Rounding (``rnd``): 0 = nearest, ties away from zero (``wp.round``; for the [0, 1] range this is
"round half up", what fixed-point conversion hardware does with an added half LSB);
1 = nearest, ties to even (``wp.rint``); 2 = truncate (``wp.floor``, i.e. drop the low bits).
Out of range (``ovf``): 0 = saturate (GeForce), 1 = wrap / bit mask (Radeon 8500): the rounded
integer is masked to ``bits`` bits (two's complement for SNORM).

Float -> int casts are clamped first (Warp casts do not saturate). NaN encodes to code 0.
Modules calling these functions should set ``fuse_fp=False`` if they need results bit-identical
between CPU and CUDA (FMA contraction would otherwise change roundings on CUDA).
"""

import warp as wp

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

KIND_UNORM = wp.constant(0)
KIND_SNORM = wp.constant(1)
KIND_FP16 = wp.constant(2)
KIND_FP32 = wp.constant(3)

RND_NEAREST = wp.constant(0)
RND_EVEN = wp.constant(1)
RND_TRUNC = wp.constant(2)

OVF_SATURATE = wp.constant(0)
OVF_WRAP = wp.constant(1)

# |v| is clamped to this before float->int casts (far outside every code range, exact in fp32)
_CAST_LIMIT = wp.constant(1073741824.0)


@wp.struct
class NumFmt:
    """Kernel-side description of a number format (see module docstring)."""

    kind: int
    bits: int
    rnd: int
    ovf: int


@wp.func
def apply_rounding(v: float, rnd: int) -> float:
    """Round ``v`` to an integer-valued float with rounding mode ``rnd``."""
    r = wp.round(v)
    if rnd == 1:
        r = wp.rint(v)
    elif rnd == 2:
        r = wp.floor(v)
    return r


@wp.func
def unorm_max(bits: int) -> int:
    return (1 << bits) - 1


@wp.func
def unorm_encode(x: float, bits: int, rnd: int, ovf: int) -> int:
    """Code of ``x`` in unsigned normalised ``bits``-bit fixed point."""
    n = unorm_max(bits)
    if wp.isnan(x):
        return 0
    v = x * float(n)
    r = apply_rounding(wp.clamp(v, -_CAST_LIMIT, _CAST_LIMIT), rnd)
    c = int(r)
    if ovf == 1:
        return c & n
    return wp.clamp(c, 0, n)


@wp.func
def unorm_decode(c: int, bits: int) -> float:
    return float(c) / float(unorm_max(bits))


@wp.func
def unorm_quantize(x: float, bits: int, rnd: int, ovf: int) -> float:
    return unorm_decode(unorm_encode(x, bits, rnd, ovf), bits)


@wp.func
def snorm_encode(x: float, bits: int, rnd: int, ovf: int) -> int:
    """Two's complement code of ``x`` in signed normalised ``bits``-bit fixed point."""
    m = (1 << (bits - 1)) - 1
    if wp.isnan(x):
        return 0
    v = x * float(m)
    c = int(apply_rounding(wp.clamp(v, -_CAST_LIMIT, _CAST_LIMIT), rnd))
    if ovf == 1:
        h = 1 << (bits - 1)
        return ((c + h) & ((1 << bits) - 1)) - h
    return wp.clamp(c, -m, m)


@wp.func
def snorm_decode(c: int, bits: int) -> float:
    m = (1 << (bits - 1)) - 1
    return wp.max(float(c) / float(m), -1.0)


@wp.func
def fp16_round(x: float) -> float:
    """``x`` rounded to IEEE binary16 (nearest even; overflow to +-inf as IEEE)."""
    return float(wp.float16(x))


@wp.func
def fmt_quantize(f: NumFmt, x: float) -> float:
    """``decode(encode(x))``: the value of the format nearest to ``x`` (by the format's rules)."""
    if f.kind == 0:
        return unorm_quantize(x, f.bits, f.rnd, f.ovf)
    if f.kind == 1:
        return snorm_decode(snorm_encode(x, f.bits, f.rnd, f.ovf), f.bits)
    if f.kind == 2:
        return fp16_round(x)
    return x


@wp.func
def fmt_encode(f: NumFmt, x: float) -> int:
    """Integer code of ``x`` for the fixed-point kinds (float kinds return 0: use :func:`fmt_quantize`)."""
    if f.kind == 0:
        return unorm_encode(x, f.bits, f.rnd, f.ovf)
    if f.kind == 1:
        return snorm_encode(x, f.bits, f.rnd, f.ovf)
    return 0


@wp.func
def fmt_decode(f: NumFmt, c: int) -> float:
    if f.kind == 1:
        return snorm_decode(c, f.bits)
    return unorm_decode(c, f.bits)


@wp.func
def quantize4(f: NumFmt, v: wp.vec4) -> wp.vec4:
    return wp.vec4(fmt_quantize(f, v[0]), fmt_quantize(f, v[1]), fmt_quantize(f, v[2]), fmt_quantize(f, v[3]))


# ------------------------------------------------------------------------------------------------
# array kernels (vectorised encode / decode / quantize; used by warpvol.gpu.formats and the tests)
# ------------------------------------------------------------------------------------------------


@wp.kernel
def k_encode(f: NumFmt, x: wp.array(dtype=wp.float32), out: wp.array(dtype=wp.int32)):
    i = wp.tid()
    out[i] = fmt_encode(f, x[i])


@wp.kernel
def k_decode(f: NumFmt, c: wp.array(dtype=wp.int32), out: wp.array(dtype=wp.float32)):
    i = wp.tid()
    out[i] = fmt_decode(f, c[i])


@wp.kernel
def k_quantize(f: NumFmt, x: wp.array(dtype=wp.float32), out: wp.array(dtype=wp.float32)):
    i = wp.tid()
    out[i] = fmt_quantize(f, x[i])


# ------------------------------------------------------------------------------------------------
# fixed-point fragment registers (register combiners, ATI fragment shader)
# ------------------------------------------------------------------------------------------------


@wp.func
def reg_fixed(v: float, rng: float, unit: float) -> float:
    """``v`` as a fixed-point fragment register holds it: clamped to ``[-rng, rng]`` (saturation,
    what every fragment arithmetic unit of the time did on overflow) and rounded to the nearest
    multiple of ``1 / unit`` (ties away from zero). ``unit <= 0``: no rounding (float register);
    ``rng <= 0``: no clamp.

    GeForce3/4 register combiners (NV_register_combiners): ``rng = 1``, ``unit = 255`` (signed
    9-bit: sign and 8 bits, 8-bit texel 255 is exactly 1.0). Radeon 8500 fragment shader
    (ATI_fragment_shader): ``rng = 8``; ``unit`` is the precision chosen in
    :mod:`warpvol.kernels.combiners`."""
    if wp.isnan(v):
        return 0.0
    x = v
    if rng > 0.0:
        x = wp.clamp(x, -rng, rng)
    if unit > 0.0:
        x = wp.round(wp.clamp(x * unit, -_CAST_LIMIT, _CAST_LIMIT)) / unit
    return x


@wp.kernel
def k_reg_fixed(x: wp.array(dtype=wp.float32), rng: float, unit: float, out: wp.array(dtype=wp.float32)):
    i = wp.tid()
    out[i] = reg_fixed(x[i], rng, unit)
