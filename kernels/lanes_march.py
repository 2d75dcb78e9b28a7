"""``raycast``'s march pass with ``LANES`` rays per thread: the lane kernel of :mod:`warpvol.kernels.lanes`.

:func:`make_march_lanes` builds, per lane count, a kernel that makes what
:func:`warpvol.kernels.raycast.make_march`'s pass makes -- the same images, counters and float64 redo marks, bit for
bit (tests/test_march_lanes.py). Lane ``j`` of a thread walks its rays one after the other (entries, write-backs
and re-entries scalar: :func:`~warpvol.kernels.lanes.make_lane_io`); all lanes take one step per pass of a
counted, branch-free ``for j in range(LANES)`` loop over lane matrices (a row per state variable, a column per
lane), which LLVM vectorises. A thick piece (libm's ``exp``), a TF control point crossed and a step out of the mesh
take the loop's walk and finish after it, one lane at a time, in the scalar walk's functions; a rare step (an
exact-zero edge side, no exit face, no progress, a clipped segment, a check that fires) is redone in
:func:`~warpvol.kernels.lanes.lane_step` on the lane's ``scratch`` record. Array reads sit in loops of their own
(in the arithmetic loop LLVM cannot bound them against the lane matrices' stores), and the matrices are read and
written by element in the kernel only (passed to a function they would escape). The kernel keeps no struct
variable: one assigned in its loops is copied on every pass (a ``LaneState`` ``memcpy`` per lane and pass was a
third of the march); a lane's state moves field by field between the matrices and ``scratch``.
"""

import warp as wp

from .cellwalk import CellMesh, RayCamera, Segments, WalkOpts, add_under_tr
from .harc_integ import Integ
from .integrate import (
    GL3_W0,
    GL3_W1,
    GL3_X0,
    GL3_X2,
    THIN_DEPTH,
    exp_neg,
    exp_neg_thin,
    flat_extinction,
    integrate_piece_flat,
    integrate_segment_tf,
    one_minus_exp_neg_thin,
)
from .lanes import LANE_OPTIONS, LANE_RUNS, FlatMesh, LaneState, lane_exit_at, lane_step_at, thin_prev
from .lanes_types import lane_io, lane_mats, made_once
from .tf import tf_eval_upper, tf_upper_from
from .walk import EPS32, STALL_STEPS, STEEP_ERR, THIN_ULPS, scalar_step, spread_error, thin_step, thin_unresolved

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


def make_march_lanes(lanes: int, segs: bool = False, harc: bool = False):
    """The pass kernel of :func:`warpvol.kernels.raycast.make_march` with ``lanes`` rays per thread (a module of
    its own per lane count: ``LANES`` is a compile-time constant); use :func:`march_lanes_kernel`. ``harc``: the pass
    of :func:`warpvol.kernels.harc.make_march`'s consistent walk with exact segments instead (``harc_best``), its ray
    start and write-back from :func:`warpvol.kernels.harc_lanes.make_harc_lane_io`. The kernel's ray start and
    write-back inputs, by configuration: :class:`~warpvol.kernels.lanes_types.LaneIO`."""
    LANES = lanes
    RUNS = LANE_RUNS
    lane_next, lane_done, StartsT, ColT, AuxT, MoreT = lane_io(LANES, segs, harc)  # (kernels/lanes_types.py)
    FFm, FGm, SFm, SIm, RVv, TFm, TIm, GIm, FLm, GVm = lane_mats(LANES)

    @wp.kernel(module="unique", module_options=LANE_OPTIONS)
    def march_lanes(cam: RayCamera, mesh: CellMesh, starts: StartsT, ig: Integ, opts: WalkOpts, first: int,
                    ids: wp.array(dtype=wp.int32), col: ColT, aux: AuxT, tcur: wp.array(dtype=float),
                    status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32), more: MoreT,
                    counters: wp.array2d(dtype=wp.int32), chunk: int, sg: Segments, count: int,
                    scratch: wp.array(dtype=LaneState), fm: FlatMesh):
        """The pass of :func:`~warpvol.kernels.raycast.make_march` for the rays ``first + LANES RUNS tid ..``
        (``< first + count``): lane ``j`` walks the thread's rays ``j, j + LANES, ..`` one after the other (its entry,
        its walk in the lane loop, its write-back and re-entries, scalar, up to ``more``; harc: none), all lanes one step
        per pass of the lane loop."""
        tid = wp.tid()
        base = first + tid * (LANES * RUNS)
        end = first + count
        scale = float(cam.radius)
        FF = FFm()
        FG = FGm()
        SF = SFm()
        SI = SIm()
        RV = RVv()
        RT = RVv()
        RX = RVv()  # the lanes whose step leaves the mesh (its exit checks after the lane loop)
        RC = RVv()  # the lanes whose step crosses a TF control point (its integral after the lane loop)
        KP = RVv()  # the lanes whose TF piece the next pass loads
        LD = RVv()  # the lanes whose state the next pass loads from scratch (a first entry, a rare step)
        FN = RVv()  # the lanes whose ray is still to be written back
        SL = RVv()  # each lane's ray: its place in the pass (first + ..)
        lane0 = (first // (LANES * RUNS) + tid + chunk) * LANES  # the thread's lanes in scratch: lane0 + j
        TF = TFm()
        TI = TIm()
        GI = GIm()
        FL = FLm()
        GV = GVm()
        lim = wp.min(end, base + LANES * RUNS)
        for j in range(LANES):
            slot = lane_next(scratch, lane0 + j, base + j, lim, ids, cam, mesh, starts, ig, opts, col, aux, tcur, status, last,
                             more, counters, chunk, sg)
            if slot >= 0:
                SL[j] = slot
                LD[j] = 1
                FN[j] = 1
        n_tf = ig.tf_s.shape[0]
        model = ig.model
        check = opts.scalar_check
        t_stop = opts.t_stop
        max_steps = opts.max_steps
        m_tets = fm.tets  # (the arrays as locals: a struct field's array read in the lane loop is an aggregate load)
        m_verts = fm.verts
        m_nbr = fm.nbr
        m_nbrv = fm.nbr_vertex
        busy = int(1)
        while busy > 0:
            # ---- the lanes' state from scratch after a first entry or a rare step (field by field) ----
            for j in range(LANES):
                if LD[j] == 1:
                    LD[j] = 0
                    slot = lane0 + j
                    for i in range(3):
                        FF[i, j] = scratch[slot].fc.pa[i]
                        FF[3 + i, j] = scratch[slot].fc.pb[i]
                        FF[6 + i, j] = scratch[slot].fc.pc[i]
                        FF[9 + i, j] = scratch[slot].fc.h[i]
                        FF[12 + i, j] = scratch[slot].fc.ma[i]
                        FF[15 + i, j] = scratch[slot].fc.mb[i]
                        FF[18 + i, j] = scratch[slot].fc.mc[i]
                        FF[21 + i, j] = scratch[slot].fc.s[i]
                        FF[24 + i, j] = scratch[slot].fc.w[i]
                        FG[i, j] = scratch[slot].fc.g[i]
                        SF[20 + i, j] = scratch[slot].r.o[i]
                        SF[23 + i, j] = scratch[slot].r.d[i]
                    for i in range(4):
                        SF[2 + i, j] = scratch[slot].acc[i]
                        SF[6 + i, j] = scratch[slot].own[i]
                        SF[10 + i, j] = scratch[slot].v_in[i]
                    SF[0, j] = scratch[slot].t_in
                    SF[1, j] = scratch[slot].s_in
                    SF[14, j] = scratch[slot].ds_in
                    SF[15, j] = scratch[slot].scal_err
                    SF[16, j] = scratch[slot].thin_mem.d
                    SF[17, j] = scratch[slot].thin_mem.dmax
                    SF[18, j] = scratch[slot].thin_mem.tr
                    SF[19, j] = scratch[slot].thin_mem.u
                    SF[26, j] = scratch[slot].t_clip
                    SI[0, j] = scratch[slot].cell
                    SI[1, j] = scratch[slot].gn
                    SI[2, j] = scratch[slot].cells
                    SI[3, j] = scratch[slot].stall
                    SI[4, j] = scratch[slot].k_in
                    SI[5, j] = scratch[slot].thin_mem.is_short
                    SI[6, j] = scratch[slot].walking
                    lo_ = wp.vec3(SF[20, j], SF[21, j], SF[22, j])  # the face's lengths (werr), kept while it moves
                    la_ = wp.vec3(FF[0, j], FF[1, j], FF[2, j])
                    lb_ = wp.vec3(FF[3, j], FF[4, j], FF[5, j])
                    lc_ = wp.vec3(FF[6, j], FF[7, j], FF[8, j])
                    FF[27, j] = wp.length(la_ - lo_)
                    FF[28, j] = wp.length(lb_ - lo_)
                    FF[29, j] = wp.length(lc_ - lo_)
                    FF[30, j] = wp.length(lb_ - la_)
                    FF[31, j] = wp.length(lc_ - lb_)
                    FF[32, j] = wp.length(la_ - lc_)
                    KP[j] = 1
                if KP[j] == 1:
                    KP[j] = 0
                    k_in = SI[4, j]
                    kl_ = wp.max(k_in - 1, 0)  # the lane's TF piece: its control points' scalars and values
                    kh_ = wp.min(k_in, n_tf - 1)
                    SF[27, j] = ig.tf_s[kl_]
                    SF[28, j] = ig.tf_s[kh_]
                    SF[29, j] = fm.tf_v[4 * kl_]
                    SF[30, j] = fm.tf_v[4 * kl_ + 1]
                    SF[31, j] = fm.tf_v[4 * kl_ + 2]
                    SF[32, j] = fm.tf_v[4 * kl_ + 3]
                    SF[33, j] = fm.tf_v[4 * kh_]
                    SF[34, j] = fm.tf_v[4 * kh_ + 1]
                    SF[35, j] = fm.tf_v[4 * kh_ + 2]
                    SF[36, j] = fm.tf_v[4 * kh_ + 3]
                    dh_ = wp.where(model == 1, SF[36, j] + wp.max(SF[33, j], wp.max(SF[34, j], SF[35, j])), SF[36, j])
                    dl_ = wp.where(model == 1, SF[32, j] + wp.max(SF[29, j], wp.max(SF[30, j], SF[31, j])), SF[32, j])
                    SF[37, j] = wp.abs(dh_ - dl_) / (SF[28, j] - SF[27, j])  # the piece's density slope
            # ---- one step of every walking lane, the common case in lane form ----
            for j in range(LANES):  # the lanes' cell records and new vertex (loads: a loop of their own)
                c4 = 4 * SI[0, j]
                v4 = 4 * SI[1, j]
                GI[0, j] = m_tets[c4]
                GI[1, j] = m_tets[c4 + 1]
                GI[2, j] = m_tets[c4 + 2]
                GI[3, j] = m_tets[c4 + 3]
                GV[0, j] = m_verts[v4]
                GV[1, j] = m_verts[v4 + 1]
                GV[2, j] = m_verts[v4 + 2]
                GV[3, j] = m_verts[v4 + 3]
            for j in range(LANES):
                walk = SI[6, j]
                cell = SI[0, j]
                gn = SI[1, j]
                stall = SI[3, j]
                k_in = SI[4, j]
                ok_steps = SI[2, j] < max_steps
                tv0 = GI[0, j]
                tv1 = GI[1, j]
                tv2 = GI[2, j]
                tv3 = GI[3, j]
                pn = wp.vec3(GV[0, j], GV[1, j], GV[2, j])
                sn = GV[3, j]
                o = wp.vec3(SF[20, j], SF[21, j], SF[22, j])
                d = wp.vec3(SF[23, j], SF[24, j], SF[25, j])
                q = pn - o
                hn = wp.dot(q, d)
                mn = wp.cross(d, q)
                pa = wp.vec3(FF[0, j], FF[1, j], FF[2, j])
                pb = wp.vec3(FF[3, j], FF[4, j], FF[5, j])
                pc = wp.vec3(FF[6, j], FF[7, j], FF[8, j])
                ma = wp.vec3(FF[12, j], FF[13, j], FF[14, j])
                mb = wp.vec3(FF[15, j], FF[16, j], FF[17, j])
                mc = wp.vec3(FF[18, j], FF[19, j], FF[20, j])
                h0 = FF[9, j]
                h1 = FF[10, j]
                h2 = FF[11, j]
                s0 = FF[21, j]
                s1 = FF[22, j]
                s2 = FF[23, j]
                w0 = FF[24, j]
                w1 = FF[25, j]
                w2 = FF[26, j]
                g0 = FG[0, j]
                g1 = FG[1, j]
                g2 = FG[2, j]
                # oriented_side of the edges N -> A, N -> B, N -> C (an exact zero: the rare path's tie-break)
                ea1 = wp.dot(pa - pn, mn)
                ea2 = wp.dot(pn - pa, ma)
                eb1 = wp.dot(pb - pn, mn)
                eb2 = wp.dot(pn - pb, mb)
                ec1 = wp.dot(pc - pn, mn)
                ec2 = wp.dot(pn - pc, mc)
                na = wp.where(gn < g0, ea1, -ea2)
                nb_ = wp.where(gn < g1, eb1, -eb2)
                nc = wp.where(gn < g2, ec1, -ec2)
                rare = na == 0.0 or nb_ == 0.0 or nc == 0.0
                # the three candidate exit faces (face_cross), the first crossed one wins
                wab = na
                wbc = w0
                wca = -nb_
                ss1 = wab + wbc + wca
                ok1 = not (wab < 0.0 or wbc < 0.0 or wca < 0.0 or not (ss1 > 0.0))
                wab2 = nb_
                wbc2 = w1
                wca2 = -nc
                ss2 = wab2 + wbc2 + wca2
                ok2 = not (wab2 < 0.0 or wbc2 < 0.0 or wca2 < 0.0 or not (ss2 > 0.0))
                wab3 = nc
                wbc3 = w2
                wca3 = -na
                ss3 = wab3 + wbc3 + wca3
                ok3 = not (wab3 < 0.0 or wbc3 < 0.0 or wca3 < 0.0 or not (ss3 > 0.0))
                rare = rare or not (ok1 or ok2 or ok3)
                # the exit face (N, X, Y) and the vertex it leaves out (its local index is the exit's)
                c2 = (not ok1) and ok2
                gx = wp.where(ok1, g0, wp.where(c2, g1, g2))
                gy = wp.where(ok1, g1, wp.where(c2, g2, g0))
                gz = wp.where(ok1, g2, wp.where(c2, g0, g1))
                px = wp.vec3(wp.where(ok1, pa[0], wp.where(c2, pb[0], pc[0])),
                              wp.where(ok1, pa[1], wp.where(c2, pb[1], pc[1])),
                              wp.where(ok1, pa[2], wp.where(c2, pb[2], pc[2])))
                py_ = wp.vec3(wp.where(ok1, pb[0], wp.where(c2, pc[0], pa[0])),
                              wp.where(ok1, pb[1], wp.where(c2, pc[1], pa[1])),
                              wp.where(ok1, pb[2], wp.where(c2, pc[2], pa[2])))
                mx = wp.vec3(wp.where(ok1, ma[0], wp.where(c2, mb[0], mc[0])),
                              wp.where(ok1, ma[1], wp.where(c2, mb[1], mc[1])),
                              wp.where(ok1, ma[2], wp.where(c2, mb[2], mc[2])))
                my = wp.vec3(wp.where(ok1, mb[0], wp.where(c2, mc[0], ma[0])),
                              wp.where(ok1, mb[1], wp.where(c2, mc[1], ma[1])),
                              wp.where(ok1, mb[2], wp.where(c2, mc[2], ma[2])))
                hx = wp.where(ok1, h0, wp.where(c2, h1, h2))
                hy = wp.where(ok1, h1, wp.where(c2, h2, h0))
                sxv = wp.where(ok1, s0, wp.where(c2, s1, s2))
                syv = wp.where(ok1, s1, wp.where(c2, s2, s0))
                wn0 = wp.where(ok1, na, wp.where(c2, nb_, nc))
                wn1 = wp.where(ok1, w0, wp.where(c2, w1, w2))
                wn2 = wp.where(ok1, -nb_, wp.where(c2, -nc, -na))
                # the crossing (face_cross) on the exit face only: its inputs selected, one division, same bits
                wsum = wn0 + wn1 + wn2
                inv = 1.0 / wsum
                mx_ = wp.min(sn, wp.min(sxv, syv))
                s_out = mx_ + ((sn - mx_) * wn1 + (sxv - mx_) * wn2 + (syv - mx_) * wn0) * inv
                t_out = (hn * wn1 + hx * wn2 + hy * wn0) * inv
                f_out = wp.where(tv3 == gz, 3, wp.where(tv2 == gz, 2, wp.where(tv1 == gz, 1, wp.where(tv0 == gz, 0, -1))))
                rare = rare or f_out < 0
                GI[4, j] = wp.max(f_out, 0)  # (its neighbour records after this loop)
                # monotone_exit
                t_in = SF[0, j]
                s_in = SF[1, j]
                adv = t_out > t_in
                t_out = wp.where(adv, t_out, t_in)
                stall = wp.where(adv, 0, stall + 1)
                rare = rare or stall > STALL_STEPS
                # the TF at the exit: the same piece as at the entry (else rare: a control point crossed)
                ts_lo = SF[27, j]
                ts_hi = SF[28, j]
                cross = not ((k_in >= n_tf or ts_hi > s_out) and (k_in == 0 or not (ts_lo > s_out)))
                wt = wp.clamp((s_out - ts_lo) / (ts_hi - ts_lo), 0.0, 1.0)
                wl = 1.0 - wt
                lo0 = SF[29, j]
                lo1 = SF[30, j]
                lo2 = SF[31, j]
                lo3 = SF[32, j]
                hi0 = SF[33, j]
                hi1 = SF[34, j]
                hi2 = SF[35, j]
                hi3 = SF[36, j]
                k_first = k_in == 0  # tf_eval_upper's end values: the first or the last control point's
                k_last = k_in >= n_tf
                vo0 = wp.where(k_first, lo0, wp.where(k_last, hi0, lo0 * wl + hi0 * wt))
                vo1 = wp.where(k_first, lo1, wp.where(k_last, hi1, lo1 * wl + hi1 * wt))
                vo2 = wp.where(k_first, lo2, wp.where(k_last, hi2, lo2 * wl + hi2 * wt))
                vo3 = wp.where(k_first, lo3, wp.where(k_last, hi3, lo3 * wl + hi3 * wt))
                v_out = wp.vec4(vo0, vo1, vo2, vo3)
                v_in = wp.vec4(SF[10, j], SF[11, j], SF[12, j], SF[13, j])
                t_clip = SF[26, j]
                rare = rare or not (t_in >= t_clip and t_out > t_clip)
                chk = False  # the one-piece checks (thin layer, scalar error): they fire on a rare step
                # integrate_piece, optically thin (else rare)
                tr = SF[5, j]
                ln = t_out - t_in
                r0 = v_in[3]
                dr = v_out[3] - r0
                pa_ = ln * r0
                pb_ = ln * dr
                tau_total = 0.5 * ln * (v_in[3] + v_out[3])
                x0 = GL3_X0 * pa_ + (0.5 * GL3_X0 * GL3_X0) * pb_
                x1 = 0.5 * pa_ + 0.125 * pb_
                x2 = GL3_X2 * pa_ + (0.5 * GL3_X2 * GL3_X2) * pb_
                cc0 = wp.vec3(v_in[0], v_in[1], v_in[2])
                cc1 = wp.vec3(v_out[0], v_out[1], v_out[2])
                om = GL3_W0 * (one_minus_exp_neg_thin(x0) + one_minus_exp_neg_thin(x2)) \
                    + GL3_W1 * one_minus_exp_neg_thin(x1)
                rr0 = cc1 * (one_minus_exp_neg_thin(tau_total) - om) + cc0 * om
                ew0 = exp_neg_thin(x0) * GL3_W0
                ew1 = exp_neg_thin(x1) * GL3_W1
                ew2 = exp_neg_thin(x2) * GL3_W0
                mm0 = ew0 + ew1 + ew2
                mm1 = GL3_X0 * ew0 + 0.5 * ew1 + GL3_X2 * ew2
                rr1 = (cc0 * (mm0 - mm1) + cc1 * mm1) * ln
                m0_ = model == 0
                positive = not (ln <= 0.0)
                # an optically thick piece: its integral (and exp) in integrate_piece_flat after the lane loop
                thick = positive and (not (tau_total <= THIN_DEPTH) or (model != 0 and not (
                    x0 <= THIN_DEPTH and x1 <= THIN_DEPTH and x2 <= THIN_DEPTH)))
                seg = wp.vec4(wp.where(positive, wp.where(m0_, rr0[0], rr1[0]), 0.0),
                              wp.where(positive, wp.where(m0_, rr0[1], rr1[1]), 0.0),
                              wp.where(positive, wp.where(m0_, rr0[2], rr1[2]), 0.0), wp.where(positive, tau_total, 0.0))
                # thin_step (one piece: k_in == k_out)
                u = EPS32 * (wp.abs(t_out) + scale)
                den_in = wp.where(model == 1, v_in[3] + wp.max(v_in[0], wp.max(v_in[1], v_in[2])), v_in[3])
                den_out = wp.where(model == 1, v_out[3] + wp.max(v_out[0], wp.max(v_out[1], v_out[2])), v_out[3])
                d_mean = 0.5 * (den_in + den_out)
                short = ln < THIN_ULPS * u
                dmax = wp.max(den_in, den_out)
                chk = short and thin_unresolved(tr, dmax, SF[16, j], u)
                chk = chk or (SI[5, j] == 1 and thin_unresolved(SF[18, j], SF[17, j], d_mean, SF[19, j]))
                # the crossing's scalar error (scalar_error_if) and the walk's bound (scalar_step, one piece)
                ln_ = wp.length(pn - o)  # |N - o|, |X - N|, |N - Y|; |X - o|, |Y - o|, |Y - X| kept from earlier steps
                lx = wp.where(ok1, FF[27, j], wp.where(c2, FF[28, j], FF[29, j]))
                ly = wp.where(ok1, FF[28, j], wp.where(c2, FF[29, j], FF[27, j]))
                exn = wp.length(px - pn)
                exy = wp.where(ok1, FF[30, j], wp.where(c2, FF[31, j], FF[32, j]))
                eyn = wp.length(pn - py_)
                werr = EPS32 * (exn * ln_ + exy * lx + eyn * ly)
                rel = wp.where(wsum > 0.0, werr / wsum, 1.0e30)
                sf_v = wp.vec3(sn, sxv, syv)
                ds_out = wp.where(check == 0, 0.0, spread_error(sf_v, rel))
                ds_in = SF[14, j]
                err = SF[15, j]
                err_new = err + tr * ln * 0.5 * SF[37, j] * (ds_in + ds_out)
                err_new = wp.where((ds_in == 0.0 and ds_out == 0.0) or k_in <= 0 or k_in >= n_tf, err, err_new)
                chk = chk or err_new > STEEP_ERR
                rare = rare or (chk and not cross)
                e = exp_neg_thin(seg[3])
                # add_under_tr, written out (a call the inliner leaves in this loop keeps it from vectorising)
                tr_o = SF[9, j]
                acc = wp.vec4(SF[2, j] + tr * seg[0], SF[3, j] + tr * seg[1], SF[4, j] + tr * seg[2], tr * e)
                own = wp.vec4(SF[6, j] + tr_o * seg[0], SF[7, j] + tr_o * seg[1], SF[8, j] + tr_o * seg[2], tr_o * e)
                stop = acc[3] < t_stop
                active = walk == 1 and ok_steps
                go = active and not rare
                gq = go and not cross  # (a crossing: its TF, integral, checks and stop after the lane loop)
                gt = gq and thick  # (its colour, transmittance and stop after the lane loop)
                gn_ = gq and not thick
                RV[j] = wp.where(active and rare, 1, 0)
                RT[j] = wp.where(gt, 1, 0)
                RC[j] = wp.where(go and cross, 1, 0)
                FL[0, j] = wp.where(go, 1, 0)
                FL[1, j] = wp.where(gn_, 1, 0)
                FL[2, j] = wp.where(gn_ and not stop, 1, 0)
                SI[6, j] = wp.where((walk == 1 and not ok_steps) or (gn_ and stop), 0, walk)
                # ---- commit the step of the lanes that took it ----
                TF[0, j] = ln
                TF[1, j] = v_in[0]
                TF[2, j] = v_in[1]
                TF[3, j] = v_in[2]
                TF[4, j] = v_in[3]
                TF[5, j] = ds_out
                TF[6, j] = s_out
                TF[7, j] = t_out
                SI[2, j] = wp.where(go, SI[2, j] + 1, SI[2, j])
                SI[3, j] = wp.where(go, stall, SI[3, j])
                SI[5, j] = wp.where(gq, wp.where(short, 1, 0), SI[5, j])
                SF[0, j] = wp.where(gq, t_out, t_in)
                SF[1, j] = wp.where(gq, s_out, s_in)
                SF[2, j] = wp.where(gn_, acc[0], SF[2, j])
                SF[6, j] = wp.where(gn_, own[0], SF[6, j])
                SF[10, j] = wp.where(gq, v_out[0], SF[10, j])
                SF[3, j] = wp.where(gn_, acc[1], SF[3, j])
                SF[7, j] = wp.where(gn_, own[1], SF[7, j])
                SF[11, j] = wp.where(gq, v_out[1], SF[11, j])
                SF[4, j] = wp.where(gn_, acc[2], SF[4, j])
                SF[8, j] = wp.where(gn_, own[2], SF[8, j])
                SF[12, j] = wp.where(gq, v_out[2], SF[12, j])
                SF[5, j] = wp.where(gn_, acc[3], SF[5, j])
                SF[9, j] = wp.where(gn_, own[3], SF[9, j])
                SF[13, j] = wp.where(gq, v_out[3], SF[13, j])
                SF[14, j] = wp.where(gq, ds_out, ds_in)
                SF[15, j] = wp.where(gq, err_new, err)
                SF[16, j] = wp.where(gq, d_mean, SF[16, j])
                SF[17, j] = wp.where(gq, wp.where(short, dmax, 0.0), SF[17, j])
                SF[18, j] = wp.where(gq, tr, SF[18, j])
                SF[19, j] = wp.where(gq, u, SF[19, j])
                FF[0, j] = wp.where(go, pn[0], FF[0, j])
                FF[3, j] = wp.where(go, px[0], FF[3, j])
                FF[6, j] = wp.where(go, py_[0], FF[6, j])
                FF[12, j] = wp.where(go, mn[0], FF[12, j])
                FF[15, j] = wp.where(go, mx[0], FF[15, j])
                FF[18, j] = wp.where(go, my[0], FF[18, j])
                FF[1, j] = wp.where(go, pn[1], FF[1, j])
                FF[4, j] = wp.where(go, px[1], FF[4, j])
                FF[7, j] = wp.where(go, py_[1], FF[7, j])
                FF[13, j] = wp.where(go, mn[1], FF[13, j])
                FF[16, j] = wp.where(go, mx[1], FF[16, j])
                FF[19, j] = wp.where(go, my[1], FF[19, j])
                FF[2, j] = wp.where(go, pn[2], FF[2, j])
                FF[5, j] = wp.where(go, px[2], FF[5, j])
                FF[8, j] = wp.where(go, py_[2], FF[8, j])
                FF[14, j] = wp.where(go, mn[2], FF[14, j])
                FF[17, j] = wp.where(go, mx[2], FF[17, j])
                FF[20, j] = wp.where(go, my[2], FF[20, j])
                FF[9, j] = wp.where(go, hn, h0)
                FF[10, j] = wp.where(go, hx, h1)
                FF[11, j] = wp.where(go, hy, h2)
                FF[21, j] = wp.where(go, sn, s0)
                FF[22, j] = wp.where(go, sxv, s1)
                FF[23, j] = wp.where(go, syv, s2)
                FF[24, j] = wp.where(go, wn0, w0)
                FF[25, j] = wp.where(go, wn1, w1)
                FF[26, j] = wp.where(go, wn2, w2)
                FF[27, j] = wp.where(go, ln_, FF[27, j])
                FF[28, j] = wp.where(go, lx, FF[28, j])
                FF[29, j] = wp.where(go, ly, FF[29, j])
                FF[30, j] = wp.where(go, exn, FF[30, j])
                FF[31, j] = wp.where(go, exy, FF[31, j])
                FF[32, j] = wp.where(go, eyn, FF[32, j])
                FG[0, j] = wp.where(go, gn, g0)
                FG[1, j] = wp.where(go, gx, g1)
                FG[2, j] = wp.where(go, gy, g2)
            # ---- the exit face's neighbour records (loads: a loop of their own), and the step to the next cell ----
            for j in range(LANES):
                c4 = 4 * SI[0, j] + GI[4, j]
                GI[5, j] = m_nbr[c4]
                GI[6, j] = m_nbrv[c4]
            for j in range(LANES):
                nb = GI[5, j]
                ex = nb < 0  # (the walk leaves the mesh: its exit checks in lane_exit_at)
                go = FL[0, j] == 1
                keep = FL[2, j] == 1 and not ex
                RX[j] = wp.where(go and ex and (FL[2, j] == 1 or FL[1, j] == 0), 1, 0)
                SI[6, j] = wp.where(FL[2, j] == 1 and ex, 0, SI[6, j])
                cell = SI[0, j]
                gn = SI[1, j]
                TI[0, j] = wp.where(ex, cell, nb >> 2)
                TI[1, j] = wp.where(ex, gn, GI[6, j])
                SI[0, j] = wp.where(keep, nb >> 2, cell)
                SI[1, j] = wp.where(keep, GI[6, j], gn)
            # ---- the steps that cross a TF control point: their integral and checks, one lane at a time ----
            for j in range(LANES):
                if RC[j] == 1:
                    t_in = SF[0, j]
                    s_in = SF[1, j]
                    t_out = TF[7, j]
                    s_out = TF[6, j]
                    ln = t_out - t_in
                    k_in = SI[4, j]
                    v_in = wp.vec4(SF[10, j], SF[11, j], SF[12, j], SF[13, j])
                    k_out = tf_upper_from(s_out, k_in, ig.tf_s)
                    v_out = tf_eval_upper(s_out, k_out, ig.tf_s, ig.tf_v)
                    seg = wp.vec4(0.0, 0.0, 0.0, 0.0)
                    if k_in == k_out:
                        seg = integrate_piece_flat(ln, v_in, v_out, flat_extinction(k_in, ig.tf_v), model)
                    else:
                        seg = integrate_segment_tf(s_in, s_out, v_in, v_out, ln, ig.tf_s, ig.tf_v, model)
                    tr = SF[5, j]
                    thin, tm = thin_step(thin_prev(SF[16, j], SI[5, j], SF[17, j], SF[18, j], SF[19, j]), ln, seg[3],
                                         t_out, scale, tr, v_in, v_out, k_in, k_out, ig.tf_v, model)
                    ds_out = TF[5, j]
                    err = scalar_step(SF[15, j], tr, ln, seg[3], s_in, s_out, v_in, v_out, k_in, k_out, SF[14, j],
                                      ds_out, ig.tf_s, ig.tf_v, model)
                    SF[14, j] = ds_out
                    SF[15, j] = err
                    SF[16, j] = tm.d
                    SF[17, j] = tm.dmax
                    SF[18, j] = tm.tr
                    SF[19, j] = tm.u
                    SI[5, j] = tm.is_short
                    e = exp_neg(seg[3])
                    acc = add_under_tr(wp.vec4(SF[2, j], SF[3, j], SF[4, j], tr), seg, e)
                    own = add_under_tr(wp.vec4(SF[6, j], SF[7, j], SF[8, j], SF[9, j]), seg, e)
                    for i in range(4):
                        SF[2 + i, j] = acc[i]
                        SF[6 + i, j] = own[i]
                    if thin == 1 or err > STEEP_ERR:
                        SI[6, j] = 0  # failed: the walk ends here (its colour is dropped)
                        RX[j] = 0
                        scratch[lane0 + j].failed = 1
                        scratch[lane0 + j].thin = thin
                    else:
                        SF[0, j] = t_out
                        SF[1, j] = s_out
                        SI[4, j] = k_out
                        for i in range(4):
                            SF[10 + i, j] = v_out[i]
                        KP[j] = 1
                        if acc[3] < t_stop:
                            SI[6, j] = 0
                            RX[j] = 0
                        else:
                            SI[0, j] = TI[0, j]
                            SI[1, j] = TI[1, j]
                            if RX[j] == 1:
                                SI[6, j] = 0
            # ---- the optically thick pieces: integrate_piece_flat, one lane at a time ----
            for j in range(LANES):
                if RT[j] == 1:
                    seg = integrate_piece_flat(TF[0, j], wp.vec4(TF[1, j], TF[2, j], TF[3, j], TF[4, j]),
                                               wp.vec4(SF[10, j], SF[11, j], SF[12, j], SF[13, j]),
                                               flat_extinction(SI[4, j], ig.tf_v), model)
                    e = exp_neg(seg[3])
                    acc = add_under_tr(wp.vec4(SF[2, j], SF[3, j], SF[4, j], SF[5, j]), seg, e)
                    own = add_under_tr(wp.vec4(SF[6, j], SF[7, j], SF[8, j], SF[9, j]), seg, e)
                    for i in range(4):
                        SF[2 + i, j] = acc[i]
                        SF[6 + i, j] = own[i]
                    if acc[3] < t_stop:
                        SI[6, j] = 0
                        RX[j] = 0
                    else:
                        SI[0, j] = TI[0, j]
                        SI[1, j] = TI[1, j]
                        if RX[j] == 1:
                            SI[6, j] = 0
            # ---- a rare step, and the write-back of a ray whose walk has ended (state to scratch, field by field) ----
            busy = int(0)
            for j in range(LANES):
                if RV[j] == 1 or (FN[j] == 1 and SI[6, j] == 0):
                    slot = lane0 + j
                    for i in range(3):
                        scratch[slot].fc.pa[i] = FF[i, j]
                        scratch[slot].fc.pb[i] = FF[3 + i, j]
                        scratch[slot].fc.pc[i] = FF[6 + i, j]
                        scratch[slot].fc.h[i] = FF[9 + i, j]
                        scratch[slot].fc.ma[i] = FF[12 + i, j]
                        scratch[slot].fc.mb[i] = FF[15 + i, j]
                        scratch[slot].fc.mc[i] = FF[18 + i, j]
                        scratch[slot].fc.s[i] = FF[21 + i, j]
                        scratch[slot].fc.w[i] = FF[24 + i, j]
                        scratch[slot].fc.g[i] = FG[i, j]
                    for i in range(4):
                        scratch[slot].acc[i] = SF[2 + i, j]
                        scratch[slot].own[i] = SF[6 + i, j]
                        scratch[slot].v_in[i] = SF[10 + i, j]
                    scratch[slot].t_in = SF[0, j]
                    scratch[slot].s_in = SF[1, j]
                    scratch[slot].ds_in = SF[14, j]
                    scratch[slot].scal_err = SF[15, j]
                    scratch[slot].thin_mem.d = SF[16, j]
                    scratch[slot].thin_mem.dmax = SF[17, j]
                    scratch[slot].thin_mem.tr = SF[18, j]
                    scratch[slot].thin_mem.u = SF[19, j]
                    scratch[slot].cell = SI[0, j]
                    scratch[slot].gn = SI[1, j]
                    scratch[slot].cells = SI[2, j]
                    scratch[slot].stall = SI[3, j]
                    scratch[slot].k_in = SI[4, j]
                    scratch[slot].thin_mem.is_short = SI[5, j]
                    scratch[slot].walking = SI[6, j]
                    if RV[j] == 1:
                        lane_step_at(scratch, slot, scale, mesh, ig, opts)
                        LD[j] = 1
                    elif RX[j] == 1:
                        lane_exit_at(scratch, slot, scale, model)
                    if scratch[slot].walking == 0:
                        LD[j] = 0
                        FN[j] = 0
                        SI[6, j] = 0
                        lane_done(scratch, slot, cam, mesh, starts, ig, opts, col, aux, tcur, status, last, more,
                                  counters, chunk, sg)
                        nxt = lane_next(scratch, slot, SL[j] + LANES, lim, ids, cam, mesh, starts, ig, opts, col, aux,
                                        tcur, status, last, more, counters, chunk, sg)
                        if nxt >= 0:
                            SL[j] = nxt
                            LD[j] = 1
                            FN[j] = 1
                busy = busy + SI[6, j] + LD[j]

    return march_lanes


def march_lanes_kernel(lanes: int, segs: bool = False, harc: bool = False):
    """:func:`make_march_lanes`'s kernel of ``(lanes, segs, harc)``, made once."""
    return made_once((int(lanes), bool(segs), bool(harc)), make_march_lanes)
