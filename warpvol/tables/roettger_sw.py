"""Roettger & Ertl 2002 software pre-integration (eqs. 5-7), faithful.

Per voxel ``n = max(n_min, ceil(o m |sf - sb|))`` samples (``m`` TF entries, oversampling ``o = 2``),
walking from the back: ``w_i = sb + i/(n-1) (sf - sb)``,
``C_{i+1} = C_i exp(-(l/n) rho(w_i)) + E_i``, ``theta_{i+1} = theta_i exp(-(l/n) rho(w_i))``,
``alpha = 1 - theta_n``. ``E_i = (l/n) kappa(w_i)`` for emission density (eq. 6 as printed), the slab's
associated colour ``kappa (1 - exp(-(l/n) rho))`` for colour times extinction.

What the paper's build did, and so the default: eq. 6 as printed with the paper's sample count
(``n >= o m |sf - sb|``), so on the diagonal (``sf ~ sb``) a thick cell is integrated in one step,
``C = l kappa`` instead of ``kappa (1 - e^{-l rho}) / rho`` (unbounded for large ``l rho``). The paper's
Table 1 shows it: its flat ~14 % maximum error between the hardware build (``o m`` steps everywhere)
and this one is that one-step error (``scripts/reproduce_roettger2002.py`` calibrates on it). ``step =
"stein"`` uses Stein et al.'s constant-chromaticity step instead (bounded by ``kappa / rho``; exact for
a TF constant over the segment), which the paper's text names as its approximation. ``n_min`` raises the
floor.
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import check_number
from warpvol.gpu import counters as cnt
from warpvol.tables.base import AXIS_KINDS, TABLE_FORMATS
from warpvol.tables.common import (
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
    timed,
)
from warpvol.tables.exact import length_axis

#: the step of eqs. 5-7: eq. 6 as printed (the paper's build) or Stein et al.'s bounded step
SW_STEPS = ("eq6", "stein")


def sw_samples(xf, xb, m: int, o: float, n_min: int) -> int:
    """Samples of one slice: ``sum over (sf, sb) of max(n_min, ceil(o m |sf - sb|))`` (as the kernel, float32)."""
    d = np.abs(np.asarray(xf, np.float32)[None, :] - np.asarray(xb, np.float32)[:, None])
    n = np.clip(np.ceil(np.float32(o) * np.float32(m) * d), n_min, 1e6)
    return int(n.astype(np.int64).sum())


def build_roettger_sw(tf, *, n_s: int = 64, n_l: int = 32, lmax: float = 1.0, m: int | None = None,
                      oversampling: float = 2.0, n_min: int = 1, l_axis: str = "centred", format: str = "fp32",
                      step: str = "eq6", device: str = "cpu"):
    """Software 3D table (Roettger & Ertl 2002 eqs. 5-7).

    Parameters
    ----------
    tf : TransferFunction
    n_s, n_l : int
        Scalar-axis and thickness-axis resolutions.
    lmax : float
        Thickness at normalised l = 1.
    m : int, optional
        TF resolution (entries of the lookup table); default: the TF's number of control points.
    oversampling : float
        ``o`` of ``n >= o m |sf - sb|`` (paper: 2).
    n_min : int
        Lower bound on the samples per voxel (paper: 1).
    l_axis : str
        ``centred`` or ``endpoint``.
    step : str
        ``eq6`` (eq. 6 as printed: the paper's build) or ``stein`` (Stein et al.'s bounded step).
    format, device : str
    """
    check_tf(tf)
    n_s = check_res("n_s", n_s, 2)
    n_l = check_res("n_l", n_l, 1 if l_axis == "centred" else 2)
    lmax = check_lmax(lmax)
    m = len(tf.points) if m is None else check_res("m", m, 1, 1 << 16)
    o = float(check_number("oversampling", oversampling, lo=0.0, lo_open=True, hi=64))
    n_min = check_res("n_min", n_min, 1, 1 << 16)
    check_choice("l_axis", l_axis, AXIS_KINDS[:2])
    check_choice("format", format, TABLE_FORMATS)
    check_choice("step", step, SW_STEPS)
    import warp as wp

    k = kernels()
    ax_f = scalar_axis("sf", tf, n_s)
    ax_b = scalar_axis("sb", tf, n_s)
    ax_l = length_axis(n_l, lmax, l_axis)
    key = table_key("roettger_sw", tf.hash, n_s=n_s, n_l=n_l, lmax=lmax, m=m, oversampling=o, n_min=n_min,
                    l_axis=l_axis, format=format, **({"step": step} if step != "eq6" else {}))
    meta = {"builder": "roettger_sw", "emission": tf.emission, "lmax": lmax, "m": m, "oversampling": o}
    out = wp.zeros((n_l, n_s, n_s), dtype=wp.vec4, device=device)
    tf_s, tf_v = tf_arrays(tf, device)
    lo, hi = tf.srange
    with timed(meta, device=device):
        xf, xb, ls = farr(ax_f.nodes, device), farr(ax_b.nodes, device), farr(ax_l.physical, device)
        launch_bands(k.roettger_sw_table3d, n_l, n_s, n_s, device, lambda l0, nl, j0, nj: [
            xf, xb[j0:j0 + nj], ls[l0:l0 + nl], lo, hi - lo, tf_s, tf_v, model_id(tf), float(m), o, n_min,
            int(step == "stein"), out[l0:l0 + nl, j0:j0 + nj]], pieces=max(n_min, int(o * m)) // 2, what=f"software table {n_l}x{n_s}x{n_s}")
    meta["samples"] = sw_samples(ax_f.nodes, ax_b.nodes, m, o, n_min) * n_l

    cnt.count(sw_samples=meta["samples"])
    return finish("roettger_sw", out.numpy(), (ax_l, ax_b, ax_f), ("r", "g", "b", "a"), format, key, meta)
