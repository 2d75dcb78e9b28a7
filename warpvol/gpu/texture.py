"""Texture units of the emulated GPU: 1D/2D/3D textures with a texel format, filtering, atlas.

Texel formats (``fmt=``), each a number format from :mod:`warpvol.gpu.formats` plus a channel layout;
what a lookup returns is always RGBA:

============  =========  ========  ====================  ============================================
name          channels   number    lookup returns        note
============  =========  ========  ====================  ============================================
``rgba8``     4          unorm8    (R, G, B, A)
``la8``       2          unorm8    (L, L, L, A)          Guthe's 16-bit alpha: A high, L low byte
``l8``        1          unorm8    (L, L, L, 1)
``a8``        1          unorm8    (0, 0, 0, A)
``rgba8s``    4          snorm8    (R, G, B, A)          signed [-1, 1] (polynomial coefficients)
``hilo16``    2          unorm16   (HI, LO, 1, 1)        NV HILO16 (Kraus et al. accurate lookups)
``rgba16``    4          unorm16   (R, G, B, A)
``r16f``      1          fp16      (R, 0, 0, 1)
``rgba16f``   4          fp16      (R, G, B, A)
``r32f``      1          fp32      (R, 0, 0, 1)
``rgba32f``   4          fp32      (R, G, B, A)
============  =========  ========  ====================  ============================================

Filtering: ``nearest`` or ``linear`` (bi-/trilinear), OpenGL texel centres ``(k + 0.5)/n`` and
clamp-to-edge (details in :mod:`warpvol.kernels.texture`). ``weight_bits`` (default 8) truncates the
filter fraction to that many bits as the fixed-point filter units of NV2x-NV4x did; ``None`` keeps
fp32 weights. The filtered value is not re-quantised. ``float_linear=False`` emulates 2004
hardware on which float textures could only be sampled nearest: a ``linear`` request then samples
nearest (``effective_filter`` says which one runs).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import warp as wp

from warpvol.errors import ConfigError, check_choice, check_number
from warpvol.gpu import counters as _cnt
from warpvol.gpu.formats import FP16, FP32, SNORM8, UNORM8, UNORM12, UNORM16, NumberFormat
from warpvol.kernels import texture as ktex

FILTERS = ("nearest", "linear")

# name -> (number format, stored channels, layout)
TEXEL_FORMATS: dict[str, tuple[NumberFormat, int, str]] = {
    "rgba8": (UNORM8, 4, "rgba"),
    "la8": (UNORM8, 2, "la"),
    "l8": (UNORM8, 1, "l"),
    "a8": (UNORM8, 1, "a"),
    "rgba8s": (SNORM8, 4, "rgba"),
    "rgba12": (UNORM12, 4, "rgba"),  # 12 bits per channel (SGI Octane MXI 12-bit visual, Roettger 2002)
    "hilo16": (UNORM16, 2, "hilo"),
    "rgba16": (UNORM16, 4, "rgba"),
    "r16f": (FP16, 1, "r"),
    "rgba16f": (FP16, 4, "rgba"),
    "r32f": (FP32, 1, "r"),
    "rgba32f": (FP32, 4, "rgba"),
}


def expand_rgba(values: np.ndarray, layout: str) -> np.ndarray:
    """Expand stored channels (..., C) to what a lookup returns (..., 4), float32."""
    v = np.asarray(values, dtype=np.float32)
    one = np.ones(v.shape[:-1], np.float32)
    zero = np.zeros(v.shape[:-1], np.float32)
    c = [v[..., k] for k in range(v.shape[-1])]
    if layout == "rgba":
        out = c
    elif layout == "la":
        out = [c[0], c[0], c[0], c[1]]
    elif layout == "l":
        out = [c[0], c[0], c[0], one]
    elif layout == "a":
        out = [zero, zero, zero, c[0]]
    elif layout == "hilo":
        out = [c[0], c[1], one, one]
    elif layout == "r":
        out = [c[0], zero, zero, one]
    else:  # pragma: no cover - table is closed
        raise ValueError(layout)
    return np.stack(out, axis=-1).astype(np.float32)


def texel_values(data: Any, fmt: str, ndim: int, name: str = "data") -> np.ndarray:
    """Validate texel data, quantise it to ``fmt`` and expand to RGBA: returns (..., 4) float32.

    ``data`` has shape ``spatial + (C,)`` with C the format's channel count, or just ``spatial`` for
    one-channel formats. Values are the *real* values to store (they are rounded to the format).
    """
    fmt = check_choice("fmt", fmt, TEXEL_FORMATS)
    num, ch, layout = TEXEL_FORMATS[fmt]
    try:
        arr = np.asarray(data, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"{name}: expected a numeric array, got {type(data).__name__}") from None
    if arr.ndim == ndim and ch == 1:
        arr = arr[..., None]
    if arr.ndim != ndim + 1 or arr.shape[-1] != ch:
        raise ConfigError(f"{name}: expected shape {'(' + ', '.join('n' * ndim)}, {ch}) for a {ndim}D "
                          f"{fmt} texture, got {arr.shape}")
    if any(s < 1 for s in arr.shape[:-1]):
        raise ConfigError(f"{name}: every texture dimension must be >= 1, got {arr.shape[:-1]}")
    if not np.isfinite(arr).all():
        raise ConfigError(f"{name}: texel data holds NaN or Inf")
    return expand_rgba(num.quantize(arr.astype(np.float32)), layout)


class _TextureBase:
    ndim = 0
    _struct_cls: Any = None

    def __init__(self, data: Any, fmt: str = "rgba8", filter: str = "linear", device: str = "cpu",
                 weight_bits: int | None = 8, float_linear: bool = True, upload: bool = True):
        self.fmt = check_choice("fmt", fmt, TEXEL_FORMATS)
        self.filter = check_choice("filter", filter, FILTERS)
        if weight_bits is not None:
            weight_bits = check_number("weight_bits", weight_bits, lo=1, hi=16, integer=True)
        if not isinstance(float_linear, bool):
            raise ConfigError(f"float_linear: expected true or false, got {float_linear!r}")
        self.weight_bits, self.float_linear, self.device = weight_bits, float_linear, device
        self.number_format = TEXEL_FORMATS[self.fmt][0]
        if self.filter == "linear" and self.number_format.is_float and not float_linear:
            self.effective_filter = "nearest"
        else:
            self.effective_filter = self.filter
        self.values = texel_values(data, self.fmt, self.ndim)  # (..., 4) float32, what texels hold
        self.shape = self.values.shape[:-1]
        self.array = wp.array(self.values, dtype=wp.vec4, device=device)
        s = self._struct_cls()
        s.data = self.array
        s.filter = ktex.FILTER_NEAREST if self.effective_filter == "nearest" else ktex.FILTER_LINEAR
        s.frac_scale = 0.0 if weight_bits is None else float(2**weight_bits)
        self._fill_dims(s)
        self.struct = s
        # counters: texture memory made resident, and its upload over the bus (unless copied on the card)
        _cnt.count(texture_bytes=self.nbytes, **({"bytes_up": self.nbytes} if upload else {}))

    @property
    def nbytes(self) -> int:
        """Texture memory of the stored texels (channels x bytes per channel, 12 bits in 2 bytes)."""
        num, ch, _ = TEXEL_FORMATS[self.fmt]
        return int(np.prod(self.shape)) * ch * ((num.bits + 7) // 8)

    def _fill_dims(self, s) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _run(self, kernel, coords: Any, vdtype, width: int) -> np.ndarray:
        c = np.asarray(coords, dtype=np.float32)
        if width == 1:
            shape = c.shape
            flat = c.reshape(-1)
        else:
            if c.shape[-1:] != (width,):
                raise ConfigError(f"coords: expected shape (..., {width}), got {c.shape}")
            shape = c.shape[:-1]
            flat = c.reshape(-1, width)
        n = flat.shape[0]
        out = wp.empty(n, dtype=wp.vec4, device=self.device)
        if n:
            wp.launch(kernel, dim=n, inputs=[self.struct, wp.array(flat, dtype=vdtype, device=self.device), out],
                      device=self.device)
            self.count(n)
        return out.numpy().reshape(shape + (4,))

    def count(self, fetches: int, counters: "_cnt.Counters | None" = None, dependent: bool = False) -> None:
        """Count ``fetches`` lookups of this texture (kernels that sample it call this from the host)."""
        c = _cnt.active(counters)
        if c is not None:
            c.tex(self, fetches, dependent)

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(shape={self.shape}, fmt={self.fmt!r}, filter={self.effective_filter!r}, "
                f"weight_bits={self.weight_bits})")


class Texture1D(_TextureBase):
    """A 1D texture of a texel format, with its own Warp array.

    ============  =========================================================  ===========================
    parameter     meaning                                                    allowed
    ============  =========================================================  ===========================
    data          texel values (width,) or (width, C), real values           finite; C per ``fmt``
    fmt           texel format (module table)                                ``rgba8`` ``la8`` ... ``rgba32f``
    filter        ``nearest`` or ``linear``                                  choice
    device        Warp device                                                ``"cpu"``, ``"cuda:0"``, ...
    weight_bits   bits of the filter fraction (None: fp32 weights)           1..16 or None (default 8)
    float_linear  False: float formats sample nearest (2004 hardware)        bool
    ============  =========================================================  ===========================

    In a kernel take ``tex: warpvol.kernels.texture.Tex1D`` and pass ``texture.struct``; sample with
    ``ktex.tex1d(tex, u)``.

    Examples
    --------
    >>> t = Texture1D([0.0, 1.0], fmt="l8", filter="linear")
    >>> t.sample([0.25, 0.5, 0.75])[:, 0].tolist()
    [0.0, 0.5, 1.0]
    """

    ndim = 1
    _struct_cls = ktex.Tex1D

    def _fill_dims(self, s) -> None:
        s.width = int(self.shape[0])

    def sample(self, u: Any) -> np.ndarray:
        """RGBA lookups (..., 4) at normalised coordinates ``u`` (any shape)."""
        return self._run(ktex.k_sample1d, u, wp.float32, 1)


class Texture2D(_TextureBase):
    """A 2D texture; ``data`` is (height, width[, C]), row ``j`` at ``v = (j + 0.5)/height``.

    Parameters as :class:`Texture1D`. In kernels: ``ktex.tex2d(tex, u, v)`` with ``tex: ktex.Tex2D``.

    Examples
    --------
    >>> t = Texture2D([[0.0, 1.0], [1.0, 1.0]], fmt="l8")
    >>> float(t.sample([[0.5, 0.5]])[0, 0])
    0.75
    """

    ndim = 2
    _struct_cls = ktex.Tex2D

    def _fill_dims(self, s) -> None:
        s.height, s.width = int(self.shape[0]), int(self.shape[1])

    def sample(self, uv: Any) -> np.ndarray:
        """RGBA lookups (..., 4) at normalised coordinates ``uv`` (..., 2)."""
        return self._run(ktex.k_sample2d, uv, wp.vec2, 2)


class Texture3D(_TextureBase):
    """A 3D texture; ``data`` is (depth, height, width[, C]) indexed [r, v, u].

    Parameters as :class:`Texture1D`. In kernels: ``ktex.tex3d(tex, u, v, r)`` with ``tex: ktex.Tex3D``.

    Examples
    --------
    >>> t = Texture3D(np.zeros((2, 2, 2, 2)), fmt="hilo16")
    >>> t.sample([[0.5, 0.5, 0.5]]).tolist()
    [[0.0, 0.0, 1.0, 1.0]]
    """

    ndim = 3
    _struct_cls = ktex.Tex3D

    def _fill_dims(self, s) -> None:
        s.depth, s.height, s.width = (int(x) for x in self.shape)

    def sample(self, uvr: Any) -> np.ndarray:
        """RGBA lookups (..., 4) at normalised coordinates ``uvr`` (..., 3)."""
        return self._run(ktex.k_sample3d, uvr, wp.vec3, 3)


class TextureAtlas:
    """2D tiles of equal size packed into one large 2D texture (Roettger & Ertl's cylindrical planes).

    Tile ``k`` sits at grid cell ``(k // cols, k % cols)``; each tile is stored with a one-texel
    border that replicates its edge texels, so bilinear filtering in the atlas equals clamp-to-edge
    filtering of the tile alone (no bleeding between tiles), exactly as such atlases were built.

    ============  =====================================================  ============================
    parameter     meaning                                                allowed
    ============  =====================================================  ============================
    tiles         (ntiles, tile_h, tile_w[, C]) real texel values        finite; C per ``fmt``
    fmt, filter,  as :class:`Texture1D`
    device, ...
    cols          tiles per atlas row (default ceil(sqrt(ntiles)))       integer >= 1
    ============  =====================================================  ============================

    In kernels: ``ktex.atlas_sample(atlas.struct, tile, u, v)`` with ``atlas: ktex.Atlas``.

    Examples
    --------
    >>> a = TextureAtlas(np.stack([np.zeros((2, 2)), np.ones((2, 2))]), fmt="l8")
    >>> a.sample([0, 1], [[0.5, 0.5], [0.0, 1.0]])[:, 0].tolist()
    [0.0, 1.0]
    """

    def __init__(self, tiles: Any, fmt: str = "rgba8", filter: str = "linear", device: str = "cpu",
                 weight_bits: int | None = 8, float_linear: bool = True, cols: int | None = None):
        fmt = check_choice("fmt", fmt, TEXEL_FORMATS)
        ch = TEXEL_FORMATS[fmt][1]
        t = np.asarray(tiles, dtype=np.float64)
        if t.ndim == 3 and ch == 1:
            t = t[..., None]
        if t.ndim != 4 or t.shape[-1] != ch or min(t.shape[:3]) < 1:
            raise ConfigError(f"tiles: expected shape (ntiles, tile_h, tile_w, {ch}) for {fmt}, got {np.shape(tiles)}")
        n, th, tw = t.shape[:3]
        if cols is None:
            cols = int(np.ceil(np.sqrt(n)))
        cols = check_number("cols", cols, lo=1, integer=True)
        rows = -(-n // cols)
        padded = np.pad(t, ((0, 0), (1, 1), (1, 1), (0, 0)), mode="edge")
        big = np.zeros((rows * (th + 2), cols * (tw + 2), ch))
        for k in range(n):
            r, c = divmod(k, cols)
            big[r * (th + 2):(r + 1) * (th + 2), c * (tw + 2):(c + 1) * (tw + 2)] = padded[k]
        self.texture = Texture2D(big, fmt=fmt, filter=filter, device=device, weight_bits=weight_bits,
                                 float_linear=float_linear)
        self.ntiles, self.tile_h, self.tile_w, self.cols, self.device = n, th, tw, cols, device
        s = ktex.Atlas()
        s.tex, s.cols, s.tile_w, s.tile_h, s.ntiles = self.texture.struct, cols, tw, th, n
        self.struct = s

    def sample(self, tiles: Any, uv: Any) -> np.ndarray:
        """RGBA lookups (M, 4) of tiles ``tiles`` (M,) at in-tile normalised ``uv`` (M, 2)."""
        k = np.asarray(tiles, dtype=np.int32).reshape(-1)
        c = np.asarray(uv, dtype=np.float32).reshape(-1, 2)
        if k.shape[0] != c.shape[0]:
            raise ConfigError(f"tiles: {k.shape[0]} tile indices for {c.shape[0]} coordinates")
        if k.size and (k.min() < 0 or k.max() >= self.ntiles):
            raise ConfigError(f"tiles: indices must be in [0, {self.ntiles - 1}]")
        out = wp.empty(k.shape[0], dtype=wp.vec4, device=self.device)
        if k.size:
            wp.launch(ktex.k_sample_atlas, dim=k.shape[0],
                      inputs=[self.struct, wp.array(k, dtype=wp.int32, device=self.device),
                              wp.array(c, dtype=wp.vec2, device=self.device), out], device=self.device)
            self.texture.count(k.shape[0])
        return out.numpy()


def sample_dependent(first: Texture1D | Texture2D, second: Texture1D, coords: Any, channel: int = 0) -> np.ndarray:
    """Dependent lookup: ``second`` sampled at channel ``channel`` of ``first(coords)`` (M, 4).

    Example: Guthe et al.'s ``alpha = alpha1D(l * rho_hat(sf, sb))`` reads the 2D texture first and
    uses one of its channels as the 1D coordinate.
    """
    channel = check_number("channel", channel, lo=0, hi=3, integer=True)
    if not isinstance(second, Texture1D):
        raise ConfigError(f"second: expected a Texture1D, got {type(second).__name__}")
    if first.device != second.device:
        raise ConfigError(f"second: on device {second.device!r}, first on {first.device!r}")
    dev = first.device
    if isinstance(first, Texture2D):
        c = np.asarray(coords, dtype=np.float32).reshape(-1, 2)
        kern, arr = ktex.k_dependent_2d_1d, wp.array(c, dtype=wp.vec2, device=dev)
    elif isinstance(first, Texture1D):
        c = np.asarray(coords, dtype=np.float32).reshape(-1)
        kern, arr = ktex.k_dependent_1d_1d, wp.array(c, dtype=wp.float32, device=dev)
    else:
        raise ConfigError(f"first: expected a Texture1D or Texture2D, got {type(first).__name__}")
    out = wp.empty(c.shape[0], dtype=wp.vec4, device=dev)
    if c.shape[0]:
        wp.launch(kern, dim=c.shape[0], inputs=[first.struct, second.struct, channel, arr, out], device=dev)
        first.count(c.shape[0])
        second.count(c.shape[0], dependent=True)
    return out.numpy()
