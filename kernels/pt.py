"""Projected tetrahedra (Shirley & Tuchman 1990): the fragment programs.

The classification and decomposition of the tets (``k_classify``) is in
:mod:`warpvol.kernels.pt_classify`.

Fragment programs (one thread per fragment of :meth:`warpvol.gpu.raster.Rasterizer.fragments`):

* ``k_frag_vertex_color``: Shirley & Tuchman / Stein et al. — per-vertex averaged colour and
  extinction ``(c̄, τ̄, l)`` interpolated linearly; ``α = 1 - exp(-τ̄ l)``;
* ``k_frag_table3d``: Röttger, Kraus & Ertl 2000 — ``(sf, sb, l)`` interpolated linearly, the RGBA of
  the pre-integration table looked up through the emulated 3D texture unit;
* ``k_frag_cylindrical``: Roettger & Ertl 2002 §4 — per vertex ``(α, s, t)`` (eq. 10, one division,
  ``k_cyl_vertices``); ``α`` is constant over each triangle (all its points lie on one plane through
  the front diagonal) and taken from the triangle's thick vertex, ``(s, t)`` interpolated linearly;
  the two nearest α-planes are sampled from the atlas by the 2D texture unit and blended with an 8-bit
  weight (or the nearest plane alone: the SGI path), :func:`warpvol.kernels.preint.cyl_planes_sample`;
* ``k_frag_guthe``: Guthe et al. 2002 — ρ̂ and the colour coefficients from 2D textures (atlas tiles),
  α by a dependent 1D lookup of ``l ρ̂``, colour a polynomial in ``l``;
* ``k_frag_exact``: no table — the fragment's segment integrated exactly (``pt_best``).

Every table program reads its fragment's (sf, sb, l) through :func:`fragment_sfsbl`: as interpolated,
or (Kraus, Qiao & Ebert 2004) from ``a/w`` and ``1/w`` of the front and back points
(``k_kraus_vertices``) divided per fragment, with the exact or the approximate thickness.
"""

import warp as wp

from .integrate import exp_neg, flat_extinction, integrate_piece_flat, integrate_pieces
from .preint import cyl_planes_sample, table_to_cyl
from .raster import snap
from .texture import Atlas, Tex1D, Tex3D, atlas_sample, tex1d, tex3d
from .tf import tf_eval, tf_eval_upper, tf_first_break_upper, tf_upper

wp.set_module_options({"enable_backward": False, "fuse_fp": False})  # same roundings on CPU and CUDA


@wp.kernel
def k_vertex_colors(attr: wp.array(dtype=wp.vec3), tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4),
                    out: wp.array2d(dtype=wp.float32)):
    """Per output vertex: averaged colour and extinction of its front and back scalars, and l."""
    i = wp.tid()
    a = attr[i]
    c = (tf_eval(a[0], tf_s, tf_v) + tf_eval(a[1], tf_s, tf_v)) * 0.5
    out[i, 0] = c[0]
    out[i, 1] = c[1]
    out[i, 2] = c[2]
    out[i, 3] = c[3]
    out[i, 4] = a[2]


@wp.kernel
def k_frag_vertex_color(attrs: wp.array2d(dtype=wp.float32), emission_density: int, out: wp.array(dtype=wp.vec4)):
    """Stein et al.: alpha = 1 - exp(-tau l) per fragment from the interpolated (tau, l); colour
    c alpha (colour times extinction) or c (1 - exp(-tau l)) / tau (emission density)."""
    f = wp.tid()
    tau = wp.max(attrs[f, 3], 0.0)
    l = wp.max(attrs[f, 4], 0.0)
    x = tau * l
    alpha = 1.0 - wp.exp(-x)
    g = alpha
    if emission_density != 0:
        g = l
        if x > 1.0e-4:
            g = alpha / tau
        else:
            g = l * (1.0 - 0.5 * x)
    out[f] = wp.vec4(attrs[f, 0] * g, attrs[f, 1] * g, attrs[f, 2] * g, alpha)


@wp.func
def axis_coord(x: float, a: float, b: float, log2_n: int) -> float:
    """Texture coordinate of a normalised table value x (clamped to [0, 1]): ``a x + b`` for centred
    and endpoint axes; Kraus et al.'s logarithmic axis when ``log2_n`` (its resolution) is > 0."""
    x = wp.clamp(x, 0.0, 1.0)
    if log2_n > 0:
        n = float(log2_n)
        dl = wp.pow(2.0, -(n - 2.0))
        lg = float(0.0)
        if x > 0.0:
            lg = wp.max(wp.log2(x / dl), 0.0)
        return (lg + wp.min(x / dl, 1.0)) / n + 0.5 / n
    return x * a + b


PERSP_OFF = wp.constant(0)
PERSP_EXACT = wp.constant(1)
PERSP_APPROX = wp.constant(2)


@wp.kernel
def k_kraus_vertices(attr: wp.array(dtype=wp.vec3), front: wp.array(dtype=wp.vec4), back: wp.array(dtype=wp.vec4),
                     out: wp.array2d(dtype=wp.float32)):
    """Kraus et al. 2004 §2.3 vertex program: per output vertex ``(sf/wf, sb/wb, 1/wf, 1/wb, xf/wf,
    yf/wf, zf/wf, zb/wb)`` of its front and back eye-space points (clip ``w``); the rasteriser
    interpolates them linearly in screen space (vertices at or behind the eye get zeros: no
    triangle of a drawn tet uses them)."""
    i = wp.tid()
    a = attr[i]
    fr = front[i]
    bk = back[i]
    iwf = float(0.0)
    iwb = float(0.0)
    if fr[3] > 0.0 and bk[3] > 0.0:
        iwf = 1.0 / fr[3]
        iwb = 1.0 / bk[3]
    out[i, 0] = a[0] * iwf
    out[i, 1] = a[1] * iwb
    out[i, 2] = iwf
    out[i, 3] = iwb
    out[i, 4] = fr[0] * iwf
    out[i, 5] = fr[1] * iwf
    out[i, 6] = fr[2] * iwf
    out[i, 7] = bk[2] * iwb


vec8f = wp.types.vector(length=8, dtype=wp.float32)


@wp.func
def sfsbl_from(a: vec8f, mode: int, ortho: int, z_off: float) -> wp.vec3:
    """(sf, sb, l) of a fragment's interpolated attributes ``a`` (3 used with ``PERSP_OFF``, else 8):
    the attributes as they are (``PERSP_OFF``), or Kraus et al.'s per-fragment division of the
    interpolated ``a/w`` by ``1/w`` (front and back apart) with the thickness ``|ve_f| |(ze_b - ze_f) /
    ze_f|`` (``PERSP_EXACT``; ``|ze_b - ze_f|``, exact, for orthographic views) or ``|ze_b - ze_f|``
    (``PERSP_APPROX``). ``z_off``: the eye-space z of the attributes is shifted by it (the vertex
    stage's ``eye_offset``; 0 for the hardware's eye space): the depth difference is taken between the
    shifted values (near the data: float32 keeps it with the eye far away), ``ze_f`` for the
    ray-length factor is the shifted value minus ``z_off``."""
    if mode == PERSP_OFF:
        return wp.vec3(a[0], a[1], a[2])
    wf = 1.0 / a[2]
    wb = 1.0 / a[3]
    zf = a[6] * wf
    zb = a[7] * wb
    l = wp.abs(zb - zf)
    if z_off != 0.0:
        zf = zf - z_off
    if mode == PERSP_EXACT and ortho == 0 and zf != 0.0:
        l = wp.length(wp.vec3(a[4] * wf, a[5] * wf, zf)) * l / wp.abs(zf)
    return wp.vec3(a[0] * wf, a[1] * wb, l)


@wp.func
def fragment_sfsbl(attrs: wp.array2d(dtype=wp.float32), f: int, mode: int, ortho: int, z_off: float) -> wp.vec3:
    """:func:`sfsbl_from` fragment ``f``'s row of a fragment attribute list (at most 8 columns)."""
    a = vec8f()
    for k in range(wp.min(attrs.shape[1], 8)):
        a[k] = attrs[f, k]
    return sfsbl_from(a, mode, ortho, z_off)


#: the clamp of an interpolated attribute counts as a move when it exceeds CLAMP_REL x range + CLAMP_ABS
CLAMP_REL = wp.constant(1.0e-5)
CLAMP_ABS = wp.constant(1.0e-7)


@wp.func
def clamp_attr(x: float, v0: float, v1: float, v2: float, moved: int):
    """``x`` clamped into the range of a triangle's three vertex values ``v0..v2`` (barycentrics of a
    sub-pixel sliver computed in fp32 can leave [0, 1]), and ``moved`` set to 1 where that moved it by
    more than rounding."""
    lo = wp.min(v0, wp.min(v1, v2))
    hi = wp.max(v0, wp.max(v1, v2))
    y = wp.clamp(x, lo, hi)
    m = moved
    if wp.abs(y - x) > CLAMP_REL * (hi - lo) + CLAMP_ABS:
        m = 1
    return y, m


@wp.func
def exact_color_upper(a: wp.vec3, kf: int, kb: int, vf: wp.vec4, vb: wp.vec4, tf_s: wp.array(dtype=float),
                      tf_v: wp.array(dtype=wp.vec4), model: int) -> wp.vec4:
    """:func:`exact_color` given both ends' TF interval ``kf = tf_upper(sf)``, ``kb = tf_upper(sb)`` and TF values
    ``vf``, ``vb`` (:func:`~warpvol.kernels.tf.tf_eval_upper`'s): no search (the span draw knows them)."""
    length = wp.max(a[2], 0.0)
    r = wp.vec4(0.0, 0.0, 0.0, 0.0)
    if length > 0.0:
        if kf == kb:
            r = integrate_piece_flat(length, vf, vb, flat_extinction(kf, tf_v), model)  # (exact constancy)
        else:
            r = integrate_pieces(a[0], a[1], vf, vb, tf_first_break_upper(kf, a[0], a[1], tf_s), length, tf_s,
                                 tf_v, model)
    return wp.vec4(r[0], r[1], r[2], 1.0 - exp_neg(r[3]))


@wp.func
def exact_color(a: wp.vec3, tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int) -> wp.vec4:
    """pt_best's fragment colour: the segment ``a = (sf, sb, l)`` integrated exactly (premultiplied
    RGB, alpha ``1 - exp(-tau)``); the values of
    :func:`~warpvol.kernels.integrate.integrate_segment`. Both ends in the same TF interval (one
    search each; most fragments of a cell are) means no control point between them: the segment is
    one piece, integrated without the walk over crossed control points (:func:`exact_color_upper`)."""
    kf = tf_upper(a[0], tf_s)
    kb = tf_upper(a[1], tf_s)
    return exact_color_upper(a, kf, kb, tf_eval_upper(a[0], kf, tf_s, tf_v), tf_eval_upper(a[1], kb, tf_s, tf_v),
                             tf_s, tf_v, model)


@wp.func
def table3d_coords(attrs: wp.array2d(dtype=wp.float32), f: int, mode: int, ortho: int, z_off: float, s_off: float,
                   s_inv: float, s_a: float, s_b: float, l_inv: float, l_a: float, l_b: float, l_log2: int) -> wp.vec3:
    """Texture coordinates ``(u, v, r)`` of fragment ``f``'s (sf, sb, l) (:func:`fragment_sfsbl`) in a 3D
    table: normalised (``(s - s_off) s_inv``, ``l l_inv``) and mapped by the table's axes."""
    a = fragment_sfsbl(attrs, f, mode, ortho, z_off)
    return wp.vec3(axis_coord((a[0] - s_off) * s_inv, s_a, s_b, 0), axis_coord((a[1] - s_off) * s_inv, s_a, s_b, 0),
                   axis_coord(a[2] * l_inv, l_a, l_b, l_log2))


@wp.kernel
def k_frag_table3d(attrs: wp.array2d(dtype=wp.float32), mode: int, ortho: int, z_off: float, tex: Tex3D,
                   s_off: float,
                   s_inv: float, s_a: float, s_b: float, l_inv: float, l_a: float, l_b: float, l_log2: int,
                   out: wp.array(dtype=wp.vec4)):
    """Röttger et al. 2000: the fragment's (sf, sb, l) looked up through the 3D texture unit at
    :func:`table3d_coords`; the table's RGBA (premultiplied C, alpha) is the fragment colour."""
    f = wp.tid()
    c = table3d_coords(attrs, f, mode, ortho, z_off, s_off, s_inv, s_a, s_b, l_inv, l_a, l_b, l_log2)
    out[f] = tex3d(tex, c[0], c[1], c[2])


@wp.kernel
def k_table3d_coords(attrs: wp.array2d(dtype=wp.float32), mode: int, ortho: int, z_off: float, s_off: float,
                     s_inv: float, s_a: float, s_b: float, l_inv: float, l_a: float, l_b: float, l_log2: int,
                     out: wp.array(dtype=wp.vec3)):
    """The texture coordinates :func:`k_frag_table3d` looks up (the texture-cache analysis reads them)."""
    f = wp.tid()
    out[f] = table3d_coords(attrs, f, mode, ortho, z_off, s_off, s_inv, s_a, s_b, l_inv, l_a, l_b, l_log2)


@wp.func
def guthe_fetch(attrs: wp.array2d(dtype=wp.float32), f: int, mode: int, ortho: int, z_off: float, coef: Atlas,
                alpha1d: Tex1D, s_off: float, s_inv: float, s_a: float, s_b: float, l_inv: float, a_a: float,
                a_b: float):
    """The texture work of Guthe et al.'s fragment program for fragment ``f`` (texture-address unit,
    fp32), shared by the fp32 and the fixed-point register programs: ``(u, v, x, t0, alpha)`` -- the
    (sf, sb) coordinates of the coefficient tiles, ``x = l / lmax`` clamped to [0, 1], tile 0's texel
    ``(C~_0, rho_hat / rho_max)`` and ``alpha = alpha1D(x rho_hat)`` (texel-centre map ``a_a x + a_b``)."""
    a = fragment_sfsbl(attrs, f, mode, ortho, z_off)
    u = axis_coord((a[0] - s_off) * s_inv, s_a, s_b, 0)
    v = axis_coord((a[1] - s_off) * s_inv, s_a, s_b, 0)
    x = wp.clamp(a[2] * l_inv, 0.0, 1.0)
    t0 = atlas_sample(coef, 0, u, v)
    alpha = tex1d(alpha1d, (x * t0[3]) * a_a + a_b)[0]
    return u, v, x, t0, alpha


@wp.kernel
def k_frag_guthe(attrs: wp.array2d(dtype=wp.float32), mode: int, ortho: int, z_off: float, coef: Atlas,
                 alpha1d: Tex1D, s_off: float, s_inv: float, s_a: float, s_b: float, l_inv: float, a_a: float, a_b: float,
                 degree: int, scale: wp.array(dtype=wp.vec3), out: wp.array(dtype=wp.vec4)):
    """Guthe et al. 2002: tile 0 of ``coef`` holds ``(C~_0, rho_hat / rho_max)``, tile i ``C~_i``
    (i = 1..degree), each a bilinear 2D lookup at (sf, sb); ``alpha = alpha1D(x rho_hat)`` by a
    dependent 1D lookup (:func:`guthe_fetch`); ``C = alpha sum_i x^i C~_i scale_i``; the output
    register clamps to [0, 1]."""
    f = wp.tid()
    u, v, x, t0, alpha = guthe_fetch(attrs, f, mode, ortho, z_off, coef, alpha1d, s_off, s_inv, s_a, s_b, l_inv,
                                     a_a, a_b)
    s0 = scale[0]
    c = wp.vec3(t0[0] * s0[0], t0[1] * s0[1], t0[2] * s0[2])
    xi = float(1.0)
    for i in range(1, degree + 1):
        xi = xi * x
        ti = atlas_sample(coef, i, u, v)
        si = scale[i]
        c = c + wp.vec3(ti[0] * si[0], ti[1] * si[1], ti[2] * si[2]) * xi
    c = c * alpha
    out[f] = wp.vec4(wp.clamp(c[0], 0.0, 1.0), wp.clamp(c[1], 0.0, 1.0), wp.clamp(c[2], 0.0, 1.0),
                     wp.clamp(alpha, 0.0, 1.0))


@wp.kernel
def k_snap_positions(win: wp.array(dtype=wp.vec4), even: int, out: wp.array(dtype=wp.vec4)):
    """Window x, y snapped to the rasteriser's 1/256 grid (attribute set-up from snapped vertices,
    as the hardware did; exact in float32)."""
    i = wp.tid()
    p = win[i]
    out[i] = wp.vec4(float(snap(p[0], even)) / 256.0, float(snap(p[1], even)) / 256.0, p[2], p[3])


@wp.kernel
def k_clamp_attrs(prim: wp.array(dtype=wp.int32), tris: wp.array(dtype=wp.vec3i),
                  vattrs: wp.array2d(dtype=wp.float32), attrs: wp.array2d(dtype=wp.float32),
                  clamped: wp.array(dtype=wp.int32)):
    """Clamp each interpolated attribute into the range of its triangle's three vertex values
    (barycentrics of a sub-pixel sliver computed in fp32 can leave [0, 1]); count clamped fragments."""
    f = wp.tid()
    t = tris[prim[f]]
    moved = int(0)
    for a in range(attrs.shape[1]):
        y, moved = clamp_attr(attrs[f, a], vattrs[t[0], a], vattrs[t[1], a], vattrs[t[2], a], moved)
        attrs[f, a] = y
    if moved != 0:
        wp.atomic_add(clamped, 0, 1)


@wp.kernel
def k_cyl_vertices(attr: wp.array(dtype=wp.vec3), s_off: float, s_inv: float, l_inv: float,
                   out: wp.array2d(dtype=wp.float32)):
    """Per output vertex ``(α, s, t)`` of its normalised ``(sf, sb, l)`` (each clamped to [0, 1]);
    silhouette vertices (``sf = sb``, ``l = 0``) get ``(0, 0, sb)``."""
    i = wp.tid()
    a = attr[i]
    c = table_to_cyl(wp.clamp((a[0] - s_off) * s_inv, 0.0, 1.0), wp.clamp((a[1] - s_off) * s_inv, 0.0, 1.0),
                     wp.clamp(a[2] * l_inv, 0.0, 1.0))
    out[i, 0] = c[0]
    out[i, 1] = c[1]
    out[i, 2] = c[2]


@wp.func
def cylindrical_coords(attrs: wp.array2d(dtype=wp.float32), prim: wp.array(dtype=wp.int32),
                       tris: wp.array(dtype=wp.vec3i), vattrs: wp.array2d(dtype=wp.float32), f: int, ua: float,
                       ub: float, va: float, vb: float) -> wp.vec3:
    """``(α, u, v)`` of fragment ``f``: ``α`` of its triangle's thick vertex, in-tile ``(u, v)``."""
    return wp.vec3(vattrs[tris[prim[f]][0], 0], ua * wp.clamp(attrs[f, 1], 0.0, 1.0) + ub,
                   va * wp.clamp(attrs[f, 2], 0.0, 1.0) + vb)


@wp.kernel
def k_frag_cylindrical(attrs: wp.array2d(dtype=wp.float32), prim: wp.array(dtype=wp.int32),
                       tris: wp.array(dtype=wp.vec3i), vattrs: wp.array2d(dtype=wp.float32), atlas: Atlas,
                       ua: float, ub: float, va: float, vb: float, weight_bits: int, nearest: int,
                       out: wp.array(dtype=wp.vec4)):
    """Plane reconstruction: ``α`` of the triangle's thick vertex (its first vertex), ``(s, t)``
    interpolated, in-tile coordinates ``u = ua s + ub``, ``v = va t + vb``; the two nearest planes
    blended with a ``weight_bits``-bit weight (0: fp32), or the nearest plane alone (``nearest``)."""
    f = wp.tid()
    c = cylindrical_coords(attrs, prim, tris, vattrs, f, ua, ub, va, vb)
    out[f] = cyl_planes_sample(atlas, c[0], c[1], c[2], weight_bits, nearest)


@wp.kernel
def k_cylindrical_coords(attrs: wp.array2d(dtype=wp.float32), prim: wp.array(dtype=wp.int32),
                         tris: wp.array(dtype=wp.vec3i), vattrs: wp.array2d(dtype=wp.float32), ua: float, ub: float,
                         va: float, vb: float, out: wp.array(dtype=wp.vec3)):
    """The ``(α, u, v)`` :func:`k_frag_cylindrical` samples (the texture-cache analysis reads them)."""
    f = wp.tid()
    out[f] = cylindrical_coords(attrs, prim, tris, vattrs, f, ua, ub, va, vb)


@wp.kernel
def k_frag_exact(attrs: wp.array2d(dtype=wp.float32), mode: int, ortho: int, z_off: float,
                 tf_s: wp.array(dtype=float),
                 tf_v: wp.array(dtype=wp.vec4), model: int, out: wp.array(dtype=wp.vec4)):
    """No table: the fragment's segment (sf, sb, l) integrated exactly for the piecewise-linear TF
    in fp32 (:func:`warpvol.kernels.integrate.integrate_segment`, the reference's closed form)."""
    f = wp.tid()
    out[f] = exact_color(fragment_sfsbl(attrs, f, mode, ortho, z_off), tf_s, tf_v, model)
