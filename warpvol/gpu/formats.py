"""Number formats of the emulated GPU: named, explicit objects with NumPy encode/decode.

Every unit of the emulated GPU (texture units, blending unit, frame buffers, hardware
pre-integration) takes its number format from here, so an artifact caused by a format is the same
wherever it appears. Each object has a NumPy reference (:meth:`encode`, :meth:`decode`,
:meth:`quantize`) and :meth:`kernel_params`, the small struct the Warp kernels use
(:mod:`warpvol.kernels.formats` holds the matching ``@wp.func`` s; tests check both agree on every code).

=====================  ===========================================================================
object                 definition
=====================  ===========================================================================
``UNorm(n)``           unsigned normalised fixed point, n in 1..16 bits; code c in [0, 2^n-1],
                       value c / (2^n - 1). Encode: ``v = float32(x) * float32(2^n - 1)`` (one fp32
                       multiply), then round (see below), then the out-of-range policy.
``SNorm(n)``           signed normalised, n in 2..16 bits; M = 2^(n-1) - 1; code in [-M, M]
                       (wrap may give -M-1); value ``max(c / M, -1)`` (OpenGL convention). Used for
                       polynomial coefficients scaled into [-1, 1].
``Float16()``          IEEE binary16, round to nearest even, overflow to +-inf (as ``np.float16``).
``Float32()``          IEEE binary32.
``Split12()``          a 12-bit code k in [0, 4080], value ``k / 4080``, carried as high 8 bits ``k >> 4``
                       and low 4 bits ``k & 15`` (Guthe et al. ping-pong filtering: value = H + L/256
                       with H, L the channels' values, so 255 in the high channel alone is 1.0). In
                       8-bit channels the low nibble sits in the channel's upper nibble (``lo << 4``).
``Pair16()``           a 16-bit ``UNorm(16)`` code carried in two 8-bit channels, A = high byte,
                       L = low byte, value ``256 A/257 + L/257`` with A, L the channels' normalised
                       values (Guthe et al.); linear in (A, L), so filtering it is a true 16-bit lookup.
=====================  ===========================================================================

Rounding (``rounding=``): ``"nearest"`` rounds half away from zero (``wp.round``; on [0, 1] this is
round-half-up, what conversion hardware does by adding half an LSB and truncating) — the default;
``"nearest_even"`` rounds half to even (``wp.rint``); ``"truncate"`` drops the bits below the LSB
(``floor``; some paths of the 2002 hardware truncated). Out of range (``overflow=``): ``"saturate"``
clamps to the code range (GeForce); ``"wrap"`` keeps only the low n bits of the rounded integer,
two's complement (Radeon 8500 bit masking: ``UNorm(8, overflow="wrap").encode(256 * v)`` extracts
the bits below 1/256).

Examples
--------
>>> from warpvol.gpu.formats import UNorm, get_format
>>> f = UNorm(8)
>>> int(f.encode(0.5)), round(float(f.decode(128)), 7)
(128, 0.5019608)
>>> int(UNorm(8, overflow="wrap").encode(1.5)), int(UNorm(8).encode(1.5))
(127, 255)
>>> get_format("fp16").quantize(0.1)
array(0.09997559, dtype=float32)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from warpvol.errors import ConfigError, check_choice, check_number

ROUNDINGS = ("nearest", "nearest_even", "truncate")
OVERFLOWS = ("saturate", "wrap")

KIND_UNORM, KIND_SNORM, KIND_FP16, KIND_FP32 = 0, 1, 2, 3
_RND_CODE = {"nearest": 0, "nearest_even": 1, "truncate": 2}
_OVF_CODE = {"saturate": 0, "wrap": 1}


def _round_np(v: np.ndarray, rounding: str) -> np.ndarray:
    """Round float32 values exactly (in float64) the way the kernels do in float32."""
    v = np.asarray(v, dtype=np.float64)
    if rounding == "nearest":
        return np.sign(v) * np.floor(np.abs(v) + 0.5)
    if rounding == "nearest_even":
        return np.rint(v)
    return np.floor(v)


class NumberFormat:
    """Base class. Subclasses define :attr:`name`, :meth:`encode`, :meth:`decode`."""

    name: str = ""
    kind: int = -1
    bits: int = 0
    rounding: str = "nearest"
    overflow: str = "saturate"
    is_float: bool = False

    def encode(self, x: Any) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def decode(self, codes: Any) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def quantize(self, x: Any) -> np.ndarray:
        """The format's value for ``x`` (``decode(encode(x))``) as float32."""
        return self.decode(self.encode(x))

    def kernel_params(self):
        """The :class:`warpvol.kernels.formats.NumFmt` struct describing this format to kernels."""
        from warpvol.kernels import formats as kf

        p = kf.NumFmt()
        p.kind, p.bits = self.kind, self.bits
        p.rnd, p.ovf = _RND_CODE[self.rounding], _OVF_CODE[self.overflow]
        return p

    @property
    def epsilon(self) -> float:
        """Spacing of representable values near 1 (one LSB for fixed point)."""
        raise NotImplementedError  # pragma: no cover

    def __eq__(self, other: object) -> bool:
        return isinstance(other, NumberFormat) and type(self) is type(other) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash((type(self).__name__,) + self._key())

    def _key(self) -> tuple:
        return (self.bits, self.rounding, self.overflow)

    def __repr__(self) -> str:
        return f"<format {self.name}>"


class _FixedPoint(NumberFormat):
    """Shared construction and scaling of the fixed-point formats (:class:`UNorm`, :class:`SNorm`)."""

    prefix = ""
    min_bits = 1

    def __init__(self, bits: int, rounding: str = "nearest", overflow: str = "saturate"):
        self.bits = check_number("bits", bits, lo=self.min_bits, hi=16, integer=True)
        self.rounding = check_choice("rounding", rounding, ROUNDINGS)
        self.overflow = check_choice("overflow", overflow, OVERFLOWS)
        self.max_code = self._max_code()
        suffix = "" if rounding == "nearest" else ("_even" if rounding == "nearest_even" else "_trunc")
        suffix += "" if overflow == "saturate" else "_wrap"
        self.name = f"{self.prefix}{self.bits}{suffix}"

    def _max_code(self) -> int:  # pragma: no cover - abstract
        raise NotImplementedError

    @property
    def epsilon(self) -> float:
        return 1.0 / self.max_code

    def _scaled_codes(self, x: Any) -> np.ndarray:
        """``float32(x) * float32(max_code)`` rounded per ``rounding`` (NaN -> 0), as int64 before
        the overflow policy; the product is clamped to +-2^30 first (casts do not saturate)."""
        x = np.asarray(x, dtype=np.float32)
        with np.errstate(invalid="ignore", over="ignore"):
            v = x * np.float32(self.max_code)
        v = np.clip(np.where(np.isnan(v), 0.0, v), -(2.0**30), 2.0**30)
        return _round_np(v, self.rounding).astype(np.int64)


class UNorm(_FixedPoint):
    """Unsigned normalised fixed point of ``bits`` bits.

    ==========  ===========================================  ==================================
    parameter   meaning                                      allowed
    ==========  ===========================================  ==================================
    bits        code width n; value = code / (2^n - 1)       integer in [1, 16]
    rounding    ``nearest`` (ties away from zero),           ``nearest`` | ``nearest_even`` |
                ``nearest_even`` or ``truncate``             ``truncate``
    overflow    ``saturate`` (GeForce) or ``wrap``           ``saturate`` | ``wrap``
                (Radeon 8500 bit mask)
    ==========  ===========================================  ==================================

    Examples
    --------
    >>> import numpy as np
    >>> UNorm(12).encode(np.float32([0.0, 0.5, 1.0])).tolist()
    [0, 2048, 4095]
    """

    kind = KIND_UNORM
    prefix = "unorm"
    min_bits = 1

    def _max_code(self) -> int:
        return (1 << self.bits) - 1

    def encode(self, x: Any) -> np.ndarray:
        """Codes (int64) of ``x``: ``float32(x) * float32(2^n - 1)``, rounded, saturated or wrapped."""
        c = self._scaled_codes(x)
        if self.overflow == "wrap":
            c = c & self.max_code
        else:
            c = np.clip(c, 0, self.max_code)
        return c

    def decode(self, codes: Any) -> np.ndarray:
        """Values (float32) ``float32(code) / float32(2^n - 1)``."""
        c = np.asarray(codes)
        return (c.astype(np.float32) / np.float32(self.max_code)).astype(np.float32)


class SNorm(_FixedPoint):
    """Signed normalised fixed point of ``bits`` bits (two's complement codes).

    ==========  ===========================================  ==================================
    parameter   meaning                                      allowed
    ==========  ===========================================  ==================================
    bits        code width n; M = 2^(n-1) - 1;               integer in [2, 16]
                value = max(code / M, -1)
    rounding    as :class:`UNorm`                            ``nearest`` | ``nearest_even`` |
                                                             ``truncate``
    overflow    ``saturate`` to [-M, M] or ``wrap``          ``saturate`` | ``wrap``
    ==========  ===========================================  ==================================

    Examples
    --------
    >>> SNorm(8).encode([-1.0, -0.5, 0.5, 1.0]).tolist()
    [-127, -64, 64, 127]
    """

    kind = KIND_SNORM
    prefix = "snorm"
    min_bits = 2

    def _max_code(self) -> int:
        return (1 << (self.bits - 1)) - 1

    def encode(self, x: Any) -> np.ndarray:
        """Two's complement codes (int64) of ``x``: ``float32(x) * float32(M)``, rounded, saturated
        to [-M, M] or wrapped to n bits."""
        c = self._scaled_codes(x)
        if self.overflow == "wrap":
            h = 1 << (self.bits - 1)
            return ((c + h) & ((1 << self.bits) - 1)) - h
        return np.clip(c, -self.max_code, self.max_code)

    def decode(self, codes: Any) -> np.ndarray:
        c = np.asarray(codes).astype(np.float32)
        return np.maximum(c / np.float32(self.max_code), np.float32(-1.0)).astype(np.float32)


class Float16(NumberFormat):
    """IEEE binary16 (``np.float16``): round to nearest even, overflow to +-inf.

    Codes are the 16-bit patterns (uint16).

    Examples
    --------
    >>> int(Float16().encode(1.0))
    15360
    """

    kind = KIND_FP16
    bits = 16
    is_float = True
    name = "fp16"

    @property
    def epsilon(self) -> float:
        return 2.0**-10

    def encode(self, x: Any) -> np.ndarray:
        with np.errstate(over="ignore"):
            return np.asarray(x, dtype=np.float32).astype(np.float16).view(np.uint16)

    def decode(self, codes: Any) -> np.ndarray:
        return np.asarray(codes, dtype=np.uint16).view(np.float16).astype(np.float32)


class Float32(NumberFormat):
    """IEEE binary32; codes are the 32-bit patterns (uint32)."""

    kind = KIND_FP32
    bits = 32
    is_float = True
    name = "fp32"

    @property
    def epsilon(self) -> float:
        return 2.0**-23

    def encode(self, x: Any) -> np.ndarray:
        return np.asarray(x, dtype=np.float32).view(np.uint32)

    def decode(self, codes: Any) -> np.ndarray:
        return np.asarray(codes, dtype=np.uint32).view(np.float32).copy()


class Split12:
    """A 12-bit value carried as high 8 bits + low 4 bits (Guthe et al. 2002 ping-pong filtering).

    The value is ``H + L / 256`` with ``H = hi / 255`` and ``L`` the low channel's value (code
    ``lo << 4``, so ``L / 256 = lo / 4080``): 255 in the high channel alone already means 1.0, as the
    paper says. Hence a 12-bit code ``k = 16 hi + lo`` in [0, 4080] has the value ``k / 4080``; this is
    the one definition the ping-pong kernel (:func:`warpvol.kernels.preint.pingpong_slice`) computes
    with. ``rounding`` applies to the encode (``truncate`` is what the 8-bit channel writes of the
    ping-pong shader do).

    Examples
    --------
    >>> s = Split12()
    >>> hi, lo = s.split(s.encode12(0.3))
    >>> int(hi), int(lo), int(s.join(hi, lo)), int(s.encode12(0.3)), float(s.decode12(4080))
    (76, 8, 1224, 1224, 1.0)
    """

    name = "split12"
    #: codes per unit: 16 * 255 (the high channel's 255 is 1.0)
    SCALE = 4080

    def __init__(self, rounding: str = "nearest"):
        self.rounding = check_choice("rounding", rounding, ROUNDINGS)

    def encode12(self, x: Any) -> np.ndarray:
        """Codes ``round(x * 4080)`` (float32 product), saturated to [0, 4080]; NaN -> 0."""
        v = np.nan_to_num(np.asarray(x, dtype=np.float32) * np.float32(self.SCALE), nan=0.0)
        return np.clip(_round_np(v.astype(np.float64), self.rounding), 0, self.SCALE).astype(np.int64)

    def decode12(self, code12: Any) -> np.ndarray:
        return (np.asarray(code12, dtype=np.float64) / self.SCALE).astype(np.float32)

    @staticmethod
    def split(code12: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(hi, lo)``: high 8 bits and low 4 bits of 12-bit codes."""
        k = np.asarray(code12, dtype=np.int64)
        if np.any((k < 0) | (k > 4095)):
            raise ConfigError("code12: values must be 12-bit codes in [0, 4095]")
        return k >> 4, k & 15

    @staticmethod
    def join(hi: Any, lo: Any) -> np.ndarray:
        """12-bit codes ``16 hi + lo`` from an 8-bit high part and a 4-bit low part."""
        return (np.asarray(hi, dtype=np.int64) << 4) | (np.asarray(lo, dtype=np.int64) & 15)

    def channels(self, x: Any) -> tuple[np.ndarray, np.ndarray]:
        """8-bit channel codes ``(hi, lo << 4)`` carrying ``x`` at 12 bits."""
        hi, lo = self.split(self.encode12(x))
        return hi, lo << 4

    def from_channels(self, hi_code: Any, lo_code: Any) -> np.ndarray:
        """Value (float32) of two 8-bit channel codes written by :meth:`channels`."""
        return self.decode12(self.join(hi_code, np.asarray(lo_code, dtype=np.int64) >> 4))

    def quantize(self, x: Any) -> np.ndarray:
        return self.decode12(self.encode12(x))


class Pair16:
    """A 16-bit value in two 8-bit channels: A = high byte, L = low byte (Guthe et al. 2002).

    ``value = 256 A/257 + L/257`` with A = a/255 and L = l/255 the channels' normalised values, which
    equals ``(256 a + l) / 65535`` exactly; :meth:`value` evaluates the formula in float32 as a
    fragment program would (also on filtered, non-integer A, L).

    Examples
    --------
    >>> p = Pair16()
    >>> a, l = p.encode(0.5)
    >>> int(a), int(l), round(float(p.value(a / 255, l / 255)), 6)
    (128, 0, 0.500008)
    """

    name = "pair16"

    def __init__(self, rounding: str = "nearest"):
        self.u16 = UNorm(16, rounding=rounding)

    def encode(self, x: Any) -> tuple[np.ndarray, np.ndarray]:
        c = self.u16.encode(x)
        return c >> 8, c & 255

    def decode(self, a_code: Any, l_code: Any) -> np.ndarray:
        return self.value(UNorm(8).decode(a_code), UNorm(8).decode(l_code))

    @staticmethod
    def value(a: Any, l: Any) -> np.ndarray:
        """``256 A/257 + L/257`` in float32 for normalised channel values A, L."""
        a = np.asarray(a, dtype=np.float32)
        l = np.asarray(l, dtype=np.float32)
        return (a * np.float32(256.0 / 257.0) + l * np.float32(1.0 / 257.0)).astype(np.float32)

    def quantize(self, x: Any) -> np.ndarray:
        return self.u16.quantize(x)


UNORM8 = UNorm(8)
UNORM12 = UNorm(12)
UNORM16 = UNorm(16)
SNORM8 = SNorm(8)
SNORM16 = SNorm(16)
FP16 = Float16()
FP32 = Float32()

_NAMED = {
    "unorm8": UNORM8, "unorm12": UNORM12, "unorm16": UNORM16,
    "unorm8_wrap": UNorm(8, overflow="wrap"), "unorm12_wrap": UNorm(12, overflow="wrap"),
    "unorm8_trunc": UNorm(8, rounding="truncate"), "unorm12_trunc": UNorm(12, rounding="truncate"),
    "snorm8": SNORM8, "snorm16": SNORM16,
    "fp16": FP16, "fp32": FP32,
}
FORMAT_NAMES = tuple(_NAMED)


def get_format(fmt: str | NumberFormat, name: str = "fmt") -> NumberFormat:
    """A :class:`NumberFormat` from an object or a name (``unorm8``, ``unorm12``, ``fp16``, ...).

    Any ``unorm<n>`` / ``snorm<n>`` with an optional ``_even`` / ``_trunc`` and ``_wrap`` suffix is
    accepted; ``name`` is the argument name used in error messages.
    """
    if isinstance(fmt, NumberFormat):
        return fmt
    if not isinstance(fmt, str):
        raise ConfigError(f"{name}: expected a format name or object, got {fmt!r}; allowed: {', '.join(FORMAT_NAMES)}")
    if fmt in _NAMED:
        return _NAMED[fmt]
    import re

    m = re.fullmatch(r"(unorm|snorm)(\d+)(_even|_trunc)?(_wrap)?", fmt)
    if m:
        cls = UNorm if m.group(1) == "unorm" else SNorm
        rnd = {None: "nearest", "_even": "nearest_even", "_trunc": "truncate"}[m.group(3)]
        try:
            return cls(int(m.group(2)), rounding=rnd, overflow="wrap" if m.group(4) else "saturate")
        except ConfigError as e:
            raise ConfigError(f"{name}: {fmt!r}: {e}") from None
    raise ConfigError(f"{name}: unknown format {fmt!r}; allowed: {', '.join(FORMAT_NAMES)} "
                      "(or unorm<1..16> / snorm<2..16> with optional _even/_trunc and _wrap)")


# ------------------------------------------------------------------------------------------------
# the same conversions run by the Warp kernels (used by tests to check kernel == NumPy)
# ------------------------------------------------------------------------------------------------


def _launch(kernel_name: str, fmt: NumberFormat, x: np.ndarray, in_dtype, out_dtype, device: str) -> np.ndarray:
    import warp as wp

    from warpvol.kernels import formats as kf

    xa = wp.array(np.ascontiguousarray(x, dtype=in_dtype).ravel(), device=device)
    out = wp.empty(xa.shape, dtype={np.int32: wp.int32, np.float32: wp.float32}.get(out_dtype, out_dtype),
                   device=device)
    wp.launch(getattr(kf, kernel_name), dim=xa.shape[0], inputs=[fmt.kernel_params(), xa, out], device=device)
    return out.numpy().reshape(np.shape(x))


def encode_warp(fmt: str | NumberFormat, x: Any, device: str = "cpu") -> np.ndarray:
    """Fixed-point codes of ``x`` computed by the Warp ``fmt_encode`` function on ``device``."""
    f = get_format(fmt)
    if f.is_float:
        raise ConfigError(f"fmt: {f.name} has no integer codes in kernels; use quantize_warp")
    return _launch("k_encode", f, np.asarray(x, np.float32), np.float32, np.int32, device)


def decode_warp(fmt: str | NumberFormat, codes: Any, device: str = "cpu") -> np.ndarray:
    """Values of fixed-point ``codes`` computed by the Warp ``fmt_decode`` function on ``device``."""
    f = get_format(fmt)
    if f.is_float:
        raise ConfigError(f"fmt: {f.name} has no integer codes in kernels; use quantize_warp")
    return _launch("k_decode", f, np.asarray(codes, np.int32), np.int32, np.float32, device)


def quantize_warp(fmt: str | NumberFormat, x: Any, device: str = "cpu") -> np.ndarray:
    """``decode(encode(x))`` computed by the Warp ``fmt_quantize`` function on ``device``."""
    f = get_format(fmt)
    return _launch("k_quantize", f, np.asarray(x, np.float32), np.float32, np.float32, device)
