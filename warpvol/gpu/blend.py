"""Blending unit and frame buffers of the emulated GPU.

A :class:`FrameBuffer` holds RGBA values of one number format (``unorm8``, ``unorm12``,
``unorm16``, ``fp16``, ``fp32``, any ``unorm<n>``; see :mod:`warpvol.gpu.formats`); a
:class:`BlendUnit` holds the blend function ``(src factor, dst factor)`` and blends fragments into a
frame buffer, rounding to the buffer's format after *every* blend (this is what makes 8-bit buffers
band). The exact arithmetic (integer for fixed point, binary16 for fp16) is documented in
:mod:`warpvol.kernels.blend`.

Factor names (case-insensitive, optional ``GL_`` prefix): ``zero``, ``one``, ``src_color``,
``one_minus_src_color``, ``src_alpha``, ``one_minus_src_alpha``, ``dst_color``,
``one_minus_dst_color``, ``dst_alpha``, ``one_minus_dst_alpha``, ``constant_color``,
``one_minus_constant_color``, ``constant_alpha``, ``one_minus_constant_alpha``.

Blend arithmetic (named choice, :class:`BlendUnit` parameter ``arithmetic``; fixed-point buffers):

* ``"exact"`` (default): each channel ``round((S Fs + D Fd) / N)`` exactly, one rounding per
  channel and blend, on 8-bit codes S, D, Fs, Fd (N = 2^n - 1);
* ``"llvmpipe"``: Mesa llvmpipe's integer blend: each product rounded on its own,
  ``(ab + (ab >> n) + 2^(n-1)) >> n``, then a saturating add; fragment colours converted to codes
  as llvmpipe does (ties to even). Premultiplied "over" differs from ``exact`` only where the
  multiply is inexact (24 of 65,536 byte pairs); straight alpha ``(src_alpha, one_minus_src_alpha)``
  by up to 2 codes (two roundings instead of one).

**Default, and why**: ``exact``. OpenGL specifies blending "as if carried out in floating point"
with the result converted to the buffer's fixed point once, which ``exact`` is. What the papers'
NVIDIA (GeForce3/4) and ATI (Radeon 8500) blenders did internally is not documented; the one GL
implementation we can observe, llvmpipe, takes a cheaper per-product shortcut, available by name and
checked code for code by ``scripts/gl_conformance.py``. Float buffers blend in float either way.

``"program"`` (float buffers only): no blending unit at all. The colour buffer is bound as a texture
and the fragment program composites ``S Fs + D Fd`` in fp32, writing the result (rounded to the
buffer format) with blending off: Kraus, Qiao & Ebert 2004 §4.1's fp16 buffer on the Quadro FX 3000,
which could not blend fp16 (NV40-style fp16 blending is ``"exact"`` on an fp16 buffer: S and the
factors rounded to binary16 first). The texture read must see the previous triangle fan's writes:
the paper rebinds the buffer texture and sends a fence after each fan; :meth:`BlendUnit.count`
counts the fragments as buffer-texture fetches and plain writes.

Compositing with premultiplied colours: back to front "over" = ``(one, one_minus_src_alpha)``
(:meth:`BlendUnit.over`); front to back "under" = ``(one_minus_dst_alpha, one)``
(:meth:`BlendUnit.under`). Roettger & Ertl's one-pass hardware pre-integration:
``BlendUnit("constant_color", "one_minus_src_alpha", constant=(1, 1, 1, 0))`` into a buffer cleared
to (0, 0, 0, 1) accumulates colour in RGB and transparency in A.

Example
-------
>>> import numpy as np
>>> fb = FrameBuffer(4, 2, "unorm8")
>>> fb.clear((0, 0, 0, 0))
>>> layers = np.full((3, 2, 4, 4), 0.5, np.float32)         # three full-screen fragments, a = 0.5
>>> BlendUnit.over().blend_layers(fb, layers)
>>> fb.codes()[0, 0].tolist()                                 # 128 -> 192 -> 224 (each rounded)
[224, 224, 224, 224]
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
import warp as wp

from warpvol.errors import ConfigError, check_choice, check_number
from warpvol.gpu import counters as _cnt
from warpvol.gpu.dither import dither_table
from warpvol.gpu.formats import NumberFormat, SNorm, UNorm, get_format
from warpvol.gpu.texture import Texture2D
from warpvol.kernels import blend as kblend

FACTORS = {
    "zero": 0, "one": 1, "src_color": 2, "one_minus_src_color": 3, "src_alpha": 4, "one_minus_src_alpha": 5,
    "dst_color": 6, "one_minus_dst_color": 7, "dst_alpha": 8, "one_minus_dst_alpha": 9,
    "constant_color": 10, "one_minus_constant_color": 11, "constant_alpha": 12, "one_minus_constant_alpha": 13,
}
ARITHMETICS = {"exact": 0, "llvmpipe": 1, "program": 2}


def factor_code(name: str, arg: str) -> int:
    """Kernel code of a blend factor name; the error names ``arg`` and lists the allowed names."""
    if not isinstance(name, str):
        raise ConfigError(f"{arg}: expected a blend factor name, got {name!r}; allowed: {', '.join(FACTORS)}")
    key = name.lower()
    if key.startswith("gl_"):
        key = key[3:]
    if key not in FACTORS:
        raise ConfigError(f"{arg}: unknown blend factor {name!r}; allowed: {', '.join(FACTORS)}")
    return FACTORS[key]


def _check_fb_format(fmt: Any, name: str = "fmt") -> NumberFormat:
    f = get_format(fmt, name)
    if isinstance(f, SNorm):
        raise ConfigError(f"{name}: {f.name} is not a frame-buffer format; allowed: unorm<n> (n = 1..16), fp16, fp32")
    return f


def _rgba(value: Any, name: str) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ConfigError(f"{name}: expected 4 numbers (RGBA), got {value!r}") from None
    if v.shape == (3,):
        v = np.append(v, 1.0)
    if v.shape != (4,) or not np.isfinite(v).all():
        raise ConfigError(f"{name}: expected 4 finite numbers (RGBA), got {value!r}")
    return v.astype(np.float32)


class FrameBuffer:
    """An RGBA colour buffer of one number format, plus an optional depth buffer.

    ===========  =================================================  ===================================
    parameter    meaning                                            allowed
    ===========  =================================================  ===================================
    width        pixels per row                                     integer >= 1
    height       rows (row 0 = top of the image)                    integer >= 1
    fmt          number format of every channel                     ``unorm<1..16>`` (e.g. ``unorm8``,
                                                                    ``unorm12``), ``fp16``, ``fp32``
                                                                    or a :class:`NumberFormat`
    device       Warp device                                        ``"cpu"``, ``"cuda:0"``, ...
    ===========  =================================================  ===========================

    The colour array ``array`` (``wp.array2d(vec4)``, H x W) always holds values of ``fmt``
    (fixed-point codes stored decoded as ``code / (2^n - 1)``); ``depth`` (H x W float32) is
    cleared to 1 by :meth:`clear_depth`.

    Examples
    --------
    >>> fb = FrameBuffer(2, 1, "unorm12")
    >>> fb.clear((0.5, 0.25, 0.0, 1.0))
    >>> fb.codes()[0, 0].tolist()
    [2048, 1024, 0, 4095]
    """

    def __init__(self, width: int, height: int, fmt: Any = "unorm8", device: str = "cpu"):
        self.width = check_number("width", width, lo=1, hi=65536, integer=True)
        self.height = check_number("height", height, lo=1, hi=65536, integer=True)
        self.fmt = _check_fb_format(fmt)
        self.device = device
        self.array = wp.zeros((self.height, self.width), dtype=wp.vec4, device=device)
        self.depth = wp.full((self.height, self.width), 1.0, dtype=wp.float32, device=device)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.height, self.width)

    def clear(self, rgba: Sequence[float] = (0.0, 0.0, 0.0, 0.0)) -> None:
        """Fill with ``rgba`` rounded to the buffer format (fixed point: saturated to [0, 1])."""
        v = _rgba(rgba, "rgba")
        if not self.fmt.is_float:
            v = np.clip(v, 0.0, 1.0)
        q = self.fmt.quantize(v)
        _cnt.count(clears=1, clear_pixels=self.width * self.height)
        wp.launch(kblend.k_fill, dim=self.shape, inputs=[self.array, wp.vec4(*map(float, q))], device=self.device)

    def clear_depth(self, value: float = 1.0) -> None:
        value = check_number("value", value)
        self.depth.fill_(float(value))

    def write(self, values: Any) -> None:
        """Upload (H, W, 4) values, rounded to the buffer format (as a draw with blending off would)."""
        v = np.asarray(values, dtype=np.float32)
        if v.shape != (self.height, self.width, 4):
            raise ConfigError(f"values: expected shape {(self.height, self.width, 4)}, got {v.shape}")
        if not np.isfinite(v).all():
            raise ConfigError("values: holds NaN or Inf")
        if not self.fmt.is_float:
            v = np.clip(v, 0.0, 1.0)
        self.array.assign(wp.array(self.fmt.quantize(v), dtype=wp.vec4, device=self.device))
        _cnt.count(bytes_up=self.width * self.height * _cnt.bytes_per_pixel(self.fmt))

    def readback(self) -> np.ndarray:
        """The colour buffer as (H, W, 4) float32 values (row 0 = top); counted as a read-back."""
        _cnt.count(readbacks=1, bytes_down=self.width * self.height * _cnt.bytes_per_pixel(self.fmt))
        return self._values()

    def _values(self) -> np.ndarray:
        return self.array.numpy().reshape(self.height, self.width, 4).copy()

    def codes(self) -> np.ndarray:
        """The colour buffer as (H, W, 4) codes: fixed-point integers, or the fp16/fp32 bit patterns."""
        if self.fmt.is_float:
            return self.fmt.encode(self._values())
        return UNorm(self.fmt.bits).encode(self._values())  # stored values are exact: nearest recovers the code

    def to_texture(self, fmt: str | None = None, filter: str = "nearest", weight_bits: int | None = 8):
        """Render to texture: a :class:`~warpvol.gpu.texture.Texture2D` holding this buffer's content.

        ``fmt`` defaults to the texel format that holds the buffer exactly: ``rgba8`` for unorm8,
        ``rgba16`` for unorm16, ``rgba16f`` for fp16, else ``rgba32f``. Texture row ``r`` = buffer row ``r``.
        """

        if fmt is None:
            fmt = {"unorm8": "rgba8", "unorm16": "rgba16", "fp16": "rgba16f"}.get(self.fmt.name, "rgba32f")
        return Texture2D(self._values(), fmt=fmt, filter=filter, device=self.device, weight_bits=weight_bits,
                         upload=False)  # a copy on the card, not a bus transfer

    def __repr__(self) -> str:
        return f"FrameBuffer({self.width}x{self.height}, {self.fmt.name}, device={self.device!r})"


class PingPong:
    """Two frame buffers used alternately: draw into :attr:`target` while reading :attr:`source`.

    Guthe et al.'s ping-pong filtering: each step reads the previous result as a texture
    (:meth:`source_texture`) and writes the next one; :meth:`swap` exchanges the roles.

    Examples
    --------
    >>> pp = PingPong(4, 4, "unorm8")
    >>> pp.target.clear((1, 0, 0, 1)); pp.swap()
    >>> pp.source.codes()[0, 0].tolist()
    [255, 0, 0, 255]
    """

    def __init__(self, width: int, height: int, fmt: Any = "unorm8", device: str = "cpu"):
        self.buffers = [FrameBuffer(width, height, fmt, device), FrameBuffer(width, height, fmt, device)]
        self._i = 0

    @property
    def target(self) -> FrameBuffer:
        return self.buffers[self._i]

    @property
    def source(self) -> FrameBuffer:
        return self.buffers[1 - self._i]

    def swap(self) -> None:
        self._i = 1 - self._i

    def source_texture(self, fmt: str | None = None, filter: str = "nearest"):
        return self.source.to_texture(fmt=fmt, filter=filter)


class BlendUnit:
    """The blending unit: ``dst' = round_fmt(src * F_src + dst * F_dst)`` per channel, per fragment.

    ============  ============================================================  =========================
    parameter     meaning                                                       allowed
    ============  ============================================================  =========================
    src, dst      RGB(A) blend factors (module docstring lists the names)       factor name
    fmt           frame-buffer format this unit is configured for; ``None``:   as :class:`FrameBuffer`
                  take the target buffer's (a mismatch is an error)             or None
    constant      blend colour for the ``constant_*`` factors                   4 finite numbers
    dither        alpha dithering (Kraus et al. 2004), fixed-point buffers     bool
    seed          seed of the dither table                                      integer in [0, 2^31)
    src_alpha,    separate alpha factors (``glBlendFuncSeparate``);             factor name or None
    dst_alpha     default: same as ``src``/``dst``
    table_size    dither table entries                                          power of two <= 2^24
    arithmetic    fixed-point rounding: once per channel (``exact``, the GL     ``exact`` | ``llvmpipe``
                  spec's) or per product (``llvmpipe``; module docstring);     | ``program``
                  float buffers: ``program`` composites in the fragment
                  program (buffer read as a texture, module docstring)
    ============  ============================================================  =========================

    Examples
    --------
    >>> import numpy as np
    >>> fb = FrameBuffer(1, 1, "unorm8"); fb.clear((0, 0, 0, 0))
    >>> bu = BlendUnit("one", "one_minus_src_alpha")
    >>> bu.blend_layers(fb, np.array([[[[0.2, 0.2, 0.2, 0.2]]]]))
    >>> fb.codes()[0, 0].tolist()
    [51, 51, 51, 51]

    Colour 152 times alpha 229 is 136.502 codes: rounded once (``exact``) 137; llvmpipe's multiply gives 136.

    >>> src = np.array([[[[152, 0, 0, 229]]]]) / 255
    >>> for arith in ("exact", "llvmpipe"):
    ...     fb.clear((0, 0, 0, 0))
    ...     BlendUnit("src_alpha", "zero", arithmetic=arith).blend_layers(fb, src)
    ...     print(arith, fb.codes()[0, 0, 0])
    exact 137
    llvmpipe 136
    """

    def __init__(self, src: str = "one", dst: str = "zero", fmt: Any = None, constant: Sequence[float] = (0, 0, 0, 0),
                 dither: bool = False, seed: int = 0, src_alpha: str | None = None, dst_alpha: str | None = None,
                 table_size: int = 65536, arithmetic: str = "exact"):
        self.src, self.dst = src, dst
        self.arithmetic = check_choice("arithmetic", arithmetic, ARITHMETICS)
        self.src_code = factor_code(src, "src")
        self.dst_code = factor_code(dst, "dst")
        self.src_alpha_code = self.src_code if src_alpha is None else factor_code(src_alpha, "src_alpha")
        self.dst_alpha_code = self.dst_code if dst_alpha is None else factor_code(dst_alpha, "dst_alpha")
        self.fmt = None if fmt is None else _check_fb_format(fmt)
        self.constant = _rgba(constant, "constant")
        if not isinstance(dither, bool):
            raise ConfigError(f"dither: expected true or false, got {dither!r}")
        if dither and self.fmt is not None and self.fmt.is_float:
            raise ConfigError(f"dither: alpha dithering needs a fixed-point frame buffer, fmt is {self.fmt.name}")
        self.dither = dither
        self.seed = check_number("seed", seed, lo=0, hi=2**31 - 1, integer=True)
        self.table = dither_table(self.seed, table_size) if dither else np.zeros(1, np.float32)
        self._tables: dict[str, Any] = {}

    @classmethod
    def over(cls, fmt: Any = None, **kw) -> "BlendUnit":
        """Back-to-front "over" for premultiplied colour: ``(one, one_minus_src_alpha)``."""
        return cls("one", "one_minus_src_alpha", fmt=fmt, **kw)

    @classmethod
    def under(cls, fmt: Any = None, **kw) -> "BlendUnit":
        """Front-to-back "under" for premultiplied colour: ``(one_minus_dst_alpha, one)``."""
        return cls("one_minus_dst_alpha", "one", fmt=fmt, **kw)

    @classmethod
    def replace(cls, fmt: Any = None) -> "BlendUnit":
        """Blending disabled: the fragment (rounded to the buffer format) replaces the pixel."""
        return cls("one", "zero", fmt=fmt)

    def state(self, fb: FrameBuffer):
        """The :class:`warpvol.kernels.blend.BlendState` struct for drawing into ``fb``."""
        if not isinstance(fb, FrameBuffer):
            raise ConfigError(f"fb: expected a FrameBuffer, got {type(fb).__name__}")
        if self.fmt is not None and self.fmt != fb.fmt:
            raise ConfigError(f"fb: frame buffer format {fb.fmt.name} differs from the blend unit's fmt {self.fmt.name}")
        if self.dither and fb.fmt.is_float:
            raise ConfigError(f"fb: alpha dithering needs a fixed-point frame buffer, got {fb.fmt.name}")
        if self.arithmetic == "program" and not fb.fmt.is_float:
            raise ConfigError(f"arithmetic: 'program' composites into a float buffer (fp16/fp32), got {fb.fmt.name}")
        s = kblend.BlendState()
        s.fmt = fb.fmt.kernel_params()
        s.src_rgb, s.dst_rgb = self.src_code, self.dst_code
        s.src_a, s.dst_a = self.src_alpha_code, self.dst_alpha_code
        s.constant = wp.vec4(*map(float, self.constant))
        s.dither = 1 if self.dither else 0
        dev = str(fb.device)
        if dev not in self._tables:
            self._tables[dev] = wp.array(self.table, dtype=wp.float32, device=fb.device)
        s.dither_table = self._tables[dev]
        s.dither_mask = int(self.table.shape[0] - 1)
        s.dither_seed = self.seed
        s.arith = ARITHMETICS[self.arithmetic]
        return s

    def blend_layers(self, fb: FrameBuffer, layers: Any, prim0: int = 0) -> None:
        """Blend K full-screen fragment layers (K, H, W, 4) into ``fb`` in order (layer k = primitive prim0 + k)."""
        st = self.state(fb)
        if isinstance(layers, wp.array):
            arr = layers
            shape = tuple(arr.shape)
            ok = arr.dtype == wp.vec4 and len(shape) == 3 and shape[1:] == fb.shape
        else:
            v = np.asarray(layers, dtype=np.float32)
            ok = v.ndim == 4 and v.shape[1:] == (fb.height, fb.width, 4)
            shape = v.shape
            if ok:
                if not np.isfinite(v).all():
                    raise ConfigError("layers: holds NaN or Inf")
                arr = wp.array(v, dtype=wp.vec4, device=fb.device)
        if not ok:
            raise ConfigError(f"layers: expected shape (K, {fb.height}, {fb.width}, 4), got {shape}")
        wp.launch(kblend.k_blend_layers, dim=fb.shape, inputs=[st, fb.array, arr, int(prim0)], device=fb.device)
        self.count(fb, shape[0] * fb.width * fb.height)

    def blend_fragments(self, fb: FrameBuffer, fragments: Any, colors: Any) -> None:
        """Blend a rasteriser fragment list (:class:`warpvol.gpu.raster.Fragments`) with per-fragment ``colors`` (F, 4)."""
        st = self.state(fb)
        if tuple(fragments.shape) != fb.shape:
            raise ConfigError(f"fragments: generated for {fragments.shape}, frame buffer is {fb.shape}")
        if isinstance(colors, wp.array):
            c = colors
            if c.ndim == 2 and c.dtype == wp.float32 and c.shape[1] == 4 and c.is_contiguous:
                c = c.view(wp.vec4)  # e.g. Fragments.attrs holding RGBA
            if c.dtype != wp.vec4 or c.ndim != 1 or c.shape[0] < fragments.count:
                raise ConfigError(f"colors: expected {fragments.count} vec4 values (or an (F, 4) float32 array)")
        else:
            cv = np.asarray(colors, dtype=np.float32).reshape(-1, 4) if np.size(colors) else np.zeros((0, 4), np.float32)
            if cv.shape[0] != fragments.count:
                raise ConfigError(f"colors: expected shape ({fragments.count}, 4), got {np.shape(colors)}")
            c = wp.array(cv, dtype=wp.vec4, device=fb.device)
        wp.launch(kblend.k_blend_fragments, dim=fb.shape,
                  inputs=[st, fb.array, fragments.offsets, c, fragments.prim], device=fb.device)
        self.count(fb, fragments.count)

    def count(self, fb: FrameBuffer, n: int, counters: "_cnt.Counters | None" = None) -> None:
        """Count ``n`` fragments through this unit into ``fb``: ``blends_<fmt>`` (``writes_<fmt>`` for
        ``(one, zero)``, blending off)."""
        c = _cnt.active(counters)
        if c is not None:
            off = (self.src_code, self.dst_code, self.src_alpha_code, self.dst_alpha_code) == (1, 0, 1, 0)
            if self.arithmetic == "program":  # the buffer texel fetched, composited in the program, written
                off = True
                c.add(**{f"tex_2d_rgba{16 if fb.fmt.name == 'fp16' else 32}f_nearest": n, "combiner_ops": n})
            c.blend(fb.fmt, n, blending=not off)

    def __repr__(self) -> str:
        return (f"BlendUnit(src={self.src!r}, dst={self.dst!r}, fmt={None if self.fmt is None else self.fmt.name}, "
                f"constant={self.constant.tolist()}, dither={self.dither})")


def blend_sequence(layers: Any, fmt: Any = "unorm8", src: str = "one", dst: str = "one_minus_src_alpha",
                   clear: Sequence[float] = (0, 0, 0, 0), device: str = "cpu", **blend_kw) -> np.ndarray:
    """Plain function: blend (K, H, W, 4) layers in order into a fresh buffer; returns its values (H, W, 4)."""
    v = np.asarray(layers, dtype=np.float32)
    if v.ndim != 4 or v.shape[-1] != 4:
        raise ConfigError(f"layers: expected shape (K, H, W, 4), got {v.shape}")
    fb = FrameBuffer(v.shape[2], v.shape[1], fmt, device)
    fb.clear(clear)
    BlendUnit(src, dst, **blend_kw).blend_layers(fb, v)
    return fb.readback()
