"""Hardware ray casting (HARC, Weiler et al. 2003) with full and partial pre-integration (Espinha &
Celes 2005), one thread per pixel = one fragment of the ray-casting fragment program.

Two walks, one kernel:

* ``WALK_PLANES`` -- the paper's Fig. 6 arithmetic on its 96 bytes/tet mesh textures (read through the
  texture unit, nearest rgba32f texel fetches): exit face = smallest ``lambda = -(e.n + o)/(d.n)``
  among the faces with ``d.n > 0``, scalars ``s = g.x + g0`` from the cell's gradient, next cell from
  the adjacency texture. Rays it cannot resolve (no face with ``d.n > 0``, no progress in ``lambda``
  for :data:`warpvol.kernels.walk.STALL_STEPS` steps, the step bound) are marked failed, counted
  and redone in float64 on the host -- never silently wrong pixels from those cases.
* ``WALK_PLUCKER`` -- the consistent walk of :mod:`warpvol.kernels.walk` (its ``@wp.func`` s
  :func:`~warpvol.kernels.walk.boundary_face`, :func:`~warpvol.kernels.walk.face_hit`,
  :func:`~warpvol.kernels.walk.next_face`; no second copy): watertight on rays through vertices
  and edges.

Ray set-up (``SETUP_*``): ``SETUP_ROBUST`` takes the ray from :func:`warpvol.kernels.walk.pixel_ray`
(float64 set-up, origin moved to the mesh; the textures are relative to the cells' origin) and marks
rays it cannot resolve failed, for the float64 redo on the host. ``SETUP_PAPER`` is the paper's
fragment program: the ray starts at the eye, its direction computed in fp32 (:func:`paper_ray`), the
textures hold planes and gradients computed in fp32 in the mesh's own frame, ``lambda'`` is taken as
computed (no clamping to the entry's ``lambda``), and a ray the walk cannot resolve is lost: what it
composited so far goes to the frame buffer and its status is :data:`STATUS_LOST` (counted; no
redo). Ray start: the front-facing boundary faces were rasterised on the host
side (:mod:`warpvol.raycasting.harc`) into per-pixel fragment lists sorted by depth; pass ``k`` takes the
first fragment beyond the ray's last exit -- the depth-peeling test "depth greater than the last
layer's" -- so pass 0 is the plain boundary rasterisation and passes >= 1 are peel layers.

Integration of a segment ``(sf, sb, l)`` (``INTEG_*``): the exact piecewise-linear integral
(:func:`warpvol.kernels.integrate.integrate_segment`, the ceiling), full pre-integration (3D table
through the 3D texture unit, premultiplied ``(C, alpha)``), or partial pre-integration (Moreland &
Angel: ``psi`` table through the 2D texture unit) with the iso-crossing splits of Fig. 6 (iso table,
nearest lookups, the ``next_s_iso`` rule). Front-to-back compositing
``(R,G,B,A) += (1 - A)(r,g,b,a)`` in fp32 registers inside the loop; the pass result is written to
the frame buffer in its number format (:func:`warpvol.kernels.formats.fmt_quantize`).

Counters per row block (``counters[chunk, k]``): 0 entries, 1 fragment-program steps (iso sub-steps
included), 2 cells visited, 3 failed rays, 4 rays stopped by the step bound, 5 iso crossings the
iso table missed (checked against the TF's control points; diagnostic), 6 texture fetches, 7 entries
whose rasterised face the consistent edge test rejected (searched among the face's neighbours), 8 failed
rays of the consistent walk with exact segments that crossed a layer too thin for float32 segment
lengths (:func:`warpvol.kernels.walk.thin_unresolved`; redone in float64 like every failed ray),
9 rays of the paper's set-up that took a step with ``lambda' < lambda`` (an exit chosen by rounding:
the ray is suspect, its pixel possibly wrong; counted, not changed).
"""

import warp as wp

from .formats import NumFmt, fmt_quantize
from .integrate import exp_neg, integrate_piece, integrate_segment, integrate_segment_tf
from .pt import axis_coord
from .raycast import STATUS_ACTIVE, STATUS_DONE, STATUS_FAILED
from .walk import (STALL_STEPS, Face, Ray, boundary_face, face_hit, monotone_exit, next_face, pixel_ray, thin_at_exit,
                   thin_start, thin_step)
from .texture import Tex2D, Tex3D, tex2d, tex2d_texel, tex3d
from .tf import tf_eval, tf_eval_upper, tf_first_break, tf_next_break, tf_upper

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

WALK_PLANES = wp.constant(0)
WALK_PLUCKER = wp.constant(1)
INTEG_EXACT = wp.constant(0)
INTEG_FULL = wp.constant(1)
INTEG_PARTIAL = wp.constant(2)
#: iso rule: 0 = the paper's (``sf == s_iso`` -> ``next_s_iso``); 1 = also when ``s_iso`` lies behind
#: ``sf`` (edge-anchored iso table, see :func:`warpvol.tables.isocross.build_isocross`)
ISO_PAPER = wp.constant(0)
ISO_BEHIND = wp.constant(1)
SETUP_ROBUST = wp.constant(0)
SETUP_PAPER = wp.constant(1)
#: a ray the paper's set-up could not resolve (no exit face, no progress, the step bound): its
#: partial result is in the frame buffer, later peel passes skip it
STATUS_LOST = wp.constant(3)


@wp.struct
class MeshTex:
    """The paper's Table 1: four face planes ``(n, o)``, gradient ``(g, g0)`` and adjacency
    (``4 * neighbour + face in neighbour``, -1 on the boundary, exact in float32 below 2^24) per
    tet, each an rgba32f 2D texture of ``width`` texels per row (texel ``t % width, t // width``)."""

    n0: Tex2D
    n1: Tex2D
    n2: Tex2D
    n3: Tex2D
    grad: Tex2D
    adj: Tex2D
    width: int


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


@wp.func
def cell_texel(mt: MeshTex, tex: Tex2D, c: int) -> wp.vec4:
    """Nearest fetch of tet ``c``'s texel from one of the mesh textures."""
    y = c // mt.width
    return tex2d_texel(tex, float(c - y * mt.width) + 0.5, float(y) + 0.5)


@wp.func
def plane_of(mt: MeshTex, c: int, i: int) -> wp.vec4:
    if i == 0:
        return cell_texel(mt, mt.n0, c)
    if i == 1:
        return cell_texel(mt, mt.n1, c)
    if i == 2:
        return cell_texel(mt, mt.n2, c)
    return cell_texel(mt, mt.n3, c)


@wp.func
def plane_lambda(p: wp.vec4, o: wp.vec3, d: wp.vec3) -> float:
    """Ray parameter where ray ``o + lambda d`` meets plane ``n.x + w = 0``."""
    n = wp.vec3(p[0], p[1], p[2])
    return -(wp.dot(o, n) + p[3]) / wp.dot(d, n)


@wp.func
def plane_exit(mt: MeshTex, c: int, o: wp.vec3, d: wp.vec3):
    """Fig. 6 lines 1-9: ``(lambda', local face)`` of the smallest ``lambda`` among faces with
    ``d . n > 0``; face -1 when none has."""
    best = float(1.0e30)
    f = int(-1)
    for i in range(4):
        p = plane_of(mt, c, i)
        dn = wp.dot(d, wp.vec3(p[0], p[1], p[2]))
        if dn > 0.0:
            lam = -(wp.dot(o, wp.vec3(p[0], p[1], p[2])) + p[3]) / dn
            if lam < best:
                best = lam
                f = i
    return best, f


@wp.func
def paper_ray(px: int, py: int, width: int, height: int, eye: wp.vec3, fwd: wp.vec3d, right: wp.vec3d,
              up: wp.vec3d, ortho: int, half_h: wp.float64, aspect: wp.float64):
    """The paper's ray through the centre of pixel (row py, column px), all in fp32: origin the eye
    ``eye`` (orthographic: the eye plane's point), unit direction from the camera frame (cast to
    fp32); returns ``(o, d)`` in the textures' frame."""
    f = wp.vec3(float(fwd[0]), float(fwd[1]), float(fwd[2]))
    rt = wp.vec3(float(right[0]), float(right[1]), float(right[2]))
    u = wp.vec3(float(up[0]), float(up[1]), float(up[2]))
    hh = float(half_h)
    qx = 2.0 * (float(px) + 0.5) / float(width) - 1.0
    qy = 1.0 - 2.0 * (float(py) + 0.5) / float(height)
    sx = qx * hh * float(aspect)
    sy = qy * hh
    o = eye
    d = f
    if ortho == 1:
        o = eye + rt * sx + u * sy
    else:
        d = wp.normalize(f + rt * sx + u * sy)
    return o, d


@wp.func
def ring_search(b: int, bf_tet: wp.array(dtype=wp.int32), bf_face: wp.array(dtype=wp.int32),
                bf_nbr: wp.array(dtype=wp.vec3i), tets: wp.array(dtype=wp.vec4i), verts: wp.array(dtype=wp.vec4),
                r: Ray):
    """First front boundary face among the edge neighbours of face ``b`` and their edge neighbours
    that the ray crosses (consistent edge test): ``(face, crossed, t, s)``."""
    nb = bf_nbr[b]
    for k in range(3):
        n1 = nb[k]
        if n1 >= 0:
            ok, t, s = face_hit(boundary_face(tets[bf_tet[n1]], bf_face[n1], verts, r), r)
            if ok:
                return n1, True, t, s
    for k in range(3):
        n1 = nb[k]
        if n1 >= 0:
            nb2 = bf_nbr[n1]
            for j in range(3):
                n2 = nb2[j]
                if n2 >= 0 and n2 != b:
                    ok, t, s = face_hit(boundary_face(tets[bf_tet[n2]], bf_face[n2], verts, r), r)
                    if ok:
                        return n2, True, t, s
    return int(-1), False, float(0.0), float(0.0)


@wp.func
def grad_scalar(g: wp.vec4, x: wp.vec3) -> float:
    return wp.dot(wp.vec3(g[0], g[1], g[2]), x) + g[3]


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
    vf = tf_eval(sf, ig.tf_s, ig.tf_v)
    vb = tf_eval(sb, ig.tf_s, ig.tf_v)
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


@wp.func
def composite(acc: wp.vec4, c: wp.vec4) -> wp.vec4:
    """Front-to-back "under": ``(R, G, B, A) + (1 - A) (r, g, b, a)`` (Fig. 6 line 24)."""
    return acc + (1.0 - acc[3]) * c


@wp.kernel
def harc_march(
    width: int,
    height: int,
    eye: wp.vec3d,
    fwd: wp.vec3d,
    right: wp.vec3d,
    up: wp.vec3d,
    ortho: int,
    half_h: wp.float64,
    aspect: wp.float64,
    radius: wp.float64,
    setup: int,
    eye_w: wp.vec3,
    walk: int,
    mt: MeshTex,
    verts: wp.array(dtype=wp.vec4),
    tets: wp.array(dtype=wp.vec4i),
    nbr: wp.array(dtype=wp.vec4i),
    frag_start: wp.array(dtype=wp.int32),
    frag_bf: wp.array(dtype=wp.int32),
    bf_tet: wp.array(dtype=wp.int32),
    bf_face: wp.array(dtype=wp.int32),
    bf_nbr: wp.array(dtype=wp.vec3i),
    far: wp.array(dtype=float),
    ig: Integ,
    fb: NumFmt,
    t_stop: float,
    max_steps: int,
    t_tol: float,
    row0: int,
    rgba: wp.array(dtype=wp.vec4),
    tcur: wp.array(dtype=float),
    status: wp.array(dtype=wp.int32),
    last: wp.array(dtype=wp.int32),
    counters: wp.array2d(dtype=wp.int32),
    chunk: int,
    px_work: wp.array(dtype=wp.vec2i),
):
    tid = wp.tid()
    idx = row0 * width + tid
    if status[idx] != STATUS_ACTIVE:
        return
    py = idx // width
    px = idx - py * width
    r, t_clip, t_end = pixel_ray(px, py, width, height, eye, fwd, right, up, ortho, half_h, aspect, radius)
    o = r.o
    d = r.d
    if setup == SETUP_PAPER:
        # the paper's fragment program: the ray from the eye in fp32, nothing clipped or culled
        o, d = paper_ray(px, py, width, height, eye_w, fwd, right, up, ortho, half_h, aspect)
        t_clip = 0.0
    elif t_end < t_clip:
        status[idx] = STATUS_DONE
        return
    t_start = tcur[idx]
    prev = last[idx]
    if prev >= 0 and walk == WALK_PLUCKER and setup != SETUP_PAPER:
        # a re-entry pass: every face the search below can reach (this pixel's list, its neighbours'
        # lists, their surface rings) lies within `far` of the eye (host bound with a rounding margin);
        # an exit beyond it cannot re-enter, so the ray is done without the search
        if t_start + wp.dot(r.back, r.d) > far[idx]:
            status[idx] = STATUS_DONE
            return

    # ---- ray start: the first rasterised front boundary face beyond the last exit (peel test) ----
    cell = int(-1)
    face_in = int(-1)
    t_in = float(0.0)
    s_in = float(0.0)
    fc = Face()
    entry_failed = int(0)
    for it in range(frag_start[idx], frag_start[idx + 1]):
        b = int(frag_bf[it])
        c = int(bf_tet[b])
        f = int(bf_face[b])
        if c == prev:
            continue
        if walk == WALK_PLANES:
            p = plane_of(mt, c, f)
            lam = plane_lambda(p, o, d)
            if setup == SETUP_PAPER and not wp.isfinite(lam):
                entry_failed = 1  # the entry face's plane gives no ray parameter: the ray is lost
                break
            if lam > t_start - t_tol:
                cell = c
                face_in = f
                t_in = wp.max(lam, t_start)
                s_in = grad_scalar(cell_texel(mt, mt.grad, c), o + d * t_in)
                break
        else:
            cand = boundary_face(tets[c], f, verts, r)
            ok, t, s = face_hit(cand, r)
            if not ok:
                # the rasteriser's snapped coverage and the edge test disagree (pixel centre within
                # 1/256 pixel of a projected edge): the ray crosses a face around this one, found
                # among its edge neighbours and theirs on the front boundary
                wp.atomic_add(counters, chunk, 7, 1)
                b2, ok, t, s = ring_search(b, bf_tet, bf_face, bf_nbr, tets, verts, r)
                if ok and prev >= 0:
                    # a re-entry (peel pass): at a crack the faces around belong to other cells,
                    # whose surface neighbours do not reach the crossed face; redone in float64
                    ok = False
                if ok:
                    c = int(bf_tet[b2])
                    f = int(bf_face[b2])
                    cand = boundary_face(tets[c], f, verts, r)
            if ok:
                if t > t_start - t_tol and c != prev:
                    cell = c
                    face_in = f
                    t_in = wp.max(t, t_start)
                    s_in = s
                    fc = cand
                    break
            else:
                entry_failed = 1  # no face around crosses either: resolved in float64 on the host
                break
    if cell < 0 and entry_failed == 0 and walk != WALK_PLANES:
        # no face of this pixel's list is crossed beyond the last exit: where the snapped coverage of a layer
        # leaves a hole at the pixel centre (an inner silhouette within 1/256 pixel) the crossed face is
        # listed at a neighbouring pixel; the exact (consistent) face test over the 8 neighbours' lists finds it
        for nb in range(9):
            qx = px + (nb % 3) - 1
            qy = py + (nb // 3) - 1
            if nb != 4 and qx >= 0 and qy >= 0 and qx < width and qy < height:
                q = qy * width + qx
                for it2 in range(frag_start[q], frag_start[q + 1]):
                    b = int(frag_bf[it2])
                    c = int(bf_tet[b])
                    f = int(bf_face[b])
                    if c != prev:
                        cand = boundary_face(tets[c], f, verts, r)
                        ok, t, s = face_hit(cand, r)
                        if ok and t > t_start - t_tol and (cell < 0 or t < t_in):
                            cell = c
                            face_in = f
                            t_in = wp.max(t, t_start)
                            s_in = s
                            fc = cand
    if entry_failed == 1 and setup == SETUP_PAPER:
        status[idx] = STATUS_LOST
        wp.atomic_add(counters, chunk, 3, 1)
        return
    if entry_failed == 1 or t_clip > 0.0:
        status[idx] = STATUS_FAILED
        wp.atomic_add(counters, chunk, 3, 1)
        return
    if cell < 0:
        status[idx] = STATUS_DONE
        return
    wp.atomic_add(counters, chunk, 0, 1)

    # ---- propagation: one cell per fragment-program step (Fig. 6) ----
    acc = rgba[idx]
    steps = int(0)
    cells_visited = int(0)
    stall = int(0)
    failed = int(0)
    exited = int(0)
    fetches = int(0)
    backward = int(0)
    k_in = int(-1)
    v_in = wp.vec4(0.0, 0.0, 0.0, 0.0)
    # thin-layer check of the consistent walk with exact segments (as raycast's march)
    check_thin = walk == WALK_PLUCKER and ig.mode == INTEG_EXACT
    thin = int(0)
    scale = float(radius)
    thin_mem = thin_start()  # the thin-layer check's memory of the previous segment
    while cells_visited < max_steps:
        cells_visited += 1
        t_out = float(0.0)
        s_out = float(0.0)
        nb = int(-1)
        if walk == WALK_PLANES:
            lam, f_out = plane_exit(mt, cell, o, d)
            fetches += 4
            if f_out < 0:
                failed = 1
                break
            g = cell_texel(mt, mt.grad, cell)
            a = cell_texel(mt, mt.adj, cell)
            fetches += 2
            t_out = lam
            if setup == SETUP_PAPER:
                # Fig. 6: lambda' as computed; a step that does not advance only counts towards
                # the stall bound (the hardware's loop would run on to its instruction limit)
                stall = stall + 1
                if lam > t_in:
                    stall = int(0)
                elif lam < t_in:
                    backward = 1  # rounding chose an exit behind the entry: the walk is suspect
            else:
                t_out, stall = monotone_exit(t_in, t_out, stall)
            s_in = grad_scalar(g, o + d * t_in)  # Fig. 6 line 10: sf from this cell's gradient
            s_out = grad_scalar(g, o + d * t_out)
            nb = int(wp.clamp(a[f_out], -1.0, 1.0e8))
        else:
            fc, f_out, t_out, s_out = next_face(tets[cell], face_in, fc, verts, r)
            if f_out < 0:
                failed = 1
                break
            t_out, stall = monotone_exit(t_in, t_out, stall)
            nb = nbr[cell][f_out]
        if stall > STALL_STEPS:
            failed = 1
            break
        if ig.mode == INTEG_EXACT:
            # the exact integral with the TF value carried from face to face (as raycast's march):
            # one TF evaluation per face, one linear piece unless a control point is crossed
            if k_in < 0:
                k_in = tf_upper(s_in, ig.tf_s)
                v_in = tf_eval_upper(s_in, k_in, ig.tf_s, ig.tf_v)
            k_out = tf_upper(s_out, ig.tf_s)
            v_out = tf_eval_upper(s_out, k_out, ig.tf_s, ig.tf_v)
            seg = wp.vec4(0.0, 0.0, 0.0, 0.0)
            seg_l = t_out - t_in
            if setup == SETUP_PAPER and seg_l < 0.0:
                seg_l = 0.0  # lambda' before lambda: nothing to integrate
            if k_in == k_out:
                seg = integrate_piece(seg_l, v_in, v_out, ig.model)
            else:
                seg = integrate_segment_tf(s_in, s_out, v_in, v_out, seg_l, ig.tf_s, ig.tf_v, ig.model)
            if check_thin:
                thin, thin_mem = thin_step(thin_mem, t_out - t_in, seg[3], t_out, scale, 1.0 - acc[3], v_in, v_out,
                                           k_in, k_out, ig.tf_v, ig.model)
                if thin == 1:
                    failed = 1
                    break
            acc = composite(acc, wp.vec4(seg[0], seg[1], seg[2], 1.0 - exp_neg(seg[3])))
            steps += 1
            k_in = k_out
            v_in = v_out
            if walk == WALK_PLANES:
                k_in = -1  # the next cell recomputes sf from its own gradient (Fig. 6 line 10)
        else:
            acc, n_sub = segment(ig, s_in, s_out, t_out - t_in, acc, t_stop, counters, chunk)
            steps += n_sub
        t_in = t_out
        s_in = s_out
        if 1.0 - acc[3] < t_stop:
            break
        if nb < 0:
            exited = 1
            if thin_at_exit(thin_mem):
                failed = 1
                thin = 1
            break
        cell = nb >> 2
        face_in = nb & 3
    wp.atomic_add(counters, chunk, 1, steps)
    wp.atomic_add(counters, chunk, 2, cells_visited)
    wp.atomic_add(counters, chunk, 6, fetches)
    px_work[idx] = wp.vec2i(cells_visited, steps)  # this pixel's loop work in this pass (one thread per pixel)
    if backward == 1:
        wp.atomic_add(counters, chunk, 9, 1)
    if failed == 1 and setup == SETUP_PAPER:
        # lost: the fragment program ends, its partial result goes to the frame buffer
        rgba[idx] = wp.vec4(fmt_quantize(fb, acc[0]), fmt_quantize(fb, acc[1]), fmt_quantize(fb, acc[2]),
                            fmt_quantize(fb, acc[3]))
        status[idx] = STATUS_LOST
        wp.atomic_add(counters, chunk, 3, 1)
        return
    if failed == 1:
        status[idx] = STATUS_FAILED
        wp.atomic_add(counters, chunk, 3, 1)
        if thin == 1:
            wp.atomic_add(counters, chunk, 8, 1)
        return
    # the pass's result goes to the frame buffer in its number format
    rgba[idx] = wp.vec4(fmt_quantize(fb, acc[0]), fmt_quantize(fb, acc[1]), fmt_quantize(fb, acc[2]),
                        fmt_quantize(fb, acc[3]))
    tcur[idx] = t_in
    last[idx] = cell
    if exited == 0:
        status[idx] = STATUS_DONE
        if 1.0 - acc[3] >= t_stop:
            wp.atomic_add(counters, chunk, 4, 1)
            if setup == SETUP_PAPER:
                status[idx] = STATUS_LOST  # the step bound ended it inside the mesh


@wp.kernel
def init_state(rgba: wp.array(dtype=wp.vec4), tcur: wp.array(dtype=float), status: wp.array(dtype=wp.int32),
               last: wp.array(dtype=wp.int32)):
    i = wp.tid()
    rgba[i] = wp.vec4(0.0, 0.0, 0.0, 0.0)
    tcur[i] = 0.0
    status[i] = STATUS_ACTIVE
    last[i] = -1


@wp.kernel
def segments_kernel(ig: Integ, sf: wp.array(dtype=float), sb: wp.array(dtype=float), l: wp.array(dtype=float),
                    counters: wp.array2d(dtype=wp.int32), out: wp.array(dtype=wp.vec4),
                    steps: wp.array(dtype=wp.int32)):
    """One segment per thread through :func:`segment` (tests: iso splits vs the exact integral)."""
    i = wp.tid()
    acc, n = segment(ig, sf[i], sb[i], l[i], wp.vec4(0.0, 0.0, 0.0, 0.0), 0.0, counters, 0)
    out[i] = acc
    steps[i] = n
