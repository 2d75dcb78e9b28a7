"""HARC's segment integration (:mod:`warpvol.kernels.harc`): the :class:`Integ` set-up, one sub-segment
by the exact integral, the full pre-integration table or partial pre-integration (:func:`integrate_sub`),
the iso-crossing splits of Espinha & Celes' Fig. 6 (:func:`iso_end`, :func:`segment`) and a test kernel
running :func:`segment` on given segments (:func:`segments_kernel`)."""

import warp as wp

from .harc_walk import composite
from .integrate import integrate_segment
from .pt import axis_coord
from .texture import Tex1D, Tex2D, Tex3D, tex1d, tex2d, tex3d
from .tf import tf_eval, tf_first_break, tf_next_break

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

INTEG_EXACT = wp.constant(0)
INTEG_FULL = wp.constant(1)
INTEG_PARTIAL = wp.constant(2)
#: iso rule: 0 = the paper's (``sf == s_iso`` -> ``next_s_iso``); 1 = also when ``s_iso`` lies behind
#: ``sf`` (edge-anchored iso table, see :func:`warpvol.tables.isocross.build_isocross`)
ISO_PAPER = wp.constant(0)
ISO_BEHIND = wp.constant(1)


@wp.struct
class Integ:
    """Integration set-up: mode, TF (arrays), tables (textures) and their coordinate maps."""

    mode: int
    model: int
    tf_s: wp.array(dtype=float)
    tf_v: wp.array(dtype=wp.vec4)
    s_off: float
    s_inv: float
    table: Tex3D
    t_sa: float
    t_sb: float
    l_inv: float
    t_la: float
    t_lb: float
    t_llog: int
    psi: Tex2D
    p_a: float
    p_b: float
    iso: Tex2D
    iso_rule: int
    tf_tex: Tex1D
    tf_tex_on: int
    tf_scale: wp.vec4


@wp.func
def tf_read(ig: Integ, s: float) -> wp.vec4:
    """The TF at scalar ``s`` as partial pre-integration's fragment program reads it: from the 1D TF
    texture (``tf_tex_on``: texel k holds the TF at k / (width - 1) of its range, read linearly at the
    texel-centre coordinate, colour and extinction stored over their maxima ``tf_scale`` and scaled
    back by one multiply) or, for the exact option, from the control-point arrays."""
    if ig.tf_tex_on == 0:
        return tf_eval(s, ig.tf_s, ig.tf_v)
    w = float(ig.tf_tex.width)
    x = wp.clamp((s - ig.s_off) * ig.s_inv, 0.0, 1.0)
    v = tex1d(ig.tf_tex, x * (w - 1.0) / w + 0.5 / w)
    return wp.cw_mul(v, ig.tf_scale)


@wp.func
def integrate_sub(ig: Integ, sf: float, sb: float, l: float) -> wp.vec4:
    """Premultiplied ``(r, g, b, alpha)`` of one sub-segment (front ``sf``, back ``sb``, length ``l``)."""
    if not (l > 0.0):
        return wp.vec4(0.0, 0.0, 0.0, 0.0)
    if ig.mode == INTEG_EXACT:
        seg = integrate_segment(sf, sb, l, ig.tf_s, ig.tf_v, ig.model)
        return wp.vec4(seg[0], seg[1], seg[2], 1.0 - wp.exp(-seg[3]))
    if ig.mode == INTEG_FULL:
        u = axis_coord((sf - ig.s_off) * ig.s_inv, ig.t_sa, ig.t_sb, 0)
        v = axis_coord((sb - ig.s_off) * ig.s_inv, ig.t_sa, ig.t_sb, 0)
        r = axis_coord(l * ig.l_inv, ig.t_la, ig.t_lb, ig.t_llog)
        return tex3d(ig.table, u, v, r)
    # partial pre-integration (Moreland & Angel 2004)
    vf = tf_read(ig, sf)
    vb = tf_read(ig, sb)
    xf = vf[3] * l
    xb = vb[3] * l
    gf = xf / (xf + 1.0)
    gb = xb / (xb + 1.0)
    p = tex2d(ig.psi, gf * ig.p_a + ig.p_b, gb * ig.p_a + ig.p_b)
    psi = p[0]
    zeta = wp.exp(-0.5 * (xf + xb))
    cf = wp.vec3(vf[0], vf[1], vf[2])
    cb = wp.vec3(vb[0], vb[1], vb[2])
    c = wp.vec3(0.0, 0.0, 0.0)
    if ig.model == 0:
        c = cb * wp.max(psi - zeta, 0.0) + cf * (1.0 - psi)
    else:
        c = (cf * (psi - p[1]) + cb * p[1]) * l
    return wp.vec4(c[0], c[1], c[2], 1.0 - zeta)


@wp.func
def iso_end(ig: Integ, nf: float, nb: float) -> float:
    """Fig. 6 lines 13-21 on normalised scalars: the end of the next sub-segment from ``nf`` towards
    ``nb`` (``nb`` itself when no iso-surface lies between) from the iso table (nearest lookup) and
    the ``next_s_iso`` rule. An ``s_iso`` behind ``nf`` (nearest sampling of the centre-anchored
    table) is ignored under the paper's rule -- a step backwards could loop -- and replaced by
    ``next_s_iso`` under ``ISO_BEHIND`` (edge-anchored table: exact splits)."""
    e = tex2d(ig.iso, nf, nb)
    s_iso = e[0]
    if s_iso != -1.0:
        if nf == s_iso:
            s_iso = e[1]
        elif (s_iso - nf) * (nb - nf) <= 0.0:
            if ig.iso_rule == ISO_BEHIND:
                s_iso = e[1]
            else:
                s_iso = -1.0
        if s_iso != -1.0 and wp.abs(nb - nf) > wp.abs(s_iso - nf):
            return s_iso
    return nb


@wp.func
def skipped_break(ig: Integ, s0: float, s1: float, n0: float, n1: float) -> bool:
    """Whether a TF control point lies inside the sub-segment ``s0 .. s1`` (normalised ``n0 .. n1``)
    by more than 1e-6 of the TF range from both ends (the ends are control points converted from
    normalised values, so they may sit a rounding step off them)."""
    k = tf_first_break(s0, s1, ig.tf_s)
    while k >= 0:
        nk = (ig.tf_s[k] - ig.s_off) * ig.s_inv
        if wp.abs(nk - n0) > 1.0e-6 and wp.abs(nk - n1) > 1.0e-6:
            return True
        k = tf_next_break(k, s0, s1, ig.tf_s)
    return False


@wp.func
def segment(ig: Integ, sf: float, sb: float, l: float, acc: wp.vec4, t_stop: float, counters: wp.array2d(dtype=wp.int32),
            chunk: int):
    """Integrate one cell's segment (iso-split for partial pre-integration) and composite it front
    to back into ``acc``; returns ``(acc, sub-steps)``. Stops splitting once ``1 - A < t_stop``.
    The split runs on normalised scalars (the tables' coordinates) so the ``sf == s_iso`` test of
    the paper compares table values with themselves."""
    if ig.mode != INTEG_PARTIAL:
        return composite(acc, integrate_sub(ig, sf, sb, l)), 1
    steps = int(0)
    n0 = (sf - ig.s_off) * ig.s_inv
    nb = (sb - ig.s_off) * ig.s_inv
    s0 = sf
    l_left = l
    while steps < 100000:
        steps += 1
        n1 = iso_end(ig, n0, nb)
        if n1 != nb:
            s1 = n1 / ig.s_inv + ig.s_off
            # the sub-segment the table chose must not skip a control point (diagnostic count)
            if skipped_break(ig, s0, s1, n0, n1):
                wp.atomic_add(counters, chunk, 5, 1)
            h = l_left * (n1 - n0) / (nb - n0)
            acc = composite(acc, integrate_sub(ig, s0, s1, h))
            l_left = l_left - h
            s0 = s1
            n0 = n1
            if 1.0 - acc[3] < t_stop:
                break
        else:
            if skipped_break(ig, s0, sb, n0, nb):
                wp.atomic_add(counters, chunk, 5, 1)
            acc = composite(acc, integrate_sub(ig, s0, sb, l_left))
            break
    return acc, steps


@wp.kernel
def segments_kernel(ig: Integ, sf: wp.array(dtype=float), sb: wp.array(dtype=float), l: wp.array(dtype=float),
                    counters: wp.array2d(dtype=wp.int32), out: wp.array(dtype=wp.vec4),
                    steps: wp.array(dtype=wp.int32)):
    """One segment per thread through :func:`segment` (tests: iso splits vs the exact integral)."""
    i = wp.tid()
    acc, n = segment(ig, sf[i], sb[i], l[i], wp.vec4(0.0, 0.0, 0.0, 0.0), 0.0, counters, 0)
    out[i] = acc
    steps[i] = n
