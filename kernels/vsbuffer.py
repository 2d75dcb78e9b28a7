"""VSBUFFER kernels (Westermann & Ertl 1997): buffer comparison and the front-to-back column walk.

One thread per ray walks its column of the VSBUFFER (one image column on one sweep plane) from the
front: a run of one ID is one cell; the cell's ray interval comes from clipping the ray against its
faces (entry: farthest front-face hit, exit: nearest back-face hit), the scalar at entry and exit
from barycentric coordinates on the hit face with the paper's robust solve (drop the row of the
dominant normal component, nudge coordinates back into [0, 1]). IDs already integrated on the ray are
kept in a list (drawing-order errors split runs); when leaving a cell its neighbours in the VSBUFFER
are checked (cells the discretisation missed in this column); the previous exit point is reused when
the next cell shares the face. A convex cell of several pieces (its tet decomposition) is integrated
piece by piece between its entry and exit.

Counters per thread (``counters[tid, k]``): see :data:`COUNTERS`.
"""

import warp as wp

from .harc import Integ, integrate_sub
from .integrate import integrate_segment
from .tf import tf_eval

wp.set_module_options({"enable_backward": False, "fuse_fp": False})  # same roundings on CPU and CUDA

INTEG_TRAPEZOID = wp.constant(0)
INTEG_EXACT = wp.constant(1)
INTEG_TABLE = wp.constant(2)
ADJ_COUNT = wp.constant(0)
ADJ_RECOVER = wp.constant(1)
BIG = wp.constant(1.0e30)
#: counter columns, in order
COUNTERS = ("runs", "cells_integrated", "pieces_integrated", "split_runs_skipped", "exit_points_reused",
            "entry_points_solved", "neighbour_found", "lost_segments", "recovered_by_adjacency",
            "list_comparisons", "list_overflow", "barycentric_nudged", "empty_intervals", "table_lookups")
NCOUNT = wp.constant(14)


@wp.struct
class VsbCells:
    """Cells on the device: pieces (tets) grouped per cell, float32 relative to the mesh centre."""

    points: wp.array(dtype=wp.vec3)
    scalars: wp.array(dtype=float)
    tets: wp.array(dtype=wp.vec4i)
    planes: wp.array(dtype=wp.vec4)       # 4 per piece: (n, o), unit outward normal, face i opposite vertex i
    adj: wp.array(dtype=wp.int32)         # 4 per piece: neighbour piece across face i, -1 on the boundary
    grad: wp.array(dtype=wp.vec4)         # per piece: scalar gradient g and offset g0, s = g . x + g0
    piece_cell: wp.array(dtype=wp.int32)
    cell_start: wp.array(dtype=wp.int32)
    tie: wp.array(dtype=wp.int32)         # 4 per piece: 1 if a ray lying in face i's plane is inside


@wp.struct
class Walk:
    """Per-launch parameters of the column walk."""

    rows: int                 # VSBUFFER rows per plane (depth resolution)
    stride: int               # rows between planes in the stacked buffer
    width: int
    height: int
    j0: int                   # image row of the batch's first plane
    eye: wp.vec3              # relative to the cell origin
    fwd: wp.vec3
    ortho: int
    cmin: float               # depth coordinate of buffer row 0's top edge
    cscale: float             # rows per unit of depth coordinate
    integ: int
    steps: int
    model: int
    t_min: float
    nbr: int
    adjacency: int
    max_list: int
    eps: float
    ig: Integ                 # pre-integration table (integ == INTEG_TABLE; mode 'full' of the HARC kernels)
    l_max: float              # the table's longest thickness: longer segments are looked up in equal parts


@wp.kernel
def vsb_compare(back: wp.array2d(dtype=wp.int32), front: wp.array2d(dtype=wp.int32),
                vsb: wp.array2d(dtype=wp.int32)):
    """VSBUFFER: the ID where both passes agree (a cross-section of that cell), else -1."""
    r, c = wp.tid()
    a = back[r, c]
    if a >= 0 and a == front[r, c]:
        vsb[r, c] = a
    else:
        vsb[r, c] = -1


@wp.func
def face_tri(t: wp.vec4i, f: int) -> wp.vec3i:
    """Vertices of local face ``f`` (opposite vertex ``f``), outward winding (``FACE_VERTS``)."""
    if f == 0:
        return wp.vec3i(t[1], t[2], t[3])
    if f == 1:
        return wp.vec3i(t[0], t[3], t[2])
    if f == 2:
        return wp.vec3i(t[0], t[1], t[3])
    return wp.vec3i(t[0], t[2], t[1])


@wp.func
def sorted3(v: wp.vec3i) -> wp.vec3i:
    a = wp.min(v[0], wp.min(v[1], v[2]))
    c = wp.max(v[0], wp.max(v[1], v[2]))
    return wp.vec3i(a, v[0] + v[1] + v[2] - a - c, c)


@wp.func
def piece_interval(cells: VsbCells, q: int, o: wp.vec3, d: wp.vec3, tol: float) -> wp.vec4:
    """Ray interval of piece ``q``: ``(t_entry, t_exit, entry face, exit face)``; empty if exit <= entry.

    A face the ray runs along (|n.d| <= 1e-6) bounds nothing; a ray within ``tol`` of its plane lies in
    the face, and is inside where ``cells.tie`` says so: the reference's rule (the ray moved by an
    infinitesimal step along the camera's right, then up), so a ray in a shared face belongs to exactly
    one of the two pieces and a ray in a boundary face is inside or outside as in the reference.
    """
    ta = float(-BIG)
    tb = float(BIG)
    fa = int(-1)
    fb = int(-1)
    for f in range(4):
        pl = cells.planes[4 * q + f]
        nd = pl[0] * d[0] + pl[1] * d[1] + pl[2] * d[2]
        dist = pl[0] * o[0] + pl[1] * o[1] + pl[2] * o[2] + pl[3]
        if wp.abs(nd) <= 1.0e-6:
            if dist > tol or (dist >= -tol and cells.tie[4 * q + f] == 0):
                tb = -BIG  # parallel and outside (or in the face plane, on its outer side by the tie rule)
        elif nd < 0.0:
            t = -dist / nd
            if t > ta:
                ta = t
                fa = f
        elif nd > 0.0:
            t = -dist / nd
            if t < tb:
                tb = t
                fb = f
    return wp.vec4(ta, tb, float(fa), float(fb))


@wp.func
def robust_scalar(cells: VsbCells, q: int, f: int, p: wp.vec3) -> wp.vec2:
    """Scalar at ``p`` on face ``f`` of piece ``q`` from barycentric coordinates (the paper's solve).

    Points are taken relative to the piece's fourth vertex (off the face plane); of the over-determined
    system ``[a b c; 1 1 1] l = [p; 1]`` the row of the dominant normal component (least information)
    is replaced by the sum row. Coordinates outside [0, 1] are nudged back. Returns ``(s, nudged)``.
    """
    t = cells.tets[q]
    v = face_tri(t, f)
    o = cells.points[t[f]]
    a = cells.points[v[0]] - o
    b = cells.points[v[1]] - o
    c = cells.points[v[2]] - o
    r = p - o
    pl = cells.planes[4 * q + f]
    k = int(0)
    if wp.abs(pl[1]) > wp.abs(pl[0]):
        k = 1
    if wp.abs(pl[2]) > wp.abs(pl[k]):
        k = 2
    m = wp.mat33(a[0], b[0], c[0], a[1], b[1], c[1], a[2], b[2], c[2])
    rhs = r
    for j in range(3):
        if j == k:
            m[j, 0] = 1.0
            m[j, 1] = 1.0
            m[j, 2] = 1.0
            rhs[j] = 1.0
    det = wp.determinant(m)
    lam = wp.vec3(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0)
    if det != 0.0:
        lam = wp.inverse(m) * rhs
    nudged = float(0.0)
    for j in range(3):
        if lam[j] < 0.0:
            lam[j] = 0.0
            nudged = 1.0
        elif lam[j] > 1.0:
            lam[j] = 1.0
            nudged = 1.0
    sm = lam[0] + lam[1] + lam[2]
    if sm > 0.0:
        lam = lam / sm
    s = lam[0] * cells.scalars[v[0]] + lam[1] * cells.scalars[v[1]] + lam[2] * cells.scalars[v[2]]
    return wp.vec2(s, nudged)


@wp.func
def trapezoid(s0: float, s1: float, length: float, steps: int, tf_s: wp.array(dtype=float),
              tf_v: wp.array(dtype=wp.vec4), model: int) -> wp.vec4:
    """The paper's rule: equal sub-steps, each with the trapezoid mean of its end values and its
    attenuation accounted for: optical depth ``tau = h (rho_a + rho_b) / 2``, colour ``c (1 - e^-tau)``
    (``color_extinction``) or ``c (1 - e^-tau) / rho`` (``emission_density``; ``c h`` where rho is 0),
    with ``c``, ``rho`` the trapezoid means. Bounded for any extinction (the step's opacity is
    ``1 - e^-tau``), exact for constant values, second order in the step."""
    h = length / float(steps)
    rgb = wp.vec3(0.0, 0.0, 0.0)
    tau = float(0.0)
    va = tf_eval(s0, tf_s, tf_v)
    for i in range(steps):
        vb = tf_eval(s0 + (s1 - s0) * float(i + 1) / float(steps), tf_s, tf_v)
        c = 0.5 * (wp.vec3(va[0], va[1], va[2]) + wp.vec3(vb[0], vb[1], vb[2]))
        rho = 0.5 * (va[3] + vb[3])
        dt = h * rho
        a = 1.0 - wp.exp(-dt)
        if model == 0:
            rgb += wp.exp(-tau) * a * c
        elif rho > 0.0:
            rgb += wp.exp(-tau) * (a / rho) * c
        else:
            rgb += wp.exp(-tau) * h * c
        tau += dt
        va = vb
    return wp.vec4(rgb[0], rgb[1], rgb[2], tau)


@wp.func
def list_has(done: wp.array2d(dtype=wp.int32), tid: int, n: int, cid: int) -> wp.vec2i:
    """Whether ``cid`` is in the ray's list of integrated cells; ``(found, comparisons)``."""
    for i in range(n):
        if done[tid, i] == cid:
            return wp.vec2i(1, i + 1)
    return wp.vec2i(0, n)


@wp.func
def cell_interval(cells: VsbCells, cid: int, o: wp.vec3, d: wp.vec3, tol: float) -> wp.vec2:
    ta = float(BIG)
    tb = float(-BIG)
    for q in range(cells.cell_start[cid], cells.cell_start[cid + 1]):
        iv = piece_interval(cells, q, o, d, tol)
        if iv[1] > iv[0]:
            ta = wp.min(ta, iv[0])
            tb = wp.max(tb, iv[1])
    return wp.vec2(ta, tb)


@wp.func
def cell_entry(cells: VsbCells, cid: int, o: wp.vec3, d: wp.vec3, tol: float) -> wp.vec3:
    """``(t_entry, piece, face)`` of the cell's first piece along the ray; piece -1 if the ray misses."""
    ta = float(BIG)
    pq = int(-1)
    pf = int(-1)
    for q in range(cells.cell_start[cid], cells.cell_start[cid + 1]):
        iv = piece_interval(cells, q, o, d, tol)
        if iv[1] > iv[0] and iv[0] < ta:
            ta = iv[0]
            pq = q
            pf = int(iv[2])
    return wp.vec3(ta, float(pq), float(pf))


@wp.func
def empty_space_check(cells: VsbCells, w: Walk, vsb: wp.array2d(dtype=wp.int32), row0: int, col: int,
                      o: wp.vec3, d: wp.vec3, done: wp.array2d(dtype=wp.int32), tid: int, nd: int, k_from: int,
                      t_from: float) -> int:
    """The neighbour check where the ray leaves empty space (in front of the mesh, or after leaving it
    through a boundary face): the first cell after ``t_from`` in the 3-column neighbourhood, between
    buffer row ``k_from`` and the column's own next cell, if it lies in front of that cell (a column
    running along an edge of the ID buffers can miss cells the ray crosses). Returns -1 if none."""
    k_next = k_from
    t_next = float(BIG)
    found = int(0)
    while k_next < w.rows and found == 0:
        v = vsb[row0 + k_next, col]
        if v >= 0:
            if list_has(done, tid, nd, v)[0] == 0:
                found = 1
                t_next = cell_interval(cells, v, o, d, w.eps)[0]
        if found == 0:
            k_next += 1
    best_t = float(BIG)
    best = int(-1)
    for di in range(-1, 2):
        cc = wp.clamp(col + di, 0, w.width - 1)
        prev = int(-1)
        for rr in range(wp.max(k_from - 1, 0), wp.min(k_next + 2, w.rows)):
            cand = vsb[row0 + rr, cc]
            if cand >= 0 and cand != prev:
                prev = cand
                ivs = cell_interval(cells, cand, o, d, w.eps)
                if (ivs[1] > wp.max(ivs[0], t_from) + w.eps and ivs[0] < t_next - w.eps and ivs[0] < best_t
                        and list_has(done, tid, nd, cand)[0] == 0):
                    best_t = ivs[0]
                    best = cand
    return best


@wp.func
def buffer_row(w: Walk, p: wp.vec3) -> int:
    z = wp.dot(p - w.eye, w.fwd)
    c = z
    if w.ortho == 0:
        c = -1.0 / wp.max(z, 1.0e-30)
    return wp.clamp(int(wp.floor((c - w.cmin) * w.cscale)), 0, w.rows - 1)


@wp.func
def integrate_cell(cells: VsbCells, w: Walk, cid: int, o: wp.vec3, d: wp.vec3, rgb_in: wp.vec3, trans_in: float,
                   t_in: float, s_in: float, key_last: wp.vec3i, tf_s: wp.array(dtype=float),
                   tf_v: wp.array(dtype=wp.vec4), counters: wp.array2d(dtype=wp.int32), tid: int):
    """Integrate cell ``cid``: its pieces in ray order between entry and exit (entry point reused from
    the previous exit across a shared face). Returns the updated ``(rgb, trans, t_last, s_last,
    key_last, exit piece, exit face)``; exit piece -1 if the ray misses the cell."""
    rgb = wp.vec3(rgb_in)
    trans = float(trans_in)
    t_last = float(t_in)
    s_last = float(s_in)
    kl = wp.vec3i(key_last)
    q0 = cells.cell_start[cid]
    q1 = cells.cell_start[cid + 1]
    t_prev = float(-BIG)
    exit_q = int(-1)
    exit_f = int(-1)
    first = int(1)
    npieces = q1 - q0
    for it in range(npieces):
        # next piece in ray order (a cell has at most a few pieces: selection by entry parameter)
        best = int(-1)
        bt = float(BIG)
        for q in range(q0, q1):
            iv = piece_interval(cells, q, o, d, w.eps)
            if iv[1] > iv[0] and iv[0] > t_prev and iv[0] < bt:
                bt = iv[0]
                best = q
        if best < 0:
            if it == 0:
                counters[tid, 12] += 1  # drawn in this column, but the ray misses it (rounding)
            break
        iv = piece_interval(cells, best, o, d, w.eps)
        t_prev = iv[0]
        fa = int(iv[2])
        fb = int(iv[3])
        ta = wp.max(iv[0], 0.0)
        tb = iv[1]
        sa = float(0.0)
        key = sorted3(face_tri(cells.tets[best], fa))
        if first == 1 and key[0] == key_last[0] and key[1] == key_last[1] and key[2] == key_last[2]:
            ta = t_last
            sa = s_last
            counters[tid, 4] += 1
        else:
            ta = wp.max(ta, t_last)
            if ta > iv[0] + w.eps:
                # the ray starts inside the piece (eye plane inside the mesh): no face to solve on
                g = cells.grad[best]
                pin = o + d * ta
                sa = g[0] * pin[0] + g[1] * pin[1] + g[2] * pin[2] + g[3]
            else:
                r = robust_scalar(cells, best, fa, o + d * ta)
                sa = r[0]
                counters[tid, 11] += int(r[1])
            counters[tid, 5] += 1
        first = 0
        rb = robust_scalar(cells, best, fb, o + d * tb)
        counters[tid, 11] += int(rb[1])
        length = tb - ta
        if length > 0.0:
            if w.integ == INTEG_TABLE:
                # (sf, sb, l) through the 3D texture unit, composited front to back; a segment longer
                # than the table's thickness axis is looked up in equal parts (scalar linear along it)
                n = wp.max(int(wp.ceil(length / w.l_max)), 1)
                for k in range(n):
                    c = integrate_sub(w.ig, sa + (rb[0] - sa) * float(k) / float(n),
                                      sa + (rb[0] - sa) * float(k + 1) / float(n), length / float(n))
                    rgb += trans * wp.vec3(c[0], c[1], c[2])
                    trans = trans * (1.0 - c[3])
                counters[tid, 13] += n
            else:
                seg = wp.vec4(0.0, 0.0, 0.0, 0.0)
                if w.integ == INTEG_EXACT:
                    seg = integrate_segment(sa, rb[0], length, tf_s, tf_v, w.model)
                else:
                    seg = trapezoid(sa, rb[0], length, w.steps, tf_s, tf_v, w.model)
                rgb += trans * wp.vec3(seg[0], seg[1], seg[2])
                trans = trans * wp.exp(-seg[3])
            t_last = tb
            # the exit point is reusable only where the ray really got to it (not behind the eye)
            s_last = rb[0]
            kl = sorted3(face_tri(cells.tets[best], fb))
        exit_q = best
        exit_f = fb
        counters[tid, 2] += 1
    return rgb, trans, t_last, s_last, kl, exit_q, exit_f


@wp.kernel
def column_walk(cells: VsbCells, w: Walk, vsb: wp.array2d(dtype=wp.int32), ray_o: wp.array(dtype=wp.vec3),
                ray_d: wp.array(dtype=wp.vec3), tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4),
                done: wp.array2d(dtype=wp.int32), out: wp.array(dtype=wp.vec4),
                counters: wp.array2d(dtype=wp.int32), p0: int):
    pl, col = wp.tid()
    p = pl + p0
    j = w.j0 + p
    if j >= w.height:
        return
    tid = p * w.width + col
    pix = j * w.width + col
    o = ray_o[pix]
    d = ray_d[pix]
    row0 = p * w.stride
    rgb = wp.vec3(0.0, 0.0, 0.0)
    trans = float(1.0)
    nd = int(0)
    t_last = float(0.0)
    s_last = float(0.0)
    key_last = wp.vec3i(-1, -1, -1)
    pend = int(-1)          # cell across the last exit face (from the derived adjacency), -1: none
    cur = int(-1)
    k = int(0)
    queued = int(-1)        # cell to integrate next (from the column, the neighbour check or recovery)
    from_nbr = int(0)
    k_run = int(0)
    if w.nbr == 1:
        queued = empty_space_check(cells, w, vsb, row0, col, o, d, done, tid, nd, 0, 0.0)
        if queued >= 0:
            from_nbr = 1
    while trans >= w.t_min:
        cid = int(-1)
        col_cell = int(0)   # cid came from the column at row k_run (else from queued)
        if queued >= 0:
            cid = queued
            queued = -1
        else:
            if k >= w.rows:
                # end of the column: a cell behind an interior exit face that was never drawn is lost
                if pend >= 0:
                    hp = list_has(done, tid, nd, pend)
                    counters[tid, 9] += hp[1]
                    if hp[0] == 0:
                        ive = cell_interval(cells, pend, o, d, w.eps)
                        if ive[1] - wp.max(ive[0], t_last) > w.eps:
                            if w.adjacency == ADJ_RECOVER:
                                cid = pend
                                counters[tid, 8] += 1
                            else:
                                counters[tid, 7] += 1
                    pend = -1
                if cid < 0:
                    break
            else:
                v = vsb[row0 + k, col]
                k_run = k
                k += 1
                if v < 0 or v == cur:
                    continue
                cur = v
                counters[tid, 0] += 1
                hv = list_has(done, tid, nd, v)
                counters[tid, 9] += hv[1]
                if hv[0] == 1:
                    counters[tid, 3] += 1
                    continue
                cid = v
                col_cell = 1
        # a cell behind the last interior exit face that the buffer missed leaves a gap before cid
        if pend >= 0 and pend != cid:
            hp = list_has(done, tid, nd, pend)
            counters[tid, 9] += hp[1]
            if hp[0] == 0:
                ivn = cell_interval(cells, cid, o, d, w.eps)
                if ivn[0] > t_last + w.eps:
                    ivp = cell_interval(cells, pend, o, d, w.eps)
                    if ivp[1] - wp.max(ivp[0], t_last) > w.eps:
                        if w.adjacency == ADJ_RECOVER:
                            if col_cell == 1:
                                k = k_run
                                cur = -1
                            else:
                                queued = cid
                            cid = pend
                            col_cell = 0
                            from_nbr = 0
                            counters[tid, 8] += 1
                        else:
                            counters[tid, 7] += 1
        pend = -1
        # a cell in front of cid, behind its interior entry face, that the buffer missed (also where
        # the column's first cells were lost); chains backwards one cell per loop turn
        for chain in range(64):
            ent = cell_entry(cells, cid, o, d, w.eps)
            nbc = int(-1)
            if ent[1] >= 0.0:
                nbp = cells.adj[4 * int(ent[1]) + int(ent[2])]
                if nbp >= 0:
                    nbc = cells.piece_cell[nbp]
            if nbc < 0 or nbc == cid:
                break
            hb = list_has(done, tid, nd, nbc)
            counters[tid, 9] += hb[1]
            if hb[0] == 1:
                break
            ivb = cell_interval(cells, nbc, o, d, w.eps)
            if not (ivb[0] < ent[0] - w.eps and ivb[1] - wp.max(ivb[0], t_last) > w.eps):
                break
            if w.adjacency != ADJ_RECOVER:
                counters[tid, 7] += 1
                break
            counters[tid, 8] += 1
            if col_cell == 1:
                k = k_run
                cur = -1
            elif queued >= 0:
                # queued holds the column cell deferred by the gap check above: re-read it from the column
                k = k_run
                cur = -1
                queued = cid
            else:
                queued = cid
            cid = nbc
            col_cell = 0
            from_nbr = 0
        # ---- integrate cell cid: its pieces in ray order between entry and exit ----
        if nd < w.max_list:
            done[tid, nd] = cid
            nd += 1
        else:
            counters[tid, 10] += 1
        counters[tid, 1] += 1
        if from_nbr == 1:
            counters[tid, 6] += 1
            from_nbr = 0
        rgb, trans, t_last, s_last, key_last, exit_q, exit_f = integrate_cell(
            cells, w, cid, o, d, rgb, trans, t_last, s_last, key_last, tf_s, tf_v, counters, tid)
        if exit_q >= 0:
            nb = cells.adj[4 * exit_q + exit_f]
            pend = -1
            if nb >= 0:
                pend = cells.piece_cell[nb]
        if w.nbr == 1 and queued < 0 and exit_q >= 0 and pend < 0:
            # left the mesh through a boundary face: the next component may start in a missed column
            queued = empty_space_check(cells, w, vsb, row0, col, o, d, done, tid, nd,
                                       buffer_row(w, o + d * t_last), t_last)
            if queued >= 0:
                from_nbr = 1
        # ---- neighbour check on leaving the cell: cells the discretisation missed in this column ----
        # (only where the column itself does not continue at the exit point)
        cont = int(0)
        if w.nbr == 1 and queued < 0 and exit_q >= 0:
            kk = k
            while kk < w.rows and cont == 0:
                v2 = vsb[row0 + kk, col]
                kk += 1
                if v2 >= 0 and v2 != cid:
                    hv2 = list_has(done, tid, nd, v2)
                    counters[tid, 9] += hv2[1]
                    if hv2[0] == 0:
                        ivv = cell_interval(cells, v2, o, d, w.eps)
                        if ivv[0] <= t_last + w.eps:
                            cont = 1
                        else:
                            kk = w.rows
        if w.nbr == 1 and queued < 0 and exit_q >= 0 and cont == 0:
            kx = buffer_row(w, o + d * t_last)
            for dk in range(-1, 2):
                for di in range(-1, 2):
                    rr = wp.clamp(kx + dk, 0, w.rows - 1)
                    cc = wp.clamp(col + di, 0, w.width - 1)
                    cand = vsb[row0 + rr, cc]
                    if queued < 0 and cand >= 0 and cand != cid:
                        hc = list_has(done, tid, nd, cand)
                        counters[tid, 9] += hc[1]
                        if hc[0] == 0:
                            ivc = cell_interval(cells, cand, o, d, w.eps)
                            if ivc[0] <= t_last + w.eps and ivc[1] > t_last + w.eps:
                                queued = cand
                                from_nbr = 1
            if queued >= 0 and queued == pend:
                pend = -1
    out[pix] = wp.vec4(rgb[0], rgb[1], rgb[2], 1.0 - trans)

