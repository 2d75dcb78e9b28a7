"""The integration set-up of the cell-walk kernels (HARC's march, the sweep's table integration) and the
texel formats and coordinate maps of pre-integration tables as textures (the projected-tetrahedra
programs read them too).
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError
from warpvol.gpu.texture import Texture1D, Texture2D, Texture3D

INTEGRATIONS = {"exact": 0, "full": 1, "partial": 2}
ISO_RULES = {"paper": 0, "behind": 1}

TEXEL_FOR_TABLE = {"fp32": "rgba32f", "fp16": "rgba16f", "rgba8": "rgba8", "hilo16": "rgba16"}


def _axis_affine(ax) -> tuple[float, float, int]:
    """``(a, b, log2_n)`` of an axis' normalised value -> texture coordinate map."""
    if ax.kind == "centred":
        return 1.0, 0.0, 0
    if ax.kind == "endpoint":
        return 1.0 - 1.0 / ax.n, 0.5 / ax.n, 0
    return 1.0, 0.0, ax.n


def integ_setup(mode: str, tf, device: str, *, table=None, psi=None, iso=None, iso_rule: str = "paper",
                lmax: float = 1.0, table_texel: str = "auto", weight_bits: int | None = 8,
                cache: dict | None = None, tf_texture: str = "exact", tf_texels: int = 256):
    """The kernel's :class:`warpvol.kernels.harc.Integ` and the textures it holds.

    ``table``: a 3D pre-integration table (``data[l, sb, sf]``) for ``full``; ``psi`` (the psi
    table) and ``iso`` (the iso-crossing table) for ``partial``; ``partial`` reads the TF from a 1D
    texture of ``tf_texels`` texels in ``tf_texture`` (``rgba8`` or ``rgba16f``, linear; extinction
    stored over its maximum) or, with ``exact``, from the control points. ``cache`` (a dict kept by the
    pipeline) holds the textures made from tables by table key, so redrawing with the same tables
    uploads nothing (as a texture stays resident on the card until the TF changes)."""
    import warp as wp

    from warpvol.kernels import harc as kh

    if mode not in INTEGRATIONS:
        raise ConfigError(f"integration: {mode!r} not allowed; allowed: {', '.join(INTEGRATIONS)}")
    ig = kh.Integ()
    ig.mode = INTEGRATIONS[mode]
    ig.model = 0 if tf.emission == "color_extinction" else 1
    # partial pre-integration splits at every control point (the iso table's, unmerged); the other
    # integrations read the TF with collinear runs merged (the same function, fewer pieces)
    ig.tf_s, ig.tf_v = tf.to_warp(device, merge=mode != "partial")
    lo, hi = tf.srange
    ig.s_off, ig.s_inv = float(lo), 1.0 / float(hi - lo)
    keep = []
    cache = {} if cache is None else cache

    def cached(key, make):
        key = (str(device),) + key
        if key not in cache:
            if len(cache) > 16:
                cache.clear()
            cache[key] = make()
        return cache[key]

    dummy2 = cached(("empty2d",), lambda: Texture2D(np.zeros((1, 1, 4)), fmt="rgba32f", filter="nearest",
                                                     device=device))
    dummy3 = cached(("empty3d",), lambda: Texture3D(np.zeros((1, 1, 1, 4)), fmt="rgba32f", filter="nearest",
                                                     device=device))
    dummy1 = cached(("empty1d",), lambda: Texture1D(np.zeros((2, 4)), fmt="rgba32f", filter="nearest", device=device))
    ig.table, ig.psi, ig.iso, ig.tf_tex, ig.tf_tex_on = dummy3.struct, dummy2.struct, dummy2.struct, dummy1.struct, 0
    ig.tf_scale = wp.vec4(1.0, 1.0, 1.0, 1.0)
    ig.t_sa, ig.t_sb, ig.l_inv, ig.t_la, ig.t_lb, ig.t_llog = 1.0, 0.0, 1.0 / lmax, 1.0, 0.0, 0
    ig.iso_rule = ISO_RULES[iso_rule]
    ig.p_a, ig.p_b = 1.0, 0.0
    keep += [dummy2, dummy3]  # (the 1D dummy stays out: keep's 1D texture is the TF's, counted per step)
    if mode == "full":
        if table is None or table.data.ndim != 4:
            raise ConfigError("integration 'full' needs a 3D table (a table stage before this one)")
        ax_l, _, ax_f = table.axes
        fmt = TEXEL_FOR_TABLE[table.format] if table_texel == "auto" else table_texel
        t3 = cached(("table", table.key, fmt, weight_bits),
                    lambda: Texture3D(table.data, fmt=fmt, filter="linear", device=device, weight_bits=weight_bits))
        ig.table = t3.struct
        ig.s_off, ig.s_inv = float(ax_f.offset), 1.0 / float(ax_f.scale)
        ig.t_sa, ig.t_sb, _ = _axis_affine(ax_f)
        ig.t_la, ig.t_lb, ig.t_llog = _axis_affine(ax_l)
        ig.l_inv = 1.0 / float(ax_l.scale)
        keep.append(t3)
    elif mode == "partial":
        if psi is None or iso is None:
            raise ConfigError("integration 'partial' needs the psi and iso tables (table_psi, table_iso)")
        pfmt = {"fp16": "rgba16f"}.get(psi.format, "rgba32f")  # fp16: linearly filtered on NV40
        pt = cached(("psi", psi.key, pfmt, weight_bits), lambda: Texture2D(
            rgba(psi.data), fmt=pfmt, filter="linear", device=device, weight_bits=weight_bits))
        ifmt = {"fp16": "rgba16f"}.get(iso.format, "rgba32f")
        it = cached(("iso", iso.key, ifmt), lambda: Texture2D(rgba(iso.data), fmt=ifmt, filter="nearest",
                                                               device=device))
        ig.psi, ig.iso = pt.struct, it.struct
        ig.p_a, ig.p_b, _ = _axis_affine(psi.axes[1])
        keep += [pt, it]
        if tf_texture != "exact":
            values, scale = tf_texture_values(tf, tf_texels)
            tt = cached(("tf", tf.hash, tf_texels, tf_texture, weight_bits), lambda: Texture1D(
                values, fmt=tf_texture, filter="linear", device=device, weight_bits=weight_bits))
            ig.tf_tex, ig.tf_tex_on, ig.tf_scale = tt.struct, 1, wp.vec4(*scale)
            keep.append(tt)
    return ig, keep


#: partial pre-integration's TF: a 1D texture in one of these formats, or the control points (``exact``)
TF_TEXTURES = ("exact", "rgba8", "rgba16f")


def tf_texture_values(tf, n: int) -> tuple[np.ndarray, tuple]:
    """Texels ``(n, 4)`` of partial pre-integration's 1D TF texture and the program's scale constant:
    texel k is the TF at k / (n - 1) of its range, ``(rgb / c_max, tau / tau_max)``, and the program
    multiplies the fetched texel by ``(c_max, c_max, c_max, tau_max)`` (colours and extinction may
    exceed a unorm texel's 1)."""
    lo, hi = tf.srange
    v = np.asarray(tf.evaluate(lo + np.arange(n) / (n - 1) * (hi - lo)), dtype=np.float64)
    c = float(v[:, :3].max()) if v[:, :3].max() > 0 else 1.0
    tau = float(v[:, 3].max()) if v[:, 3].max() > 0 else 1.0
    return v / np.array([c, c, c, tau]), (c, c, c, tau)


def rgba(two: np.ndarray) -> np.ndarray:
    """A two-channel table ``(..., 2)`` as RGBA texels ``(a, b, 1, 1)``."""
    return np.concatenate([two, np.ones(two.shape[:-1] + (2,), two.dtype)], axis=-1)
