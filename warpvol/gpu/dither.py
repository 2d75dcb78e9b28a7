"""Alpha dithering (Kraus, Qiao & Ebert 2004, Sec. 4.2): reproducible pseudo-random threshold tables.

The blending unit rounds a fragment's alpha ``a`` to ``floor(N a) + 1`` if ``N a - floor(N a) > q``
else ``floor(N a)`` (N = 2^bits - 1; N = 255 in the paper), where ``q`` is read from a table of
uniform pseudo-random numbers in [0, 1) at ``dither_index(x, y, prim, seed) & (size - 1)`` (an
integer hash of pixel, primitive and seed, :func:`warpvol.kernels.blend.dither_index`). The table
is ``numpy.random.default_rng(seed).random(size)`` as float32, so everything is reproducible from
the seed, on every device. Since P(q < f) = f, the expected code is exactly N a: unbiased.
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError, check_number


def dither_table(seed: int = 0, size: int = 65536) -> np.ndarray:
    """The threshold table (float32 in [0, 1)) for ``seed``; ``size`` must be a power of two."""
    seed = check_number("seed", seed, lo=0, hi=2**31 - 1, integer=True)
    size = check_number("size", size, lo=1, hi=2**24, integer=True)
    if size & (size - 1):
        raise ConfigError(f"size: {size} is not a power of two")
    return np.random.default_rng(seed).random(size, dtype=np.float32)


def dither_index_np(x, y, prim, seed: int, mask: int) -> np.ndarray:
    """NumPy twin of the kernels' ``dither_index`` (uint32 arithmetic), for references and tests."""
    u = np.uint32
    with np.errstate(over="ignore"):
        h = np.asarray(x).astype(np.int64).astype(u) * u(73856093)
        h ^= np.asarray(y).astype(np.int64).astype(u) * u(19349663)
        h ^= np.asarray(prim).astype(np.int64).astype(u) * u(83492791)
        h ^= u(np.uint32(seed & 0xFFFFFFFF) * u(1103515245))
        h ^= h >> u(16)
        h *= u(2146121005)
        h ^= h >> u(15)
        h *= u(739982445)
        h ^= h >> u(16)
    return (h & u(mask)).astype(np.int64)


def dither_codes_np(a, n: int, q) -> np.ndarray:
    """NumPy twin of ``dither_code``: randomised rounding of alpha ``a`` to codes of ``n`` steps."""
    v = np.clip(np.nan_to_num(np.asarray(a, dtype=np.float32)), 0, 1).astype(np.float32) * np.float32(n)
    f = np.floor(v)
    c = f.astype(np.int64) + ((v - f) > np.asarray(q, np.float32))
    return np.minimum(c, n)
