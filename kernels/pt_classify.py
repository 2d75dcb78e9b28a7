"""Projected tetrahedra (Shirley & Tuchman 1990): classification and decomposition of the tets.

``k_classify`` (one thread per tet, in visibility order) works on the rasteriser's snapped window
coordinates (``snap``: 1/256 pixel with the rasteriser's tie rule ``even``; orientations are the
rasteriser's exact int64 edge functions ``edge``), so the decomposition agrees with
what the rasteriser will cover:

* **class 2 (3 triangles)**: one vertex projects inside (or onto the boundary of) the triangle of the
  other three. It becomes the *thick vertex*; the other three are silhouette vertices.
  Degenerate members, classified apart: the vertex on an edge (one triangle of zero area) or on
  another vertex (two).
* **class 1 (4 triangles)**: the projection is a convex quadrilateral whose diagonals are two
  opposite tet edges; the thick vertex is where they cross, rounded to the 1/256 grid. If rounding
  would put it outside the quadrilateral (a sliver), a neighbouring grid point inside is taken, else
  the nearest diagonal end (counted in ``stats[3]``): coverage stays exact, attributes move by < 1/256 px.
* **flat**: all four projections collinear (the tet projects to a segment or a point): nothing is
  drawn.
* **culled**: a vertex at or behind the eye (``w <= 0``): nothing is drawn (no clipping).

The thick vertex carries ``(sf, sb, l)``: the scalars at the front and back points on the ray
through it and their eye-space distance (world units). The two points are found with
perspective-correct weights (interpolate ``a/w`` and ``1/w``), so ``l`` is right in perspective
and orthographic views alike; silhouette vertices carry ``(s, s, 0)``. Output vertex ``V + k`` is the
thick vertex of the k-th tet in the order; its triangles are ``4k .. 4k+3`` (unused ones degenerate).
"""

import warp as wp

from .raster import edge, snap

wp.set_module_options({"enable_backward": False, "fuse_fp": False})  # same roundings on CPU and CUDA

CLASS_FOUR = wp.constant(0)
CLASS_THREE = wp.constant(1)
CLASS_FLAT = wp.constant(2)
CLASS_CULLED = wp.constant(3)
CLASS_ON_EDGE = wp.constant(4)
CLASS_ON_VERTEX = wp.constant(5)


@wp.func
def store_thick(thick_attr: wp.array(dtype=wp.vec3), thick_front: wp.array(dtype=wp.vec4),
                thick_back: wp.array(dtype=wp.vec4), k: int, sa: float, sb: float, thick: float,
                pa: wp.vec4, pb: wp.vec4) -> int:
    """Store tet ``k``'s thick vertex: (sf, sb, l) and its front and back eye points ``(x, y, z, w)``,
    ``a`` in front when it is nearer the eye (eye space looks down -z). Returns 1 if ``a`` is the front."""
    if pa[2] >= pb[2]:
        thick_attr[k] = wp.vec3(sa, sb, thick)
        thick_front[k] = pa
        thick_back[k] = pb
        return 1
    thick_attr[k] = wp.vec3(sb, sa, thick)
    thick_front[k] = pb
    thick_back[k] = pa
    return 0


@wp.func
def sgn(v: wp.int64) -> int:
    if v > wp.int64(0):
        return 1
    if v < wp.int64(0):
        return -1
    return 0


@wp.func
def in_closed_tri(x: wp.vec4i, y: wp.vec4i, i: int, j: int, k: int, l: int) -> bool:
    """Is vertex i inside or on the boundary of the non-degenerate triangle (j, k, l)?"""
    a = sgn(edge(x[j], y[j], x[k], y[k], x[l], y[l]))
    if a == 0:
        return False
    s0 = sgn(edge(x[j], y[j], x[k], y[k], x[i], y[i])) * a
    s1 = sgn(edge(x[k], y[k], x[l], y[l], x[i], y[i])) * a
    s2 = sgn(edge(x[l], y[l], x[j], y[j], x[i], y[i])) * a
    return s0 >= 0 and s1 >= 0 and s2 >= 0


@wp.func
def zero_subtriangles(x: wp.vec4i, y: wp.vec4i, i: int, j: int, k: int, l: int) -> int:
    """How many of the triangles (i, j, k), (i, k, l), (i, l, j) have zero area (i on an edge: 1,
    on a vertex: 2)."""
    n = int(0)
    if edge(x[j], y[j], x[k], y[k], x[i], y[i]) == wp.int64(0):
        n += 1
    if edge(x[k], y[k], x[l], y[l], x[i], y[i]) == wp.int64(0):
        n += 1
    if edge(x[l], y[l], x[j], y[j], x[i], y[i]) == wp.int64(0):
        n += 1
    return n


@wp.func
def in_closed_quad(x: wp.vec4i, y: wp.vec4i, a: int, c: int, b: int, d: int, tx: int, ty: int) -> bool:
    """Is (tx, ty) inside or on the convex quadrilateral a, c, b, d (in this cyclic order)?"""
    s0 = sgn(edge(x[a], y[a], x[c], y[c], tx, ty))
    s1 = sgn(edge(x[c], y[c], x[b], y[b], tx, ty))
    s2 = sgn(edge(x[b], y[b], x[d], y[d], tx, ty))
    s3 = sgn(edge(x[d], y[d], x[a], y[a], tx, ty))
    pos = s0 >= 0 and s1 >= 0 and s2 >= 0 and s3 >= 0
    neg = s0 <= 0 and s1 <= 0 and s2 <= 0 and s3 <= 0
    return pos or neg


@wp.func
def crossing(x: wp.vec4i, y: wp.vec4i, a: int, b: int, c: int, d: int) -> bool:
    """Do the segments a-b and c-d cross at a point interior to both?"""
    o1 = sgn(edge(x[a], y[a], x[b], y[b], x[c], y[c]))
    o2 = sgn(edge(x[a], y[a], x[b], y[b], x[d], y[d]))
    o3 = sgn(edge(x[c], y[c], x[d], y[d], x[a], y[a]))
    o4 = sgn(edge(x[c], y[c], x[d], y[d], x[b], y[b]))
    return o1 * o2 < 0 and o3 * o4 < 0


@wp.func
def persp_param(t: float, wa: float, wb: float) -> float:
    """Parameter along a 3D segment a-b of the point whose projection is at screen parameter t."""
    q = t / wb
    return q / ((1.0 - t) / wa + q)


@wp.func
def unsnapped_crossing(pa: wp.vec4, pb: wp.vec4, pc: wp.vec4, pd: wp.vec4) -> wp.vec2:
    """Screen parameters ``(t, u)`` along a -> b and c -> d of the crossing of the two unsnapped
    projected segments (float64 from the float32 window positions); ``(-1, -1)`` for parallel ones."""
    ax = wp.float64(pa[0])
    ay = wp.float64(pa[1])
    d1x = wp.float64(pb[0]) - ax
    d1y = wp.float64(pb[1]) - ay
    d2x = wp.float64(pd[0]) - wp.float64(pc[0])
    d2y = wp.float64(pd[1]) - wp.float64(pc[1])
    ex = wp.float64(pc[0]) - ax
    ey = wp.float64(pc[1]) - ay
    den = d1x * d2y - d1y * d2x
    if den == wp.float64(0.0):
        return wp.vec2(-1.0, -1.0)
    return wp.vec2(float((ex * d2y - ey * d2x) / den), float((ex * d1y - ey * d1x) / den))


@wp.kernel
def k_classify(win: wp.array(dtype=wp.vec4), eye: wp.array(dtype=wp.vec4), scal: wp.array(dtype=wp.float32),
               tets: wp.array2d(dtype=wp.int32), order: wp.array(dtype=wp.int32), n_points: int, even: int,
               thick_pos: wp.array(dtype=wp.vec4), thick_attr: wp.array(dtype=wp.vec3),
               tris: wp.array(dtype=wp.vec3i), klass: wp.array(dtype=wp.int32), moved: wp.array(dtype=wp.int32),
               thick_front: wp.array(dtype=wp.vec4), thick_back: wp.array(dtype=wp.vec4),
               attr_pos: wp.array(dtype=wp.vec4), exact: int, k0: int):
    k = k0 + wp.tid()  # a block of tets from k0 (blocks may be launched concurrently)
    c = order[k]
    v = wp.vec4i(tets[c, 0], tets[c, 1], tets[c, 2], tets[c, 3])
    tv = n_points + k
    moved[k] = 0
    for q in range(4):
        tris[4 * k + q] = wp.vec3i(tv, tv, tv)
    thick_pos[k] = win[v[0]]
    attr_pos[k] = win[v[0]]
    s0 = scal[v[0]]
    thick_attr[k] = wp.vec3(s0, s0, 0.0)
    e0 = eye[v[0]]
    thick_front[k] = wp.vec4(e0[0], e0[1], e0[2], win[v[0]][3])
    thick_back[k] = thick_front[k]
    ok = True
    for q in range(4):
        if not (win[v[q]][3] > 0.0):
            ok = False
    if not ok:
        klass[k] = CLASS_CULLED
        return
    x = wp.vec4i(snap(win[v[0]][0], even), snap(win[v[1]][0], even), snap(win[v[2]][0], even),
                 snap(win[v[3]][0], even))
    y = wp.vec4i(snap(win[v[0]][1], even), snap(win[v[1]][1], even), snap(win[v[2]][1], even),
                 snap(win[v[3]][1], even))
    # class 2: a vertex inside the triangle of the other three
    inner = int(-1)
    for i in range(4):
        if inner < 0:
            j = (i + 1) % 4
            kk = (i + 2) % 4
            l = (i + 3) % 4
            if in_closed_tri(x, y, i, j, kk, l):
                inner = i
    if inner >= 0:
        i = inner
        j = (i + 1) % 4
        kk = (i + 2) % 4
        l = (i + 3) % 4
        # perspective-correct weights of the inner vertex's projection on the face (j, kk, l)
        pj = win[v[j]]
        pk = win[v[kk]]
        pl = win[v[l]]
        pi = win[v[i]]
        area = (pk[0] - pj[0]) * (pl[1] - pj[1]) - (pk[1] - pj[1]) * (pl[0] - pj[0])
        bj = ((pk[0] - pi[0]) * (pl[1] - pi[1]) - (pk[1] - pi[1]) * (pl[0] - pi[0])) / area
        bk = ((pl[0] - pi[0]) * (pj[1] - pi[1]) - (pl[1] - pi[1]) * (pj[0] - pi[0])) / area
        bj = wp.clamp(bj, 0.0, 1.0)
        bk = wp.clamp(bk, 0.0, 1.0 - bj)
        bl = 1.0 - bj - bk
        qj = bj / pj[3]
        qk = bk / pk[3]
        ql = bl / pl[3]
        qs = qj + qk + ql
        qj = qj / qs
        qk = qk / qs
        ql = ql / qs
        ej = eye[v[j]]
        ek = eye[v[kk]]
        el = eye[v[l]]
        ef = ej * qj + ek * qk + el * ql
        sface = scal[v[j]] * qj + scal[v[kk]] * qk + scal[v[l]] * ql
        ei = eye[v[i]]
        thick = wp.length(wp.vec3(ef[0] - ei[0], ef[1] - ei[1], ef[2] - ei[2]))
        si = scal[v[i]]
        pin = wp.vec4(ei[0], ei[1], ei[2], pi[3])
        pface = wp.vec4(ef[0], ef[1], ef[2], pj[3] * qj + pk[3] * qk + pl[3] * ql)
        store_thick(thick_attr, thick_front, thick_back, k, si, sface, thick, pin, pface)
        thick_pos[k] = wp.vec4(float(x[i]) / 256.0, float(y[i]) / 256.0, pi[2], pi[3])  # = the snapped vertex
        attr_pos[k] = pi  # where its attributes are taken: the unsnapped vertex
        tris[4 * k + 0] = wp.vec3i(tv, v[j], v[kk])
        tris[4 * k + 1] = wp.vec3i(tv, v[kk], v[l])
        tris[4 * k + 2] = wp.vec3i(tv, v[l], v[j])
        z = zero_subtriangles(x, y, i, j, kk, l)
        klass[k] = CLASS_THREE
        if z == 1:
            klass[k] = CLASS_ON_EDGE
        elif z >= 2:
            klass[k] = CLASS_ON_VERTEX
        return
    # class 1: two opposite edges a-b and c-d cross
    a = int(-1)
    b = int(-1)
    cc = int(-1)
    d = int(-1)
    if crossing(x, y, 0, 1, 2, 3):
        a = 0
        b = 1
        cc = 2
        d = 3
    elif crossing(x, y, 0, 2, 1, 3):
        a = 0
        b = 2
        cc = 1
        d = 3
    elif crossing(x, y, 0, 3, 1, 2):
        a = 0
        b = 3
        cc = 1
        d = 2
    if a < 0:
        klass[k] = CLASS_FLAT  # all four projections on one line
        return
    oca = edge(x[cc], y[cc], x[d], y[d], x[a], y[a])
    ocb = edge(x[cc], y[cc], x[d], y[d], x[b], y[b])
    oac = edge(x[a], y[a], x[b], y[b], x[cc], y[cc])
    oad = edge(x[a], y[a], x[b], y[b], x[d], y[d])
    t = float(wp.float64(oca) / (wp.float64(oca) - wp.float64(ocb)))  # along a -> b
    u = float(wp.float64(oac) / (wp.float64(oac) - wp.float64(oad)))  # along c -> d
    fx = wp.float64(x[a]) + wp.float64(t) * wp.float64(x[b] - x[a])
    fy = wp.float64(y[a]) + wp.float64(t) * wp.float64(y[b] - y[a])
    tx = int(wp.round(fx))
    ty = int(wp.round(fy))
    ax = float(0.0)
    ay = float(0.0)
    at_exact = int(0)
    if exact != 0:  # the attributes where the unsnapped projections cross (the snapped crossing is coverage's)
        te = unsnapped_crossing(win[v[a]], win[v[b]], win[v[cc]], win[v[d]])
        if te[0] >= 0.0 and te[0] <= 1.0 and te[1] >= 0.0 and te[1] <= 1.0:
            t = te[0]
            u = te[1]
            ax = win[v[a]][0] + t * (win[v[b]][0] - win[v[a]][0])
            ay = win[v[a]][1] + t * (win[v[b]][1] - win[v[a]][1])
            at_exact = 1
    if not in_closed_quad(x, y, a, cc, b, d, tx, ty):
        found = False
        fx0 = int(wp.floor(fx))
        fy0 = int(wp.floor(fy))
        for q in range(4):
            cx = fx0 + q % 2
            cy = fy0 + q / 2
            if (not found) and in_closed_quad(x, y, a, cc, b, d, cx, cy):
                tx = cx
                ty = cy
                found = True
        if not found:
            tx = x[a]
            ty = y[a]
            if t > 0.5:
                tx = x[b]
                ty = y[b]
        moved[k] = 1
    wa = win[v[a]]
    wb = win[v[b]]
    wc = win[v[cc]]
    wd = win[v[d]]
    t3 = persp_param(t, wa[3], wb[3])
    u3 = persp_param(u, wc[3], wd[3])
    e1 = eye[v[a]] * (1.0 - t3) + eye[v[b]] * t3
    e2 = eye[v[cc]] * (1.0 - u3) + eye[v[d]] * u3
    s1 = scal[v[a]] * (1.0 - t3) + scal[v[b]] * t3
    s2 = scal[v[cc]] * (1.0 - u3) + scal[v[d]] * u3
    thick = wp.length(wp.vec3(e1[0] - e2[0], e1[1] - e2[1], e1[2] - e2[2]))
    z1 = wa[2] * (1.0 - t) + wb[2] * t
    z2 = wc[2] * (1.0 - u) + wd[2] * u
    w1 = wa[3] * (1.0 - t) + wb[3] * t
    p1 = wp.vec4(e1[0], e1[1], e1[2], wa[3] * (1.0 - t3) + wb[3] * t3)
    p2 = wp.vec4(e2[0], e2[1], e2[2], wc[3] * (1.0 - u3) + wd[3] * u3)
    if store_thick(thick_attr, thick_front, thick_back, k, s1, s2, thick, p1, p2) == 0:
        z1 = z2
    thick_pos[k] = wp.vec4(float(tx) / 256.0, float(ty) / 256.0, z1, w1)
    attr_pos[k] = thick_pos[k]
    if at_exact != 0:
        attr_pos[k] = wp.vec4(ax, ay, z1, w1)
    tris[4 * k + 0] = wp.vec3i(tv, v[a], v[cc])
    tris[4 * k + 1] = wp.vec3i(tv, v[cc], v[b])
    tris[4 * k + 2] = wp.vec3i(tv, v[b], v[d])
    tris[4 * k + 3] = wp.vec3i(tv, v[d], v[a])
    klass[k] = CLASS_FOUR
