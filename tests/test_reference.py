"""The exact float64 reference renderer (warpvol/reference/numpy_render.py) against closed forms.

Every expected value here is derived independently of the code under test: slab formulas for
constant media, closed forms (erfc / an all-positive series) for linear extinction, a fine composite
Simpson rule for many-point transfer functions, and analytic ray/box chords for geometry.
"""

import math

import numpy as np
import pytest

from helpers import merge
from warpvol.reference.numpy_render import (
    composite_front_to_back,
    integrate_segments,
    render_reference,
    segmented_exclusive_cumsum,
    trace_segments,
)
from warpvol.scene.camera import Camera
from warpvol.scene.grids import grid_points, structured_to_tets
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import TransferFunction

EMISSIONS = ["color_extinction", "emission_density"]


# -- builders --------------------------------------------------------------------------------------
def grid_mesh(xs, ys, zs, scalar=None, drop_cells=()):
    """Tensor-product grid (point index i + ni*(j + nj*k)), 6 tets per hex; ``drop_cells`` lists
    (ci, cj, ck) cells to leave out (non-convex meshes)."""
    xs, ys, zs = (np.asarray(a, dtype=np.float64) for a in (xs, ys, zs))
    dims = (len(xs), len(ys), len(zs))
    pts = grid_points(xs, ys, zs)
    tets = structured_to_tets(dims)
    if drop_cells:
        nci, ncj = dims[0] - 1, dims[1] - 1
        drop = {ci + nci * (cj + ncj * ck) for ci, cj, ck in drop_cells}
        keep = np.array([c not in drop for c in range(len(tets) // 6)])
        tets = tets.reshape(-1, 6, 4)[keep].reshape(-1, 4)
        used = np.unique(tets)
        remap = np.full(len(pts), -1)
        remap[used] = np.arange(len(used))
        pts, tets = pts[used], remap[tets]
    s = np.ones(len(pts)) if scalar is None else scalar(pts)
    return TetMesh(pts, tets, s)


def const_tf(rho, c=(0.9, 0.5, 0.1), emission="color_extinction"):
    return TransferFunction([[-10, *c, rho], [10, *c, rho]], emission)


def box_chord(o, d, lo, hi):
    """Length of ``{t >= 0 : o + t d in [lo, hi]}`` per ray (slab method), arrays (..., 3)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (lo - o) / d
        t2 = (hi - o) / d
    par = d == 0
    inside = (o >= lo) & (o <= hi)
    tmin = np.where(par, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2)).max(-1)
    tmax = np.where(par, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2)).min(-1)
    return np.maximum(tmax - np.maximum(tmin, 0.0), 0.0)


def per_pixel(seg, key, n):
    return np.bincount(seg["pixel"], weights=key, minlength=n)


# -- closed forms for one segment with linear extinction and linear colour ------------------------
def _series_int_exp_sq(x):
    """int_0^x exp(y^2) dy by its all-positive Taylor series (no cancellation)."""
    term, total, k = x, x, 0
    while term > 1e-18 * total:
        k += 1
        term *= x * x / k
        total += term / (2 * k + 1)
    return total


def closed_I0(r0, r1, h):
    """int_0^h exp(-R(t)) dt with R(t) = r0 t + a t^2 / 2, a = (r1 - r0) / h."""
    a = (r1 - r0) / h
    tau = 0.5 * h * (r0 + r1)
    if a == 0:
        return h if r0 == 0 else -math.expm1(-tau) / r0
    if a > 0:  # complete the square: erfc form, E(x) = exp(x^2) erfc(x)
        x0 = r0 / math.sqrt(2 * a)
        x1 = x0 + math.sqrt(a / 2) * h
        E = lambda x: math.exp(x * x) * math.erfc(x)  # noqa: E731
        return math.sqrt(math.pi / (2 * a)) * (E(x0) - math.exp(-tau) * E(x1))
    b = -a  # R = r0 t - b t^2/2 = r0^2/(2b) - (b/2)(t* - t)^2, t* = r0/b >= h
    y0 = r0 / math.sqrt(2 * b)
    y1 = math.sqrt(b / 2) * (r0 / b - h)
    return math.sqrt(2 / b) * math.exp(-y0 * y0) * (_series_int_exp_sq(y0) - _series_int_exp_sq(y1))


def closed_radiance(r0, r1, c0, c1, h, emission):
    """Radiance of a segment with rho linear r0 -> r1 and colour linear c0 -> c1 over length h."""
    tau = 0.5 * h * (r0 + r1)
    a = (r1 - r0) / h
    cp = (c1 - c0) / h
    I0 = closed_I0(r0, r1, h)
    if emission == "color_extinction":
        # int c rho e^{-R} = [-c e^{-R}]_0^h + c' int e^{-R}
        return c0 - c1 * math.exp(-tau) + cp * I0
    # int (c0 + c' t) e^{-R};  int t e^{-R} = ((1 - e^{-tau}) - r0 I0) / a   (a != 0)
    if a != 0:
        I1 = (-math.expm1(-tau) - r0 * I0) / a
    elif r0 > 0:  # int t e^{-r0 t} = (1 - e^{-tau} (1 + tau)) / r0^2
        I1 = (-math.expm1(-tau) - tau * math.exp(-tau)) / r0 ** 2
    else:
        I1 = 0.5 * h * h
    return c0 * I0 + cp * I1


def simpson_reference(tf, sf, sb, L, n_per_piece=400):
    """Brute force: composite Simpson on every piece between TF control points; the optical depth at
    the nodes by the trapezoid rule (exact: rho is linear between consecutive nodes)."""
    S = tf.points[:, 0]
    inner = S[(S > min(sf, sb)) & (S < max(sf, sb))]
    u_bp = np.unique(np.concatenate([[0.0, 1.0], (inner - sf) / (sb - sf)]))
    u = np.concatenate([np.linspace(u_bp[k], u_bp[k + 1], 2 * n_per_piece + 1)[:-1]
                        for k in range(len(u_bp) - 1)] + [[1.0]])
    t = u * L
    v = tf.evaluate(sf + u * (sb - sf))
    rho, c = v[:, 3], v[:, :3]
    R = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (rho[1:] + rho[:-1]))])
    f = c * np.exp(-R)[:, None]
    if tf.emission == "color_extinction":
        f = f * rho[:, None]
    out = np.zeros(3)
    m = 2 * n_per_piece
    for k in range(len(u_bp) - 1):
        sl = slice(k * m, (k + 1) * m + 1)
        tt, ff = t[sl], f[sl]
        hh = (tt[-1] - tt[0]) / m
        out += hh / 3 * (ff[0] + ff[-1] + 4 * ff[1:-1:2].sum(0) + 2 * ff[2:-1:2].sum(0))
    return out, R[-1]


# -- constant media ---------------------------------------------------------------------------------
@pytest.mark.parametrize("emission", EMISSIONS)
@pytest.mark.parametrize("rho", [1e-3, 0.7, 6.0])
def test_constant_box_orthographic_matches_slab_formula(emission, rho):
    c = np.array([0.9, 0.5, 0.1])
    m = grid_mesh(*[np.linspace(-1, 1, 4)] * 3)
    cam = Camera(projection="orthographic", eye=[0.05, 0.03, 5], target=[0.05, 0.03, 0], ortho_height=3.0,
                 width_px=24, height_px=20)
    img = render_reference(m, const_tf(rho, c, emission), cam)
    o, d = cam.rays()
    inside = (np.abs(o[..., 0]) < 0.99) & (np.abs(o[..., 1]) < 0.99)
    outside = (np.abs(o[..., 0]) > 1.01) | (np.abs(o[..., 1]) > 1.01)
    alpha = -math.expm1(-2 * rho)
    rgb = c * alpha if emission == "color_extinction" else c * alpha / rho
    np.testing.assert_allclose(img[inside][:, 3], alpha, rtol=1e-12)
    np.testing.assert_allclose(img[inside][:, :3], np.broadcast_to(rgb, (inside.sum(), 3)), rtol=1e-12)
    assert (img[outside] == 0).all()
    assert inside.sum() > 100 and outside.sum() > 50


@pytest.mark.parametrize("emission", EMISSIONS)
def test_perspective_constant_box_alpha_matches_analytic_chord(emission):
    rho, lo, hi = 1.3, np.array([-1.0, -0.8, -0.6]), np.array([1.0, 0.9, 0.7])
    m = grid_mesh(np.linspace(lo[0], hi[0], 5), np.linspace(lo[1], hi[1], 4), np.linspace(lo[2], hi[2], 3))
    cam = Camera(eye=[2.3, 1.7, 3.1], target=[0.1, 0.0, -0.1], up=[0.1, 1, 0], fov_y_deg=45,
                 width_px=40, height_px=32)
    img = render_reference(m, const_tf(rho, emission=emission), cam)
    o, d = cam.rays()
    chord = box_chord(o, d, lo, hi)
    assert (chord > 0).sum() > 300 and (chord == 0).sum() > 100
    np.testing.assert_allclose(img[..., 3], -np.expm1(-rho * chord), rtol=0, atol=1e-12)
    assert (img[chord == 0] == 0).all()


def test_perspective_eye_inside_mesh_clips_at_the_eye():
    rho, lo, hi = 0.8, -np.ones(3), np.ones(3)
    s = lambda p: 0.3 * p[:, 0] + 0.2 * p[:, 1] - 0.1 * p[:, 2]  # noqa: E731  (linear field)
    m = grid_mesh(*[np.linspace(-1, 1, 5)] * 3, scalar=s)
    tf = TransferFunction([[-1, 0.2, 0.4, 0.6, rho], [1, 0.9, 0.1, 0.5, rho]], "color_extinction")
    cam = Camera(eye=[0.13, -0.21, 0.37], target=[1, 0.3, -2], fov_y_deg=100, width_px=24, height_px=24)
    img = render_reference(m, tf, cam)
    o, d = cam.rays()
    chord = box_chord(o, d, lo, hi)
    assert (chord > 0).all()
    np.testing.assert_allclose(img[..., 3], -np.expm1(-rho * chord), rtol=0, atol=1e-12)
    # the colour along a ray is linear in t from the eye's scalar: closed form per pixel
    ii, jj = np.unravel_index([0, 100, 300, 575], chord.shape)
    for i, j in zip(ii, jj):
        sf = s(o[i, j][None])[0]
        sb = s((o[i, j] + chord[i, j] * d[i, j])[None])[0]
        c0, c1 = tf.evaluate(sf)[:3], tf.evaluate(sb)[:3]
        want = [closed_radiance(rho, rho, c0[k], c1[k], chord[i, j], "color_extinction") for k in range(3)]
        np.testing.assert_allclose(img[i, j, :3], want, rtol=1e-11)


# -- linear fields: closed forms ---------------------------------------------------------------------
@pytest.mark.parametrize("emission", EMISSIONS)
@pytest.mark.parametrize("rho_top,rho_bottom", [(0.3, 2.5), (2.5, 0.3), (0.0, 3.0), (3.0, 0.0), (1.1, 1.1)])
def test_linear_field_matches_closed_form(emission, rho_top, rho_bottom):
    """scalar = z, TF linear in s: rho and c are linear along rays down -z through z = 1 .. -1."""
    zs = np.array([-1.0, -0.7, -0.1, 0.35, 1.0])
    m = grid_mesh(np.linspace(-1, 1, 4), np.linspace(-1, 1, 3), zs, scalar=lambda p: p[:, 2])
    c_bot, c_top = np.array([0.1, 0.8, 0.3]), np.array([0.9, 0.2, 0.6])
    tf = TransferFunction([[-1, *c_bot, rho_bottom], [1, *c_top, rho_top]], emission)
    cam = Camera(projection="orthographic", eye=[0, 0, 4], target=[0, 0, 0], ortho_height=1.6, width_px=12,
                 height_px=10)
    img = render_reference(m, tf, cam)
    tau = 0.5 * 2.0 * (rho_top + rho_bottom)
    want = [closed_radiance(rho_top, rho_bottom, c_top[k], c_bot[k], 2.0, emission) for k in range(3)]
    np.testing.assert_allclose(img[..., 3], -math.expm1(-tau), rtol=1e-12)
    np.testing.assert_allclose(img[..., :3].reshape(-1, 3), np.broadcast_to(want, (120, 3)), rtol=1e-9)


@pytest.mark.parametrize("emission", EMISSIONS)
@pytest.mark.parametrize("r0,r1,h", [(0.5, 2.0, 2.0), (2.0, 0.5, 2.0), (0.0, 40.0, 1.5), (40.0, 0.0, 1.5),
                                     (3.0, 9.0, 0.01), (0.2, 0.25, 7.0)])
def test_integrate_segments_single_piece_matches_closed_form(emission, r0, r1, h):
    c0, c1 = np.array([0.2, 0.7, 0.0]), np.array([0.9, 0.1, 0.4])
    tf = TransferFunction([[0, *c0, r0], [1, *c1, r1]], emission)
    rgb, tau = integrate_segments([0.0], [1.0], [h], tf)
    assert tau[0] == pytest.approx(0.5 * h * (r0 + r1), rel=1e-14)
    want = [closed_radiance(r0, r1, c0[k], c1[k], h, emission) for k in range(3)]
    np.testing.assert_allclose(rgb[0], want, rtol=1e-9, atol=1e-300)


# -- many control points -----------------------------------------------------------------------------
@pytest.mark.parametrize("emission", EMISSIONS)
@pytest.mark.parametrize("K", [64, 1024])
@pytest.mark.parametrize("sf,sb", [(0.013, 0.991), (0.97, 0.02), (0.31, 0.33)])
def test_many_point_tf_matches_composite_simpson(emission, K, sf, sb):
    rng = np.random.default_rng(K)
    s = np.concatenate([[0.0], np.sort(rng.uniform(0, 1, K - 2)), [1.0]])
    vals = np.column_stack([rng.uniform(0, 1, (K, 3)), rng.uniform(0, 6, K)])
    vals[rng.uniform(size=K) < 0.2, 3] = 0.0  # some transparent stretches
    tf = TransferFunction(np.column_stack([s, vals]), emission)
    L = 0.8
    rgb, tau = integrate_segments([sf], [sb], [L], tf)
    want, want_tau = simpson_reference(tf, sf, sb, L, n_per_piece=300 if K == 64 else 40)
    assert tau[0] == pytest.approx(want_tau, rel=1e-12)
    np.testing.assert_allclose(rgb[0], want, rtol=1e-9)


def test_integrate_segments_is_vectorised_consistently():
    """A batch (mixed directions, lengths and crossings) gives the same values as one at a time."""
    rng = np.random.default_rng(5)
    K = 50
    tf = TransferFunction(np.column_stack([np.linspace(0, 1, K), rng.uniform(0, 1, (K, 3)),
                                           rng.uniform(0, 50, K)]), "color_extinction")
    sf, sb = rng.uniform(-0.1, 1.1, 200), rng.uniform(-0.1, 1.1, 200)
    L = rng.uniform(0, 2, 200)
    rgb, tau = integrate_segments(sf, sb, L, tf)
    for k in range(0, 200, 17):
        r1, t1 = integrate_segments(sf[k:k + 1], sb[k:k + 1], L[k:k + 1], tf)
        np.testing.assert_allclose(rgb[k], r1[0], rtol=1e-14, atol=0)
        assert tau[k] == pytest.approx(t1[0], rel=1e-14)


# -- stiff and degenerate ----------------------------------------------------------------------------
@pytest.mark.parametrize("emission", EMISSIONS)
def test_stiff_extinction_matches_its_analytic_limit(emission):
    rho, L = 1e6, 0.01  # optical depth 1e4
    c0, c1 = np.array([0.3, 0.6, 0.9]), np.array([0.9, 0.1, 0.2])
    tf = TransferFunction([[0, *c0, rho], [1, *c1, rho]], emission)
    rgb, tau = integrate_segments([0.0, 1.0], [1.0, 0.0], [L, L], tf)
    assert np.isfinite(rgb).all() and np.isfinite(tau).all()
    np.testing.assert_allclose(tau, rho * L, rtol=1e-14)
    for k, (ca, cb) in enumerate([(c0, c1), (c1, c0)]):
        cp = (cb - ca) / L
        if emission == "color_extinction":  # int (ca + cp t) rho e^{-rho t} = ca + cp / rho  (+ e^{-1e4})
            want, limit = ca + cp / rho, ca
        else:  # int (ca + cp t) e^{-rho t} = ca / rho + cp / rho^2
            want, limit = ca / rho + cp / rho ** 2, ca / rho
        np.testing.assert_allclose(rgb[k], want, rtol=1e-12)
        np.testing.assert_allclose(rgb[k], limit, rtol=1e-3)


def test_stiff_varying_extinction_is_finite_and_tends_to_entry_colour():
    c0, c1 = np.array([0.3, 0.6, 0.9]), np.array([0.9, 0.1, 0.2])
    tf = TransferFunction([[0, *c0, 1e6], [1, *c1, 3e6]], "color_extinction")
    rgb, tau = integrate_segments([0.0], [1.0], [0.01], tf)
    assert tau[0] == pytest.approx(0.5 * 0.01 * 4e6, rel=1e-14)
    # C = c0 + c'/rho0 + O(1/rho0^2) with c' = (c1 - c0)/L
    np.testing.assert_allclose(rgb[0], c0 + (c1 - c0) / 0.01 / 1e6, rtol=1e-6)


@pytest.mark.parametrize("emission", EMISSIONS)
def test_stiff_box_render_is_opaque_and_finite(emission):
    rho = 1e6
    m = grid_mesh(*[np.linspace(-1, 1, 3)] * 3, scalar=lambda p: p[:, 2])
    c_bot, c_top = np.array([0.1, 0.8, 0.3]), np.array([0.9, 0.2, 0.6])
    tf = TransferFunction([[-1, *c_bot, rho], [1, *c_top, rho]], emission)
    cam = Camera(projection="orthographic", eye=[0, 0, 4], target=[0, 0, 0], ortho_height=1.6, width_px=8, height_px=8)
    img = render_reference(m, tf, cam)
    assert np.isfinite(img).all()
    np.testing.assert_allclose(img[..., 3], 1.0, rtol=0, atol=1e-12)
    cp = (c_bot - c_top) / 2.0  # colour slope along the ray (scalar = z goes from 1 to -1)
    want = c_top + cp / rho if emission == "color_extinction" else c_top / rho + cp / rho ** 2
    np.testing.assert_allclose(img[..., :3].reshape(-1, 3), np.broadcast_to(want, (64, 3)), rtol=1e-12)


def test_zero_length_and_invalid_segments_contribute_exactly_nothing():
    tf = TransferFunction([[0, 1, 1, 1, 5.0], [1, 0.5, 0.2, 0.1, 1e6]], "emission_density")
    sf = np.array([0.0, 0.3, 1.0, -7.0, 0.5, np.nan, 0.2])
    sb = np.array([1.0, 0.3, 0.0, 9.0, 0.5, 0.1, np.inf])
    L = np.array([0.0, 0.0, -1.0, 0.0, np.nan, 1.0, 1.0])
    rgb, tau = integrate_segments(sf, sb, L, tf)
    assert (rgb == 0).all() and (tau == 0).all()
    # tiny but positive lengths stay finite and tiny
    rgb, tau = integrate_segments([0.0], [1.0], [1e-300], tf)
    assert np.isfinite(rgb).all() and 0 <= tau[0] < 1e-290


# -- geometry: non-convex, disconnected, watertight --------------------------------------------------
@pytest.mark.parametrize("projection", ["orthographic", "perspective"])
def test_disconnected_boxes_composite_in_depth_order(projection):
    """Two separated boxes on the view axis, different scalars: alpha = 1 - exp(-rho1 d1 - rho2 d2),
    RGB = C1 + T1 C2 (near box first); a pixel missing both is exactly 0."""
    near = grid_mesh(np.linspace(-1, 1, 3), np.linspace(-1, 1, 3), [1.5, 2.0, 2.5], scalar=lambda p: 0 * p[:, 0])
    far = grid_mesh(np.linspace(-0.7, 0.7, 3), np.linspace(-0.7, 0.7, 2), [-2.0, -1.0, -0.5],
                    scalar=lambda p: 1 + 0 * p[:, 0])
    m = merge(far, near)  # tets of the far box come first: order must come from depth, not input
    c_near, c_far, r_near, r_far = np.array([0.9, 0.1, 0.1]), np.array([0.1, 0.2, 0.9]), 0.6, 1.7
    tf = TransferFunction([[0.2, *c_near, r_near], [0.8, *c_far, r_far]], "color_extinction")
    if projection == "orthographic":
        cam = Camera(projection="orthographic", eye=[0, 0, 6], target=[0, 0, 0], ortho_height=3.1, width_px=15,
                     height_px=15)
    else:
        cam = Camera(eye=[0.02, 0.01, 6], target=[0, 0, 0], fov_y_deg=60, width_px=25, height_px=25)
    img = render_reference(m, tf, cam)
    o, d = cam.rays()
    d1 = box_chord(o, d, [-1, -1, 1.5], [1, 1, 2.5])
    d2 = box_chord(o, d, [-0.7, -0.7, -2], [0.7, 0.7, -0.5])
    assert (d2 > 0).sum() >= 9 and ((d1 > 0) & (d2 == 0)).sum() > 10 and (d1 == 0).sum() > 10
    np.testing.assert_allclose(img[..., 3], -np.expm1(-r_near * d1 - r_far * d2), rtol=0, atol=1e-12)
    a1, a2 = -np.expm1(-r_near * d1), -np.expm1(-r_far * d2)
    want = a1[..., None] * c_near + (1 - a1)[..., None] * a2[..., None] * c_far
    np.testing.assert_allclose(img[..., :3], want, rtol=0, atol=1e-12)
    assert (img[d1 + d2 == 0] == 0).all()


def test_non_convex_mesh_rays_exit_and_reenter():
    """A U-shaped mesh (grid with a notch) seen from the side: rays cross both arms."""
    xs = np.linspace(-1.5, 1.5, 4)  # cells [-1.5,-.5], [-.5,.5], [.5,1.5]
    zs = np.array([-1.0, 0.0, 1.0])
    drop = [(1, j, 1) for j in range(2)]  # remove the middle-top cells: notch in x in [-.5, .5], z in [0, 1]
    m = grid_mesh(xs, np.linspace(-1, 1, 3), zs, drop_cells=drop)
    rho = 0.9
    cam = Camera(projection="orthographic", eye=[-5, 0, 0], target=[0, 0, 0], up=[0, 0, 1], ortho_height=2.5,
                 width_px=10, height_px=10)
    img = render_reference(m, const_tf(rho), cam)
    o, d = cam.rays()
    chord = box_chord(o, d, [-1.5, -1, -1], [1.5, 1, 1]) - box_chord(o, d, [-0.5, -1, 0], [0.5, 1, 1])
    assert (np.abs(chord - 2.0) < 1e-12).sum() > 10  # rays through the notch: two arms of length 1
    np.testing.assert_allclose(img[..., 3], -np.expm1(-rho * chord), rtol=0, atol=1e-12)


def _tiling_check(seg, chord, n_pix, t_entry=None):
    """Per pixel: the segments, sorted, tile [t_entry, t_entry + chord] with no gap or overlap."""
    L = seg["t_out"] - seg["t_in"]
    total = per_pixel(seg, L, n_pix)
    np.testing.assert_allclose(total, chord.ravel(), rtol=0, atol=1e-12)
    # consecutive segments of a ray share the face: the exit depth of one is the entry depth of the
    # next (bit-identical through face interiors; within an ulp where a ray grazes an edge and cuts
    # a sliver of a tet). Slivers at rounding level (an eye on an edge, in rounded camera
    # coordinates) are left out of the chain; their lengths are in the sum above.
    real = L > 1e-14 * np.maximum(1.0, seg["t_out"])
    order = np.lexsort((seg["t_out"][real], seg["t_in"][real], seg["pixel"][real]))
    p, ti, to = seg["pixel"][real][order], seg["t_in"][real][order], seg["t_out"][real][order]
    same = p[1:] == p[:-1]
    gap = np.abs(ti[1:][same] - to[:-1][same])
    assert (gap <= 1e-15 * np.maximum(1.0, to[:-1][same])).all()
    # each tet at most once per pixel
    key = seg["pixel"] * (seg["tet"].max() + 1) + seg["tet"]
    assert len(np.unique(key)) == len(key)
    return np.flatnonzero(real)[order], same


def test_coverage_identity_rays_in_faces_and_along_edges():
    """Orthographic view down -z with pixel centres exactly on grid lines (rays along tet edges) and
    on the cells' diagonal faces (rays inside shared faces): the summed segment lengths equal the
    chord exactly -- no double counting, no gaps."""
    g = np.array([-1.0, -0.625, -0.125, 0.375, 1.0])  # pixel centres at odd multiples of 1/8
    m = grid_mesh(g, g, np.array([-1.0, -0.5, 0.25, 1.0]))
    cam = Camera(projection="orthographic", eye=[0, 0, 5], target=[0, 0, 0], ortho_height=2.0, width_px=8, height_px=8)
    o, _ = cam.rays()
    on_line = np.isin(o[..., 0], g) & np.isin(o[..., 1], g)
    assert on_line.sum() == 9  # the rays that run along vertical grid edges
    seg = trace_segments(m, cam)
    _tiling_check(seg, np.full((8, 8), 2.0), 64)
    order = np.lexsort((seg["t_in"], seg["pixel"]))
    first = np.r_[True, seg["pixel"][order][1:] != seg["pixel"][order][:-1]]
    assert (seg["t_in"][order][first] == 4.0).all()


@pytest.mark.parametrize("eye,W", [([0.0, 0.0, 5.0], 9), ([1.7, 2.9, 3.3], 31), ([0.0, 0.0, 0.3], 17)])
def test_coverage_identity_perspective(eye, W):
    """Perspective, including the central ray running exactly along the edge x = y = 0 and an eye
    inside the mesh: segments tile the analytic chord."""
    g = np.linspace(-1, 1, 5)
    m = grid_mesh(g, g, np.linspace(-1, 1, 4))
    cam = Camera(eye=eye, target=[0, 0, 0], up=[0, 1, 0] if eye[0] == 0 else [0.2, 1, 0.1], fov_y_deg=50,
                 width_px=W, height_px=W)
    o, d = cam.rays()
    chord = box_chord(o, d, -np.ones(3), np.ones(3))
    seg = trace_segments(m, cam)
    _tiling_check(seg, chord, W * W)
    assert (chord > 0).sum() > W


@pytest.mark.parametrize("eye,target", [
    ([0.5, 0.5, -3.0], [0.0, 0.0, 0.1]),   # eye and target in the plane x = y of diagonal faces
    ([0.0, 0.0, 3.0], [-1.0, -1.0, -1.0]),  # central ray in x = y, through grid vertices
    ([0.5, 0.5, 0.5], [0.0, 0.0, -5.0]),   # eye at a mesh vertex, ray inside a face plane
    ([0.0, 0.0, 0.3], [0.2, -0.1, -1.0]),  # eye on a mesh edge
    ([0.25, 0.0, 0.5], [0.3, 0.1, -1.0]),  # eye on a face
])
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_coverage_identity_near_degenerate_cameras(eye, target, projection):
    """Rays lying in face planes that are exact in world space but not in the rotated camera frame
    (coordinates are rounded), and eyes on vertices / edges / faces: exact edge predicates keep the
    segments a tiling of the chord."""
    g = np.linspace(-1, 1, 5)
    m = grid_mesh(g, g, g, scalar=lambda p: p[:, 0] + 2 * p[:, 1])
    cam = Camera(projection=projection, eye=eye, target=target, fov_y_deg=90, ortho_height=2.0, width_px=9, height_px=9)
    o, d = cam.rays()
    chord = box_chord(o, d, -np.ones(3), np.ones(3))
    seg = trace_segments(m, cam)
    order, same = _tiling_check(seg, chord, 81)
    # the scalar is continuous along the ray: each entry value equals the previous exit value
    si, so = seg["s_in"][order], seg["s_out"][order]
    np.testing.assert_allclose(si[1:][same], so[:-1][same], rtol=0, atol=1e-13)
    # and equals the linear field at the entry point
    pt = o.reshape(-1, 3)[seg["pixel"]] + seg["t_in"][:, None] * d.reshape(-1, 3)[seg["pixel"]]
    np.testing.assert_allclose(seg["s_in"], pt[:, 0] + 2 * pt[:, 1], rtol=0, atol=1e-12)


def test_exact_edge_predicate_matches_rational_arithmetic():
    from fractions import Fraction

    from warpvol.reference.numpy_render import _exact_sum_of_products

    rng = np.random.default_rng(11)
    n = 3000
    d = np.column_stack([rng.normal(size=(n, 2)), np.ones(n)])
    A = rng.normal(size=(n, 3))
    B = A * rng.uniform(0.5, 2, (n, 1)) + d * rng.uniform(-1, 1, (n, 1))  # d . (A x B) ~ 0
    B += rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-18, -12, (n, 1)) * (rng.random((n, 1)) < 0.6)
    B[:500] = A[:500] * 3.0 + d[:500] * 0.5  # exact zeros for float inputs? (checked rationally)
    A[500:1000] = np.round(A[500:1000] * 8) / 8
    B[500:1000] = A[500:1000] * 2.0 + np.round(d[500:1000] * 4) / 4  # exactly representable, det 0
    d[500:1000] = np.round(d[500:1000] * 4) / 4
    terms = [(d[:, 0], A[:, 1], B[:, 2]), (-d[:, 0], A[:, 2], B[:, 1]), (d[:, 1], A[:, 2], B[:, 0]),
             (-d[:, 1], A[:, 0], B[:, 2]), (A[:, 0], B[:, 1]), (-A[:, 1], B[:, 0])]
    sign, value = _exact_sum_of_products(terms)
    zeros = 0
    for i in range(n):
        exact = sum(math.prod(Fraction(float(f[i])) for f in t) for t in terms)
        assert sign[i] == (exact > 0) - (exact < 0), i
        if exact == 0:
            zeros += 1
            assert value[i] == 0
        else:
            assert abs(float((Fraction(float(value[i])) - exact) / exact)) < 1e-15
    assert zeros >= 400


def test_orthographic_eye_plane_inside_mesh_clips_at_the_plane():
    rho = 0.9
    m = grid_mesh(*[np.linspace(-1, 1, 4)] * 3)
    cam = Camera(projection="orthographic", eye=[0.1, 0.2, 0.35], target=[0.6, 0.4, -2.0], up=[0, 1, 0.2],
                 ortho_height=2.5, width_px=17, height_px=13)
    img = render_reference(m, const_tf(rho), cam)
    o, d = cam.rays()
    chord = box_chord(o, d, -np.ones(3), np.ones(3))
    assert (chord > 0).sum() > 50
    np.testing.assert_allclose(img[..., 3], -np.expm1(-rho * chord), rtol=0, atol=1e-12)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_mesh_behind_the_camera_renders_transparent(projection):
    m = grid_mesh(*[np.linspace(-1, 1, 3)] * 3)
    cam = Camera(projection=projection, eye=[0, 0, 3], target=[0, 0, 6], width_px=8, height_px=8)
    img = render_reference(m, const_tf(2.0), cam)
    assert (img == 0).all()


# -- plumbing -----------------------------------------------------------------------------------------
def test_chunking_and_bands_do_not_change_the_image():
    s = lambda p: np.sin(2 * p[:, 0]) + p[:, 1] * p[:, 2]  # noqa: E731
    m = grid_mesh(*[np.linspace(-1, 1, 5)] * 3, scalar=s)
    rng = np.random.default_rng(3)
    K = 32
    tf = TransferFunction(np.column_stack([np.linspace(-1.5, 1.5, K), rng.uniform(0, 1, (K, 3)),
                                           rng.uniform(0, 4, K)]), "emission_density")
    cam = Camera(eye=[2.5, 1.5, 3.0], target=[0, 0, 0], fov_y_deg=40, width_px=23, height_px=19)
    calls = []
    st = {}
    a = render_reference(m, tf, cam, stats=st)
    b = render_reference(m, tf, cam, chunk_tets=7, band_pairs=500, progress=calls.append)
    np.testing.assert_allclose(a, b, rtol=1e-14, atol=0)
    assert calls and calls[-1] == pytest.approx(1.0) and all(x <= y for x, y in zip(calls, calls[1:]))
    assert st["n_segments"] > 0 and st["n_pairs"] >= st["n_segments"]
    assert a.dtype == np.float64 and a.shape == (19, 23, 4) and np.isfinite(a).all()


def test_composite_front_to_back_sorts_by_depth():
    rgb = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    tau = np.array([1.0, 0.5, 2.0])
    img = composite_front_to_back(np.array([0, 0, 1]), np.array([2.0, 1.0, 0.0]), rgb, tau, 3)
    np.testing.assert_allclose(img[0, :3], [1.0, 0.0, math.exp(-0.5)], rtol=1e-15)
    np.testing.assert_allclose(img[0, 3], -math.expm1(-1.5), rtol=1e-15)
    np.testing.assert_allclose(img[1], [0, 1, 0, -math.expm1(-2.0)], rtol=1e-15)
    assert (img[2] == 0).all()


def test_segmented_cumsum_has_no_cancellation_across_groups():
    x = np.array([1e300, 1e20, 1e-3, 2e-3, 4e-3, 5.0])
    g = np.array([0, 0, 1, 1, 1, 2])
    out = segmented_exclusive_cumsum(x, g)
    assert out.tolist() == [0.0, 1e300, 0.0, 1e-3, 3e-3, 0.0]
