"""Projected tetrahedra (Shirley & Tuchman 1990): classification, decomposition, fragment programs.

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

from .integrate import exp_neg, integrate_piece, integrate_pieces
from .preint import cyl_planes_sample, table_to_cyl
from .raster import edge, snap
from .texture import Atlas, Tex1D, Tex3D, atlas_sample, tex1d, tex3d
from .tf import tf_eval, tf_eval_upper, tf_first_break_upper, tf_upper

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
def exact_color(a: wp.vec3, tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int) -> wp.vec4:
    """pt_best's fragment colour: the segment ``a = (sf, sb, l)`` integrated exactly (premultiplied
    RGB, alpha ``1 - exp(-tau)``); the values of
    :func:`~warpvol.kernels.integrate.integrate_segment`. Both ends in the same TF interval (one
    search each; most fragments of a cell are) means no control point between them: the segment is
    one piece, integrated without the walk over crossed control points."""
    length = wp.max(a[2], 0.0)
    r = wp.vec4(0.0, 0.0, 0.0, 0.0)
    if length > 0.0:
        kf = tf_upper(a[0], tf_s)
        kb = tf_upper(a[1], tf_s)
        vf = tf_eval_upper(a[0], kf, tf_s, tf_v)
        vb = tf_eval_upper(a[1], kb, tf_s, tf_v)
        if kf == kb:
            r = integrate_piece(length, vf, vb, model)
        else:
            r = integrate_pieces(a[0], a[1], vf, vb, tf_first_break_upper(kf, a[0], a[1], tf_s), length, tf_s,
                                 tf_v, model)
    return wp.vec4(r[0], r[1], r[2], 1.0 - exp_neg(r[3]))


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
