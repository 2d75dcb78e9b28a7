"""Warp kernels of the pre-integration table builders (host steps of the emulated pipelines).

Axis conventions: a scalar axis node is a normalised value ``x`` in [0, 1] (passed as an array of
node values, so any axis kind works); the physical scalar is ``smin + x * srange``. Thickness nodes
are passed in world units. 3D outputs are ``out[l, sb, sf]`` (texture order), 2D ``out[sb, sf]``.

Exact integrals reuse :func:`warpvol.kernels.integrate.integrate_segment` (one float32 segment
integrator for the whole project: the ray caster and the table builders agree by construction).
"""

import warp as wp

from .integrate import integrate_piece, integrate_segment
from .tf import tf_eval, tf_first_break, tf_lower, tf_next_break, tf_upper

# fuse_fp off: the hardware builders inline the blending unit and formats, whose results must not
# depend on FMA contraction (CPU and CUDA give the same codes)
wp.set_module_options({"enable_backward": False, "fuse_fp": False})

vec7 = wp.types.vector(length=7, dtype=wp.float32)


# ------------------------------------------------------------------------------------------------
# shared math
# ------------------------------------------------------------------------------------------------


@wp.func
def one_minus_exp(x: float) -> float:
    """``1 - exp(-x)`` without cancellation for small ``x`` (float32 has no expm1)."""
    if x < 1.0e-3:
        return x * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x / 24.0)))
    return 1.0 - wp.exp(-x)


@wp.func
def over(front: wp.vec4, back: wp.vec4) -> wp.vec4:
    """Front-to-back composite of two (premultiplied rgb, alpha) segments: front over back."""
    t = 1.0 - front[3]
    return wp.vec4(front[0] + t * back[0], front[1] + t * back[1], front[2] + t * back[2],
                   1.0 - t * (1.0 - back[3]))


@wp.func
def lerp_row(tab: wp.array2d(dtype=wp.vec4), row: int, x: float) -> wp.vec4:
    """Linear interpolation along a row (x direction, continuous texel index, clamp to edge)."""
    n = tab.shape[1]
    t = wp.clamp(x, 0.0, float(n - 1))
    i0 = wp.min(int(wp.floor(t)), wp.max(n - 2, 0))
    i1 = wp.min(i0 + 1, n - 1)
    f = t - float(i0)
    return tab[row, i0] * (1.0 - f) + tab[row, i1] * f


@wp.func
def lerp_col(tab: wp.array2d(dtype=wp.vec4), col: int, y: float) -> wp.vec4:
    """Linear interpolation along a column (y direction, continuous texel index, clamp to edge)."""
    n = tab.shape[0]
    t = wp.clamp(y, 0.0, float(n - 1))
    i0 = wp.min(int(wp.floor(t)), wp.max(n - 2, 0))
    i1 = wp.min(i0 + 1, n - 1)
    f = t - float(i0)
    return tab[i0, col] * (1.0 - f) + tab[i1, col] * f


@wp.func
def axis_index(x: float, a: float, b: float) -> float:
    """Continuous texel index of normalised value x on a linear axis: ``a * x + b``."""
    return a * wp.clamp(x, 0.0, 1.0) + b


@wp.func
def _piece_moments(h: float, v0: wp.vec4, v1: wp.vec4) -> vec7:
    """Exact ``(int c rho [3], int rho, int c [3])`` of one piece of length h with linear values."""
    c0 = wp.vec3(v0[0], v0[1], v0[2])
    c1 = wp.vec3(v1[0], v1[1], v1[2])
    cr = h * (c0 * (v0[3] / 3.0 + v1[3] / 6.0) + c1 * (v0[3] / 6.0 + v1[3] / 3.0))
    cm = 0.5 * h * (c0 + c1)
    return vec7(cr[0], cr[1], cr[2], 0.5 * h * (v0[3] + v1[3]), cm[0], cm[1], cm[2])


@wp.func
def segment_moments(sf: float, sb: float, tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4)) -> vec7:
    """Exact ``(int c rho [rgb], int rho, int c [rgb])`` over t in [0, 1] along ``sf + t (sb - sf)``.

    Products of two linear functions per TF piece are integrated in closed form; ``sf = sb`` is one
    piece of unit length (no division).
    """
    ds = sb - sf
    u0 = float(0.0)
    v0 = tf_eval(sf, tf_s, tf_v)
    acc = vec7()
    k = tf_first_break(sf, sb, tf_s)
    while k >= 0:
        u1 = (tf_s[k] - sf) / ds
        v1 = tf_v[k]
        acc += _piece_moments(u1 - u0, v0, v1)
        u0 = u1
        v0 = v1
        k = tf_next_break(k, sf, sb, tf_s)
    acc += _piece_moments(1.0 - u0, v0, tf_eval(sb, tf_s, tf_v))
    return acc


# ------------------------------------------------------------------------------------------------
# 1. exact 3D table (piecewise-linear TF integrated exactly) and Roettger's software table
# ------------------------------------------------------------------------------------------------


@wp.kernel
def exact_table3d(xf: wp.array(dtype=float), xb: wp.array(dtype=float), lengths: wp.array(dtype=float),
                  smin: float, srange: float, tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4),
                  model: int, out: wp.array3d(dtype=wp.vec4)):
    """``out[l, sb, sf] = (C, alpha)`` exactly (float32) for a piecewise-linear TF."""
    k, j, i = wp.tid()
    sf = smin + srange * xf[i]
    sb = smin + srange * xb[j]
    r = integrate_segment(sf, sb, lengths[k], tf_s, tf_v, model)
    out[k, j, i] = wp.vec4(r[0], r[1], r[2], one_minus_exp(r[3]))


@wp.kernel
def roettger_sw_table3d(xf: wp.array(dtype=float), xb: wp.array(dtype=float), lengths: wp.array(dtype=float),
                        smin: float, srange: float, tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4),
                        model: int, m: float, o: float, n_min: int, stein: int, out: wp.array3d(dtype=wp.vec4)):
    """Roettger & Ertl 2002 eqs. 5-7: n >= o m |sf - sb| samples walking from the back.

    ``C_{i+1} = C_i exp(-(l/n) rho(w_i)) + E(w_i)``, ``theta_{i+1} = theta_i exp(-(l/n) rho(w_i))``
    with ``w_i = sb + i/(n-1) (sf - sb)``; E = ``(l/n) kappa`` for emission density (eq. 6 as printed;
    ``stein``: Stein et al.'s step ``kappa (1 - exp(-(l/n) rho)) / rho``) or ``kappa (1 - exp(-(l/n) rho))``
    for colour times extinction (the slab's associated colour).
    """
    k, j, i = wp.tid()
    xfi = xf[i]
    xbj = xb[j]
    l = lengths[k]
    d = wp.abs(xfi - xbj)
    nf = wp.ceil(o * m * d)
    nf = wp.clamp(nf, float(n_min), 1.0e6)
    n = int(nf)
    h = l / nf
    c = wp.vec3(0.0, 0.0, 0.0)
    theta = float(1.0)
    sf = smin + srange * xfi
    sb = smin + srange * xbj
    for s in range(n):
        w = sb
        if n > 1:
            w = sb + (float(s) / float(n - 1)) * (sf - sb)
        v = tf_eval(w, tf_s, tf_v)
        e = wp.exp(-h * v[3])
        kap = wp.vec3(v[0], v[1], v[2])
        if model == 1:
            # eq. 6 as printed: h kappa (first order; unbounded for a thick cell integrated in one step);
            # ``stein``: Stein et al.'s constant-chromaticity step kappa (1 - exp(-h rho)) / rho
            x = h * v[3]
            f = h
            if stein != 0 and x > 1.0e-6:
                f = one_minus_exp(x) / v[3]
            c = c * e + f * kap
        else:
            c = c * e + kap * one_minus_exp(h * v[3])
        theta = theta * e
    out[k, j, i] = wp.vec4(c[0], c[1], c[2], 1.0 - theta)


# ------------------------------------------------------------------------------------------------
# 4. incremental pre-integration (Weiler 2003; Kraus 2004's doubling variant)
# ------------------------------------------------------------------------------------------------


@wp.kernel
def incremental_step(front: wp.array2d(dtype=wp.vec4), back: wp.array2d(dtype=wp.vec4),
                     x: wp.array(dtype=float), frac: float, ia: float, ib: float,
                     out: wp.array2d(dtype=wp.vec4)):
    """``out(sf, sb) = front(sf, s') over back(s', sb)``, ``s' = sf + frac (sb - sf)``.

    ``front`` is the slice of the front piece's length, ``back`` the slice of the rest; both are
    bilinearly sampled (linear along the one off-node coordinate). ``ia, ib``: index = ia x + ib.
    """
    j, i = wp.tid()
    sf = x[i]
    sb = x[j]
    sm = sf + frac * (sb - sf)
    t = axis_index(sm, ia, ib)
    f = lerp_col(front, i, t)
    b = lerp_row(back, j, t)
    out[j, i] = over(f, b)


# ------------------------------------------------------------------------------------------------
# 5. cylindrical planes (Roettger & Ertl 2002 §4)
# ------------------------------------------------------------------------------------------------


@wp.func
def cyl_to_table(a: float, s: float, t: float) -> wp.vec3:
    """Roettger & Ertl 2002 eq. 9: ``(alpha, s, t) -> (sf, sb, l)`` (normalised)."""
    if a <= 0.25:
        return wp.vec3(t + s, t, 4.0 * a * s)
    if a <= 0.5:
        return wp.vec3(t + 4.0 * (0.5 - a) * s, t, s)
    if a <= 0.75:
        return wp.vec3(t - 4.0 * (a - 0.5) * s, t, s)
    return wp.vec3(t - s, t, 4.0 * (1.0 - a) * s)


@wp.func
def table_to_cyl(sf: float, sb: float, l: float) -> wp.vec3:
    """Roettger & Ertl 2002 eq. 10, ``(sf, sb, l) -> (alpha, s, t)``; one division, never by zero.

    The front diagonal ``sf = sb, l = 0`` (silhouette) maps to ``(0, 0, sb)``.
    """
    d = sf - sb
    if d >= 0.0:
        if l <= d:
            if d <= 0.0:
                return wp.vec3(0.0, 0.0, sb)
            return wp.vec3(l / (4.0 * d), d, sb)
        return wp.vec3(0.5 - d / (4.0 * l), l, sb)
    if l >= -d:
        return wp.vec3(0.5 - d / (4.0 * l), l, sb)
    return wp.vec3(1.0 + l / (4.0 * d), -d, sb)


@wp.func
def trilinear(tab: wp.array3d(dtype=wp.vec4), fi: float, bi: float, li: float) -> wp.vec4:
    """Trilinear filtering of ``tab[l, sb, sf]`` at continuous texel indices (clamp to edge)."""
    nl = tab.shape[0]
    nb = tab.shape[1]
    nf = tab.shape[2]
    tf_ = wp.clamp(fi, 0.0, float(nf - 1))
    tb = wp.clamp(bi, 0.0, float(nb - 1))
    tl = wp.clamp(li, 0.0, float(nl - 1))
    f0 = wp.min(int(wp.floor(tf_)), wp.max(nf - 2, 0))
    b0 = wp.min(int(wp.floor(tb)), wp.max(nb - 2, 0))
    l0 = wp.min(int(wp.floor(tl)), wp.max(nl - 2, 0))
    f1 = wp.min(f0 + 1, nf - 1)
    b1 = wp.min(b0 + 1, nb - 1)
    l1 = wp.min(l0 + 1, nl - 1)
    wf = tf_ - float(f0)
    wb = tb - float(b0)
    wl = tl - float(l0)
    c0 = (tab[l0, b0, f0] * (1.0 - wf) + tab[l0, b0, f1] * wf) * (1.0 - wb) + \
         (tab[l0, b1, f0] * (1.0 - wf) + tab[l0, b1, f1] * wf) * wb
    c1 = (tab[l1, b0, f0] * (1.0 - wf) + tab[l1, b0, f1] * wf) * (1.0 - wb) + \
         (tab[l1, b1, f0] * (1.0 - wf) + tab[l1, b1, f1] * wf) * wb
    return c0 * (1.0 - wl) + c1 * wl


@wp.kernel
def cylindrical_resample(tab: wp.array3d(dtype=wp.vec4), alphas: wp.array(dtype=float),
                         xs: wp.array(dtype=float), xt: wp.array(dtype=float),
                         fa: float, fb: float, ba: float, bb: float, la: float, lb: float,
                         out: wp.array3d(dtype=wp.vec4)):
    """``out[plane, t, s]`` = trilinear resample of the 3D table at ``f(alpha, s, t)`` (eq. 9)."""
    p, j, i = wp.tid()
    q = cyl_to_table(alphas[p], xs[i], xt[j])
    out[p, j, i] = trilinear(tab, axis_index(q[0], fa, fb), axis_index(q[1], ba, bb), axis_index(q[2], la, lb))


@wp.kernel
def cylindrical_exact(alphas: wp.array(dtype=float), xs: wp.array(dtype=float), xt: wp.array(dtype=float),
                      lmax: float, smin: float, srange: float, tf_s: wp.array(dtype=float),
                      tf_v: wp.array(dtype=wp.vec4), model: int, out: wp.array3d(dtype=wp.vec4)):
    """``out[plane, t, s]`` = exact integral at ``f(alpha, s, t)`` (clamped to the unit cube)."""
    p, j, i = wp.tid()
    q = cyl_to_table(alphas[p], xs[i], xt[j])
    sf = smin + srange * wp.clamp(q[0], 0.0, 1.0)
    sb = smin + srange * wp.clamp(q[1], 0.0, 1.0)
    r = integrate_segment(sf, sb, lmax * wp.clamp(q[2], 0.0, 1.0), tf_s, tf_v, model)
    out[p, j, i] = wp.vec4(r[0], r[1], r[2], one_minus_exp(r[3]))


@wp.func
def trilinear_plane(planes: wp.array3d(dtype=wp.vec4), p: int, si: float, ti: float) -> wp.vec4:
    ns = planes.shape[2]
    nt = planes.shape[1]
    x = wp.clamp(si, 0.0, float(ns - 1))
    y = wp.clamp(ti, 0.0, float(nt - 1))
    i0 = wp.min(int(wp.floor(x)), wp.max(ns - 2, 0))
    j0 = wp.min(int(wp.floor(y)), wp.max(nt - 2, 0))
    i1 = wp.min(i0 + 1, ns - 1)
    j1 = wp.min(j0 + 1, nt - 1)
    fx = x - float(i0)
    fy = y - float(j0)
    return (planes[p, j0, i0] * (1.0 - fx) + planes[p, j0, i1] * fx) * (1.0 - fy) + \
           (planes[p, j1, i0] * (1.0 - fx) + planes[p, j1, i1] * fx) * fy


@wp.kernel
def cylindrical_lookup(planes: wp.array3d(dtype=wp.vec4), sf: wp.array(dtype=float), sb: wp.array(dtype=float),
                       l: wp.array(dtype=float), sa: float, sb_: float, ta: float, tb: float,
                       out: wp.array(dtype=wp.vec4)):
    """Reconstruction: inverse mapping, then linear blend of the two nearest planes (each bilinear).

    Planes sit at ``alpha_p = p / (P - 1)``; out-of-cube ``(s, t)`` clamp to the plane's edge.
    """
    k = wp.tid()
    c = table_to_cyl(sf[k], sb[k], l[k])
    np_ = planes.shape[0]
    pa = wp.clamp(c[0], 0.0, 1.0) * float(np_ - 1)
    p0 = wp.min(int(wp.floor(pa)), wp.max(np_ - 2, 0))
    p1 = wp.min(p0 + 1, np_ - 1)
    w = pa - float(p0)
    si = axis_index(c[1], sa, sb_)
    ti = axis_index(c[2], ta, tb)
    v0 = trilinear_plane(planes, p0, si, ti)
    v1 = trilinear_plane(planes, p1, si, ti)
    out[k] = v0 * (1.0 - w) + v1 * w


from .formats import unorm_quantize  # noqa: E402
from .texture import Atlas, atlas_sample  # noqa: E402


@wp.func
def cyl_planes_sample(atlas: Atlas, a: float, u: float, v: float, weight_bits: int, nearest: int) -> wp.vec4:
    """Colour of the α-planes at ``α = a`` and in-tile ``(u, v)``: the planes sit at ``p / (P - 1)``.

    ``nearest = 0``: the two nearest planes (two texture units), blended linearly in ``α`` with the
    weight ``w`` held as an unsigned ``weight_bits``-bit value (the 8-bit colour the combiner
    interpolates with: ``t0 (1 - w) + t1 w``, ``1 - w`` by the combiner's input inversion, exact for
    the code); ``weight_bits = 0``: ``w`` in fp32. ``nearest = 1``: one texture, the nearest plane
    (ties round up), no blend (the SGI path of Roettger & Ertl 2002 Fig. 8).
    """
    np_ = atlas.ntiles
    pa = wp.clamp(a, 0.0, 1.0) * float(np_ - 1)
    if nearest != 0:
        return atlas_sample(atlas, wp.clamp(int(wp.floor(pa + 0.5)), 0, np_ - 1), u, v)
    p0 = wp.min(int(wp.floor(pa)), wp.max(np_ - 2, 0))
    p1 = wp.min(p0 + 1, np_ - 1)
    w = pa - float(p0)
    if weight_bits > 0:
        w = unorm_quantize(w, weight_bits, 0, 0)
    return atlas_sample(atlas, p0, u, v) * (1.0 - w) + atlas_sample(atlas, p1, u, v) * w


@wp.kernel
def cylindrical_lookup_tex(atlas: Atlas, sf: wp.array(dtype=float), sb: wp.array(dtype=float),
                           l: wp.array(dtype=float), ua: float, ub: float, va: float, vb: float,
                           weight_bits: int, nearest: int, out: wp.array(dtype=wp.vec4)):
    """Reconstruction as the 2002 hardware computed it: inverse mapping (eq. 10, one division), then
    :func:`cyl_planes_sample` (each plane sampled by the texture unit: atlas tile = plane, its filter,
    filter-weight quantisation and texel-centre convention).

    ``(ua, ub)``, ``(va, vb)`` map normalised ``s``, ``t`` to in-tile texture coordinates
    (``u = ua * clamp(s, 0, 1) + ub``: the planes' axis kind, ``centred`` 1, 0; ``endpoint``
    ``(n - 1)/n``, ``0.5/n``), so texel centres coincide with the planes' nodes as in
    :func:`cylindrical_lookup`.
    """
    k = wp.tid()
    c = table_to_cyl(sf[k], sb[k], l[k])
    u = ua * wp.clamp(c[1], 0.0, 1.0) + ub
    v = va * wp.clamp(c[2], 0.0, 1.0) + vb
    out[k] = cyl_planes_sample(atlas, c[0], u, v, weight_bits, nearest)


# ------------------------------------------------------------------------------------------------
# 6. Guthe 2002 2D tables
# ------------------------------------------------------------------------------------------------


@wp.kernel
def guthe_moments(xf: wp.array(dtype=float), xb: wp.array(dtype=float), smin: float, srange: float,
                  tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), out: wp.array2d(dtype=wp.vec4)):
    """``out[sb, sf] = (C0_hat rgb, rho_hat)``: normalised emission at l -> 0 and mean extinction.

    ``C0_hat = int kappa rho / int rho`` (a rho-weighted mean of kappa, so bounded by the colours);
    where ``int rho`` vanishes (no absorption on the whole segment) the limit is undefined and the
    unweighted mean colour is stored instead (it is multiplied by alpha = 0 anyway).
    """
    j, i = wp.tid()
    sf = smin + srange * xf[i]
    sb = smin + srange * xb[j]
    m = segment_moments(sf, sb, tf_s, tf_v)
    r = m[3]
    c = wp.vec3(m[4], m[5], m[6])
    if r > 1.0e-30:
        c = wp.vec3(m[0], m[1], m[2]) / r
    out[j, i] = wp.vec4(c[0], c[1], c[2], r)


# ------------------------------------------------------------------------------------------------
# 7. partial pre-integration psi table (Moreland & Angel 2004)
# ------------------------------------------------------------------------------------------------


@wp.func
def psi_pair(gf: float, gb: float) -> wp.vec2:
    """``(psi, psi1)``: ``psi = int_0^1 T(u) du`` and ``psi1 = int_0^1 u T(u) du`` where
    ``T(u) = exp(-int_0^u (Tf (1-u') + Tb u') du')`` is the transmittance from the segment's front,
    ``T = gamma / (1 - gamma)`` (optical depth of the segment at the front / back extinction).

    gamma >= 1 (infinite depth) gives psi = psi1 = 0, the limit.
    """
    if gf >= 1.0 or gb >= 1.0:
        return wp.vec2(0.0, 0.0)
    g0 = wp.max(gf, 0.0)
    g1 = wp.max(gb, 0.0)
    tf_ = g0 / (1.0 - g0)
    tb = g1 / (1.0 - g1)
    # integrate_piece with h = 1: channel 0 colour 1 -> int T; channel 1 colour u -> int u T
    p = integrate_piece(1.0, wp.vec4(1.0, 0.0, 0.0, tf_), wp.vec4(1.0, 1.0, 0.0, tb), 1)
    return wp.vec2(p[0], p[1])


@wp.kernel
def psi_table(gf: wp.array(dtype=float), gb: wp.array(dtype=float), out: wp.array2d(dtype=wp.vec2)):
    """``out[gb, gf] = (psi, psi1)``."""
    j, i = wp.tid()
    out[j, i] = psi_pair(gf[i], gb[j])


@wp.kernel
def psi_points(gf: wp.array(dtype=float), gb: wp.array(dtype=float), out: wp.array(dtype=wp.vec2)):
    """``out[k] = (psi, psi1)(gf[k], gb[k])``."""
    k = wp.tid()
    out[k] = psi_pair(gf[k], gb[k])


# ------------------------------------------------------------------------------------------------
# 8. iso-crossing table (Espinha & Celes 2005 §4.2)
# ------------------------------------------------------------------------------------------------


@wp.kernel
def iso_table(x: wp.array(dtype=float), iso: wp.array(dtype=float), limit: int, tol: float, edge: float,
              out: wp.array2d(dtype=wp.vec2)):
    """``out[sb, sf] = (s_iso, next_s_iso)``: the first control point at or beyond ``sf`` in the
    direction of ``sb`` and the one after it, ``-1`` where there is none.

    ``limit = 1``: ``s_iso`` must also lie within ``sb + tol`` (``sb - tol`` going down), else -1
    (the paper's "no iso-surface between sf and sb"); ``limit = 0``: direction only.
    ``next_s_iso`` is never limited by ``sb`` (the ray step compares it with ``sb`` itself).
    ``edge > 0`` anchors the search at the texel's edge behind ``sf`` (``sf - edge`` going up,
    ``sf + edge`` going down) instead of its centre, so no control point inside the texel is missed;
    its diagonal texels hold the control point inside the texel (direction unknown there).
    """
    j, i = wp.tid()
    sf = x[i]
    sb = x[j]
    n = iso.shape[0]
    first = float(-1.0)
    nxt = float(-1.0)
    if edge > 0.0 and i == j:
        # sf and sb in one texel: the direction is unknown, so store the control point inside the
        # texel (at most one when control points are more than a texel apart) and no next one; the
        # ray step keeps it only if it lies between sf and sb
        lo = tf_lower(sf - edge, iso)
        if lo < n:
            if iso[lo] <= sf + edge:
                first = iso[lo]
    elif sb > sf:
        lo = tf_lower(sf - edge, iso)  # smallest k with iso[k] >= sf (- edge)
        if lo < n:
            if limit == 0 or iso[lo] <= sb + tol:
                first = iso[lo]
                if lo + 1 < n:
                    nxt = iso[lo + 1]
    elif sb < sf:
        k = tf_upper(sf + edge, iso) - 1  # largest k with iso[k] <= sf (+ edge)
        if k >= 0:
            if limit == 0 or iso[k] >= sb - tol:
                first = iso[k]
                if k - 1 >= 0:
                    nxt = iso[k - 1]
    out[j, i] = wp.vec2(first, nxt)


# ------------------------------------------------------------------------------------------------
# 2./3. hardware pre-integration on the emulated GPU units (texture unit + blending unit)
# ------------------------------------------------------------------------------------------------
# These kernels only *drive* the emulated units: the TF texture is sampled with the texture unit's
# ``tex1d`` and fragments are blended with the blending unit's ``blend`` (its frame-buffer rounding);
# combiner / pixel-shader outputs are rounded with the number formats' ``fmt_quantize`` /
# ``fmt_encode``. One thread = one frame-buffer pixel = one (sf, sb) texel of the slice; the loop over
# the n textured rectangles runs in drawing order, which is what the rasteriser + blender would do
# for full-slice rectangles (every rectangle covers every pixel exactly once).

from .blend import BlendState, blend  # noqa: E402
from .formats import NumFmt, fmt_encode, fmt_quantize, unorm_encode  # noqa: E402
from .texture import Tex1D, tex1d  # noqa: E402


@wp.func
def rect_coord(sf: float, sb: float, s: int, n: int) -> float:
    """Texture coordinate of rectangle ``s`` of ``n`` at slice pixel (sf, sb): ``w_s`` of eq. 5."""
    if n <= 1:
        return sb
    return sb + (float(s) / float(n - 1)) * (sf - sb)


# 4x4 ordered-dither thresholds (Bayer), in 16ths: OpenGL's GL_DITHER on the hardware of the time
BAYER4 = wp.constant(wp.mat44(0.0, 8.0, 2.0, 10.0, 12.0, 4.0, 14.0, 6.0, 3.0, 11.0, 1.0, 9.0, 15.0, 7.0, 13.0, 5.0))


@wp.func
def gl_dither_over(bs: BlendState, src: wp.vec4, dst: wp.vec4, x: int, y: int) -> wp.vec4:
    """GL_DITHER (OpenGL 1.x §4.1.9: dithering after blending) for the blend functions of hardware
    pre-integration, ``src * K + dst * (1 - src.a)`` with K = the constant colour (one-pass) or 1:
    the exact integer blend of :func:`warpvol.kernels.blend.blend_unorm`, but rounded by the 4x4
    ordered-dither threshold of pixel (x, y) instead of to nearest. Fixed-point buffers only."""
    bits = bs.fmt.bits
    n = (1 << bits) - 1
    t = (BAYER4[y % 4, x % 4] + 0.5) / 16.0
    tn = int(t * float(n))
    sa = unorm_encode(wp.clamp(src[3], 0.0, 1.0), bits, 0, 0)
    out = wp.vec4()
    for c in range(4):
        kc = n
        if bs.src_rgb == 10:  # constant_color
            kc = unorm_encode(wp.clamp(bs.constant[c], 0.0, 1.0), bits, 0, 0)
        sc = unorm_encode(wp.clamp(src[c], 0.0, 1.0), bits, 0, 0)
        dc = unorm_encode(dst[c], bits, 0, 0)
        num = sc * kc + dc * (n - sa)
        out[c] = float(wp.min((num + tn) / n, n)) / float(n)
    return out


@wp.kernel
def hw_preint_slice(tex: Tex1D, bs: BlendState, fb: wp.array2d(dtype=wp.vec4), xf: wp.array(dtype=float),
                    xb: wp.array(dtype=float), n_steps: int, n_draw: int, group: int, comb: NumFmt,
                    modulate: wp.vec4, ua: float, ub: float, e_scale: float, gl_dither: int, row0: int):
    """Draw the n rectangles of one slice (Roettger & Ertl 2002 §3) into ``fb[sb, sf]``.

    ``group = 1``: one textured rectangle per step, fragment = texel * ``modulate`` (primary colour).
    ``group = 4``: GeForce3 register combiners: 4 texture units sample 4 consecutive steps, 3 general
    combiner steps fold them back to front, each rounded to ``comb`` (12-bit internal precision), and
    the final combiner outputs ``(C, 1 - theta)`` (the blending unit rounds it to the 8-bit buffer).
    ``e_scale`` != 1 (combiners only): the texture holds kappa and each combiner step computes
    ``(l/n) kappa + (1 - a) C`` with ``e_scale = l/n`` at 12 bits (the texel's 8 bits then carry
    kappa, not the small ``(l/n) kappa``). ``gl_dither``: blends rounded with OpenGL's ordered dither
    (:func:`gl_dither_over`; ``row0``: the block's first row). Only the first ``n_draw`` rectangles are drawn (Fig. 4). The texture
    coordinate of scalar ``w`` is ``ua w + ub`` (eq. 8: texel k of m holds TF entry k at w = k/(m-1),
    so ``ua = (m-1)/m``, ``ub = 1/(2m)``; the affine map is what the rectangles' corner coordinates carry).
    """
    j, i = wp.tid()
    sf = xf[i]
    sb = xb[j]
    d = fb[j, i]
    s = int(0)
    prim = int(0)
    while s < n_draw:
        t = tex1d(tex, ua * rect_coord(sf, sb, s, n_steps) + ub)
        rgb = wp.vec3(t[0], t[1], t[2])
        if e_scale != 1.0:
            rgb = wp.vec3(fmt_quantize(comb, e_scale * t[0]), fmt_quantize(comb, e_scale * t[1]),
                          fmt_quantize(comb, e_scale * t[2]))
        th = 1.0 - t[3]
        for g in range(1, group):
            if s + g < n_draw:
                u = tex1d(tex, ua * rect_coord(sf, sb, s + g, n_steps) + ub)
                a = u[3]
                rgb = wp.vec3(fmt_quantize(comb, e_scale * u[0] + (1.0 - a) * rgb[0]),
                              fmt_quantize(comb, e_scale * u[1] + (1.0 - a) * rgb[1]),
                              fmt_quantize(comb, e_scale * u[2] + (1.0 - a) * rgb[2]))
                th = fmt_quantize(comb, (1.0 - a) * th)
        frag = wp.vec4(rgb[0] * modulate[0], rgb[1] * modulate[1], rgb[2] * modulate[2], (1.0 - th) * modulate[3])
        if gl_dither != 0:
            d = gl_dither_over(bs, frag, d, i, j + row0)  # pattern of the whole slice (row blocks)
        else:
            d = blend(bs, frag, d, i, j, prim)
        prim += 1
        s += group
    fb[j, i] = d


@wp.kernel
def pingpong_slice(tex: Tex1D, xf: wp.array(dtype=float), xb: wp.array(dtype=float), n_steps: int,
                   per_pass: int, hi_fmt: NumFmt, lo_fmt: NumFmt, out: wp.array2d(dtype=float)):
    """Guthe et al. 2002 §4 ping-pong filtering of one colour channel of one slice, ``out[sb, sf]``.

    The TF texture (RGBA8) holds kappa (R = high 8 bits, G = low 4 bits in the upper nibble) and
    ``a = 1 - exp(-(l/m) rho)`` (B high, A low). Each pass reads the previous 12-bit result from the
    ping texture (red = high, alpha = low: ``C = H + L / 256``, 255 in H meaning 1.0), runs
    ``per_pass`` steps ``C = kappa a + (1 - a) C`` in the pixel shader, and writes the result split
    back: high = the 8-bit channel write of C, low = the 8-bit write of ``256 C`` with the bits above
    1.0 masked (``hi_fmt``/``lo_fmt`` with ``wrap``: Radeon 8500) or saturated (GeForce4), keeping
    its upper nibble. The ping texture is read at the pixel's own texel (exact), so it is carried
    in registers between passes; every value crossing a pass boundary is the written one.
    """
    j, i = wp.tid()
    sf = xf[i]
    sb = xb[j]
    h = float(0.0)
    lo = float(0.0)
    s = int(0)
    while s < n_steps:
        x = h + lo * (1.0 / 256.0)
        for g in range(per_pass):
            if s < n_steps:
                t = tex1d(tex, rect_coord(sf, sb, s, n_steps))
                kap = t[0] + t[1] * (1.0 / 256.0)
                a = t[2] + t[3] * (1.0 / 256.0)
                x = kap * a + (1.0 - a) * x
                s += 1
        hc = fmt_encode(hi_fmt, x)
        lc = fmt_encode(lo_fmt, 256.0 * x)
        lc = (lc >> 4) << 4
        h = float(hc) / 255.0
        lo = float(lc) / 255.0
    out[j, i] = h + lo * (1.0 / 256.0)
