"""Exact float64 predicates of the reference renderer's walk (kernels: :mod:`warpvol.kernels.reference`).

Where a pixel's line meets a tet, in float64 camera coordinates (``x`` right, ``y`` up, ``z``
forward from the eye). None of the renderers' ``@wp.func``s are used here.

* :func:`edge_side` -- side of a pixel's line against a mesh edge ``(a, b)``, endpoints in
  ascending global vertex order so every tet sharing the edge gets the same value. Perspective: the
  Plücker product ``d . (a x b)`` (``d = (dx, dy, 1)``, the line through the eye); orthographic: the
  2D orientation ``(a - q) x (b - a)`` of the pixel position ``q``. The sign is exact: a
  floating-point filter, and where it cannot decide, an exact evaluation with error-free
  transformations (Dekker two-product, Knuth two-sum, Shewchuk's grow-expansion). Exact zeros are
  broken by simulation of simplicity (the direction perturbed by ``(eps, eps^2, 0)``, resp. the
  pixel position by ``(eps, eps^2)``); an edge whose line passes through the eye keeps sign 0.
* :func:`face_cross` -- a face is pierced when the signs of its three edges agree; entry or exit
  from the tet's orientation; depth and scalar from the clamped barycentric weights of the three
  edge values (bit-identical from both tets sharing the face).
* :func:`tet_segment` -- entry / exit faces, depths and scalars of the line in one tet (:class:`Seg`); a walk
  passes the exit face's edge values on to the next tet, which shares them (:func:`shared_face`).
"""

from __future__ import annotations

import warp as wp

wp.set_module_options({"enable_backward": False})  # functions only: they take the calling kernel's options

FILTER = wp.constant(wp.float64(1e-15))  # relative rounding bound of the float filter
SPLITTER = wp.constant(wp.float64(134217729.0))  # 2^27 + 1 (Dekker split)

vec24d = wp.types.vector(length=24, dtype=wp.float64)
vec6d = wp.types.vector(length=6, dtype=wp.float64)


@wp.struct
class Seg:
    ne: int  # entry faces pierced
    nx: int  # exit faces pierced
    kin: int  # first entry face (sorted-local face index), -1 if none
    kout: int  # first exit face, -1 if none
    deg: int  # some edge line of the tet passes through the eye (perspective)
    t_in: wp.float64
    t_out: wp.float64
    s_in: wp.float64
    s_out: wp.float64
    nexact: int  # exact (expansion) evaluations
    xf: wp.vec3i  # global vertices of the first exit face, ascending ((-1, -1, -1) if none)
    xab: wp.vec4d  # its edges' edge_side values: (a, b), (b, c), (a, c)
    xbc: wp.vec4d
    xac: wp.vec4d


# ------------------------------------------------------------------------------------------------
# exact arithmetic
# ------------------------------------------------------------------------------------------------
@wp.func
def fsign(x: wp.float64) -> wp.float64:
    if x > wp.float64(0.0):
        return wp.float64(1.0)
    if x < wp.float64(0.0):
        return wp.float64(-1.0)
    return wp.float64(0.0)


@wp.func
def two_sum_err(a: wp.float64, b: wp.float64, s: wp.float64) -> wp.float64:
    bb = s - a
    return (a - (s - bb)) + (b - bb)


@wp.func
def two_prod_err(a: wp.float64, b: wp.float64, p: wp.float64) -> wp.float64:
    c = SPLITTER * a
    ah = c - (c - a)
    al = a - ah
    d = SPLITTER * b
    bh = d - (d - b)
    bl = b - bh
    return al * bl - (((p - ah * bh) - al * bh) - ah * bl)


@wp.func
def put_prod2(parts: vec24d, n: int, a: wp.float64, b: wp.float64) -> vec24d:
    p = a * b
    out = parts
    out[n] = p
    out[n + 1] = two_prod_err(a, b, p)
    return out


@wp.func
def put_prod3(parts: vec24d, n: int, a: wp.float64, b: wp.float64, c: wp.float64) -> vec24d:
    p = a * b
    e = two_prod_err(a, b, p)
    p1 = p * c
    p2 = e * c
    out = parts
    out[n] = p1
    out[n + 1] = two_prod_err(p, c, p1)
    out[n + 2] = p2
    out[n + 3] = two_prod_err(e, c, p2)
    return out


@wp.func
def expansion_sum(parts: vec24d, n: int) -> wp.vec2d:
    """Exact sign and nearly correctly rounded value of ``sum(parts[:n])`` (grow-expansion)."""
    e = vec24d()
    m = int(0)
    for i in range(n):
        q = parts[i]
        for j in range(m):
            s = q + e[j]
            e[j] = two_sum_err(q, e[j], s)
            q = s
        e[m] = q
        m = m + 1
    value = wp.float64(0.0)
    sg = wp.float64(0.0)
    for j in range(m):
        value = value + e[j]
        if e[j] != wp.float64(0.0):
            sg = fsign(e[j])
    return wp.vec2d(sg, value)


@wp.func
def sign_det2(p: wp.float64, q: wp.float64, r: wp.float64, t: wp.float64) -> wp.float64:
    """Exact ``sign(p q - r t)``."""
    pq = p * q
    rt = r * t
    v = pq - rt
    bound = FILTER * (wp.abs(pq) + wp.abs(rt))
    if wp.abs(v) > bound or bound == wp.float64(0.0):
        return fsign(v)
    parts = vec24d()
    parts = put_prod2(parts, 0, p, q)
    parts = put_prod2(parts, 2, -r, t)
    return expansion_sum(parts, 4)[0]


# ------------------------------------------------------------------------------------------------
# ray / tet classification
# ------------------------------------------------------------------------------------------------
@wp.func
def edge_side(a: wp.vec3d, b: wp.vec3d, dx: wp.float64, dy: wp.float64, persp: int) -> wp.vec4d:
    """``(value, exact sign after simulation of simplicity, exact evaluations, edge line through the
    eye)`` of the pixel's line against the edge ``a -> b`` (ascending global order)."""
    one = wp.float64(1.0)
    zero = wp.float64(0.0)
    nex = zero
    if persp != 0:
        p1 = a[1] * b[2]
        p2 = a[2] * b[1]
        p3 = a[2] * b[0]
        p4 = a[0] * b[2]
        p5 = a[0] * b[1]
        p6 = a[1] * b[0]
        cx = p1 - p2
        cy = p3 - p4
        cz = p5 - p6
        w = cx * dx + cy * dy + cz
        # A x B = 0 exactly: the edge's line passes through the eye, and w = 0 exactly
        zero_edge = int(0)
        if cx == zero and cy == zero and cz == zero:
            if p1 == zero and p2 == zero and p3 == zero and p4 == zero and p5 == zero and p6 == zero:
                zero_edge = 1
            elif sign_det2(a[1], b[2], a[2], b[1]) == zero and sign_det2(a[2], b[0], a[0], b[2]) == zero \
                    and sign_det2(a[0], b[1], a[1], b[0]) == zero:
                zero_edge = 1
        if zero_edge == 1:
            return wp.vec4d(zero, zero, zero, one)
        bound = FILTER * (wp.abs(dx) * (wp.abs(p1) + wp.abs(p2)) + wp.abs(dy) * (wp.abs(p3) + wp.abs(p4))
                          + (wp.abs(p5) + wp.abs(p6)))
        sg = fsign(w)
        if wp.abs(w) <= bound and bound > zero:
            parts = vec24d()
            parts = put_prod3(parts, 0, dx, a[1], b[2])
            parts = put_prod3(parts, 4, -dx, a[2], b[1])
            parts = put_prod3(parts, 8, dy, a[2], b[0])
            parts = put_prod3(parts, 12, -dy, a[0], b[2])
            parts = put_prod2(parts, 16, a[0], b[1])
            parts = put_prod2(parts, 18, -a[1], b[0])
            r = expansion_sum(parts, 20)
            sg = r[0]
            w = r[1]
            nex = one
        if sg == zero:  # perturbed direction d + (eps, eps^2, 0)
            sg = sign_det2(a[1], b[2], a[2], b[1])
            if sg == zero:
                sg = sign_det2(a[2], b[0], a[0], b[2])
        return wp.vec4d(w, sg, nex, zero)
    # orthographic: pixel position q = (dx, dy)
    ex = b[0] - a[0]
    ey = b[1] - a[1]
    left = (a[0] - dx) * ey
    right = (a[1] - dy) * ex
    w = left - right
    bound = FILTER * (wp.abs(left) + wp.abs(right))
    sg = fsign(w)
    if wp.abs(w) <= bound and bound > zero:
        parts = vec24d()
        parts = put_prod2(parts, 0, a[0], b[1])
        parts = put_prod2(parts, 2, -a[0], dy)
        parts = put_prod2(parts, 4, -dx, b[1])
        parts = put_prod2(parts, 6, -a[1], b[0])
        parts = put_prod2(parts, 8, a[1], dx)
        parts = put_prod2(parts, 10, dy, b[0])
        r = expansion_sum(parts, 12)
        sg = r[0]
        w = r[1]
        nex = one
    if sg == zero:  # perturbed position q + (eps, eps^2): w + (bx - ax) eps^2 - (by - ay) eps
        sg = -fsign(ey)
        if sg == zero:
            sg = fsign(ex)
    return wp.vec4d(w, sg, nex, zero)


@wp.func
def face_cross(wab: wp.float64, sab: wp.float64, wbc: wp.float64, sbc: wp.float64, wac: wp.float64,
               sac: wp.float64, za: wp.float64, zb: wp.float64, zc: wp.float64, sa: wp.float64,
               sb: wp.float64, sc: wp.float64, outward: wp.float64, dn: wp.float64, s_eye: wp.float64,
               persp: int) -> wp.vec3d:
    """``(kind, t, s)``: kind 0 not pierced, 1 entry, 2 exit; ``outward`` = +-1, the sign that makes
    the face's edge-sign outward for the tet."""
    zero = wp.float64(0.0)
    sca = -sac
    if not (sab == sbc and sbc == sca and sab != zero):
        return wp.vec3d(zero, zero, zero)
    kind = wp.float64(1.0)
    if sab * outward > zero:
        kind = wp.float64(2.0)
    wa = wp.max(sab * wbc, zero)
    wb = wp.max(-sab * wac, zero)
    wc = wp.max(sab * wab, zero)
    tot = wa + wb + wc
    al = wp.float64(1.0) / wp.float64(3.0)
    be = al
    ga = al
    if tot > zero:
        al = wa / tot
        be = wb / tot
        ga = wc / tot
    zz = al * za + be * zb + ga * zc
    ss = al * sa + be * sb + ga * sc
    if persp != 0:
        zz = zz * dn
        if not (tot > zero):  # the line lies in a face plane through the eye: it meets the face at the eye
            zz = zero
            ss = s_eye
    return wp.vec3d(kind, zz, ss)


@wp.func
def shared_face(v0: int, v1: int, v2: int, v3: int, pf: wp.vec3i) -> int:
    """The face (opposite ascending local vertex 0..3) of the tet ``v0 < v1 < v2 < v3`` whose vertices are
    ``pf`` (ascending), -1 if none."""
    if pf[0] < 0:
        return -1
    if v0 == pf[0] and v1 == pf[1] and v2 == pf[2]:
        return 3
    if v0 == pf[0] and v1 == pf[1] and v3 == pf[2]:
        return 2
    if v0 == pf[0] and v2 == pf[1] and v3 == pf[2]:
        return 1
    if v1 == pf[0] and v2 == pf[1] and v3 == pf[2]:
        return 0
    return -1


@wp.func
def edge_or_shared(i: int, j: int, sh: int, pab: wp.vec4d, pbc: wp.vec4d, pac: wp.vec4d, a: wp.vec3d, b: wp.vec3d,
                   dx: wp.float64, dy: wp.float64, persp: int) -> wp.vec4d:
    """The :func:`edge_side` value of the tet's edge ``i -> j`` (ascending local vertices, at ``a``, ``b``): the
    shared face's (:func:`shared_face` ``sh``, vertices ``fa < fb < fc``: edges ``pab`` = (fa, fb), ``pbc`` =
    (fb, fc), ``pac`` = (fa, fc)) where that face holds the edge, else evaluated."""
    if sh < 0 or sh == i or sh == j:
        return edge_side(a, b, dx, dy, persp)
    fa = int(0)
    if sh == 0:
        fa = 1
    fc = int(3)
    if sh == 3:
        fc = 2
    if i != fa:
        return pbc
    if j == fc:
        return pac
    return pab


@wp.func
def tet_segment(c: int, P: wp.array(dtype=wp.vec3d), S: wp.array(dtype=wp.float64),
                T: wp.array2d(dtype=wp.int32), orient: wp.array(dtype=wp.float64),
                s_eye: wp.array(dtype=wp.float64), dx: wp.float64, dy: wp.float64, dn: wp.float64,
                persp: int, pf: wp.vec3i, pab: wp.vec4d, pbc: wp.vec4d, pac: wp.vec4d) -> Seg:
    """The line's :class:`Seg` in tet ``c``. ``pf``, ``pab``, ``pbc``, ``pac``: the previous tet's exit face
    and its edge values (its :class:`Seg`'s ``xf``, ``xab``, ``xbc``, ``xac``; ``pf = (-1, -1, -1)``: none).
    Where ``c`` has that face (same global vertices), its three edges take those values instead of
    evaluating :func:`edge_side` again: the same function of the same vertices in the same order, so the
    same values bit for bit (the walk's step costs three edges instead of six)."""
    v0 = T[c, 0]
    v1 = T[c, 1]
    v2 = T[c, 2]
    v3 = T[c, 3]
    p0 = P[v0]
    p1 = P[v1]
    p2 = P[v2]
    p3 = P[v3]
    sh = shared_face(v0, v1, v2, v3, pf)
    # edges (0,1) (0,2) (0,3) (1,2) (1,3) (2,3) of the ascending vertices
    e0 = edge_or_shared(0, 1, sh, pab, pbc, pac, p0, p1, dx, dy, persp)
    e1 = edge_or_shared(0, 2, sh, pab, pbc, pac, p0, p2, dx, dy, persp)
    e2 = edge_or_shared(0, 3, sh, pab, pbc, pac, p0, p3, dx, dy, persp)
    e3 = edge_or_shared(1, 2, sh, pab, pbc, pac, p1, p2, dx, dy, persp)
    e4 = edge_or_shared(1, 3, sh, pab, pbc, pac, p1, p3, dx, dy, persp)
    e5 = edge_or_shared(2, 3, sh, pab, pbc, pac, p2, p3, dx, dy, persp)
    r = Seg()
    r.nexact = int(e0[2] + e1[2] + e2[2] + e3[2] + e4[2] + e5[2])
    r.deg = int(0)
    if e0[3] + e1[3] + e2[3] + e3[3] + e4[3] + e5[3] > wp.float64(0.0):
        r.deg = 1
    o = orient[c]
    se = wp.float64(0.0)
    if persp != 0:
        se = s_eye[c]
    s0 = S[v0]
    s1 = S[v1]
    s2 = S[v2]
    s3 = S[v3]
    # face f opposite ascending vertex f: (a, b, c) and edges (ab, bc, ac); outward for o * (-1)^f
    f0 = face_cross(e3[0], e3[1], e5[0], e5[1], e4[0], e4[1], p1[2], p2[2], p3[2], s1, s2, s3, o, dn, se, persp)
    f1 = face_cross(e1[0], e1[1], e5[0], e5[1], e2[0], e2[1], p0[2], p2[2], p3[2], s0, s2, s3, -o, dn, se, persp)
    f2 = face_cross(e0[0], e0[1], e4[0], e4[1], e2[0], e2[1], p0[2], p1[2], p3[2], s0, s1, s3, o, dn, se, persp)
    f3 = face_cross(e0[0], e0[1], e3[0], e3[1], e1[0], e1[1], p0[2], p1[2], p2[2], s0, s1, s2, -o, dn, se, persp)
    r.ne = int(0)
    r.nx = int(0)
    r.kin = int(-1)
    r.kout = int(-1)
    r.t_in = wp.float64(0.0)
    r.t_out = wp.float64(0.0)
    r.s_in = wp.float64(0.0)
    r.s_out = wp.float64(0.0)
    for f in range(4):
        fc = f0
        if f == 1:
            fc = f1
        elif f == 2:
            fc = f2
        elif f == 3:
            fc = f3
        if fc[0] == wp.float64(1.0):
            if r.ne == 0:
                r.kin = f
                r.t_in = fc[1]
                r.s_in = fc[2]
            r.ne = r.ne + 1
        elif fc[0] == wp.float64(2.0):
            if r.nx == 0:
                r.kout = f
                r.t_out = fc[1]
                r.s_out = fc[2]
            r.nx = r.nx + 1
    r.xf = wp.vec3i(-1, -1, -1)
    if r.kout == 0:
        r.xf = wp.vec3i(v1, v2, v3)
        r.xab = e3
        r.xbc = e5
        r.xac = e4
    elif r.kout == 1:
        r.xf = wp.vec3i(v0, v2, v3)
        r.xab = e1
        r.xbc = e5
        r.xac = e2
    elif r.kout == 2:
        r.xf = wp.vec3i(v0, v1, v3)
        r.xab = e0
        r.xbc = e4
        r.xac = e2
    elif r.kout == 3:
        r.xf = wp.vec3i(v0, v1, v2)
        r.xab = e0
        r.xbc = e3
        r.xac = e1
    return r
