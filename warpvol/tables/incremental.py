"""Incremental pre-integration (Weiler et al. 2003, as adapted by Kraus, Qiao & Ebert 2004).

Only the first non-zero slice ``l = Δl`` is integrated (``base``: exact or Roettger's software
rule); every further 2D slice is composited from already computed ones, sampled bilinearly
(linear along the one off-node scalar):

Scalar axes use Kraus' texel-centre convention too (``endpoint`` nodes, ``[(2n)^-1, 1 - (2n)^-1]``).

* ``uniform`` thickness axis (``endpoint`` nodes ``l_k = k Δl``, ``Δl = lmax / (n_l - 1)``, Kraus'
  texel-centre convention ``r = (2n)^-1 + (l / lmax)(1 - 1/n)``): Weiler's step
  ``T(sf, sb, l + Δl) = T(sf, s', Δl) over T(s', sb, l)``, ``s' = sf + Δl / (l + Δl) (sb - sf)``.
* ``log2`` thickness axis (Kraus 2004 eq. 1, slices ``0, Δl, 2Δl, 4Δl, ..., lmax``,
  ``Δl = 2^-(n_l - 2) lmax``): doubling ``T(sf, sb, 2l) = T(sf, sm, l) over T(sm, sb, l)``,
  ``sm = (sf + sb) / 2``.

Slice 0 is exactly ``(0, 0, 0, 0)`` (a zero-length segment contributes nothing). Errors come from
the bilinear resampling (second order in the scalar spacing) and accumulate with the number of
steps: ``n_l - 2`` for uniform, ``n_l - 2`` doublings for log2 (but each over a doubled length).

Float32 limits the log2 axis: each doubling composites ``1 - (1 - a)(1 - a)``, and float32 holds
``1 - a`` in steps of ``2^-24`` below 1, so every doubling rounds the opacity by up to ``2^-25`` and
every later one doubles what was rounded: up to about ``2^(n_l - 26)`` of optical depth at ``lmax``.
:data:`LOG2_MAX_N_L` keeps that within ``2^-8`` (one step of an 8-bit channel); beyond it the
first slices vanish into the rounding (from ``n_l`` about 28 the first slice's ``1 - a`` rounds to
1 and the whole table loses its opacity), so larger ``n_l`` are refused.
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError, check_number
from warpvol.tables.base import TABLE_FORMATS, Axis
from warpvol.tables.common import (
    check_choice,
    check_lmax,
    check_res,
    check_tf,
    farr,
    finish,
    kernels,
    launch_bands,
    linear_index_map,
    model_id,
    scalar_axis,
    table_key,
    tf_arrays,
    tf_pieces,
    timed,
)

THICKNESS_AXES = {"uniform": "endpoint", "log2": "log2"}
#: largest n_l on the log2 axis: the doublings' float32 rounding, up to 2^(n_l - 26) in optical
#: depth at lmax, stays within 2^-8 (the paper's n_l = 16: 2^-10)
LOG2_MAX_N_L = 18


def check_n_l(where: str, n_l, axis: str) -> int:
    """``n_l`` checked for its thickness axis: [3, 64] uniform, [3, :data:`LOG2_MAX_N_L`] log2."""
    if axis != "log2":
        return check_res(where, n_l, 3, 64)
    n_l = int(check_number(where, n_l, lo=3, integer=True))
    if n_l > LOG2_MAX_N_L:
        raise ConfigError(
            f"{where}: {n_l} is outside the allowed range [3, {LOG2_MAX_N_L}] for axis = \"log2\": the first "
            f"slice is 2^-{n_l - 2} lmax thin and the {n_l - 2} float32 doublings that build the table from "
            f"it round the opacity by up to 2^{n_l - 26} in optical depth at lmax (more than 2^-8; from "
            f"n_l = 28 on the first slice's 1 - alpha rounds to 1 and the table has no opacity); use "
            f"n_l <= {LOG2_MAX_N_L} or axis = \"uniform\" (n_l up to 64)")
    return n_l


def build_incremental(tf, *, n_s: int = 64, n_l: int = 16, lmax: float = 1.0, axis: str = "log2",
                      base: str = "exact", format: str = "fp32", device: str = "cpu"):
    """Incremental 3D table on a uniform or logarithmic thickness axis.

    Parameters
    ----------
    tf : TransferFunction
    n_s : int
        Resolution of the scalar axes (``endpoint`` nodes ``k / (n_s - 1)``: Kraus' texel-centre range
        ``[(2n)^-1, 1 - (2n)^-1]``, so the TF's end values sit at texel centres).
    n_l : int
        Number of thickness slices: [3, 64] on the uniform axis, [3, :data:`LOG2_MAX_N_L`] on
        the log2 axis (float32 doublings, see the module's notes).
    lmax : float
        Largest thickness (the last slice).
    axis : str
        ``"log2"`` (Kraus 2004 eq. 1) or ``"uniform"``.
    base : str
        How the ``Δl`` slice is integrated: ``"exact"`` or ``"roettger_sw"`` (eqs. 5-7, o = 2, eq. 6
        as printed: :func:`warpvol.tables.roettger_sw.build_roettger_sw`'s default step).
    format, device : str
    """
    check_tf(tf)
    n_s = check_res("n_s", n_s, 2)
    check_choice("axis", axis, tuple(THICKNESS_AXES))
    n_l = check_n_l("n_l", n_l, axis)
    lmax = check_lmax(lmax)
    check_choice("base", base, ("exact", "roettger_sw"))
    check_choice("format", format, TABLE_FORMATS)
    import warp as wp

    k = kernels()
    # Kraus 2004 §3: texel centres span [(2n)^-1, 1 - (2n)^-1], i.e. node k at k / (n - 1) on the scalar axes
    ax_f = scalar_axis("sf", tf, n_s, kind="endpoint")
    ax_b = scalar_axis("sb", tf, n_s, kind="endpoint")
    ax_l = Axis("l", n_l, THICKNESS_AXES[axis], scale=lmax)
    dl = float(ax_l.physical[1])
    key = table_key("incremental", tf.hash, n_s=n_s, n_l=n_l, lmax=lmax, axis=axis, base=base, format=format)
    meta = {"builder": "incremental", "emission": tf.emission, "lmax": lmax, "axis": axis, "dl": dl}
    x = farr(ax_f.nodes, device)
    ia, ib = linear_index_map(ax_f)
    tf_s, tf_v = tf_arrays(tf, device)
    lo, hi = tf.srange
    slices = [wp.zeros((n_s, n_s), dtype=wp.vec4, device=device) for _ in range(n_l)]
    with timed(meta, device=device):
        base3 = wp.zeros((1, n_s, n_s), dtype=wp.vec4, device=device)
        lengths = farr([dl], device)
        if base == "exact":
            launch_bands(k.exact_table3d, 1, n_s, n_s, device, lambda l0, nl, j0, nj: [
                x, x[j0:j0 + nj], lengths, lo, hi - lo, tf_s, tf_v, model_id(tf), base3[:, j0:j0 + nj]],
                pieces=tf_pieces(tf), what=f"incremental base slice {n_s}x{n_s}")
        else:
            m = float(len(tf.points))
            launch_bands(k.roettger_sw_table3d, 1, n_s, n_s, device, lambda l0, nl, j0, nj: [
                x, x[j0:j0 + nj], lengths, lo, hi - lo, tf_s, tf_v, model_id(tf), m, 2.0, 1, 0,
                base3[:, j0:j0 + nj]],
                pieces=len(tf.points), what=f"incremental base slice {n_s}x{n_s}")
        wp.copy(slices[1], base3.reshape((n_s, n_s)))
        for s in range(2, n_l):
            if axis == "uniform":
                # slice s = l_{s-1} + dl: front piece of length dl, back piece of length l_{s-1}
                front, back, frac = slices[1], slices[s - 1], 1.0 / s
            else:
                front, back, frac = slices[s - 1], slices[s - 1], 0.5
            wp.launch(k.incremental_step, dim=(n_s, n_s), device=device,
                      inputs=[front, back, x, frac, ia, ib, slices[s]])
        data = np.stack([sl.numpy() for sl in slices])
    return finish("incremental", data, (ax_l, ax_b, ax_f), ("r", "g", "b", "a"), format, key, meta)
