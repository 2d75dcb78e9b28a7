"""``pt_best``'s fused draw with its fragments in SIMD spans (``pt_integrate.lanes`` > 1; beyond the papers).

:func:`span_kernel` builds, per lane count ``LANES``, a kernel that draws what
:func:`warpvol.kernels.pt_draw.k_pt_exact_tiles` draws -- the same bins, triangles, covered pixels, order,
counters and float32 values -- but gathers a triangle's fragments in its bin, row after row (a span may
take the end of one row and the start of the next; each row's covered run from its edges' ``floor(e / |sj|)``,
stepped from row to row with exact int64 adds, :func:`~warpvol.kernels.pt_span_lanes.edge_start` /
:func:`~warpvol.kernels.pt_span_lanes.edge_next`), into spans of ``LANES`` and runs the common
fragment's work for a whole span at once, in counted branch-free loops over local lane vectors that LLVM
vectorises (8 float32 lanes per AVX-512 instruction with LLVM's preferred 256-bit width here):

1. the attributes from the triangle's planes, the test that the pixel centre lies in the unsnapped
   triangle, the clamp into the vertex range (with its "moved" test), ``(sf, sb, l)`` by Kraus'
   division and the zero-segment test (:func:`~warpvol.kernels.pt_draw.sfsbl_ray`'s operations);
2. the TF interval of both ends, counted over the control points (:func:`~warpvol.kernels.tf.tf_upper`'s
   result: the count of points not above the scalar), and the control points on both sides of it,
   selected from flat float32 values (``tf_flat``, 4 per point; no ``vec4`` loads in the loop);
3. the TF values at both ends and, for a segment inside one TF interval and optically thin, the 3-point
   Gauss moments of :func:`~warpvol.kernels.integrate.integrate_piece` and the alpha polynomial of
   :func:`~warpvol.kernels.pt.exact_color`.

Each bin entry's triangle data (box, vertices, snapped vertices) is loaded two entries ahead and its vertices'
attributes and positions one entry ahead, so their cache misses overlap the draw of the entries before. A span's
lanes are filled from the row runs by counted selects over all lanes. A row's covered run all terminated is
skipped as a whole, as there. Then one pass over the span's
pixels, in order, does what stays per fragment: the early-termination test (a terminated pixel is
skipped and counted in ``skipped``, as there), the counters, the blend and the termination bookkeeping. A *rare* fragment leaves the span for the one-fragment
kernel's functions: a pixel centre outside the unsnapped triangle, whole
(:func:`~warpvol.kernels.pt_draw.nearest_on_triangle`, ``clamp8``, ``sfsbl_ray``,
:func:`~warpvol.kernels.pt.exact_color`); a segment crossing a TF control point, an optically thick
piece or a TF of more than :data:`TF_COUNTED` points, :func:`~warpvol.kernels.pt.exact_color` on the
span's ``(sf, sb, l)``. ``fuse_fp`` is off and every lane value is computed by the same float32
operations in the same order as the scalar functions, so the image and the counters are those of
``lanes = 1`` (tests/test_pt_spans.py, bit for bit). Lanes past a span's fragments compute on its last
pixel and are dropped. Each loop over lanes is written without ``if`` (``wp.where``: a uniform ``if``
inside one kept LLVM from vectorising it).

Inputs and outputs are bundled in :class:`FusedIn` / :class:`FusedOut` (the kernel takes 6 parameters). The
scalar helper functions the kernels inline are in :mod:`warpvol.kernels.pt_span_lanes`.
"""

import warp as wp

from .blend import BlendState
from .integrate import GL3_W0, GL3_W1, GL3_X0, GL3_X2, THIN_DEPTH, one_minus_exp_neg_thin
from .pt import CLAMP_REL, PERSP_EXACT, PERSP_OFF, exact_color, exact_color_upper, vec8f
from .pt_draw import attribute_planes, clamp8, nearest_on_triangle, sfsbl_ray, span_done, zero_segments
from .pt_span_lanes import (
    bin_entry,
    blend_by,
    blend_kind,
    clamp1,
    edge_hi,
    edge_lo,
    edge_next,
    edge_start,
    exp_neg_thin,
    moved1,
    plane1,
    segment_bounds,
    tf_lane_value,
)
from .raster import SUBPIX64, TriSetup, edges_of, tile_rect, vec3l

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

#: module options of the span kernels: no FMA contraction (the scalar functions' roundings), and loops
#: unrolled at most 2 deep so that the counted lane loops stay loops LLVM vectorises
SPAN_OPTIONS = {"enable_backward": False, "fuse_fp": False, "max_unroll": 2}

#: up to this many TF control points each lane counts the points below its scalars (a counted loop);
#: beyond it every fragment's colour is :func:`~warpvol.kernels.pt.exact_color`'s (binary searches)
TF_COUNTED = wp.constant(32)


@wp.struct
class FusedIn:
    """What the fused draw reads (:func:`warpvol.projection.pt._draw_fused`)."""

    pos: wp.array(dtype=wp.vec4)  # the attribute planes' window positions
    vattrs: wp.array(dtype=vec8f)
    mode: int
    ortho: int
    ray_len: wp.array2d(dtype=float)  # per-pixel ray factors (exact thickness in perspective; else 1x1, unread)
    tf_s: wp.array(dtype=float)
    tf_v: wp.array(dtype=wp.vec4)
    tf_flat: wp.array(dtype=float)  # tf_v flat: 4 per control point
    model: int
    t_min: float
    tet0: int
    zero_lo: float
    zero_hi: float


@wp.struct
class FusedOut:
    """What the fused draw writes besides the frame buffer (see :mod:`warpvol.kernels.pt_draw`)."""

    counts: wp.array(dtype=wp.vec2i)
    skipped: wp.array(dtype=wp.vec2i)
    occluded: wp.array(dtype=wp.vec3i)
    done_rows: wp.array(dtype=wp.uint64)
    term_at: wp.array2d(dtype=wp.int32)
    binned: wp.array(dtype=wp.int32)
    walked: wp.array(dtype=wp.int32)


def span_kernel(lanes: int):
    """The span draw kernel for ``lanes`` fragments per span (a module of its own per lane count, compiled on
    first launch; cached by :func:`span_kernel_cached`)."""
    L = int(lanes)
    lanef = wp.types.vector(length=L, dtype=wp.float32)
    lanei = wp.types.vector(length=L, dtype=wp.int32)

    @wp.func
    def point_lanes(tf_s: wp.array(dtype=float), tf_flat: wp.array(dtype=float), p: int):
        """Control point ``p`` ``(s, r, g, b, extinction)`` in every lane, twice: the start values of the front
        end's and of the back end's selection (flat float32 loads, no ``vec4``)."""
        s = lanef(tf_s[p])
        r = lanef(tf_flat[4 * p])
        g = lanef(tf_flat[4 * p + 1])
        b = lanef(tf_flat[4 * p + 2])
        x = lanef(tf_flat[4 * p + 3])
        return s, r, g, b, x, s, r, g, b, x

    @wp.kernel(module="unique", module_options=SPAN_OPTIONS)
    def k_pt_span_tiles(s: TriSetup, fi: FusedIn, fo: FusedOut, bs: BlendState, fb: wp.array2d(dtype=wp.vec4),
                        tile0: int):
        tile = tile0 + wp.tid()
        nfrag = int(0)
        nclamp = int(0)
        rect = tile_rect(s, tile, fb.shape[1], fb.shape[0])
        mode = fi.mode
        model = fi.model
        per_ray = mode == PERSP_EXACT and fi.ortho == 0
        persp = mode != PERSP_OFF
        zero_lo = fi.zero_lo
        zero_hi = fi.zero_hi
        t_min = fi.t_min
        tet0 = fi.tet0
        ntf = fi.tf_s.shape[0]
        bkind = blend_kind(bs)
        many = ntf > TF_COUNTED  # too many control points to count: every fragment through exact_color
        ntf_lanes = wp.where(many, 0, ntf)
        area = (rect[2] - rect[0] + 1) * (rect[3] - rect[1] + 1)
        term = t_min > 0.0
        done = int(0)
        nskip = int(0)
        ntail = int(0)
        nocc = int(0)
        nzero = int(0)
        nzt = int(0)
        rows0 = tile * s.tile_size
        if term:
            for r in range(s.tile_size):
                fo.done_rows[rows0 + r] = wp.uint64(0)
        e0 = s.tile_start[tile]
        ne = s.tile_end[tile] - e0
        if ne == 0:
            fo.counts[tile] = wp.vec2i(0, 0)
            fo.skipped[tile] = wp.vec2i(0, 0)
            fo.occluded[tile] = wp.vec3i(0, 0, 0)
            return
        # the bin entries' triangle data loaded ahead (their misses overlap the draw of the entries before):
        # the triangle, its box, vertices and snapped vertices two entries ahead, the vertices' attributes and
        # positions one entry ahead (the last entry's where there is none)
        pf_t1 = s.tri_of[bin_entry(e0, ne, 0, term)]
        pf_b1 = s.bbox[pf_t1]
        pf_v1 = s.vidx[pf_t1]
        pf_x1 = s.sx[pf_t1]
        pf_y1 = s.sy[pf_t1]
        pf_c1 = s.bias[pf_t1]
        pf_t2 = s.tri_of[bin_entry(e0, ne, 1, term)]
        pf_b2 = s.bbox[pf_t2]
        pf_v2 = s.vidx[pf_t2]
        pf_x2 = s.sx[pf_t2]
        pf_y2 = s.sy[pf_t2]
        pf_c2 = s.bias[pf_t2]
        pf_n0 = fi.vattrs[pf_v1[0]]
        pf_n1 = fi.vattrs[pf_v1[1]]
        pf_n2 = fi.vattrs[pf_v1[2]]
        pf_npa = fi.pos[pf_v1[0]]
        pf_npb = fi.pos[pf_v1[1]]
        pf_npc = fi.pos[pf_v1[2]]
        for q in range(ne):
            if term and done >= area:
                ntail = ne - q
                for q2 in range(q, ne):
                    fo.binned[tet0 + s.tri_of[e0 + ne - 1 - q2] / 4] = 1
                break
            t = pf_t1
            tb = pf_b1
            tsx = pf_x1
            tsy = pf_y1
            tbi = pf_c1
            a0 = pf_n0
            a1 = pf_n1
            a2 = pf_n2
            pa = pf_npa
            pb = pf_npb
            pc = pf_npc
            pf_t1 = pf_t2
            pf_b1 = pf_b2
            pf_v1 = pf_v2
            pf_x1 = pf_x2
            pf_y1 = pf_y2
            pf_c1 = pf_c2
            pf_n0 = fi.vattrs[pf_v1[0]]
            pf_n1 = fi.vattrs[pf_v1[1]]
            pf_n2 = fi.vattrs[pf_v1[2]]
            pf_npa = fi.pos[pf_v1[0]]
            pf_npb = fi.pos[pf_v1[1]]
            pf_npc = fi.pos[pf_v1[2]]
            pf_t2 = s.tri_of[bin_entry(e0, ne, q + 2, term)]
            pf_b2 = s.bbox[pf_t2]
            pf_v2 = s.vidx[pf_t2]
            pf_x2 = s.sx[pf_t2]
            pf_y2 = s.sy[pf_t2]
            pf_c2 = s.bias[pf_t2]
            j0 = wp.max(tb[0], rect[0])  # tile_span
            i0 = wp.max(tb[1], rect[1])
            j1 = wp.min(tb[2], rect[2])
            i1 = wp.min(tb[3], rect[3])
            if term:
                fo.binned[tet0 + t / 4] = 1
            if j0 > j1 or i0 > i1:
                continue
            if term and done > 0:
                if span_done(fo.done_rows, rows0 + i0 - rect[1], rows0 + i1 - rect[1], j0 - rect[0], j1 - rect[0]):
                    nocc += 1
                    continue
            if term:
                fo.walked[tet0 + t / 4] = 1
            lo = wp.min(a0, wp.min(a1, a2))
            hi = wp.max(a0, wp.max(a1, a2))
            # the segments' bounds (zero_segments' corners): the zero test and the control points reachable
            sbd = segment_bounds(lo, hi, mode)
            bounded = sbd[0] == sbd[0]  # (NaN: no bound)
            zt = (sbd[1] <= zero_lo and sbd[3] <= zero_lo) or (sbd[0] >= zero_hi and sbd[2] >= zero_hi)
            if not bounded:
                zt = zero_segments(lo, hi, mode, zero_lo, zero_hi)
            if zt:
                nzt += 1
                continue
            g = attribute_planes(pa, pb, pc, a0, a1, a2)
            gx = g[0]
            gy = g[1]
            tol = CLAMP_REL * (hi - lo)
            # the control points the triangle's segments can reach: each end's tf_upper lies in [m_lo, m_hi]
            # (monotone in the scalar), so the lanes count only the points m_lo .. m_hi - 1
            # (tf_upper of each bound: the points not above it, counted; no bound: every point counted)
            m_lo = int(0)
            m_hi = ntf_lanes
            if not many and bounded:
                u0 = int(0)
                u1 = int(0)
                u2 = int(0)
                u3 = int(0)
                for m in range(ntf):
                    sm = fi.tf_s[m]
                    u0 += wp.where(sm > sbd[0], 0, 1)
                    u1 += wp.where(sm > sbd[1], 0, 1)
                    u2 += wp.where(sm > sbd[2], 0, 1)
                    u3 += wp.where(sm > sbd[3], 0, 1)
                m_lo = wp.min(u0, u2)
                m_hi = wp.max(u1, u3)
            p0 = wp.max(m_lo - 1, 0)  # the points below / above a scalar counted at m_lo / m_hi
            p1 = wp.min(m_hi, ntf - 1)
            # the unsnapped triangle's inside test (nearest_on_triangle's), per lane
            ux = pb[0] - pa[0]
            uy = pb[1] - pa[1]
            vx = pc[0] - pa[0]
            vy = pc[1] - pa[1]
            den = ux * vy - vx * uy
            row = edges_of(tsx, tsy, tbi, j0, i0)  # edges_at, edge_step_j, edge_step_i of the loaded vertices
            sj = vec3l(-wp.int64(tsy[2] - tsy[1]) * SUBPIX64, -wp.int64(tsy[0] - tsy[2]) * SUBPIX64,
                       -wp.int64(tsy[1] - tsy[0]) * SUBPIX64)
            si = vec3l(wp.int64(tsx[2] - tsx[1]) * SUBPIX64, wp.int64(tsx[0] - tsx[2]) * SUBPIX64,
                       wp.int64(tsx[1] - tsx[0]) * SUBPIX64)
            # the rows' runs stepped exactly with adds (edge_start / edge_next: row_span's runs)
            nrow = j1 - j0 + 1
            sj0 = sj[0]
            sj1 = sj[1]
            sj2 = sj[2]
            ef0, er0, ed0, eq0, es0 = edge_start(row[0], sj0, si[0])
            ef1, er1, ed1, eq1, es1 = edge_start(row[1], sj1, si[1])
            ef2, er2, ed2, eq2, es2 = edge_start(row[2], sj2, si[2])
            # the triangle's fragments in the bin, row by row, in spans of L (a span may take several rows)
            i = i0  # next row to open
            ci = i0  # the open row
            cj = int(1)  # next pixel of the open row's run, its last: none open
            ce = int(0)
            while True:
                ii = lanei()
                jj = lanei()
                n = int(0)
                while n < L:
                    if cj > ce:  # the run is used up: the next row's
                        if i > i1:
                            break
                        ci = i
                        i += 1
                        cj = j0 + wp.max(wp.max(edge_lo(ef0, sj0, nrow), edge_lo(ef1, sj1, nrow)), edge_lo(ef2, sj2, nrow))
                        ce = j0 + wp.min(wp.min(edge_hi(ef0, sj0, nrow), edge_hi(ef1, sj1, nrow)), edge_hi(ef2, sj2, nrow))
                        ef0, er0 = edge_next(ef0, er0, eq0, es0, ed0)
                        ef1, er1 = edge_next(ef1, er1, eq1, es1, ed1)
                        ef2, er2 = edge_next(ef2, er2, eq2, es2, ed2)
                        if term and done > 0 and cj <= ce:  # the run all terminated: skipped without a fragment
                            rr = rows0 + ci - rect[1]
                            if span_done(fo.done_rows, rr, rr, cj - rect[0], ce - rect[0]):
                                nskip += ce - cj + 1
                                cj = ce + 1
                        continue
                    take = wp.min(L - n, ce - cj + 1)  # the run's next pixels (a terminated one: skipped below)
                    for l in range(L):  # lanes n .. n + take - 1 (all lanes: a counted loop)
                        sel = l >= n and l < n + take
                        ii[l] = wp.where(sel, ci, ii[l])
                        jj[l] = wp.where(sel, cj + l - n, jj[l])
                    n += take
                    cj += take
                if n == 0:
                    break
                il = ii[n - 1]
                jl = jj[n - 1]
                for l in range(L):  # lanes past the fragments: the last one's pixel (dropped)
                    ii[l] = wp.where(l >= n, il, ii[l])
                    jj[l] = wp.where(l >= n, jl, jj[l])
                sfv = lanef()
                sbv = lanef()
                lv = lanef()
                flag = lanei()  # 1 outside the unsnapped triangle, 2 zero segment, 4 clamp moved
                # 1. attributes, inside test, clamp, (sf, sb, l), zero test
                for l in range(L):
                    j = jj[l]
                    tx = float(j) + 0.5 - pa[0]
                    dy = float(ii[l]) + 0.5 - pa[1]
                    x0 = plane1(a0[0], gx[0], tx, gy[0] * dy)
                    x1 = plane1(a0[1], gx[1], tx, gy[1] * dy)
                    x2 = plane1(a0[2], gx[2], tx, gy[2] * dy)
                    x3 = plane1(a0[3], gx[3], tx, gy[3] * dy)
                    x4 = plane1(a0[4], gx[4], tx, gy[4] * dy)
                    x5 = plane1(a0[5], gx[5], tx, gy[5] * dy)
                    x6 = plane1(a0[6], gx[6], tx, gy[6] * dy)
                    x7 = plane1(a0[7], gx[7], tx, gy[7] * dy)
                    b1 = (tx * vy - dy * vx) / den
                    b2 = (dy * ux - tx * uy) / den
                    outside = den != 0.0 and not (b1 >= 0.0 and b2 >= 0.0 and 1.0 - b1 - b2 >= 0.0)
                    y0 = clamp1(x0, lo[0], hi[0])
                    y1 = clamp1(x1, lo[1], hi[1])
                    y2 = clamp1(x2, lo[2], hi[2])
                    y3 = clamp1(x3, lo[3], hi[3])
                    y4 = clamp1(x4, lo[4], hi[4])
                    y5 = clamp1(x5, lo[5], hi[5])
                    y6 = clamp1(x6, lo[6], hi[6])
                    y7 = clamp1(x7, lo[7], hi[7])
                    mv = (moved1(x0, y0, tol[0]) | moved1(x1, y1, tol[1]) | moved1(x2, y2, tol[2])
                          | moved1(x3, y3, tol[3]) | moved1(x4, y4, tol[4]) | moved1(x5, y5, tol[5])
                          | moved1(x6, y6, tol[6]) | moved1(x7, y7, tol[7]))
                    wf = 1.0 / y2
                    wb = 1.0 / y3
                    lp = wp.abs(y7 * wb - y6 * wf)
                    lp = wp.where(per_ray, lp * fi.ray_len[wp.where(per_ray, ii[l], 0), wp.where(per_ray, j, 0)], lp)
                    sf = wp.where(persp, y0 * wf, y0)
                    sb = wp.where(persp, y1 * wb, y1)
                    ln = wp.where(persp, lp, y2)
                    zero = (sf <= zero_lo and sb <= zero_lo) or (sf >= zero_hi and sb >= zero_hi)
                    sfv[l] = sf
                    sbv[l] = sb
                    lv[l] = ln
                    flag[l] = wp.where(outside, 1, 0) | wp.where(zero, 2, 0) | (mv * 4)
                # 2. the TF interval of each end (tf_upper's result: the points not above the scalar, counted) and
                #    the control points around it (k - 1 and k, clamped into the TF), selected, not loaded
                kfv = lanei(m_lo)
                kbv = lanei(m_lo)
                fs0, fr0, fg0, fb0, fa0, bs0, br0, bg0, bb0, ba0 = point_lanes(fi.tf_s, fi.tf_flat, p0)
                for m in range(m_lo, m_hi):
                    sm = fi.tf_s[m]
                    vr = fi.tf_flat[4 * m]
                    vg = fi.tf_flat[4 * m + 1]
                    vb = fi.tf_flat[4 * m + 2]
                    va = fi.tf_flat[4 * m + 3]
                    for l in range(L):
                        fin = not (sm > sfv[l])
                        kfv[l] = kfv[l] + wp.where(fin, 1, 0)
                        fs0[l] = wp.where(fin, sm, fs0[l])
                        fr0[l] = wp.where(fin, vr, fr0[l])
                        fg0[l] = wp.where(fin, vg, fg0[l])
                        fb0[l] = wp.where(fin, vb, fb0[l])
                        fa0[l] = wp.where(fin, va, fa0[l])
                        bin_ = not (sm > sbv[l])
                        kbv[l] = kbv[l] + wp.where(bin_, 1, 0)
                        bs0[l] = wp.where(bin_, sm, bs0[l])
                        br0[l] = wp.where(bin_, vr, br0[l])
                        bg0[l] = wp.where(bin_, vg, bg0[l])
                        bb0[l] = wp.where(bin_, vb, bb0[l])
                        ba0[l] = wp.where(bin_, va, ba0[l])
                fs1, fr1, fg1, fb1, fa1, bs1, br1, bg1, bb1, ba1 = point_lanes(fi.tf_s, fi.tf_flat, p1)
                for mm in range(m_hi - m_lo):
                    m = m_hi - 1 - mm  # descending: the last above the scalar selected is the first
                    sm = fi.tf_s[m]
                    vr = fi.tf_flat[4 * m]
                    vg = fi.tf_flat[4 * m + 1]
                    vb = fi.tf_flat[4 * m + 2]
                    va = fi.tf_flat[4 * m + 3]
                    for l in range(L):
                        fab = sm > sfv[l]
                        fs1[l] = wp.where(fab, sm, fs1[l])
                        fr1[l] = wp.where(fab, vr, fr1[l])
                        fg1[l] = wp.where(fab, vg, fg1[l])
                        fb1[l] = wp.where(fab, vb, fb1[l])
                        fa1[l] = wp.where(fab, va, fa1[l])
                        bab = sm > sbv[l]
                        bs1[l] = wp.where(bab, sm, bs1[l])
                        br1[l] = wp.where(bab, vr, br1[l])
                        bg1[l] = wp.where(bab, vg, bg1[l])
                        bb1[l] = wp.where(bab, vb, bb1[l])
                        ba1[l] = wp.where(bab, va, ba1[l])
                # 3. TF values and the thin one-piece integral (integrate_piece's, then exact_color's alpha)
                cr = lanef()
                cg = lanef()
                cb = lanef()
                ca = lanef()
                slow = lanei()
                for l in range(L):
                    sf3 = sfv[l]
                    sb3 = sbv[l]
                    kf = kfv[l]
                    kb = kbv[l]
                    h = wp.max(lv[l], 0.0)
                    fe = kf == 0 or kf >= ntf  # tf_eval_upper's ends: the end point's value
                    wfr = wp.clamp((sf3 - fs0[l]) / (fs1[l] - fs0[l]), 0.0, 1.0)
                    f0 = wp.where(fe, fr1[l], fr0[l] * (1.0 - wfr) + fr1[l] * wfr)
                    f1 = wp.where(fe, fg1[l], fg0[l] * (1.0 - wfr) + fg1[l] * wfr)
                    f2 = wp.where(fe, fb1[l], fb0[l] * (1.0 - wfr) + fb1[l] * wfr)
                    f3 = wp.where(fe, fa1[l], fa0[l] * (1.0 - wfr) + fa1[l] * wfr)
                    be = kb == 0 or kb >= ntf
                    wbk = wp.clamp((sb3 - bs0[l]) / (bs1[l] - bs0[l]), 0.0, 1.0)
                    g0 = wp.where(be, br1[l], br0[l] * (1.0 - wbk) + br1[l] * wbk)
                    g1 = wp.where(be, bg1[l], bg0[l] * (1.0 - wbk) + bg1[l] * wbk)
                    g2 = wp.where(be, bb1[l], bb0[l] * (1.0 - wbk) + bb1[l] * wbk)
                    g3 = wp.where(be, ba1[l], ba0[l] * (1.0 - wbk) + ba1[l] * wbk)
                    aa = h * f3
                    bb = h * (g3 - f3)
                    tau = 0.5 * h * (f3 + g3)
                    z0 = GL3_X0 * aa + (0.5 * GL3_X0 * GL3_X0) * bb
                    z1 = 0.5 * aa + 0.125 * bb
                    z2 = GL3_X2 * aa + (0.5 * GL3_X2 * GL3_X2) * bb
                    # color_extinction
                    om = GL3_W0 * (one_minus_exp_neg_thin(z0) + one_minus_exp_neg_thin(z2)) \
                        + GL3_W1 * one_minus_exp_neg_thin(z1)
                    tt = one_minus_exp_neg_thin(tau) - om
                    # emission_density
                    w0 = exp_neg_thin(z0) * GL3_W0
                    w1 = exp_neg_thin(z1) * GL3_W1
                    w2 = exp_neg_thin(z2) * GL3_W0
                    m0 = w0 + w1 + w2
                    m1 = GL3_X0 * w0 + 0.5 * w1 + GL3_X2 * w2
                    r0 = wp.where(model == 0, g0 * tt + f0 * om, (f0 * (m0 - m1) + g0 * m1) * h)
                    r1 = wp.where(model == 0, g1 * tt + f1 * om, (f1 * (m0 - m1) + g1 * m1) * h)
                    r2 = wp.where(model == 0, g2 * tt + f2 * om, (f2 * (m0 - m1) + g2 * m1) * h)
                    some = h > 0.0
                    # rare: a control point inside the segment, an optically thick piece, too many control points
                    # to count, and for emission_density a Gauss node past exp_neg's polynomial (no if: one loop)
                    thin_nodes = wp.where(z0 <= THIN_DEPTH, 1, 0) & wp.where(z1 <= THIN_DEPTH, 1, 0) \
                        & wp.where(z2 <= THIN_DEPTH, 1, 0)
                    rare = wp.where(kf != kb, 1, 0) | wp.where(tau <= THIN_DEPTH, 0, 1) | wp.where(many, 1, 0) \
                        | (wp.where(model != 0, 1, 0) & (1 - thin_nodes))
                    slow[l] = wp.where(some, rare, 0)
                    cr[l] = wp.where(some, r0, 0.0)
                    cg[l] = wp.where(some, r1, 0.0)
                    cb[l] = wp.where(some, r2, 0.0)
                    ca[l] = 1.0 - exp_neg_thin(wp.where(some, tau, 0.0))
                # 4. per pixel, in order: termination, counters, rare fragments, blend
                for l in range(n):
                    ip = ii[l]
                    jp = jj[l]
                    d = fb[ip, jp]
                    if term and 1.0 - d[3] <= t_min:  # terminated: no more fragments
                        nskip += 1
                        continue
                    fl = flag[l]
                    c = wp.vec4(cr[l], cg[l], cb[l], ca[l])
                    if (fl & 1) != 0:  # outside the unsnapped triangle: the one-fragment kernel's functions, whole
                        ry = gy * (float(ip) + 0.5 - pa[1])
                        xx = nearest_on_triangle(pa, pb, pc, a0, a1, a2, float(jp) + 0.5, float(ip) + 0.5,
                                                 a0 + gx * (float(jp) + 0.5 - pa[0]) + ry)
                        ac, moved = clamp8(xx, lo, hi, tol)
                        factor = float(1.0)
                        if per_ray:
                            factor = fi.ray_len[ip, jp]
                        seg = sfsbl_ray(ac, mode, fi.ortho, factor)
                        if (seg[0] <= zero_lo and seg[1] <= zero_lo) or (seg[0] >= zero_hi and seg[1] >= zero_hi):
                            nzero += 1
                            continue
                        nclamp += moved
                        c = exact_color(seg, fi.tf_s, fi.tf_v, model)
                    else:
                        if (fl & 2) != 0:
                            nzero += 1
                            continue
                        nclamp += (fl >> 2) & 1
                        if slow[l] != 0:  # a control point inside, optically thick: exact_color on the lane's segment
                            seg = wp.vec3(sfv[l], sbv[l], lv[l])
                            if many:
                                c = exact_color(seg, fi.tf_s, fi.tf_v, model)
                            else:  # the lane's TF intervals and values: no search
                                tvf = tf_lane_value(sfv[l], kfv[l], ntf, fs0[l], fs1[l], fr0[l], fg0[l], fb0[l], fa0[l],
                                                   fr1[l], fg1[l], fb1[l], fa1[l])
                                tvb = tf_lane_value(sbv[l], kbv[l], ntf, bs0[l], bs1[l], br0[l], bg0[l], bb0[l], ba0[l],
                                                   br1[l], bg1[l], bb1[l], ba1[l])
                                c = exact_color_upper(seg, kfv[l], kbv[l], tvf, tvb, fi.tf_s, fi.tf_v, model)
                    nfrag += 1
                    d = blend_by(bkind, bs, c, d, jp, ip, t)
                    fb[ip, jp] = d
                    if term and 1.0 - d[3] <= t_min:
                        done += 1
                        rr = rows0 + ip - rect[1]
                        fo.done_rows[rr] = fo.done_rows[rr] | (wp.uint64(1) << wp.uint64(jp - rect[0]))
                        fo.term_at[ip, jp] = tet0 + t / 4
        fo.counts[tile] = wp.vec2i(nfrag, nclamp)
        fo.skipped[tile] = wp.vec2i(nskip, ntail)
        fo.occluded[tile] = wp.vec3i(nocc, nzero, nzt)

    return k_pt_span_tiles


_KERNELS: dict = {}


def span_kernel_cached(lanes: int):
    """:func:`span_kernel` built once per lane count."""
    k = _KERNELS.get(int(lanes))
    if k is None:
        k = _KERNELS[int(lanes)] = span_kernel(lanes)
    return k
