"""Segment integration and compositing of the exact float64 reference (:mod:`warpvol.reference.numpy_render`,
steps 3 and 4): each ray segment split at the transfer function's control points, optical depth
exact per piece, radiance by Gauss-Legendre quadrature on sub-intervals of optical depth at most
:data:`SUB_DEPTH` (a tail interval after :data:`MAX_DEPTH`); segments composited front to back with
segmented cumulative sums. Pure NumPy.
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError, check_choice
from warpvol.scene.transfer import EMISSION_MODELS, TransferFunction

#: Gauss-Legendre nodes per sub-interval.
GL_NODES = 10
#: Largest optical depth of one quadrature sub-interval.
SUB_DEPTH = 1.0
#: Optical depth after which a piece's remainder is lumped into one tail interval
#: (``exp(-42) = 5.7e-19``).
MAX_DEPTH = 42.0

_N_MAIN = int(np.ceil(MAX_DEPTH / SUB_DEPTH))
_GL_X, _GL_W = np.polynomial.legendre.leggauss(GL_NODES)
# optically thin pieces (depth <= 0.03) need only 5 nodes for ~3e-13 relative accuracy
_THIN_DEPTH = 0.03
_GL_THIN = np.polynomial.legendre.leggauss(5)

_BLOCK_PIECES = 400_000  # TF pieces per integration block
_BLOCK_SUBS = 250_000  # quadrature sub-intervals per evaluation block


# ------------------------------------------------------------------------------------------------
# segmented scans and compositing
# ------------------------------------------------------------------------------------------------
def segmented_exclusive_cumsum(x: np.ndarray, group: np.ndarray) -> np.ndarray:
    """Exclusive cumulative sum of ``x`` restarting at every change of ``group``.

    Parameters
    ----------
    x : (n,) float array
        Values, typically non-negative optical depths.
    group : (n,) int array
        Group label of each value; the members of a group must be contiguous.

    Returns
    -------
    (n,) float64
        ``out[k] = sum(x[j] for j < k in the same group)``; 0 at the first member of a group.

    Notes
    -----
    A log-step (Hillis-Steele) scan: every partial sum only ever adds values of its own group, so
    there is no cancellation (unlike a global ``cumsum`` minus group offsets) and the relative error
    stays at a few ulps even when other groups hold huge values.

    Examples
    --------
    >>> segmented_exclusive_cumsum(np.array([1.0, 2, 3, 4, 5]), np.array([0, 0, 0, 7, 7])).tolist()
    [0.0, 1.0, 3.0, 0.0, 4.0]
    """
    x = np.asarray(x, dtype=np.float64)
    group = np.asarray(group)
    n = len(x)
    y = np.zeros(n, dtype=np.float64)
    if n <= 1:
        return y
    same1 = group[1:] == group[:-1]
    y[1:] = np.where(same1, x[:-1], 0.0)
    # longest run of one group bounds the number of passes
    starts = np.flatnonzero(np.concatenate([[True], ~same1]))
    longest = int(np.diff(np.append(starts, n)).max())
    step = 1
    while step < longest:
        same = group[step:] == group[:-step]
        y[step:] = y[step:] + np.where(same, y[:-step], 0.0)
        step *= 2
    return y


def composite_front_to_back(pixel: np.ndarray, depth: np.ndarray, rgb: np.ndarray, tau: np.ndarray,
                            n_pixels: int, depth_tie: np.ndarray | None = None) -> np.ndarray:
    """Composite segments front to back per pixel over transparent black.

    Parameters
    ----------
    pixel : (n,) int array
        Pixel (flat index in ``[0, n_pixels)``) of each segment.
    depth : (n,) float array
        Sort key along the ray (entry depth ``t_in``).
    rgb : (n, 3) float array
        Radiance of each segment on its own (transmittance 1 at its entry).
    tau : (n,) float array
        Optical depth of each segment.
    n_pixels : int
        Number of pixels of the output.
    depth_tie : (n,) float array, optional
        Secondary sort key for equal ``depth`` (exit depth ``t_out``), so that a (near) zero-length
        segment at a shared edge sorts before the segment that starts where it ends.

    Returns
    -------
    (n_pixels, 4) float64
        Premultiplied RGBA: ``RGB = sum_k exp(-sum_{j<k} tau_j) rgb_k`` in depth order,
        ``A = 1 - exp(-sum_k tau_k)``.
    """
    pixel = np.asarray(pixel, dtype=np.int64)
    out = np.zeros((int(n_pixels), 4), dtype=np.float64)
    if len(pixel) == 0:
        return out
    order = np.lexsort((np.asarray(depth, dtype=np.float64), pixel)) if depth_tie is None else \
        np.lexsort((np.asarray(depth_tie, dtype=np.float64), np.asarray(depth, dtype=np.float64), pixel))
    p = pixel[order]
    t = np.asarray(tau, dtype=np.float64)[order]
    c = np.asarray(rgb, dtype=np.float64)[order]
    trans = np.exp(-segmented_exclusive_cumsum(t, p))
    for ch in range(3):
        out[:, ch] = np.bincount(p, weights=trans * c[:, ch], minlength=n_pixels)
    out[:, 3] = -np.expm1(-np.bincount(p, weights=t, minlength=n_pixels))
    return out


# ------------------------------------------------------------------------------------------------
# segment integration
# ------------------------------------------------------------------------------------------------
def _tf_eval(tf: TransferFunction, s: np.ndarray) -> np.ndarray:
    pts = tf.points
    out = np.empty(s.shape + (4,), dtype=np.float64)
    for c in range(4):
        out[..., c] = np.interp(s, pts[:, 0], pts[:, c + 1])
    return out


def _depth_to_t(target: np.ndarray, rho0: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Smallest ``t >= 0`` with ``rho0 t + a t^2 / 2 = target`` (``rho(t) = rho0 + a t >= 0``)."""
    disc = np.maximum(rho0 * rho0 + 2.0 * a * target, 0.0)
    den = rho0 + np.sqrt(disc)
    return np.where(den > 0, 2.0 * target / np.where(den > 0, den, 1.0), 0.0)


def _gl(ta, tb, r0, r1, h, x, wts, emission_density: bool):
    """Gauss-Legendre (nodes ``x``, weights ``wts``) over ``[ta, tb]`` inside pieces of length ``h``
    (all arrays per sub-interval) of ``(1-u) w T`` and ``u w T`` with ``u = t/h``."""
    half = 0.5 * (tb - ta)
    t = (0.5 * (ta + tb))[:, None] + half[:, None] * x[None, :]
    u = np.clip(t / h[:, None], 0.0, 1.0)
    rt = r0[:, None] * (1.0 - u) + r1[:, None] * u
    f = np.exp(-0.5 * t * (r0[:, None] + rt)) * (wts[None, :] * half[:, None])
    if not emission_density:
        f *= rt
    g1 = (f * u).sum(axis=1)
    return f.sum(axis=1) - g1, g1


def _integrate_pieces(h, rho0, rho1, emission_density: bool):
    """Per piece (length ``h``, extinction linear ``rho0 -> rho1``) the radiance weights
    ``F0 = int (1-u) w(t) T(t) dt`` and ``F1 = int u w(t) T(t) dt`` (``u = t/h``, ``w = rho`` or 1,
    ``T = exp(-int_0^t rho)``), so that the radiance of a linear colour ``c0 -> c1`` is
    ``F0 c0 + F1 c1``; and the optical depth ``tau``."""
    P = len(h)
    tau = 0.5 * h * (rho0 + rho1)
    capped = tau > MAX_DEPTH
    nsub = np.where(capped, _N_MAIN + 1, np.maximum(1, np.ceil(tau / SUB_DEPTH))).astype(np.int64)
    nsub[h <= 0] = 1
    hsafe = np.where(h > 0, h, 1.0)
    F0 = np.zeros(P)
    F1 = np.zeros(P)
    # single sub-interval pieces (the common case): optically thin ones need fewer nodes
    one = nsub == 1
    for sel_mask, (x, wts) in ((one & (tau <= _THIN_DEPTH), _GL_THIN), (one & (tau > _THIN_DEPTH), (_GL_X, _GL_W))):
        idx = np.flatnonzero(sel_mask)
        for k in range(0, len(idx), _BLOCK_SUBS):
            ii = idx[k:k + _BLOCK_SUBS]
            F0[ii], F1[ii] = _gl(np.zeros(len(ii)), h[ii], rho0[ii], rho1[ii], hsafe[ii], x, wts, emission_density)
    # pieces split into sub-intervals of bounded optical depth (blocks of whole pieces)
    multi = np.flatnonzero(~one)
    if len(multi) == 0:
        return F0, F1, tau
    ns_all = nsub[multi]
    csum = np.cumsum(ns_all)
    q_lo = 0
    while q_lo < len(multi):
        base = csum[q_lo] - ns_all[q_lo]
        q_hi = max(int(np.searchsorted(csum, base + _BLOCK_SUBS, side="right")), q_lo + 1)
        pcs = multi[q_lo:q_hi]
        ns = ns_all[q_lo:q_hi]
        loc = np.repeat(np.arange(len(pcs)), ns)
        pp = pcs[loc]
        m = np.arange(int(ns.sum())) - np.repeat(np.cumsum(ns) - ns, ns)
        nsp = nsub[pp]
        r0, hp = rho0[pp], h[pp]
        ap = (rho1[pp] - r0) / hsafe[pp]
        step = np.where(capped[pp], SUB_DEPTH, tau[pp] / nsp)
        ta = np.where(m > 0, _depth_to_t(m * step, r0, ap), 0.0)
        tb = np.where(m == nsp - 1, hp, _depth_to_t((m + 1) * step, r0, ap))
        ta = np.clip(ta, 0.0, hp)
        tb = np.clip(np.maximum(tb, ta), 0.0, hp)
        g0, g1 = _gl(ta, tb, r0, rho1[pp], hsafe[pp], _GL_X, _GL_W, emission_density)
        F0[pcs] = np.bincount(loc, weights=g0, minlength=len(pcs))
        F1[pcs] = np.bincount(loc, weights=g1, minlength=len(pcs))
        q_lo = q_hi
    return F0, F1, tau


def _integrate_block(sf, sb, L, tf: TransferFunction, emission_density: bool):
    S = tf.points[:, 0]
    K = len(S)
    n = len(sf)
    lo = np.minimum(sf, sb)
    hi = np.maximum(sf, sb)
    i0 = np.searchsorted(S, lo, side="right")
    i1 = np.searchsorted(S, hi, side="left")
    nc = np.maximum(i1 - i0, 0)
    npc = nc + 1
    seg = np.repeat(np.arange(n), npc)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(npc) - npc, npc)
    asc = (sb >= sf)[seg]
    i0s, i1s, ncs = i0[seg], i1[seg], nc[seg]
    sfs, sbs = sf[seg], sb[seg]

    def crossing(mm):
        idx = np.where(asc, i0s + mm, i1s - 1 - mm)
        return S[np.clip(idx, 0, K - 1)]

    has_s = k > 0
    has_e = k < ncs
    s_start = np.where(has_s, crossing(k - 1), sfs)
    s_end = np.where(has_e, crossing(k), sbs)
    ds = sbs - sfs
    dss = np.where(ds != 0, ds, 1.0)
    u_start = np.where(has_s, np.clip((s_start - sfs) / dss, 0.0, 1.0), 0.0)
    u_end = np.where(has_e, np.clip((s_end - sfs) / dss, 0.0, 1.0), 1.0)
    h = np.maximum(L[seg] * (u_end - u_start), 0.0)
    v0 = _tf_eval(tf, s_start)
    v1 = _tf_eval(tf, s_end)
    F0, F1, tau_p = _integrate_pieces(h, v0[:, 3], v1[:, 3], emission_density)
    E = F0[:, None] * v0[:, :3] + F1[:, None] * v1[:, :3]
    if len(seg) > n:  # some segment has several pieces: attenuate later pieces
        E *= np.exp(-segmented_exclusive_cumsum(tau_p, seg))[:, None]
    rgb = np.empty((n, 3))
    for ch in range(3):
        rgb[:, ch] = np.bincount(seg, weights=E[:, ch], minlength=n)
    tau = np.bincount(seg, weights=tau_p, minlength=n)
    return rgb, tau


def integrate_segments(sf, sb, length, tf: TransferFunction) -> tuple[np.ndarray, np.ndarray]:
    """Radiance and optical depth of ray segments through a linear scalar field.

    Parameters
    ----------
    sf, sb : (n,) array_like
        Scalar at the front (entry) and back (exit) of each segment; linear in between.
    length : (n,) array_like
        World length of each segment.
    tf : TransferFunction
        Piecewise-linear transfer function; ``tf.emission`` selects the optical model.

    Returns
    -------
    rgb : (n, 3) float64
        Radiance of each segment seen from its entry (transmittance 1 there):
        ``int_0^L c(t) rho(t) T(t) dt`` (``color_extinction``) or ``int_0^L c(t) T(t) dt``
        (``emission_density``) with ``T(t) = exp(-int_0^t rho)``.
    tau : (n,) float64
        Optical depth ``int_0^L rho`` (exact for the piecewise-linear TF, up to rounding); the
        segment's opacity is ``1 - exp(-tau)``.

    Notes
    -----
    Each segment is split at every TF control point it crosses. On a piece of length ``h`` colour
    and extinction are linear, ``tau = h (rho0 + rho1) / 2`` exactly, and the radiance is computed by
    Gauss-Legendre quadrature (:data:`GL_NODES` nodes) on sub-intervals of optical depth at most
    :data:`SUB_DEPTH`; after :data:`MAX_DEPTH` the rest of the piece is one tail interval. The
    relative error is ~1e-14 for any extinction, including stiff ones. Segments with non-positive
    or non-finite length or non-finite scalars contribute exactly nothing.

    Examples
    --------
    >>> tf = TransferFunction([[0, 1, 1, 1, 2.0], [1, 1, 1, 1, 2.0]])
    >>> rgb, tau = integrate_segments([0.5], [0.5], [1.0], tf)
    >>> bool(np.isclose(tau[0], 2.0)), bool(np.isclose(rgb[0, 0], 1 - np.exp(-2.0)))
    (True, True)
    """
    check_choice("tf.emission", tf.emission, EMISSION_MODELS)
    sf = np.asarray(sf, dtype=np.float64).ravel()
    sb = np.asarray(sb, dtype=np.float64).ravel()
    L = np.asarray(length, dtype=np.float64).ravel()
    if not (len(sf) == len(sb) == len(L)):
        raise ConfigError(f"integrate_segments: sf, sb, length have different lengths "
                          f"({len(sf)}, {len(sb)}, {len(L)})")
    n = len(L)
    rgb = np.zeros((n, 3))
    tau = np.zeros(n)
    ok = np.isfinite(sf) & np.isfinite(sb) & np.isfinite(L) & (L > 0)
    idx = np.flatnonzero(ok)
    if len(idx) == 0:
        return rgb, tau
    S = tf.points[:, 0]
    lo = np.minimum(sf[idx], sb[idx])
    hi = np.maximum(sf[idx], sb[idx])
    npc = np.maximum(np.searchsorted(S, hi, "left") - np.searchsorted(S, lo, "right"), 0) + 1
    csum = np.cumsum(npc)
    ed = tf.emission == "emission_density"
    a = 0
    while a < len(idx):
        base = csum[a] - npc[a]
        b = max(int(np.searchsorted(csum, base + _BLOCK_PIECES, side="right")), a + 1)
        ii = idx[a:b]
        r, t = _integrate_block(sf[ii], sb[ii], L[ii], tf, ed)
        rgb[ii] = r
        tau[ii] = t
        a = b
    return rgb, tau
