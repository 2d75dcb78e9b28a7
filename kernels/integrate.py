"""Exact ray-segment integration for piecewise-linear transfer functions (``@wp.func`` only).

Along a segment of length ``L`` the scalar is linear from ``sf`` (front) to ``sb`` (back). The
segment is split at every transfer-function control point it crosses; on each piece colour ``c`` and
extinction ``rho`` are linear in the ray parameter, the optical depth is exact
(``tau = h (rho0 + rho1) / 2``) and the radiance

* ``color_extinction`` (model 0):  ``int_0^h c(t) rho(t) exp(-int_0^t rho) dt``
* ``emission_density`` (model 1):  ``int_0^h c(t) exp(-int_0^t rho) dt``

is integrated by 4-point Gauss-Legendre on sub-steps of optical depth <= 1 (error ~1e-9 relative,
far below float32). Sub-steps stop once the transmittance inside the piece is below ``1e-10``, so
stiff extinction (depth 1e4 in one cell) costs ~25 sub-steps, not 1e4. An optically thin piece
(depth ``T <= 0.05``, most pieces of a cell walk) is integrated through scalar moments of the
transmittance ``M0 = int_0^1 exp(-tau(x)) dx`` (and ``M1 = int_0^1 x exp(-tau(x)) dx``) by 3-point
Gauss-Legendre, exact up to degree 5 in ``x``: by parts, the ``color_extinction`` radiance is
``c1 (M0 - exp(-T)) + c0 (1 - M0)`` (colours ``c0``, ``c1`` at the piece's ends; both terms >= 0, each
factor from a Taylor polynomial of ``1 - exp(-x)`` without cancellation), the ``emission_density`` one
``h ((M0 - M1) c0 + M1 c1)``. A piece of constant extinction (both ends' extinction equal: an opaque
or constant-density transfer function) deeper than that has the closed form ``c0 A + c1 B``
(:func:`constant_weights`; over the extinction for ``emission_density``): one ``exp`` or two
polynomials instead of four ``exp`` s per sub-step. The improved presets decide that constancy at the transfer
function (:func:`integrate_piece_flat`: both control points of the piece's interval of equal extinction), where
the ends' interpolated extinctions may round an ulp apart. A zero-length segment contributes nothing.
"""

import warp as wp

from .tf import tf_eval_upper, tf_first_break, tf_first_break_upper, tf_next_break, tf_upper

wp.set_module_options({"enable_backward": False, "fuse_fp": False})  # same roundings on CPU and CUDA

# 4-point Gauss-Legendre on [0, 1]
GL_X0 = wp.constant(0.0694318442029737)
GL_X1 = wp.constant(0.3300094782075719)
GL_X2 = wp.constant(0.6699905217924281)
GL_X3 = wp.constant(0.9305681557970263)
GL_W0 = wp.constant(0.1739274225687269)
GL_W1 = wp.constant(0.3260725774312731)
T_CUTOFF = wp.constant(1.0e-10)
# 3-point Gauss-Legendre on [0, 1] for optically thin pieces
GL3_X0 = wp.constant(0.1127016653792583)
GL3_X2 = wp.constant(0.8872983346207417)
GL3_W0 = wp.constant(0.2777777777777778)
GL3_W1 = wp.constant(0.4444444444444444)
THIN_DEPTH = wp.constant(0.05)


@wp.func
def exp_neg(x: float) -> float:
    """``exp(-x)`` for ``x >= 0``; below :data:`THIN_DEPTH` by its degree-4 Taylor polynomial
    (truncation <= x^5/120 = 2.6e-9 relative, below float32 rounding) -- the walkers' hot path."""
    if x <= THIN_DEPTH:
        return exp_neg_thin(x)
    return wp.exp(-x)


@wp.func
def exp_neg_thin(x: float) -> float:
    """:func:`exp_neg` for ``0 <= x <=`` :data:`THIN_DEPTH` (no branch: the lane walk's form)."""
    # 1 - x + x^2/2 - x^3/6 + x^4/24 in Estrin's form: three dependent multiplies instead of eight
    x2 = x * x
    return (1.0 - x) + x2 * ((0.5 - x * (1.0 / 6.0)) + x2 * (1.0 / 24.0))


@wp.func
def one_minus_exp_neg_thin(x: float) -> float:
    """``1 - exp(-x)`` for ``0 <= x <=`` :data:`THIN_DEPTH` by its degree-5 Taylor polynomial (no
    cancellation; truncation x^6/720: <= 4e-10 relative)."""
    # x - x^2/2 + x^3/6 - x^4/24 + x^5/120 in Estrin's form (short dependency chains)
    x2 = x * x
    return (x - 0.5 * x2) + (x2 * x) * (((1.0 / 6.0) - x * (1.0 / 24.0)) + x2 * (1.0 / 120.0))


@wp.func
def constant_weights(a: float):
    """The weights ``(A, B)`` of a piece's end colours ``c0``, ``c1`` under constant extinction, optical depth
    ``a > 0``: ``A = int_0^1 (1 - x) a e^(-a x) dx = 1 - M0``, ``B = int_0^1 x a e^(-a x) dx = M0 - e^(-a)``,
    ``M0 = (1 - e^(-a)) / a``; the ``color_extinction`` radiance is ``c0 A + c1 B``, the ``emission_density``
    one that over the extinction. For ``a < 1`` by their Taylor series ``A = a sum_n (-a)^n / (n + 2)!``
    (n <= 9) and ``B = a sum_n (n + 1) (-a)^n / (n + 2)!`` (n <= 10) in Estrin's form (short dependency
    chains; truncation < 1e-8 relative at ``a = 1``), where the closed form would cancel; from ``a >= 1`` on
    the closed form (cancellation at most a factor 2.4)."""
    if a < 1.0:
        a2 = a * a
        a4 = a2 * a2
        a8 = a4 * a4
        qa = ((0.5 - a * (1.0 / 6.0)) + a2 * ((1.0 / 24.0) - a * (1.0 / 120.0))) \
            + a4 * (((1.0 / 720.0) - a * (1.0 / 5040.0)) + a2 * ((1.0 / 40320.0) - a * (1.0 / 362880.0))) \
            + a8 * ((1.0 / 3628800.0) - a * (1.0 / 39916800.0))
        qb = ((0.5 - a * (1.0 / 3.0)) + a2 * ((1.0 / 8.0) - a * (1.0 / 30.0))) \
            + a4 * (((1.0 / 144.0) - a * (1.0 / 840.0)) + a2 * ((1.0 / 5760.0) - a * (1.0 / 45360.0))) \
            + a8 * (((1.0 / 403200.0) - a * (1.0 / 3991680.0)) + a2 * (1.0 / 43545600.0))
        return a * qa, a * qb
    e = wp.exp(-a)
    m0 = (1.0 - e) / a
    return 1.0 - m0, m0 - e


@wp.func
def _piece_term(x: float, a: float, b: float, r0: float, dr: float,
                c0: wp.vec3, dc: wp.vec3, model: int) -> wp.vec3:
    # integrand at local parameter x of the piece (0..1); tau(x) = a x + b x^2 / 2
    tau = a * x + 0.5 * b * x * x
    w = exp_neg(tau)
    c = c0 + dc * x
    if model == 0:
        w = w * (r0 + dr * x)
    return c * w


@wp.func
def integrate_piece(h: float, front: wp.vec4, back: wp.vec4, model: int) -> wp.vec4:
    """Radiance (xyz) and optical depth (w) of a piece of length ``h`` with linear TF values."""
    if h <= 0.0:
        return wp.vec4(0.0, 0.0, 0.0, 0.0)
    c0 = wp.vec3(front[0], front[1], front[2])
    r0 = front[3]
    dr = back[3] - r0
    a = h * r0  # depth rate at x = 0 (per unit x)
    b = h * dr  # its change over the piece
    tau_total = 0.5 * h * (front[3] + back[3])
    if tau_total <= THIN_DEPTH:
        # optically thin piece: scalar moments of the transmittance by 3-point Gauss-Legendre at the
        # depths x0, x1, x2 = tau(GL3_X0), tau(1/2), tau(GL3_X2) (exact up to degree 5 in x)
        # (two products summed: short dependency chains)
        x0 = GL3_X0 * a + (0.5 * GL3_X0 * GL3_X0) * b
        x1 = 0.5 * a + 0.125 * b
        x2 = GL3_X2 * a + (0.5 * GL3_X2 * GL3_X2) * b
        c1 = wp.vec3(back[0], back[1], back[2])
        if model == 0:
            # int c tau' e^-tau = c1 (1 - e^-T) - (c1 - c0) (1 - M0) = c1 (M0 - e^-T) + c0 (1 - M0),
            # M0 = int_0^1 e^-tau(x) dx (integration by parts); both terms >= 0
            om = GL3_W0 * (one_minus_exp_neg_thin(x0) + one_minus_exp_neg_thin(x2)) \
                + GL3_W1 * one_minus_exp_neg_thin(x1)  # 1 - M0
            r = c1 * (one_minus_exp_neg_thin(tau_total) - om) + c0 * om
            return wp.vec4(r[0], r[1], r[2], tau_total)
        # emission density: h int (c0 + dc x) e^-tau = h (c0 M0 + (c1 - c0) M1), M1 = int x e^-tau
        w0 = exp_neg(x0) * GL3_W0
        w1 = exp_neg(x1) * GL3_W1
        w2 = exp_neg(x2) * GL3_W0
        m0 = w0 + w1 + w2
        m1 = GL3_X0 * w0 + 0.5 * w1 + GL3_X2 * w2
        r = (c0 * (m0 - m1) + c1 * m1) * h
        return wp.vec4(r[0], r[1], r[2], tau_total)
    if b == 0.0:
        # constant extinction over the piece (an opaque or constant-density TF): closed form, one exp at most
        wa, wb = constant_weights(a)
        r = c0 * wa + wp.vec3(back[0], back[1], back[2]) * wb
        if model == 1:
            r = r / r0  # (r0 > 0: a = h r0 > THIN_DEPTH)
        return wp.vec4(r[0], r[1], r[2], tau_total)
    dc = wp.vec3(back[0], back[1], back[2]) - c0
    acc = wp.vec3(0.0, 0.0, 0.0)
    x = float(0.0)
    while x < 1.0:
        # step width with optical depth <= 1 over [x, x + dx]: rate(x) dx + b dx^2 / 2 = 1
        rate = a + b * x
        dx = float(1.0)
        if b > 0.0:
            dx = 2.0 / (rate + wp.sqrt(rate * rate + 2.0 * b))
        elif rate > 1.0:
            dx = 1.0 / rate
        dx = wp.min(dx, 1.0 - x)
        if dx <= 0.0:
            break
        s = _piece_term(x + GL_X0 * dx, a, b, r0, dr, c0, dc, model) * GL_W0
        s += _piece_term(x + GL_X1 * dx, a, b, r0, dr, c0, dc, model) * GL_W1
        s += _piece_term(x + GL_X2 * dx, a, b, r0, dr, c0, dc, model) * GL_W1
        s += _piece_term(x + GL_X3 * dx, a, b, r0, dr, c0, dc, model) * GL_W0
        acc += s * (dx * h)
        x = x + dx
        if x < 1.0:  # (the piece's end ends the loop anyway: no transmittance test there)
            if wp.exp(-(a * x + 0.5 * b * x * x)) < T_CUTOFF:
                break
    return wp.vec4(acc[0], acc[1], acc[2], tau_total)


@wp.func
def flat_extinction(k: int, tf_v: wp.array(dtype=wp.vec4)) -> float:
    """The extinction of TF interval ``k`` (``tf_upper``'s index) where it is exactly constant: both its control
    points' extinctions equal (the interpolated values inside it may round apart by an ulp); -1 otherwise (and at
    the clamped ends, whose values are not interpolated)."""
    n = tf_v.shape[0]
    if k > 0 and k < n:
        r = tf_v[k][3]
        if tf_v[k - 1][3] == r:
            return r
    return -1.0


@wp.func
def integrate_piece_flat(h: float, front: wp.vec4, back: wp.vec4, rho: float, model: int) -> wp.vec4:
    """:func:`integrate_piece` for a piece inside one TF interval of extinction ``rho``
    (:func:`flat_extinction`; < 0: not known constant): an optically thick piece of exactly constant extinction
    takes the closed form (:func:`constant_weights` of ``h rho``) even where its ends' interpolated extinctions
    round apart, not the sub-stepped quadrature of a sloped piece. Optical depth and the thin pieces are
    :func:`integrate_piece`'s (the improved presets' walks and draws; the faithful ones call that directly)."""
    if rho > 0.0 and h > 0.0:
        tau_total = 0.5 * h * (front[3] + back[3])
        if not (tau_total <= THIN_DEPTH):
            wa, wb = constant_weights(h * rho)
            r = wp.vec3(front[0], front[1], front[2]) * wa + wp.vec3(back[0], back[1], back[2]) * wb
            if model == 1:
                r = r / rho
            return wp.vec4(r[0], r[1], r[2], tau_total)
    return integrate_piece(h, front, back, model)


@wp.func
def attenuated(tau: float, p: wp.vec4) -> wp.vec3:
    """A piece's radiance ``p.xyz`` behind optical depth ``tau`` (``exp(-0) = 1`` without the call:
    most segments are one piece)."""
    if tau == 0.0:
        return wp.vec3(p[0], p[1], p[2])
    return wp.exp(-tau) * wp.vec3(p[0], p[1], p[2])


@wp.func
def integrate_segment_tf(sf: float, sb: float, vf: wp.vec4, vb: wp.vec4, length: float,
                         tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int) -> wp.vec4:
    """:func:`integrate_segment` with the TF values at both ends given (``vf = tf(sf)``,
    ``vb = tf(sb)``), so a walker that carries the exit value into the next cell evaluates the TF
    once per face."""
    if not (length > 0.0):
        return wp.vec4(0.0, 0.0, 0.0, 0.0)
    return integrate_pieces(sf, sb, vf, vb, tf_first_break(sf, sb, tf_s), length, tf_s, tf_v, model)


@wp.func
def integrate_pieces(sf: float, sb: float, vf: wp.vec4, vb: wp.vec4, k_first: int, length: float,
                     tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int) -> wp.vec4:
    """:func:`integrate_segment_tf` given its first crossed control point ``k_first``
    (:func:`~warpvol.kernels.tf.tf_first_break`; -1: none) and ``length > 0``."""
    ds = sb - sf
    rgb = wp.vec3(0.0, 0.0, 0.0)
    tau = float(0.0)
    u0 = float(0.0)
    v0 = vf
    k = k_first
    while k >= 0:
        u1 = (tf_s[k] - sf) / ds
        v1 = tf_v[k]
        p = integrate_piece((u1 - u0) * length, v0, v1, model)
        rgb += attenuated(tau, p)
        tau += p[3]
        u0 = u1
        v0 = v1
        k = tf_next_break(k, sf, sb, tf_s)
    v1 = vb
    p = integrate_piece((1.0 - u0) * length, v0, v1, model)
    rgb += attenuated(tau, p)
    tau += p[3]
    return wp.vec4(rgb[0], rgb[1], rgb[2], tau)


@wp.func
def integrate_segment(sf: float, sb: float, length: float, tf_s: wp.array(dtype=float),
                      tf_v: wp.array(dtype=wp.vec4), model: int) -> wp.vec4:
    """Radiance (xyz) and optical depth (w) of one ray segment, front-to-back over TF pieces."""
    if not (length > 0.0):
        return wp.vec4(0.0, 0.0, 0.0, 0.0)
    kf = tf_upper(sf, tf_s)  # one search per end: the TF value and (at sf) the first crossed control point
    return integrate_pieces(sf, sb, tf_eval_upper(sf, kf, tf_s, tf_v), tf_eval_upper(sb, tf_upper(sb, tf_s), tf_s, tf_v),
                            tf_first_break_upper(kf, sf, sb, tf_s), length, tf_s, tf_v, model)


@wp.kernel
def integrate_segments_kernel(sf: wp.array(dtype=float), sb: wp.array(dtype=float),
                              length: wp.array(dtype=float), tf_s: wp.array(dtype=float),
                              tf_v: wp.array(dtype=wp.vec4), model: int, out: wp.array(dtype=wp.vec4)):
    """Batch form of :func:`integrate_segment` (tests and table builders)."""
    i = wp.tid()
    out[i] = integrate_segment(sf[i], sb[i], length[i], tf_s, tf_v, model)
