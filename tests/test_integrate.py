"""The float32 segment integrator (kernels/integrate.py) against closed forms."""

import math

import numpy as np
import pytest
import warp as wp

from tolerances import TOLERANCES
from warpvol.kernels import integrate as ki
from warpvol.scene.transfer import TransferFunction

TOL = TOLERANCES["segment/fp32"]


@wp.kernel
def k_first_breaks(sf: wp.array(dtype=float), sb: wp.array(dtype=float), tf_s: wp.array(dtype=float),
                   out: wp.array(dtype=wp.vec2i)):
    i = wp.tid()
    out[i] = wp.vec2i(ki.tf_first_break(sf[i], sb[i], tf_s),
                      ki.tf_first_break_upper(ki.tf_upper(sf[i], tf_s), sf[i], sb[i], tf_s))


def run_segments(tf, sf, sb, length, device="cpu"):
    sf, sb, length = (np.atleast_1d(np.asarray(a, np.float32)) for a in (sf, sb, length))
    n = len(sf)
    out = wp.zeros(n, dtype=wp.vec4, device=device)
    tf_s, tf_v = tf.to_warp(device)
    wp.launch(ki.integrate_segments_kernel, dim=n, device=device,
              inputs=[wp.array(sf, device=device), wp.array(sb, device=device), wp.array(length, device=device),
                      tf_s, tf_v, 0 if tf.emission == "color_extinction" else 1, out])
    return out.numpy().astype(np.float64)


@pytest.mark.parametrize("rho", [0.0, 1e-3, 0.7, 5.0, 40.0])
@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_constant_segment_matches_slab_formula(rho, emission):
    c = np.array([0.9, 0.5, 0.1])
    tf = TransferFunction([[0, *c, rho], [1, *c, rho]], emission)
    d = 0.8
    out = run_segments(tf, 0.3, 0.6, d)[0]
    tau = rho * d
    assert out[3] == pytest.approx(tau, rel=1e-6, abs=1e-9)
    if emission == "color_extinction":
        want = c * -math.expm1(-tau)
    else:
        want = c * (d if rho == 0 else -math.expm1(-tau) / rho)
    np.testing.assert_allclose(out[:3], want, rtol=TOL["rtol"], atol=TOL["atol"])


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_constant_extinction_linear_colour_closed_form(emission):
    """Constant extinction, colour linear along the segment (the closed-form path of integrate_piece: Taylor
    series below optical depth 1, exp above) against the float64 closed form, depths 0.051 .. 60 across 1."""
    c0, c1, rho = np.array([0.9, 0.2, 0.05]), np.array([0.1, 0.7, 1.0]), 2.5
    tf = TransferFunction([[0, *c0, rho], [1, *c1, rho]], emission)
    depth = np.concatenate([np.geomspace(0.051, 60.0, 200), 1.0 + np.linspace(-1e-3, 1e-3, 21)])
    d = (depth / rho).astype(np.float32)
    out = run_segments(tf, np.zeros_like(d), np.ones_like(d), d)
    a = np.float64(d) * rho
    m0 = -np.expm1(-a) / a
    want = np.outer(1.0 - m0, c0) + np.outer(m0 - np.exp(-a), c1)
    if emission == "emission_density":
        want /= rho
    np.testing.assert_allclose(out[:, 3], a, rtol=1e-6)
    assert (np.abs(out[:, :3] - want).max(axis=1) <= 1e-6 * np.abs(want).max(axis=1)).all()


def linear_rho_closed_form(r0, r1, c, d, emission):
    """rho linear along the ray from r0 to r1, constant colour c."""
    tau = 0.5 * d * (r0 + r1)
    if emission == "color_extinction":
        return c * -math.expm1(-tau), tau
    # emission density: c * int_0^d exp(-(r0 t + k t^2/2)) dt, k = (r1 - r0)/d, via erf for k > 0
    k = (r1 - r0) / d
    from math import erf, exp, pi, sqrt
    a = sqrt(k / 2)
    integral = sqrt(pi) / (2 * a) * exp(r0 ** 2 / (2 * k)) * (erf(a * d + r0 / (2 * a)) - erf(r0 / (2 * a)))
    return c * integral, tau


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_linear_extinction_segment(emission):
    c = np.array([0.2, 0.4, 0.8])
    tf = TransferFunction([[0, *c, 0.5], [1, *c, 2.5]], emission)
    d = 1.3
    out = run_segments(tf, 0.0, 1.0, d)[0]
    want, tau = linear_rho_closed_form(0.5, 2.5, c, d, emission)
    assert out[3] == pytest.approx(tau, rel=1e-6)
    np.testing.assert_allclose(out[:3], want, rtol=TOL["rtol"], atol=TOL["atol"])


def test_front_to_back_direction_matters():
    # dense at the front hides the back: integrating sf->sb must differ from sb->sf
    tf = TransferFunction([[0, 1, 0, 0, 10.0], [1, 0, 0, 1, 0.1]])
    fwd = run_segments(tf, 0.0, 1.0, 1.0)[0]
    bwd = run_segments(tf, 1.0, 0.0, 1.0)[0]
    assert fwd[0] > 5 * fwd[2] and bwd[2] > bwd[0] * 0.05
    assert fwd[3] == pytest.approx(bwd[3], rel=1e-6)


def test_many_control_points_match_fine_quadrature():
    rng = np.random.default_rng(3)
    k = 64
    pts = np.column_stack([np.linspace(0, 1, k), rng.random((k, 3)), 3 * rng.random(k)])
    tf = TransferFunction(pts)
    sf, sb, d = 0.05, 0.93, 0.7
    out = run_segments(tf, sf, sb, d)[0]
    # brute force: composite midpoint rule with 200k samples in float64
    n = 200_000
    t = (np.arange(n) + 0.5) / n * d
    v = tf.evaluate(sf + (sb - sf) * t / d)
    tau_cum = np.cumsum(v[:, 3]) * (d / n) - 0.5 * v[:, 3] * (d / n)
    want = (v[:, :3] * v[:, 3:4] * np.exp(-tau_cum)[:, None]).sum(0) * (d / n)
    np.testing.assert_allclose(out[:3], want, rtol=1e-4)
    assert out[3] == pytest.approx(v[:, 3].mean() * d, rel=1e-5)


def test_stiff_extinction_is_finite_and_saturates():
    c = np.array([0.3, 0.6, 0.9])
    tf = TransferFunction([[0, *c, 1e6], [1, 0.1, 0.1, 0.1, 1e6]])
    out = run_segments(tf, [0.0, 0.2], [1.0, 0.9], [0.01, 1.0])
    assert np.isfinite(out).all()
    # color_extinction with huge extinction: radiance -> colour at the entry point
    np.testing.assert_allclose(out[0, :3], c, rtol=1e-4)
    assert out[0, 3] >= 1e3


def test_zero_length_segment_contributes_nothing():
    tf = TransferFunction([[0, 1, 1, 1, 5.0], [1, 1, 1, 1, 5.0]])
    out = run_segments(tf, [0.2, 0.5], [0.9, 0.5], [0.0, 0.0])
    assert (out == 0).all()


def test_first_break_from_one_search_equals_the_two_search_version():
    """integrate_segment's first crossed control point from the one search at sf (tf_first_break_upper)
    equals tf_first_break, exhaustively over ends on, between and outside the control points, both
    directions, equal ends and NaN."""
    nodes = np.array([0.0, 0.25, 0.5, 1.0, 2.0], np.float32)
    vals = np.concatenate([nodes, (nodes[1:] + nodes[:-1]) / 2, [-1.0, 3.0, np.nextafter(np.float32(0.5), 1)],
                           [np.nan]]).astype(np.float32)
    sf, sb = (a.ravel().astype(np.float32) for a in np.meshgrid(vals, vals))
    out = wp.zeros(len(sf), dtype=wp.vec2i)
    wp.launch(k_first_breaks, dim=len(sf), inputs=[wp.array(sf), wp.array(sb), wp.array(nodes), out])
    o = out.numpy()
    assert np.array_equal(o[:, 0], o[:, 1])
    assert (o[:, 0] >= 0).sum() > 50  # many segments do cross a control point


@wp.kernel
def k_flat_pieces(sf: wp.array(dtype=float), sb: wp.array(dtype=float), length: wp.array(dtype=float),
                  tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int,
                  out: wp.array2d(dtype=wp.vec4)):
    i = wp.tid()
    k = ki.tf_upper(sf[i], tf_s)
    vf = ki.tf_eval_upper(sf[i], k, tf_s, tf_v)
    vb = ki.tf_eval_upper(sb[i], k, tf_s, tf_v)
    rho = ki.flat_extinction(k, tf_v)
    out[i, 0] = ki.integrate_piece_flat(length[i], vf, vb, rho, model)  # the improved presets' path
    # integrate_piece's closed form: both ends at the interval's exact extinction
    out[i, 1] = ki.integrate_piece(length[i], wp.vec4(vf[0], vf[1], vf[2], rho), wp.vec4(vb[0], vb[1], vb[2], rho),
                                   model)
    out[i, 2] = ki.integrate_piece(length[i], vf, vb, model)  # the faithful presets' path (rounded slope)
    out[i, 3] = wp.vec4(vf[3], vb[3], rho, 0.0)

@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_flat_extinction_thick_piece_takes_the_closed_form(emission):
    """A thick piece inside one TF interval of equal control extinctions: its ends' interpolated extinctions
    round apart (``v (1 - w) + v w``), yet integrate_piece_flat gives integrate_piece's closed form at the exact
    extinction, bit for bit, within 1e-6 of the float64 analytic integral (colour linear, extinction constant)."""
    rho = 2.7
    c0, c1 = np.array([0.9, 0.2, 0.05]), np.array([0.1, 0.7, 1.0])
    tf = TransferFunction([[0, *c0, 0.3], [0.1, *c0, rho], [0.9, *c1, rho], [1, *c1, 0.3]], emission)
    rng = np.random.default_rng(7)
    n = 400
    sf = rng.uniform(0.11, 0.89, n).astype(np.float32)
    sb = rng.uniform(0.11, 0.89, n).astype(np.float32)
    length = np.geomspace(0.05, 30.0, n).astype(np.float32)  # optical depths 0.135 .. 81: all thick
    tf_s, tf_v = tf.to_warp("cpu")
    out = wp.zeros((n, 4), dtype=wp.vec4, device="cpu")
    wp.launch(k_flat_pieces, dim=n, device="cpu",
              inputs=[wp.array(sf), wp.array(sb), wp.array(length), tf_s, tf_v,
                      0 if emission == "color_extinction" else 1, out])
    o = out.numpy()
    flat, closed, sloped, ends = o[:, 0], o[:, 1], o[:, 2], o[:, 3]
    rho32 = np.float32(rho)
    assert (ends[:, 2] == rho32).all()
    rounded = ends[:, 0] != ends[:, 1]
    assert rounded.sum() > n // 10  # the case at issue: many pieces' end extinctions differ by rounding
    np.testing.assert_array_equal(flat[:, :3], closed[:, :3])
    assert (sloped[rounded, :3] != closed[rounded, :3]).any()  # integrate_piece: the rounded slope's quadrature
    np.testing.assert_array_equal(flat[:, 3], sloped[:, 3])  # optical depth as before
    # the float64 analytic integral: colour linear from the ends' colours, extinction rho32 throughout
    a = length.astype(np.float64) * np.float64(rho32)
    m0 = -np.expm1(-a) / a

    tfv = np.array([[*c0, rho], [*c1, rho]])
    wf = np.clip((sf.astype(np.float64) - 0.1) / 0.8, 0, 1)[:, None]
    wb = np.clip((sb.astype(np.float64) - 0.1) / 0.8, 0, 1)[:, None]
    cf = tfv[0, :3] * (1 - wf) + tfv[1, :3] * wf
    cb = tfv[0, :3] * (1 - wb) + tfv[1, :3] * wb
    want = cf * (1.0 - m0)[:, None] + cb * (m0 - np.exp(-a))[:, None]
    if emission == "emission_density":
        want /= np.float64(rho32)
    err = np.abs(flat[:, :3] - want).max(axis=1) / np.abs(want).max(axis=1)
    assert err.max() <= 1e-6
