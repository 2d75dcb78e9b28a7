"""Exact signs for the reference's ray/edge classification (:mod:`warpvol.reference.numpy_render`, step 2): a
floating-point filter, and where it cannot decide, error-free transformations (two-sum /
two-product expansions, Dekker's split) that give the sign of a sum of products of floats exactly.
Pure NumPy.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

_FILTER = 1e-15  # ~9 units of roundoff: a float sign with |value| above FILTER * permanent is exact


_STATS = {"exact": 0}  # number of exact (expansion) evaluations, for diagnostics
_SPLITTER = 134217729.0  # 2^27 + 1 (Dekker split)


def _two_sum(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``a + b = s + e`` exactly (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _two_prod(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``a * b = p + e`` exactly (Dekker / Veltkamp split; no FMA needed)."""
    p = a * b
    c = _SPLITTER * a
    ah = c - (c - a)
    al = a - ah
    c = _SPLITTER * b
    bh = c - (c - b)
    bl = b - bh
    return p, al * bl - (((p - ah * bh) - al * bh) - ah * bl)


def _exact_sum_of_products(terms: list[tuple[np.ndarray, ...]]) -> tuple[np.ndarray, np.ndarray]:
    """Exact sign and (nearly correctly rounded) value of ``sum(prod(t) for t in terms)``.

    Every product of two or three floats is expanded exactly into floats (two-product), and the
    floats are accumulated into a non-overlapping expansion (Shewchuk's Grow-Expansion), whose
    largest non-zero component carries the sign of the exact sum. Vectorised over arrays.
    """
    parts: list[np.ndarray] = []
    for t in terms:
        if len(t) == 2:
            parts.extend(_two_prod(t[0], t[1]))
        else:
            p, e = _two_prod(t[0], t[1])
            parts.extend(_two_prod(p, t[2]))
            parts.extend(_two_prod(e, t[2]))
    comps = [parts[0]]
    for x in parts[1:]:
        q = x
        new = []
        for c in comps:
            q, h = _two_sum(q, c)
            new.append(h)
        new.append(q)
        comps = new
    sign = np.zeros_like(parts[0])
    for c in reversed(comps):
        sign = np.where(sign == 0, np.sign(c), sign)
    value = comps[0]
    for c in comps[1:]:
        value = value + c
    _STATS["exact"] += len(sign)
    return sign, value


def _certify(value: np.ndarray, bound: np.ndarray, exact: Callable[[np.ndarray], tuple]) -> np.ndarray:
    """Exact sign of ``value``, the float result of a sum of products with rounding error at most
    ``bound`` (``bound == 0``: every product vanished exactly, so 0 is exact). Where the float sign
    is not certain, ``exact(flat_indices)`` gives the exact sign and value, and the value is
    replaced *in place* by the accurate one."""
    s = np.sign(value)
    amb = np.flatnonzero((np.abs(value) <= bound) & (bound > 0))
    if len(amb):
        es, ev = exact(amb)
        s.flat[amb] = es
        value.flat[amb] = ev
    return s


def _sign_det2(p: np.ndarray, q: np.ndarray, r: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Exact ``sign(p q - r t)`` (float filter + exact fallback), arrays of one shape."""
    pq, rt = p * q, r * t

    def exact(ix):
        return _exact_sum_of_products([(p.flat[ix], q.flat[ix]), (-r.flat[ix], t.flat[ix])])

    return _certify(pq - rt, _FILTER * (np.abs(pq) + np.abs(rt)), exact)


