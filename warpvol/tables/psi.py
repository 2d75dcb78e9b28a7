"""Partial pre-integration (Moreland & Angel 2004, used by Espinha & Celes 2005): the psi table.

For a segment of length ``l`` whose colour ``C`` and extinction ``tau`` are linear from front
(``Cf, tau_f``) to back (``Cb, tau_b``), with ``gamma = tau l / (tau l + 1)`` in [0, 1):

``psi(gf, gb) = int_0^1 exp(-int_lam^1 (gb/(1-gb) (1 - lam') + gf/(1-gf) lam') dlam') dlam``,
the mean transmittance from the front over the segment (TF-free: one 2D table for every TF), and
``zeta = exp(-l (tau_f + tau_b) / 2)``. Colour-times-extinction radiance of the segment with
incoming radiance ``I0`` behind it: ``I = I0 zeta + Cb (psi - zeta) + Cf (1 - psi)`` (exact).

A second channel holds ``psi1 = int_0^1 u T(u) du`` (u from the front), which makes the emission
density model exact too: ``C = l (kappa_f (psi - psi1) + kappa_b psi1)``.

Nodes are texel centres ``gamma_k = (k + 0.5) / n``, so gamma = 1 (infinite depth) is never a node;
:func:`psi_exact` returns the limit 0 there. Values lie in [0, 1].
"""

from __future__ import annotations

import numpy as np

from warpvol.tables.base import TABLE_FORMATS, Axis, Table
from warpvol.tables.common import check_choice, check_res, farr, finish, kernels, table_key, timed
from warpvol.tables.guthe2d import _bilinear2d


def build_psi(*, n: int = 128, format: str = "fp32", axis: str = "centred", device: str = "cpu") -> Table:
    """psi table ``data[gb, gf] = (psi, psi1)``.

    Parameters
    ----------
    n : int
        Resolution of both gamma axes.
    format : str
        ``fp32``, ``fp16``, ``hilo16`` (the two channels as one HILO texture) or ``rgba8``.
    axis : str
        ``centred`` (nodes at texel centres) or ``endpoint`` (nodes ``k / (n - 1)``: gamma = 0, a thin
        segment, is a node, so bilinear lookups of thin segments are not clamped to half a texel).
    device : str
    """
    n = check_res("n", n, 2)
    check_choice("format", format, TABLE_FORMATS[:4])
    check_choice("axis", axis, ("centred", "endpoint"))
    import warp as wp

    k = kernels()
    ax = Axis("gamma_f", n, axis), Axis("gamma_b", n, axis)
    key = table_key("psi", None, n=n, format=format, **({"axis": axis} if axis != "centred" else {}))
    meta = {"builder": "psi", "tf_free": True}
    out = wp.zeros((n, n), dtype=wp.vec2, device=device)
    g = farr(ax[0].nodes, device)
    with timed(meta, device=device):
        wp.launch(k.psi_table, dim=(n, n), device=device, inputs=[g, g, out])
    return finish("psi", out.numpy(), (ax[1], ax[0]), ("psi", "psi1"), format, key, meta)


def gamma(tau, l) -> np.ndarray:
    """``gamma = tau l / (tau l + 1)`` (float64), 1 for infinite depth."""
    x = np.asarray(tau, dtype=np.float64) * np.asarray(l, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.where(np.isinf(x), 1.0, x / (x + 1.0))


def psi_exact(gf, gb, device: str = "cpu") -> np.ndarray:
    """``(psi, psi1)`` at arbitrary gammas computed by the table's kernel function (float32)."""
    import warp as wp

    k = kernels()
    gf, gb = np.broadcast_arrays(np.asarray(gf, np.float32), np.asarray(gb, np.float32))
    out = wp.zeros(max(gf.size, 1), dtype=wp.vec2, device=device)
    wp.launch(k.psi_points, dim=gf.size, device=device,
              inputs=[farr(gf.ravel(), device), farr(gb.ravel(), device), out])
    return out.numpy()[: gf.size].reshape(gf.shape + (2,))


def combine(I0, Cf, Cb, tau_f, tau_b, l, psi) -> np.ndarray:
    """Moreland & Angel's segment: ``I0 zeta + Cb (psi - zeta) + Cf (1 - psi)`` (back to front).

    ``psi`` is looked up (or computed) at ``(gamma(tau_f, l), gamma(tau_b, l))``; arrays broadcast,
    colours have a trailing axis of 3. Returns ``(I, alpha)`` with ``alpha = 1 - zeta``.
    """
    l = np.asarray(l, np.float64)
    zeta = np.exp(-0.5 * l * (np.asarray(tau_f, np.float64) + np.asarray(tau_b, np.float64)))
    p = np.asarray(psi, np.float64)[..., None]
    z = zeta[..., None]
    I = np.asarray(I0, np.float64) * z + np.asarray(Cb, np.float64) * (p - z) + np.asarray(Cf, np.float64) * (1 - p)
    return I, 1.0 - zeta


def lookup(table: Table, gf, gb) -> np.ndarray:
    """Bilinear lookup of the psi table at ``(gf, gb)`` (texel centres, clamp to edge), float64."""

    ax_b, ax_f = table.axes
    return _bilinear2d(table.data, ax_f.index(gf), ax_b.index(gb))
