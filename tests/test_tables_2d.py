"""Incremental, cylindrical, Guthe 2D, psi and iso-crossing tables."""

import numpy as np
import pytest

from test_tables_common import TOLERANCES, reference_at_nodes, report, smooth_tf
from warpvol.tables.base import sample3d
from warpvol.tables.cylindrical import build_cylindrical, from_cylinder, reconstruct, to_cylinder
from warpvol.tables.exact import build_exact3d
from warpvol.tables.guthe2d import build_guthe2d, reconstruct as guthe_reconstruct
from warpvol.tables.incremental import build_incremental
from warpvol.tables.isocross import build_isocross, lookup_nearest, split_segment
from warpvol.tables.psi import build_psi, combine, lookup, psi_exact


@pytest.mark.parametrize("axis", ["log2", "uniform"])
def test_incremental_matches_exact_at_nodes(axis):
    tf = smooth_tf(rho_max=2.0)
    inc = build_incremental(tf, n_s=48, n_l=7, lmax=1.0, axis=axis)
    ref = reference_at_nodes(inc, tf, 1.0)
    d = np.abs(inc.data - ref)
    report(f"incremental/{axis}", max=d.max(), rms=np.sqrt((d ** 2).mean()))
    assert d.max() <= TOLERANCES[f"incremental/{axis}"]["max"]
    assert np.all(inc.data[0] == 0)  # l = 0 contributes nothing


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
    errs = {}
    for f in ("4x", "2x", "1x"):
        cyl = build_cylindrical(tf, table=t3, planes=f)
        errs[f] = float(np.abs(reconstruct(cyl, p[:, 0], p[:, 1], p[:, 2]) - look).max())
    # interpolation error scale of the 3D table itself: trilinear vs exact at the same points
    from test_tables_common import integrate_segments
    lo, hi = tf.srange
    rgb, tau = integrate_segments(lo + p[:, 0] * (hi - lo), lo + p[:, 1] * (hi - lo), p[:, 2], tf)
    exact = np.column_stack([rgb, -np.expm1(-tau)])
    own = float(np.abs(look - exact).max())
    report("cylindrical vs trilinear 3D table", **errs, table_vs_exact=own)
    assert errs["4x"] <= TOLERANCES["cylindrical/4x"]["max"]
    assert errs["4x"] <= own  # within the table's own interpolation error
    assert errs["4x"] <= errs["2x"] <= errs["1x"]
    assert cyl.extra["atlas"].shape[0] * cyl.extra["atlas"].shape[1] >= 16 * 16 * 16


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
    from warpvol.reference import integrate_segments
    from warpvol.transfer import TransferFunction

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
    from warpvol.transfer import TransferFunction

    tf = TransferFunction([[10, 0, 0, 0, 0], [12.5, 1, 0, 0, 1], [15, 0, 1, 0, 1], [17.5, 0, 0, 1, 1],
                           [20, 0, 0, 0, 0]])
    t = build_isocross(tf, n=64)
    assert split_segment(t, 0.2, 0.7) == [(0.2, 0.25), (0.25, 0.5), (0.5, 0.7)]
