"""Table object, table axes and stored formats shared by every pre-integration builder.

Conventions (DESIGN.md, "Numerical conventions")
------------------------------------------------
* Scalars are normalised to ``[0, 1]`` over the transfer function's range, thickness over ``lmax``.
* Arrays are in texture order: a 3D table is ``data[l, sb, sf, channel]`` (x = sf, y = sb, z = l),
  a 2D table ``data[y, x, channel]``; ``Table.axes`` lists the axes in the same (array) order.
* Axis kinds (where the texel nodes sit, and how a normalised value maps to a texture coordinate):

  ==============  ==============================  ===============================================
  kind            node k (normalised value)       texture coordinate of a normalised value x
  ==============  ==============================  ===============================================
  ``centred``     ``(k + 0.5) / n``               ``x`` (DESIGN default; ends half a texel out)
  ``endpoint``    ``k / (n - 1)``                 ``(2n)^-1 + x (1 - 1/n)`` (Kraus 2004 §3)
  ``log2``        ``0, Δl, 2Δl, 4Δl, ... , 1``    eq. 1 of Kraus 2004, ``Δl = 2^-(n-2)``
  ==============  ==============================  ===============================================

Stored formats
--------------
``fp32`` (as computed), ``fp16``, ``rgba8`` (UNorm8 per channel), ``hilo16`` (UNorm16 per channel,
NVIDIA HILO: two 16-bit channels per texture, so an RGBA table is two HILO textures),
``snorm8`` (signed texels in [-1, 1], Guthe's polynomial coefficients) and ``al16`` (Guthe's 16-bit
opacity in an 8-bit A/L pair). Quantisation goes through :mod:`warpvol.gpu.formats` (the emulated GPU's
number formats); this module only picks the codec.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from warpvol.errors import ConfigError, check_choice, check_number
from warpvol.gpu import formats as F

AXIS_KINDS = ("centred", "endpoint", "log2")
TABLE_FORMATS = ("fp32", "fp16", "rgba8", "hilo16", "snorm8", "al16")


# ------------------------------------------------------------------------------------------------
# axes
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Axis:
    """One table axis: ``n`` texel nodes of a quantity normalised to ``[0, 1]`` (times ``scale``).

    ``scale`` converts the normalised value to physical units (``lmax`` for thickness, the TF range
    width for scalars, 1 for dimensionless axes); ``offset`` is added after scaling.
    """

    name: str
    n: int
    kind: str = "centred"
    scale: float = 1.0
    offset: float = 0.0

    def __post_init__(self):
        check_choice(f"axis {self.name}.kind", self.kind, AXIS_KINDS)
        if self.n < 1 or (self.kind != "centred" and self.n < 2):
            raise ConfigError(f"axis {self.name}: resolution {self.n} too small for kind {self.kind!r}")

    @property
    def nodes(self) -> np.ndarray:
        """Normalised values at the texel centres (float64, length n)."""
        k = np.arange(self.n, dtype=np.float64)
        if self.kind == "centred":
            return (k + 0.5) / self.n
        if self.kind == "endpoint":
            return k / (self.n - 1)
        dl = 2.0 ** -(self.n - 2)
        return np.concatenate([[0.0], dl * 2.0 ** (k[1:] - 1)])

    @property
    def physical(self) -> np.ndarray:
        return self.offset + self.scale * self.nodes

    def coord(self, x: Any) -> np.ndarray:
        """Texture coordinate in [0, 1] of normalised value(s) ``x`` (clamped to [0, 1] first)."""
        x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
        n = self.n
        if self.kind == "centred":
            return x
        if self.kind == "endpoint":
            return 0.5 / n + x * (1.0 - 1.0 / n)
        dl = 2.0 ** -(n - 2)
        with np.errstate(divide="ignore"):
            lg = np.where(x > 0, np.log2(np.maximum(x, 1e-300) / dl), -np.inf)
        return (np.maximum(lg, 0.0) + np.minimum(x / dl, 1.0)) / n + 0.5 / n

    def index(self, x: Any) -> np.ndarray:
        """Continuous texel index (``coord * n - 0.5``) of normalised value(s) ``x``."""
        return self.coord(x) * self.n - 0.5

    def describe(self) -> str:
        return f"{self.name}[{self.n}, {self.kind}, x{self.scale:g}]"


# ------------------------------------------------------------------------------------------------
# formats (codec choice only; the arithmetic is warpvol.gpu.formats)
# ------------------------------------------------------------------------------------------------


STORAGE = {
    # table format -> warpvol.gpu.formats object (per channel) and what the raw texels are
    "fp16": "fp16",      # raw: IEEE binary16 bit patterns (uint16)
    "rgba8": "unorm8",   # raw: 8-bit codes per channel, round to nearest, saturate
    "hilo16": "unorm16", # raw: 16-bit codes per channel (HILO: 2 channels per texture)
    "snorm8": "snorm8",  # raw: signed 8-bit codes, value max(c/127, -1)
}


def quantise(values: np.ndarray, fmt: str) -> tuple[np.ndarray, np.ndarray | None]:
    """``(decoded float32 values, raw stored texels or None)`` of ``values`` stored as ``fmt``.

    Every conversion is :mod:`warpvol.gpu.formats` (one emulated GPU); ``al16`` stores each channel as
    Guthe's 8-bit A/L pair (raw has a trailing axis of 2: A code, L code).
    """

    check_choice("format", fmt, TABLE_FORMATS)
    v = np.asarray(values, dtype=np.float32)
    if fmt == "fp32":
        return np.ascontiguousarray(v), None
    if fmt == "al16":
        pair = F.Pair16()
        a, l = pair.encode(v)
        return pair.decode(a, l), np.stack([a, l], axis=-1).astype(np.uint8)
    f = F.get_format(STORAGE[fmt])
    raw = f.encode(v)
    dec = f.decode(raw)
    if fmt in ("rgba8",):
        raw = raw.astype(np.uint8)
    elif fmt == "hilo16":
        raw = raw.astype(np.uint16)
    elif fmt == "snorm8":
        raw = raw.astype(np.int8)
    return np.ascontiguousarray(dec, dtype=np.float32), raw


# ------------------------------------------------------------------------------------------------
# table
# ------------------------------------------------------------------------------------------------


@dataclass
class Table:
    """A pre-integration table (or a set of planes / an atlas) with its axes, format and cache key.

    Attributes
    ----------
    name : str
        Builder name (``"exact3d"``, ``"roettger_sw"``, ...).
    data : numpy.ndarray
        Decoded float32 values in texture order, last axis = channels.
    axes : tuple of Axis
        One per leading array dimension, in array order.
    channels : tuple of str
        Channel meanings, e.g. ``("r", "g", "b", "a")``.
    format : str
        Stored format (``fp32``, ``fp16``, ``rgba8``, ``hilo16``, ``snorm8``, ``al16``).
    key : tuple
        Cache key (builder, TF hash or ``None``, parameters).
    raw : numpy.ndarray or None
        Stored texels (integers for fixed-point formats, float16 for fp16); ``None`` for fp32.
    meta : dict
        Builder parameters, derived scales, build time and (for faithful low-precision builders)
        their measured error.
    extra : dict
        Further named arrays of the same table set (e.g. Guthe's alpha1D texture).
    """

    name: str
    data: np.ndarray
    axes: tuple
    channels: tuple
    format: str = "fp32"
    key: tuple = ()
    raw: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple:
        return self.data.shape

    @property
    def nbytes(self) -> int:
        n = self.data.nbytes + sum(np.asarray(v).nbytes for v in self.extra.values() if hasattr(v, "nbytes"))
        return int(n)

    def to_warp(self, device: str):
        """The decoded data as a Warp array on ``device`` (vec4 / float per channel count)."""
        import warp as wp

        c = self.data.shape[-1]
        dtype = {1: wp.float32, 2: wp.vec2, 3: wp.vec3, 4: wp.vec4}[c]
        arr = self.data if c > 1 else self.data[..., 0]
        return wp.array(np.ascontiguousarray(arr, dtype=np.float32), dtype=dtype, device=device)

    def with_format(self, fmt: str) -> "Table":
        """A copy stored in ``fmt`` (quantised from this table's decoded values)."""
        dec, raw = quantise(self.data, fmt)
        key = self.key[:-1] + (("format", fmt),) if self.key else ()
        return Table(self.name, dec, self.axes, self.channels, fmt, key, raw, dict(self.meta), dict(self.extra))

    def __repr__(self) -> str:
        ax = ", ".join(a.describe() for a in self.axes)
        return f"Table({self.name!r}, {ax}, channels={''.join(self.channels)}, format={self.format})"


def table_key(name: str, tf_hash: str | None, **params: Any) -> tuple:
    """Hashable cache key: builder name, TF hash (``None`` for TF-free tables), sorted parameters."""

    def freeze(v):
        if isinstance(v, Table):  # a source table (e.g. the one cylindrical planes resample): its own key
            return ("table",) + tuple(v.key)
        if isinstance(v, float):
            return float(np.float64(v))  # normalise -0.0 etc.
        if isinstance(v, (list, tuple)):
            return tuple(freeze(x) for x in v)
        return v

    items = tuple(sorted((k, freeze(v)) for k, v in params.items() if k != "format"))
    return (name, tf_hash) + items + (("format", params.get("format", "fp32")),)


# ------------------------------------------------------------------------------------------------
# small shared helpers
# ------------------------------------------------------------------------------------------------


def model_id(tf) -> int:
    """0 = colour times extinction, 1 = emission density (kernel convention of kernels/integrate)."""
    return 0 if tf.emission == "color_extinction" else 1


def check_resolution(name: str, n: Any, lo: int = 1, hi: int = 4096) -> int:
    return int(check_number(name, n, lo=lo, hi=hi, integer=True))


def check_positive(name: str, v: Any) -> float:
    return float(check_number(name, v, lo=0.0, lo_open=True))


def lerp_axis(data: np.ndarray, idx: np.ndarray, axis: int) -> np.ndarray:
    """Linear interpolation along ``axis`` at continuous indices ``idx`` (clamp to edge), float64."""
    n = data.shape[axis]
    t = np.clip(np.asarray(idx, dtype=np.float64), 0.0, n - 1)
    i0 = np.floor(t).astype(np.int64)
    i0 = np.minimum(i0, max(n - 2, 0))
    f = t - i0
    i1 = np.minimum(i0 + 1, n - 1)
    a = np.take(data, i0, axis=axis).astype(np.float64)
    b = np.take(data, i1, axis=axis).astype(np.float64)
    shape = [1] * a.ndim
    shape[axis] = -1
    f = f.reshape(shape) if f.ndim == 1 else f
    return a + (b - a) * f


def sample3d(table: Table, sf: Any, sb: Any, l: Any) -> np.ndarray:
    """Trilinear lookup (clamp to edge) of a 3D table at normalised ``(sf, sb, l)``, float64.

    An analysis helper (tests, scripts, host-side resampling); fragment-stage lookups at render time
    go through the emulated texture unit.
    """
    ax_l, ax_b, ax_f = table.axes
    sf, sb, l = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (sf, sb, l)))
    fi, bi, li = ax_f.index(sf), ax_b.index(sb), ax_l.index(l)
    d = table.data
    nl, nb, nf = d.shape[:3]

    def split(t, n):
        t = np.clip(t, 0.0, n - 1)
        i0 = np.minimum(np.floor(t).astype(np.int64), max(n - 2, 0))
        return i0, np.minimum(i0 + 1, n - 1), (t - i0)[..., None]

    f0, f1, wf = split(fi, nf)
    b0, b1, wb = split(bi, nb)
    l0, l1, wl = split(li, nl)
    d = d.astype(np.float64)

    def bil(lk):
        c00 = d[lk, b0, f0] * (1 - wf) + d[lk, b0, f1] * wf
        c01 = d[lk, b1, f0] * (1 - wf) + d[lk, b1, f1] * wf
        return c00 * (1 - wb) + c01 * wb

    return bil(l0) * (1 - wl) + bil(l1) * wl


def isfinite_table(t: Table) -> bool:
    return bool(np.isfinite(t.data).all()) and all(
        np.isfinite(np.asarray(v, dtype=np.float64)).all() for v in t.extra.values() if isinstance(v, np.ndarray))


def next_pow2(n: int) -> int:
    return 1 << max(0, math.ceil(math.log2(max(n, 1))))
