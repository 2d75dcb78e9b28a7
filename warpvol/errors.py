"""Exceptions and validation helpers that name the offending argument.

Every user-facing check in warpvol goes through these helpers so that an error message always says
*which* field (file, key, argument) was wrong, what value it had and what was expected, in the style
of pyvista's validation helpers.
"""

from __future__ import annotations

import math
from typing import Any, Iterable

import numpy as np


class WarpvolError(ValueError):
    """Base class of all errors raised for bad input."""


class ConfigError(WarpvolError):
    """A scene file, pipeline config or stage parameter is wrong."""


class MeshError(WarpvolError):
    """A mesh is malformed (indices, NaN, non-manifold faces, ...)."""


class NonFiniteImage(WarpvolError):
    """An image holds NaN or Inf pixels: it is not written (no command writes a non-finite pixel)."""


def check_finite_image(path, image) -> None:
    """Raise :class:`NonFiniteImage` naming ``path`` and the count of pixels with a NaN or Inf channel."""
    img = np.asarray(image)
    if img.dtype.kind not in "fc":
        return
    fin = np.isfinite(img)
    if not fin.all():
        bad = ~(fin.all(axis=-1) if img.ndim == 3 else fin)
        raise NonFiniteImage(f"{path}: {int(bad.sum()):,} of {bad.size:,} pixels are not finite (NaN or Inf); the "
                             "image is not written")


def check_finite_array(name: str, arr: np.ndarray) -> None:
    """Raise if ``arr`` holds NaN or Inf; the message names ``name`` and the first bad index."""
    arr = np.asarray(arr)
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        raise MeshError(
            f"{name}: {int(bad.sum())} non-finite value(s) (NaN/Inf); first at index "
            f"{tuple(int(i) for i in idx)} = {arr[tuple(idx)].item()!r}; expected finite numbers"
        )


def check_number(
    name: str,
    value: Any,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    integer: bool = False,
) -> float | int:
    """Validate a scalar: finite, optionally integer, inside ``[lo, hi]`` (open ends as flagged).

    Examples
    --------
    >>> check_number("fov_y_deg", 30.0, lo=0, hi=180, lo_open=True, hi_open=True)
    30.0
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ConfigError(f"{name}: expected a number, got {value!r}")
    if integer and not float(value).is_integer():
        raise ConfigError(f"{name}: expected an integer, got {value!r}")
    if not math.isfinite(float(value)):
        raise ConfigError(f"{name}: expected a finite number, got {value!r}")
    lo_ok = lo is None or (value > lo if lo_open else value >= lo)
    hi_ok = hi is None or (value < hi if hi_open else value <= hi)
    if not (lo_ok and hi_ok):
        lb = "(" if lo_open else "["
        rb = ")" if hi_open else "]"
        lo_s = "-inf" if lo is None else f"{lo:g}"
        hi_s = "inf" if hi is None else f"{hi:g}"
        raise ConfigError(f"{name}: {value!r} is outside the allowed range {lb}{lo_s}, {hi_s}{rb}")
    return int(value) if integer else float(value)


def check_choice(name: str, value: Any, allowed: Iterable[str]) -> str:
    """Validate that ``value`` is one of ``allowed``; the error lists the allowed values."""
    allowed = list(allowed)
    if value not in allowed:
        raise ConfigError(f"{name}: unknown value {value!r}; allowed: {', '.join(map(repr, allowed))}")
    return value


def check_vec3(name: str, value: Any) -> np.ndarray:
    """Validate a 3-vector of finite numbers."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"{name}: expected 3 numbers, got {value!r}") from None
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise ConfigError(f"{name}: expected 3 finite numbers, got {value!r}")
    return arr


def close_key(key: Any, allowed: Iterable[str]) -> str | None:
    """The allowed key ``key`` was most likely meant as (:func:`difflib.get_close_matches`, or an allowed
    key that starts with it, ``fov`` for ``fov_y_deg``), or ``None``.

    Examples
    --------
    >>> close_key("trasnfer", ["mesh", "transfer", "camera"]), close_key("fov", ["eye", "fov_y_deg"])
    ('transfer', 'fov_y_deg')
    >>> close_key("lights", ["mesh", "transfer", "camera"]) is None
    True
    """
    import difflib

    allowed = [str(a) for a in allowed]
    if not isinstance(key, str) or not key:
        return None
    folded = {a.casefold(): a for a in allowed}
    hit = difflib.get_close_matches(key.casefold(), list(folded), n=1, cutoff=0.6)
    if hit:
        return folded[hit[0]]
    starts = [a for a in allowed if len(key) >= 2 and a.casefold().startswith(key.casefold())]
    return starts[0] if len(starts) == 1 else None


def unknown_keys(given: Iterable[str], allowed: Iterable[str]) -> str | None:
    """``unknown key(s) 'a' (did you mean 'b'?), 'c'; allowed: ...`` for the keys of ``given`` not in
    ``allowed``, each with the allowed key it most likely meant (:func:`close_key`); ``None`` when every key
    is allowed."""
    allowed = list(allowed)
    unknown = [k for k in given if k not in allowed]
    if not unknown:
        return None
    named = []
    for k in unknown:
        near = close_key(k, allowed)
        named.append(repr(k) + (f" (did you mean {near!r}?)" if near else ""))
    return f"unknown key(s) {', '.join(named)}; allowed: {', '.join(map(repr, allowed))}"


def check_keys(where: str, given: Iterable[str], allowed: Iterable[str]) -> None:
    """Raise naming every unknown key in ``given``, with a did-you-mean where one is close, and listing
    what ``where`` allows.

    Examples
    --------
    >>> check_keys("camera", {"fov": 30, "eyes": [0, 0, 1]}, ["eye", "fov_y_deg"])
    Traceback (most recent call last):
    ...
    warpvol.errors.ConfigError: camera: unknown key(s) 'fov' (did you mean 'fov_y_deg'?), 'eyes' (did you mean 'eye'?); allowed: 'eye', 'fov_y_deg'
    """
    msg = unknown_keys(given, allowed)
    if msg:
        raise ConfigError(f"{where}: {msg}")
