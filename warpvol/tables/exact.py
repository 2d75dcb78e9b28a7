"""Exact 3D pre-integration table: the piecewise-linear TF integrated exactly (accuracy ceiling).

``T3D(sf, sb, l) = (C, alpha)`` for both emission models, with every TF control point crossed by a
segment as a piece boundary and each piece integrated by the project's float32 segment integrator
(:mod:`warpvol.kernels.integrate`, relative error ~1e-7). Table layout ``data[l, sb, sf, rgba]``.
"""

from __future__ import annotations

from warpvol.tables.base import AXIS_KINDS, TABLE_FORMATS, Table
from warpvol.tables.common import (
    Axis,
    check_choice,
    check_lmax,
    check_res,
    check_tf,
    farr,
    finish,
    kernels,
    launch_bands,
    model_id,
    scalar_axis,
    table_key,
    tf_arrays,
    tf_pieces,
    timed,
)


def length_axis(n_l: int, lmax: float, kind: str) -> Axis:
    return Axis("l", n_l, kind, scale=lmax)


def build_exact3d(tf, *, n_s: int = 64, n_l: int = 32, lmax: float = 1.0, l_axis: str = "centred",
                  s_axis: str = "centred", format: str = "fp32", device: str = "cpu") -> "Table":
    """Exact 3D table.

    Parameters
    ----------
    tf : TransferFunction
    n_s : int
        Resolution of both scalar axes (sf, sb).
    n_l : int
        Resolution of the thickness axis.
    lmax : float
        Thickness (world units) at normalised l = 1.
    l_axis, s_axis : str
        Axis kinds (``centred``, ``endpoint``; ``log2`` for l), see :mod:`warpvol.tables.base`.
    format : str
        Stored format.
    device : str
        Warp device.
    """
    check_tf(tf)
    n_s = check_res("n_s", n_s, 2)
    n_l = check_res("n_l", n_l, 1 if l_axis == "centred" else 2)
    lmax = check_lmax(lmax)
    check_choice("l_axis", l_axis, AXIS_KINDS)
    check_choice("s_axis", s_axis, AXIS_KINDS[:2])
    check_choice("format", format, TABLE_FORMATS)
    import warp as wp

    k = kernels()
    ax_f = scalar_axis("sf", tf, n_s, s_axis)
    ax_b = scalar_axis("sb", tf, n_s, s_axis)
    ax_l = length_axis(n_l, lmax, l_axis)
    key = table_key("exact3d", tf.hash, n_s=n_s, n_l=n_l, lmax=lmax, l_axis=l_axis, s_axis=s_axis, format=format)
    meta = {"builder": "exact3d", "emission": tf.emission, "lmax": lmax}
    out = wp.zeros((n_l, n_s, n_s), dtype=wp.vec4, device=device)
    tf_s, tf_v = tf_arrays(tf, device)
    lo, hi = tf.srange
    xf, xb, ls = farr(ax_f.nodes, device), farr(ax_b.nodes, device), farr(ax_l.physical, device)
    with timed(meta, device=device):
        launch_bands(k.exact_table3d, n_l, n_s, n_s, device, lambda l0, nl, j0, nj: [
            xf, xb[j0:j0 + nj], ls[l0:l0 + nl], lo, hi - lo, tf_s, tf_v, model_id(tf), out[l0:l0 + nl, j0:j0 + nj]],
            pieces=tf_pieces(tf), what=f"exact table {n_l}x{n_s}x{n_s}")
    return finish("exact3d", out.numpy(), (ax_l, ax_b, ax_f), ("r", "g", "b", "a"), format, key, meta)
