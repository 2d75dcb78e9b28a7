"""Guthe et al. 2002 §3: the 3D table replaced by 2D textures and a dependent 1D opacity texture.

Opacity, separated exactly: ``rho_hat(sf, sb) = int_0^1 rho(sf + t (sb - sf)) dt`` (a 2D texture,
stored normalised by its maximum ``rho_max``) and ``alpha = alpha1D(l rho_hat)``,
``alpha1D(x) = 1 - exp(-x)``, a 1D dependent texture over ``x_n = (l / lmax)(rho_hat / rho_max)``
holding 16-bit opacity as an 8-bit A/L pair (``alpha = 256 A/257 + L/257``, :class:`warpvol.gpu.formats.Pair16`).

Colour: normalised emission ``C_hat(l) = C(l) / alpha(l)`` approximated by a polynomial in
``x = l / lmax``: ``C ~ alpha sum_i x^i C~_i``. The coefficients interpolate ``degree + 1`` equally
spaced slices ``x_i = i / degree`` with ``C_hat(0) = C0_hat = int kappa rho / int rho`` (the l -> 0
limit); degree 1 gives ``C~_0 = C0_hat``, ``C~_1 = dC1 = C_hat(lmax) - C0_hat`` (the paper's linear
setup). Each coefficient texture is scaled into the signed texel range [-1, 1] and the shader
multiplies it back (``meta["coef_scale"][i]``, per channel). ``scales`` says which factors exist:
``free`` (any per-channel float constant: a float shader), ``nv_combiner`` (the GeForce3/4 register
combiners' output scale ops: one power of two per coefficient from {1/2, 1, 2, 4}) or ``ati_fs``
(the Radeon 8500 fragment shader's destination modifiers: {1/8, ..., 8}). With a restricted set the
scale is the smallest factor that holds the coefficient; a coefficient beyond the largest factor
saturates at +-1 in its texel (counted in ``meta["coef_saturated"]``, texel channels).

Only the colour-times-extinction model factors this way (the paper's model): with emission density
``C / alpha`` is unbounded where extinction vanishes, so such a TF is rejected.

Documented behaviour at vanishing quantities: ``sf = sb`` needs no division (``rho_hat = rho(sf)``,
``C0_hat = kappa(sf)``); where ``int rho = 0`` ``C0_hat`` is the plain mean colour (alpha = 0 there
anyway); where ``alpha(l) < 1e-6`` ``C_hat(l)`` is replaced by ``C0_hat`` (its limit, error O(alpha)).
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError
from warpvol.gpu import counters as cnt
from warpvol.gpu.formats import Pair16
from warpvol.gpu.texture import Texture1D, Texture2D
from warpvol.tables.base import Axis, Table, quantise
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
    tf_pieces,
    timed,
)

COEF_FORMATS = ("snorm8", "fp16", "fp32")
#: coefficient scale factors the fragment arithmetic can apply (``None``: any float constant)
SCALE_SETS = {"free": None, "nv_combiner": (0.5, 1.0, 2.0, 4.0),
              "ati_fs": (0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0)}
SCALE_RTOL = 1e-5
ALPHA_FORMATS = ("al16", "rgba8", "fp32")
ALPHA_MIN = 1e-6


#: how the colour slices are integrated: the paper's software build, its hardware ping-pong build, exactly
SLICES = ("software", "pingpong", "exact")


def build_guthe2d(tf, *, n_s: int = 128, degree: int = 1, lmax: float = 1.0, n_alpha: int = 1024,
                  format: str = "snorm8", alpha_format: str = "al16", slices: str = "exact", m: int = 128,
                  gpu: str = "radeon8500", scales: str = "free", device: str = "cpu",
                  emulate: bool = True) -> Table:
    """Guthe 2D tables.

    Parameters
    ----------
    tf : TransferFunction
        Must use the ``color_extinction`` model.
    n_s : int
        Resolution of the 2D textures (sf, sb); the paper uses 512.
    degree : int
        Polynomial degree in l: 1 (linear), 2 (GeForce4), 4 (Radeon 8500); any 1..6 accepted.
    lmax : float
        Thickness at x = 1.
    n_alpha : int
        Entries of the dependent alpha1D texture.
    format : str
        Coefficient textures: ``snorm8`` (signed texels, the paper), ``fp16`` or ``fp32``.
        ``rho_hat`` is stored as unsigned 8 bits with ``snorm8`` (NV ``SIGNED_RGB_UNSIGNED_ALPHA``),
        else in the same float format.
    alpha_format : str
        ``al16`` (16-bit A/L pair, the paper), ``rgba8`` (8-bit alpha) or ``fp32``.
    slices : str
        How the colour slices ``C(l_i)`` are integrated: ``software`` (the paper's software build, §4:
        ``m`` samples along the segment, each step blending the sample's colour and opacity,
        ``C = kappa a + (1 - a) C`` with ``a = 1 - exp(-(l/m) rho)``, in float32; the table's alpha
        for ``C / alpha`` is the same samples' opacity), ``pingpong`` (hardware, ping-pong filtering
        with ``m`` steps at 12 bits on the card ``gpu``; §4) or ``exact`` (the exact integral of the
        piecewise-linear TF: no paper's build, an improvement).
    m : int
        Integration steps of the software and the ping-pong slices.
    gpu : str
        Ping-pong overflow rule: ``radeon8500`` (bit masking) or ``geforce4`` (saturation, which
        loses the low bits: the paper's reason only the Radeon builds these tables).
    scales : str
        Coefficient scale factors: ``free``, ``nv_combiner`` or ``ati_fs`` (:data:`SCALE_SETS`).
    device : str
    emulate : bool
        ``slices="pingpong"`` only: False counts the ping-pong work without running it (throughput model).

    Returns
    -------
    Table
        ``data[i, sb, sf, rgba]``: coefficient i in rgb (scaled to [-1, 1]), ``rho_hat / rho_max`` in
        the alpha channel of i = 0. ``extra``: ``alpha1d`` (decoded, (n_alpha,)), ``alpha1d_raw``,
        ``c_hat`` (the slices the polynomial interpolates, float32), ``coef`` (unscaled coefficients).
    """
    check_tf(tf)
    if tf.emission != "color_extinction":
        raise ConfigError("tf.emission: Guthe's 2D tables need the 'color_extinction' model (C / alpha is "
                          f"unbounded for {tf.emission!r} where extinction vanishes)")
    n_s = check_res("n_s", n_s, 2)
    degree = check_res("degree", degree, 1, 6)
    lmax = check_lmax(lmax)
    n_alpha = check_res("n_alpha", n_alpha, 2, 1 << 16)
    check_choice("format", format, COEF_FORMATS)
    check_choice("alpha_format", alpha_format, ALPHA_FORMATS)
    check_choice("slices", slices, SLICES)
    m = check_res("m", m, 1, 1 << 16)
    check_choice("gpu", gpu, ("radeon8500", "geforce4"))
    check_choice("scales", scales, tuple(SCALE_SETS))
    import warp as wp

    k = kernels()
    ax_f = scalar_axis("sf", tf, n_s)
    ax_b = scalar_axis("sb", tf, n_s)
    key = table_key("guthe2d", tf.hash, n_s=n_s, degree=degree, lmax=lmax, n_alpha=n_alpha,
                    alpha_format=alpha_format, slices=slices, m=m if slices != "exact" else 0, format=format,
                    gpu=gpu if slices == "pingpong" else "")
    key = key if scales == "free" else key + (("scales", scales),)
    key = key if emulate else key + (("emulate", False),)
    meta = {"builder": "guthe2d", "emission": tf.emission, "lmax": lmax, "degree": degree, "alpha_format": alpha_format,
            "slices": slices, "m": m if slices != "exact" else None, "gpu": gpu if slices == "pingpong" else None}
    x = farr(ax_f.nodes, device)
    tf_s, tf_v = tf_arrays(tf, device)
    lo, hi = tf.srange
    mom = wp.zeros((n_s, n_s), dtype=wp.vec4, device=device)
    sl = wp.zeros((degree, n_s, n_s), dtype=wp.vec4, device=device)
    with timed(meta, device=device):
        pieces = tf_pieces(tf)
        launch_bands(k.guthe_moments, None, n_s, n_s, device, lambda l0, nl, j0, nj: [
            x, x[j0:j0 + nj], lo, hi - lo, tf_s, tf_v, mom[j0:j0 + nj]], pieces=pieces,
            what=f"Guthe moments {n_s}x{n_s}")
        lengths = farr(lmax * np.arange(1, degree + 1) / degree, device)
        if slices == "exact":
            launch_bands(k.exact_table3d, degree, n_s, n_s, device, lambda l0, nl, j0, nj: [
                x, x[j0:j0 + nj], lengths[l0:l0 + nl], lo, hi - lo, tf_s, tf_v, model_id(tf),
                sl[l0:l0 + nl, j0:j0 + nj]], pieces=pieces, what=f"Guthe slices {degree}x{n_s}x{n_s}")
            s = sl.numpy().astype(np.float64)
        elif slices == "software":
            # the software step of Roettger & Ertl's eqs. 5-7 for colour times extinction, walked from the back:
            # each of exactly m samples adds its slab's associated colour kappa (1 - exp(-(l/m) rho))
            # (oversampling ~0 with n_min = m: m samples for every (sf, sb))
            launch_bands(k.roettger_sw_table3d, degree, n_s, n_s, device, lambda l0, nl, j0, nj: [
                x, x[j0:j0 + nj], lengths[l0:l0 + nl], lo, hi - lo, tf_s, tf_v, model_id(tf), 1.0, 1e-9, m, 0,
                sl[l0:l0 + nl, j0:j0 + nj]], pieces=max(1, m // 2), what=f"Guthe software slices {degree}x{n_s}x{n_s}")
            s = sl.numpy().astype(np.float64)
            from warpvol.gpu import counters as cnt

            cnt.count(sw_samples=degree * n_s * n_s * m)
        else:
            from warpvol.tables.pingpong import build_pingpong

            pp = build_pingpong(tf, n_s=n_s, lengths=tuple(np.arange(1, degree + 1) / degree), lmax=lmax, m=m,
                                gpu=gpu, device=device, emulate=emulate)
            s = pp.data.astype(np.float64)
            meta["pingpong_passes"] = pp.meta["passes"]
        mo = mom.numpy().astype(np.float64)
        c0 = mo[..., :3]
        rho_hat = mo[..., 3]
        a = s[..., 3:4]
        with np.errstate(divide="ignore", invalid="ignore"):
            ch = np.where(a >= ALPHA_MIN, s[..., :3] / np.maximum(a, ALPHA_MIN), c0[None])
        c_hat = np.concatenate([c0[None], ch], axis=0)  # (degree+1, N, N, 3)
        xs = np.arange(degree + 1) / degree
        V = np.vander(xs, degree + 1, increasing=True)
        coef = np.einsum("ij,j...->i...", np.linalg.inv(V), c_hat)  # (degree+1, N, N, 3)
        scale = hardware_scales(coef, scales)
        rho_max = float(rho_hat.max()) if rho_hat.max() > 0 else 1.0
        data = np.zeros((degree + 1, n_s, n_s, 4), dtype=np.float32)
        scaled = coef / scale[:, None, None, :]
        meta["coef_saturated"] = int(np.count_nonzero(np.abs(scaled) > 1.0 + SCALE_RTOL))
        data[..., :3] = np.clip(scaled, -1.0, 1.0)
        data[0, ..., 3] = rho_hat / rho_max
        # alpha1D at x_n = k / (n_alpha - 1) (the dependent lookup applies Kraus' texel-centre scale and
        # bias, so x_n = 0 hits alpha = 0 exactly); x_n = 1 <-> optical depth lmax * rho_max
        xa = np.arange(n_alpha) / (n_alpha - 1)
        alpha1d = -np.expm1(-xa * lmax * rho_max)
    dec, raw = quantise(data[..., :3], format)
    rho_dec, _ = quantise(data[..., 3], "rgba8" if format == "snorm8" else format)
    data_q = np.concatenate([dec, rho_dec[..., None]], axis=-1)
    data_q[1:, ..., 3] = 0.0
    a_dec, a_raw = quantise(alpha1d, alpha_format)
    meta.update(coef_scale=scale.tolist(), coef_scales=scales, rho_max=rho_max, alpha_depth=lmax * rho_max, alpha_format=alpha_format)
    t = finish("guthe2d", data_q, (Axis("coef", degree + 1), ax_b, ax_f), ("r", "g", "b", "rho"), "fp32", key, meta,
               extra={"alpha1d": a_dec, "alpha1d_raw": a_raw, "c_hat": c_hat.astype(np.float32),
                      "coef": coef.astype(np.float32), "coef_raw": raw})
    t.format = format
    return t


def hardware_scales(coef: np.ndarray, scales: str = "free") -> np.ndarray:
    """``(degree + 1, 3)`` scale factors of coefficients ``coef[i, ..., rgb]`` (:data:`SCALE_SETS`):
    ``free``: each channel's largest magnitude (1 where it is 0); otherwise per coefficient the
    smallest factor of the set that is >= the largest magnitude over all channels (within relative
    ``SCALE_RTOL``: an excess of float rounding is clipped, not a saturation; the largest
    factor where none is), the same for r, g, b (one scale op per combiner stage / instruction).

    Examples
    --------
    >>> c = np.array([[[0.3, 0.9, 0.0]], [[0.2, -3.0, 0.1]], [[0.01, 0.0, 0.02]]])
    >>> hardware_scales(c, "nv_combiner")[:, 0].tolist()
    [1.0, 4.0, 0.5]
    >>> hardware_scales(c, "ati_fs")[:, 0].tolist()
    [1.0, 4.0, 0.125]
    """
    check_choice("scales", scales, tuple(SCALE_SETS))
    n = coef.shape[0]
    mag = np.abs(coef).reshape(n, -1, 3).max(axis=1)
    if SCALE_SETS[scales] is None:
        return np.where(mag > 0, mag, 1.0)
    opts = np.asarray(SCALE_SETS[scales])
    m = mag.max(axis=1)
    # a magnitude above a factor by float rounding only (relative 1e-5) takes that factor
    idx = np.minimum(np.searchsorted(opts, m / (1.0 + SCALE_RTOL), side="left"), len(opts) - 1)
    return np.repeat(opts[idx][:, None], 3, axis=1)


def _bilinear2d(tex: np.ndarray, fx: np.ndarray, fy: np.ndarray) -> np.ndarray:
    """Bilinear lookup of ``tex[y, x, C]`` at continuous texel indices (clamp to edge), float64."""
    ny, nx = tex.shape[:2]
    x = np.clip(fx, 0, nx - 1)
    y = np.clip(fy, 0, ny - 1)
    x0 = np.minimum(np.floor(x).astype(np.int64), nx - 2)
    y0 = np.minimum(np.floor(y).astype(np.int64), ny - 2)
    wx = (x - x0)[..., None]
    wy = (y - y0)[..., None]
    t = tex.astype(np.float64)
    return ((t[y0, x0] * (1 - wx) + t[y0, x0 + 1] * wx) * (1 - wy)
            + (t[y0 + 1, x0] * (1 - wx) + t[y0 + 1, x0 + 1] * wx) * wy)


RECONSTRUCT_VIA = ("texture", "float")
#: fragment arithmetic: ``(register range, 1 / register step)`` (0: none) and the coefficient scale set
#: it offers. ``nv_combiner``: NV_register_combiners, signed 9-bit [-1, 1] (8-bit texel 255 = 1.0);
#: ``ati_fs``: ATI_fragment_shader, range [-8, 8], 12 fraction bits (the range is the extension's;
#: its text gives no precision: 12 bits is this emulation's choice, s3.12 in 16 bits)
ARITH = {"fp32": (0.0, 0.0), "nv_combiner": (1.0, 255.0), "ati_fs": (8.0, 4096.0)}
ARITH_SCALES = {"fp32": "free", "nv_combiner": "nv_combiner", "ati_fs": "ati_fs"}


def arith_constants(table: Table, arith: str) -> tuple[np.ndarray, float, float, float]:
    """``(w, s_acc, rng, unit)`` of :mod:`warpvol.kernels.combiners` for ``table`` run in ``arith``:
    per-coefficient scale modifiers ``w_i = s_i / s_acc`` and the accumulator scale ``s_acc``
    (``max s_i`` on the combiners, 1 on the Radeon). The table's scales must be ``arith``'s set."""
    check_choice("arith", arith, tuple(ARITH))
    have = table.meta.get("coef_scales", "free")
    if arith == "fp32" or have != ARITH_SCALES[arith]:
        raise ConfigError(f"arith: {arith!r} runs tables built with scales={ARITH_SCALES[arith]!r} "
                          f"(table_guthe.scales); this table has scales={have!r}")
    s = np.asarray(table.meta["coef_scale"], dtype=np.float64)[:, 0]
    s_acc = float(max(1.0, s.max())) if arith == "nv_combiner" else 1.0
    rng, unit = ARITH[arith]
    return (s / s_acc).astype(np.float32), s_acc, rng, unit
_COEF_TEXEL = {"snorm8": "rgba8s", "fp16": "rgba16f", "fp32": "rgba32f"}
_RHO_TEXEL = {"snorm8": "l8", "fp16": "r16f", "fp32": "r32f"}
_ALPHA_TEXEL = {"al16": "la8", "rgba8": "l8", "fp32": "r32f"}


def textures(table: Table, device: str = "cpu", weight_bits: int | None = 8) -> dict:
    """The stored tables as the emulated texture unit holds them: ``coef`` (one RGBA 2D texture per
    coefficient, signed 8-bit for ``snorm8``), ``rho`` (unsigned 8-bit 2D: ``SIGNED_RGB_UNSIGNED_ALPHA``)
    and ``alpha1d`` (1D, the 16-bit opacity as an A/L pair in ``la8``)."""

    kw = dict(filter="linear", device=device, weight_bits=weight_bits)
    d = table.data
    coef = [Texture2D(np.concatenate([d[i, ..., :3], np.zeros(d.shape[1:3] + (1,), np.float32)], -1),
                      fmt=_COEF_TEXEL[table.format], **kw) for i in range(d.shape[0])]
    rho = Texture2D(d[0, ..., 3], fmt=_RHO_TEXEL[table.format], **kw)
    afmt = table.meta.get("alpha_format", "fp32")
    if afmt == "al16":
        raw = table.extra["alpha1d_raw"].astype(np.float64) / 255.0
        alpha = Texture1D(raw[:, ::-1], fmt="la8", **kw)  # L = low byte, A = high byte
    else:
        alpha = Texture1D(table.extra["alpha1d"], fmt=_ALPHA_TEXEL[afmt], **kw)
    return {"coef": coef, "rho": rho, "alpha1d": alpha, "alpha_format": afmt}


def reconstruct(table: Table, sf, sb, l, device: str = "cpu", via: str = "texture",
                weight_bits: int | None = 8, arith: str = "auto") -> np.ndarray:
    """``(C rgb, alpha)`` at normalised ``(sf, sb, l)`` from the stored (quantised) textures.

    The fragment program of Guthe's Table 1/2 setup: coefficient and ``rho_hat`` lookups, the
    dependent alpha1D lookup at ``x_n = l rho_hat`` (texel-centre scale and bias), and
    ``C = alpha sum_i l^i C~_i``.

    via : str
        ``"texture"`` (default): every lookup through the emulated texture unit (texel formats of the
        stored tables, linear filtering with ``weight_bits`` filter fractions; the A/L alpha pair
        filtered per channel and combined as ``256 A/257 + L/257``), shader arithmetic as ``arith``. ``"float"``: float64 bilinear filtering of the decoded
        textures, the approximation error alone (``weight_bits`` unused).
    arith : str
        ``via="texture"`` only: the shader arithmetic after the fetches, :data:`ARITH` (``fp32``,
        ``nv_combiner``, ``ati_fs``); ``auto``: the one the table's ``scales`` were chosen for.
    """
    from warpvol.errors import check_choice

    via = check_choice("via", via, RECONSTRUCT_VIA)
    if via == "float":
        return _reconstruct_float(table, sf, sb, l)

    sf, sb, l = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (sf, sb, l)))
    shape = sf.shape
    uv = np.stack([table.axes[2].coord(sf).ravel(), table.axes[1].coord(sb).ravel()], -1).astype(np.float32)
    tx = textures(table, device, weight_bits)
    scale = np.asarray(table.meta["coef_scale"], dtype=np.float32)
    lc = np.clip(l.ravel(), 0, 1).astype(np.float32)
    rho_n = tx["rho"].sample(uv)[:, 0]
    na = tx["alpha1d"].shape[0]
    ua = np.float32(0.5 / na) + lc * rho_n * np.float32(1.0 - 1.0 / na)
    a = tx["alpha1d"].sample(ua)

    cnt.count(dependent_fetches=uv.shape[0])  # the alpha1D fetch's coordinate came from the rho fetch
    alpha = Pair16.value(a[:, 3], a[:, 0]) if tx["alpha_format"] == "al16" else a[:, 0]
    if arith == "auto":
        arith = {v: k for k, v in ARITH_SCALES.items()}[table.meta.get("coef_scales", "free")]
    if arith != "fp32":
        return _reconstruct_fixed(table, tx, uv, lc, alpha, arith, device).reshape(shape + (4,))
    c = np.zeros((uv.shape[0], 3), np.float32)
    for i, t in enumerate(tx["coef"]):
        c += (lc ** np.float32(i))[:, None] * t.sample(uv)[:, :3] * scale[i]
    out = np.concatenate([c * alpha[:, None], alpha[:, None]], axis=-1)
    return out.reshape(shape + (4,))


def _reconstruct_fixed(table, tx, uv, lc, alpha, arith, device) -> np.ndarray:
    """The fetched texels through :func:`warpvol.kernels.combiners.k_guthe_fixed`."""
    import warp as wp

    from warpvol.kernels import combiners as kc

    w, s_acc, rng, unit = arith_constants(table, arith)
    taps = np.stack([t.sample(uv)[:, :3] for t in tx["coef"]], axis=1).astype(np.float32)
    n = uv.shape[0]
    out = wp.zeros(n, dtype=wp.vec4, device=device)
    wp.launch(kc.k_guthe_fixed, dim=n, inputs=[wp.array(taps, dtype=wp.vec3, device=device),
                                               wp.array(lc, dtype=wp.float32, device=device),
                                               wp.array(np.asarray(alpha, np.float32), dtype=wp.float32, device=device),
                                               wp.array(w, dtype=wp.float32, device=device), s_acc, rng, unit, out],
              device=device)
    return out.numpy()


def _reconstruct_float(table: Table, sf, sb, l) -> np.ndarray:
    """Float64 bilinear form of :func:`reconstruct` (``via="float"``)."""
    sf, sb, l = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (sf, sb, l)))
    ax_b, ax_f = table.axes[1], table.axes[2]
    fx, fy = ax_f.index(sf), ax_b.index(sb)
    deg = table.data.shape[0] - 1
    scale = np.asarray(table.meta["coef_scale"], dtype=np.float64)
    t0 = _bilinear2d(table.data[0], fx, fy)
    rho_n = t0[..., 3]
    xa = np.clip(l, 0, 1) * rho_n
    a1 = table.extra["alpha1d"].astype(np.float64)
    na = a1.shape[0]
    ia = np.clip(xa * (na - 1), 0, na - 1)
    i0 = np.minimum(np.floor(ia).astype(np.int64), na - 2)
    w = ia - i0
    alpha = a1[i0] * (1 - w) + a1[i0 + 1] * w
    c = np.zeros(sf.shape + (3,))
    for i in range(deg + 1):
        ci = t0[..., :3] if i == 0 else _bilinear2d(table.data[i], fx, fy)[..., :3]
        c += (np.clip(l, 0, 1) ** i)[..., None] * ci * scale[i]
    return np.concatenate([c * alpha[..., None], alpha[..., None]], axis=-1)
