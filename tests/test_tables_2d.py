"""Incremental, cylindrical, Guthe 2D, psi and iso-crossing tables."""

import numpy as np
import pytest

from test_tables_common import TOLERANCES, reference_at_nodes, report, smooth_tf
from warpvol.errors import ConfigError
from warpvol.tables.base import sample3d
from warpvol.tables.cylindrical import build_cylindrical, from_cylinder, plane_texture, reconstruct, to_cylinder
from warpvol.tables.exact import build_exact3d
from warpvol.tables.guthe2d import build_guthe2d
from warpvol.tables.guthe2d import reconstruct as guthe_reconstruct
from warpvol.tables.incremental import LOG2_MAX_N_L, build_incremental
from warpvol.tables.isocross import build_isocross, lookup_nearest, split_segment
from warpvol.tables.psi import build_psi, combine, psi_exact


@pytest.mark.parametrize("axis", ["log2", "uniform"])
def test_incremental_matches_exact_at_nodes(axis):
    tf = smooth_tf(rho_max=2.0)
    inc = build_incremental(tf, n_s=48, n_l=7, lmax=1.0, axis=axis)
    ref = reference_at_nodes(inc, tf, 1.0)
    d = np.abs(inc.data - ref)
    report(f"incremental/{axis}", max=d.max(), rms=np.sqrt((d ** 2).mean()))
    assert d.max() <= TOLERANCES[f"incremental/{axis}"]["max"]
    assert np.all(inc.data[0] == 0)  # l = 0 contributes nothing
    # Kraus' texel-centre range on the scalar axes: the TF's ends at the first and last texel centres
    for ax in inc.axes[1:]:
        assert ax.kind == "endpoint" and ax.coord([0.0, 1.0]) == pytest.approx([0.5 / 48, 1 - 0.5 / 48], abs=1e-15)
        assert ax.physical[0] == tf.srange[0] and ax.physical[-1] == tf.srange[1]


def test_incremental_roettger_sw_base():
    """``base = "roettger_sw"``: the first slice by Roettger & Ertl's software rule (eq. 6 as printed,
    o = 2), the rest composited; thin slices make its one-step error small."""
    tf = smooth_tf(rho_max=2.0)
    inc = build_incremental(tf, n_s=32, n_l=12, lmax=1.0, axis="log2", base="roettger_sw")
    d = np.abs(inc.data - reference_at_nodes(inc, tf, 1.0))
    report("incremental/log2 roettger_sw base", max=d.max())
    assert d.max() <= TOLERANCES["incremental/log2"]["max"]
    exact = build_incremental(tf, n_s=32, n_l=12, lmax=1.0, axis="log2")
    assert not np.array_equal(inc.data[1], exact.data[1])  # its own base slice, not the exact one

def _doubling_f32(s):
    """One log2 doubling in numpy float32, as ``incremental_step`` with ``frac = 0.5`` computes it (no
    fused multiply-adds): ``out(sf, sb) = s(sf, sm) over s(sm, sb)``, ``sm = (sf + sb) / 2`` on the
    scalar axes' endpoint nodes, linear along the off-node coordinate."""
    f32 = np.float32
    n = s.shape[0]
    x = (np.arange(n, dtype=np.float64) / (n - 1)).astype(f32)
    sf, sb = x[None, :], x[:, None]  # out[j, i]: sf = x[i], sb = x[j]
    t = f32(n - 1) * np.clip(sf + f32(0.5) * (sb - sf), f32(0), f32(1)) + f32(0)
    i0 = np.minimum(np.floor(t).astype(np.int64), n - 2)
    w = (t - i0.astype(f32))[..., None]
    i_col, j_row = np.broadcast_to(np.arange(n)[None, :], t.shape), np.broadcast_to(np.arange(n)[:, None], t.shape)
    front = s[i0, i_col] * (f32(1) - w) + s[i0 + 1, i_col] * w  # s(sf, sm)
    back = s[j_row, i0] * (f32(1) - w) + s[j_row, i0 + 1] * w   # s(sm, sb)
    tr = f32(1) - front[..., 3:]
    return np.concatenate([front[..., :3] + tr * back[..., :3], f32(1) - tr * (f32(1) - back[..., 3:])], axis=-1)


def test_incremental_log2_paper_n_l_is_the_float32_doubling():
    """n_l = 16 (Kraus et al.'s table) is built as published: every slice after the first is the
    float32 doubling of the one before, bit for bit (the n_l bound changes no arithmetic)."""
    tf = smooth_tf(rho_max=2.0)
    data = build_incremental(tf, n_s=16, n_l=16, lmax=1.0, axis="log2").data
    assert data.dtype == np.float32
    for k in range(2, 16):
        np.testing.assert_array_equal(data[k], _doubling_f32(data[k - 1]), err_msg=f"slice {k}")


@pytest.mark.parametrize("n_l", [12, 16, LOG2_MAX_N_L])
def test_incremental_log2_accepted_n_l_within_float32_bound(n_l):
    """Up to LOG2_MAX_N_L the doublings' float32 rounding (up to 2^(n_l - 26) of optical depth at
    lmax) stays below 2^-8: the table matches the exact one within that and the resampling error."""
    tf = smooth_tf(rho_max=2.0)
    inc = build_incremental(tf, n_s=32, n_l=n_l, lmax=1.0, axis="log2")
    d = np.abs(inc.data - reference_at_nodes(inc, tf, 1.0))
    report(f"incremental/log2 n_l = {n_l}", max=d.max())
    assert d.max() <= TOLERANCES["incremental/log2"]["max"]
    assert inc.data[1, ..., 3].min() > 0 and inc.data[-1, ..., 3].min() > 0.1  # extinction >= 0.2: opacity kept


@pytest.mark.parametrize("n_l", [LOG2_MAX_N_L + 1, 24, 28, 64])
def test_incremental_log2_refuses_n_l_beyond_float32(n_l):
    """Beyond LOG2_MAX_N_L the log2 axis is refused, by the builder and when a pipeline is built, in
    words (parameter, value, range, why); the uniform axis keeps n_l up to 64. (Unrefused, n_l = 64
    built a table without opacity: the first slice's 1 - alpha rounds to 1 in float32.)"""
    from warpvol.pipeline import Pipeline

    tf = smooth_tf(rho_max=2.0)
    with pytest.raises(ConfigError) as e:
        build_incremental(tf, n_s=8, n_l=n_l, axis="log2")
    msg = str(e.value)
    assert msg.startswith(f"n_l: {n_l} is outside the allowed range [3, {LOG2_MAX_N_L}] for axis = \"log2\"")
    assert "float32" in msg and f"2^-{n_l - 2} lmax" in msg
    stages = [{"stage": "table_incremental", "n_s": 8, "n_l": n_l, "axis": "log2"}]
    with pytest.raises(ConfigError, match=rf"table_incremental.*\.n_l: {n_l} is outside .*\[3, {LOG2_MAX_N_L}\]"):
        Pipeline.from_config({"stages": stages})
    assert build_incremental(tf, n_s=8, n_l=n_l, axis="uniform").data.shape[0] == n_l


def test_log_axis_mapping_kraus_eq1():
    from warpvol.tables.base import Axis

    ax = Axis("l", 8, "log2", scale=1.0)
    nodes = ax.nodes
    np.testing.assert_allclose(nodes, [0, 1 / 64, 1 / 32, 1 / 16, 1 / 8, 1 / 4, 1 / 2, 1])
    np.testing.assert_allclose(ax.coord(nodes), (np.arange(8) + 0.5) / 8)  # every slice at its texel centre
    # linear below dl, logarithmic above (Kraus Fig. 6)
    np.testing.assert_allclose(ax.coord(0.5 / 64), 1 / 16 + 0.5 / 8)
    np.testing.assert_allclose(ax.coord(np.sqrt(2) / 64), (1.5 + 0.5) / 8)


def test_cylindrical_mapping_round_trip():
    rng = np.random.default_rng(3)
    p = rng.random((500, 3))
    c = to_cylinder(p[:, 0], p[:, 1], p[:, 2])
    assert np.all((c[:, 0] >= 0) & (c[:, 0] <= 1))
    np.testing.assert_allclose(from_cylinder(c[:, 0], c[:, 1], c[:, 2]), p, atol=1e-12)


def test_cylindrical_4x_reconstructs_3d_table():
    tf = smooth_tf(rho_max=2.0)
    t3 = build_exact3d(tf, n_s=16, n_l=16, lmax=1.0)
    rng = np.random.default_rng(5)
    p = rng.random((3000, 3))
    look = sample3d(t3, p[:, 0], p[:, 1], p[:, 2])
    errs, errs_float = {}, {}
    for f in ("4x", "2x", "1x"):
        cyl = build_cylindrical(tf, table=t3, planes=f)
        # through the emulated texture unit (what the 2002 hardware computed) ...
        errs[f] = float(np.abs(reconstruct(cyl, p[:, 0], p[:, 1], p[:, 2], via="texture") - look).max())
        # ... and the fp32 analysis path (interpolation error of the mapping alone)
        errs_float[f] = float(np.abs(reconstruct(cyl, p[:, 0], p[:, 1], p[:, 2], via="float") - look).max())
    # interpolation error scale of the 3D table itself: trilinear vs exact at the same points
    from test_tables_common import integrate_segments
    lo, hi = tf.srange
    rgb, tau = integrate_segments(lo + p[:, 0] * (hi - lo), lo + p[:, 1] * (hi - lo), p[:, 2], tf)
    exact = np.column_stack([rgb, -np.expm1(-tau)])
    own = float(np.abs(look - exact).max())
    report("cylindrical (texture unit) vs trilinear 3D table", **errs, table_vs_exact=own)
    report("cylindrical (float path) vs trilinear 3D table", **errs_float)
    for e in (errs, errs_float):
        assert e["4x"] <= TOLERANCES["cylindrical/4x"]["max"]
        assert e["4x"] <= own  # within the table's own interpolation error
        assert e["4x"] <= e["2x"] <= e["1x"]
    assert cyl.extra["atlas"].shape[0] * cyl.extra["atlas"].shape[1] >= 16 * 16 * 16


@pytest.mark.parametrize("s_axis", ["centred", "endpoint"])
def test_cylindrical_texture_path_matches_float_path(s_axis):
    """The texture-unit path differs from the fp32 path only by the unit's 8-bit filter weights.

    Bound: the unit truncates each bilinear fraction to 8 bits, an error in [0, 2^-8) of the weight
    on one axis; a linear step with weight error e changes the result by e * |T1 - T0|. With D the
    largest difference of adjacent texels in any plane, the x pass errs by < D 2^-8; the y pass
    lerps two rows (whose difference is itself <= D, being lerps of adjacent rows at the same
    weight) with a weight off by < 2^-8, another D 2^-8: < 2 D 2^-8 per plane. The blend of the two
    planes is convex with the same fp32 weight in both paths, so the bound holds for the result.
    Slack 1e-5 for fp32 rounding of the atlas coordinates (a half-texel misalignment of the texel
    centres would instead show as ~D / 2, far above the bound).
    """
    tf = smooth_tf(rho_max=2.0)
    t3 = build_exact3d(tf, n_s=16, n_l=16, lmax=1.0, s_axis=s_axis)
    cyl = build_cylindrical(tf, table=t3, planes="4x")
    assert cyl.axes[2].kind == s_axis
    rng = np.random.default_rng(11)
    p = rng.random((4000, 3))
    p[:200, 2] = 0.0                      # silhouette / l = 0 plane
    p[200:400, 1] = p[200:400, 0]         # sf = sb
    rt = reconstruct(cyl, p[:, 0], p[:, 1], p[:, 2], via="texture")
    rf = reconstruct(cyl, p[:, 0], p[:, 1], p[:, 2], via="float")
    d = cyl.data.astype(np.float64)
    D = max(np.abs(np.diff(d, axis=1)).max(), np.abs(np.diff(d, axis=2)).max())
    diff = float(np.abs(rt - rf).max())
    report(f"cylindrical texture vs float path ({s_axis})", max=diff, bound=2 * D / 256, D=D)
    assert 0.0 < diff <= 2 * D / 256 + 1e-5
    # fp32 filter weights: the texture unit computes the float path's bilinear filter; what remains
    # is fp32 rounding of the texel coordinate in the atlas (width W texels: ulp(W) ~ W 2^-23 of a
    # texel per axis, times D), ~1e-6 here
    rn = reconstruct(cyl, p[:, 0], p[:, 1], p[:, 2], via="texture", weight_bits=None)
    W = plane_texture(cyl).texture.shape[1]
    np.testing.assert_allclose(rn, rf, rtol=0, atol=2 * D * W * 2.0 ** -23 + 1e-6)


@pytest.mark.parametrize("fmt,texel", [("rgba8", "rgba8"), ("hilo16", "rgba16"), ("fp16", "rgba16f"),
                                       ("fp32", "rgba32f")])
def test_cylindrical_planes_as_texture_atlas(fmt, texel):
    tf = smooth_tf(rho_max=2.0)
    cyl = build_cylindrical(tf, n_s=8, planes="2x", format=fmt)
    assert "texture" not in cyl.extra  # uploaded on first use only
    tex = plane_texture(cyl)
    assert cyl.extra["texture"] is tex and plane_texture(cyl) is tex
    assert (tex.texture.fmt, tex.texture.filter, tex.texture.weight_bits) == (texel, "linear", 8)
    assert (tex.ntiles, tex.tile_h, tex.tile_w) == cyl.data.shape[:3]
    # texels hold exactly the stored planes (the format round trip is exact); tile p at (p // cols, p % cols)
    v = tex.texture.values
    for p in (0, 5, cyl.data.shape[0] - 1):
        r, c = divmod(p, tex.cols)
        np.testing.assert_array_equal(v[r * 10 + 1:r * 10 + 9, c * 10 + 1:c * 10 + 9], cyl.data[p])
    with pytest.raises(ConfigError, match="via"):
        reconstruct(cyl, 0.5, 0.5, 0.5, via="bilinear")


@pytest.mark.parametrize("degree", [1, 2, 4])
def test_guthe_exact_at_interpolation_slices(degree):
    tf = smooth_tf(rho_max=3.0)
    g = build_guthe2d(tf, n_s=16, degree=degree, lmax=1.0, n_alpha=4096, format="fp32", alpha_format="fp32")
    ex = build_exact3d(tf, n_s=16, n_l=degree + 1, lmax=1.0, l_axis="endpoint")
    x = ex.axes[2].nodes
    for i, l in enumerate(ex.axes[0].nodes):
        L, B, F = np.meshgrid([l], x, x, indexing="ij")
        r = guthe_reconstruct(g, F, B, L)[0]
        d = np.abs(r - ex.data[i]).max()
        assert d <= TOLERANCES["guthe/nodes"]["max"], (l, d)
    # stored as the paper does (signed 8-bit coefficients, 16-bit A/L alpha): error reported
    g8 = build_guthe2d(tf, n_s=16, degree=degree, lmax=1.0)
    assert g8.extra["alpha1d_raw"].shape[-1] == 2 and g8.extra["coef_raw"].dtype == np.int8
    assert np.all(np.abs(g8.data[..., :3]) <= 1.0)
    L, B, F = np.meshgrid(ex.axes[0].nodes, x, x, indexing="ij")
    d8 = np.abs(guthe_reconstruct(g8, F, B, L) - ex.data)
    report(f"guthe degree {degree} snorm8 + al16 at slices", max=d8.max(), rms=np.sqrt((d8 ** 2).mean()))


def test_guthe_reconstruction_goes_through_the_texture_unit():
    """With fp32 texels and fp32 filter weights the texture-unit path is the float path; with the paper's
    storage and 8-bit filter weights it differs (and is what the hardware computed)."""
    tf = smooth_tf(rho_max=3.0)
    rng = np.random.default_rng(3)
    p = rng.uniform(0, 1, (500, 3))
    g = build_guthe2d(tf, n_s=16, degree=2, lmax=1.0, n_alpha=256, format="fp32", alpha_format="fp32")
    rt = guthe_reconstruct(g, p[:, 0], p[:, 1], p[:, 2], weight_bits=None)
    rf = guthe_reconstruct(g, p[:, 0], p[:, 1], p[:, 2], via="float")
    np.testing.assert_allclose(rt, rf, atol=2e-6)
    g8 = build_guthe2d(tf, n_s=16, degree=2, lmax=1.0, n_alpha=256)
    r8 = guthe_reconstruct(g8, p[:, 0], p[:, 1], p[:, 2])
    f8 = guthe_reconstruct(g8, p[:, 0], p[:, 1], p[:, 2], via="float")
    d = np.abs(r8 - f8)
    report("guthe snorm8 + al16: texture unit (8-bit weights) vs float64 filtering", max=d.max())
    assert 0 < d.max() < 0.02
    from warpvol.gpu.counters import Counters

    with Counters() as c:
        guthe_reconstruct(g8, p[:, 0], p[:, 1], p[:, 2])
    assert c["tex_2d_rgba8s_linear"] == 3 * 500 and c["tex_2d_l8_linear"] == 500
    assert c["tex_1d_la8_linear"] == c["dependent_fetches"] == 500


def test_guthe_alpha_16bit_pair():
    tf = smooth_tf(rho_max=3.0)
    g = build_guthe2d(tf, n_s=8, degree=1, n_alpha=256)
    a, l = g.extra["alpha1d_raw"][..., 0].astype(int), g.extra["alpha1d_raw"][..., 1].astype(int)
    np.testing.assert_allclose(g.extra["alpha1d"], (256 * a + l) / 65535, atol=1e-7)


def psi_quadrature(gf, gb, n=200001):
    tf_, tb = gf / (1 - gf), gb / (1 - gb)
    u = np.linspace(0, 1, n)
    T = np.exp(-(tf_ * u + 0.5 * (tb - tf_) * u * u))
    w = np.full(n, 1.0)
    w[1:-1:2], w[2:-1:2] = 4, 2
    h = 1 / (n - 1)
    return (T * w).sum() * h / 3, (u * T * w).sum() * h / 3


def test_psi_matches_quadrature():
    t = build_psi(n=12)
    g = t.axes[1].nodes
    err = 0.0
    for j, gb in enumerate(g):
        for i, gf in enumerate(g):
            p0, p1 = psi_quadrature(gf, gb)
            err = max(err, abs(t.data[j, i, 0] - p0), abs(t.data[j, i, 1] - p1))
    report("psi/fp32 vs Simpson", max=err)
    assert err <= TOLERANCES["psi/fp32"]["atol"]


def test_psi_combination_is_exact_for_linear_segments():
    """I0 zeta + Cb (psi - zeta) + Cf (1 - psi) equals the exact integral of a linear TF segment."""
    from warpvol.reference.numpy_render import integrate_segments
    from warpvol.scene.transfer import TransferFunction

    cf, cb, rf, rb, l = np.array([0.9, 0.2, 0.4]), np.array([0.1, 0.7, 0.3]), 1.5, 4.0, 0.8
    tf = TransferFunction([[0, *cf, rf], [1, *cb, rb]], "color_extinction")
    rgb, tau = integrate_segments([0.0], [1.0], [l], tf)
    from warpvol.tables.psi import gamma

    p = psi_exact(gamma(rf, l), gamma(rb, l))[..., 0]
    I, a = combine(np.zeros(3), cf, cb, rf, rb, l, p)
    np.testing.assert_allclose(I, rgb[0], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(a, -np.expm1(-tau[0]), rtol=1e-6)


def test_iso_table_paper_worked_example():
    """Espinha & Celes 2005 §4.2: control points .25, .5, .75; sf = .2, sb = .7."""
    for limit in ("segment", "direction"):
        t = build_isocross(iso=[0.25, 0.5, 0.75], n=256, limit=limit)
        assert lookup_nearest(t, 0.2, 0.7) == (0.25, 0.5)
        s_iso, nxt = lookup_nearest(t, 0.25, 0.7)
        assert s_iso in (0.25, 0.5)  # either neighbouring texel: the next_s_iso rule handles both
        assert split_segment(t, 0.2, 0.7) == [(0.2, 0.25), (0.25, 0.5), (0.5, 0.7)]
        # downward ray and a ray with no crossing
        assert split_segment(t, 0.7, 0.2) == [(0.7, 0.5), (0.5, 0.25), (0.25, 0.2)]
        assert split_segment(t, 0.3, 0.45) == [(0.3, 0.45)]
    t = build_isocross(iso=[0.25, 0.5, 0.75], n=256, limit="direction")
    assert lookup_nearest(t, 0.5, 0.7)[0] == 0.75  # as in the paper: rejected by the ray step


def test_iso_table_from_tf_uses_normalised_control_points():
    from warpvol.scene.transfer import TransferFunction

    tf = TransferFunction([[10, 0, 0, 0, 0], [12.5, 1, 0, 0, 1], [15, 0, 1, 0, 1], [17.5, 0, 0, 1, 1],
                           [20, 0, 0, 0, 0]])
    t = build_isocross(tf, n=64)
    assert split_segment(t, 0.2, 0.7) == [(0.2, 0.25), (0.25, 0.5), (0.5, 0.7)]
