"""Rasteriser of the emulated GPU: triangle setup, tile binning, coverage and interpolation (the
``@wp.func`` pieces every draw shares; the draw kernels are :mod:`warpvol.kernels.raster_draw`, and
the fused projected-tetrahedra draw :mod:`warpvol.kernels.pt_draw`).

Window coordinates: x in [0, W] left to right, y in [0, H] top to bottom (row index), z depth,
w the clip-space w (1 for orthographic). Pixel (row i, column j) has its centre at (j + .5, i + .5).

* **Snapping**: x, y are snapped to fixed point with ``SUBPIX`` = 8 fractional bits (round to nearest;
  ties to even (``snap_even=1``, ``wp.rint``, as Mesa's ``lrintf``) or away from zero (``wp.round``)),
  and edge functions are evaluated *exactly* in int64. Triangles with a vertex
  outside the guard band |x|, |y| <= 2^20 px, a non-finite coordinate or ``w <= 0`` are discarded
  (there is no geometric clipping; the vertex stage's users keep geometry in front of the eye).
* **Fill rule**: after orienting every triangle clockwise on screen (positive area in y-down
  coordinates), a pixel centre on an edge belongs to the triangle iff the edge is a *left* edge
  (going up the screen, interior to its right) or the inclusive horizontal edge: with
  ``fill_bottom=1`` the *bottom* edge as displayed (interior above; in GL window coordinates, y up,
  the horizontal edge with the smaller y, as Mesa llvmpipe), else the *top* edge (interior below).
  Either way a closed mesh covers each pixel centre exactly once per layer.
* **Interpolation** (``TriSetup.interp_rule``): ``INTERP_RULE_BARYCENTRIC``: barycentrics at the
  pixel centre from the *unsnapped* fp32 positions; ``linear`` (screen space) ``a = sum l_i a_i``;
  ``perspective`` ``a = sum (l_i/w_i) a_i / sum l_i/w_i``. ``INTERP_RULE_LLVMPIPE``: Mesa llvmpipe's
  plane equations (:func:`plane_attr`), evaluated in GL window coordinates (y up, GL y = H - y,
  pixel (row i, column j) at integer (j, H - 1 - i)) with llvmpipe's vertex order and fp32 operation
  order, FMA in the per-pixel step; ``perspective`` interpolates ``a/w`` and ``1/w`` the same way and
  multiplies by ``1 / (1/w)``. ``flat`` takes the last vertex of the triangle as given (OpenGL
  provoking vertex) under both rules. Depth is always barycentric (window z is affine in screen space).
* **Order**: triangles are binned to square tiles by a stable radix sort on the tile key, so each
  tile lists its triangles in submission order; one thread per pixel (or per tile) walks its tile's
  list, which keeps primitive order per pixel with no atomics. ``k_setup`` and ``k_emit`` take a
  first triangle ``t0``: blocks of triangles may be set up concurrently.
"""

import warp as wp

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

SUBPIX = wp.constant(256)
SUBPIX64 = wp.constant(wp.int64(256))
GUARD = wp.constant(1048576.0)

CULL_NONE = wp.constant(0)
CULL_BACK = wp.constant(1)
CULL_FRONT = wp.constant(2)

DEPTH_ALWAYS = wp.constant(0)
DEPTH_LESS = wp.constant(1)
DEPTH_GREATER = wp.constant(2)
DEPTH_LEQUAL = wp.constant(3)
DEPTH_GEQUAL = wp.constant(4)
DEPTH_NEVER = wp.constant(5)

INTERP_LINEAR = wp.constant(0)
INTERP_PERSPECTIVE = wp.constant(1)
INTERP_FLAT = wp.constant(2)

INTERP_RULE_BARYCENTRIC = wp.constant(0)
INTERP_RULE_LLVMPIPE = wp.constant(1)


@wp.struct
class TriSetup:
    """Per-triangle setup produced by :func:`k_setup` and the bins of :func:`k_tile_ranges`."""

    vidx: wp.array(dtype=wp.vec3i)  # vertex indices, reordered clockwise on screen
    sx: wp.array(dtype=wp.vec3i)  # snapped x (fixed point, SUBPIX per pixel)
    sy: wp.array(dtype=wp.vec3i)
    bias: wp.array(dtype=wp.vec3i)  # 0 if the edge opposite vertex k is inclusive (E == 0 counts), else 1
    bbox: wp.array(dtype=wp.vec4i)  # j0, i0, j1, i1 pixel range (inclusive)
    tile_start: wp.array(dtype=wp.int32)
    tile_end: wp.array(dtype=wp.int32)
    tri_of: wp.array(dtype=wp.int32)  # sorted bin entries -> triangle index
    tile_size: int
    tiles_x: int
    interp_rule: int  # INTERP_RULE_BARYCENTRIC or INTERP_RULE_LLVMPIPE
    height: int  # viewport height (GL window y = height - y for the llvmpipe rule)


@wp.func
def floordiv(a: int, b: int) -> int:
    q = a / b
    if (a % b != 0) and (a < 0):
        q = q - 1
    return q


@wp.func
def snap(x: float, even: int) -> int:
    """Fixed-point position (``SUBPIX`` steps per pixel); exact ties to even if ``even`` else away from zero."""
    v = x * float(SUBPIX)  # exact: a power-of-two scale of a coordinate inside the guard band
    if even != 0:
        return int(wp.rint(v))
    return int(wp.round(v))


@wp.func
def edge(ax: int, ay: int, bx: int, by: int, px: int, py: int) -> wp.int64:
    return wp.int64(bx - ax) * wp.int64(py - ay) - wp.int64(by - ay) * wp.int64(px - ax)


@wp.func
def edge_bias(ax: int, ay: int, bx: int, by: int, fill_bottom: int) -> int:
    """0 if edge a -> b of a clockwise (y-down) triangle is inclusive, else 1: left edges (going up the
    screen) and the bottom (``fill_bottom``: dx < 0, interior above) or top (dx > 0) horizontal edge."""
    dx = bx - ax
    dy = by - ay
    if dy < 0:
        return 0
    if dy == 0:
        if (fill_bottom != 0 and dx < 0) or (fill_bottom == 0 and dx > 0):
            return 0
    return 1


@wp.kernel
def k_setup(pos: wp.array(dtype=wp.vec4), tris: wp.array(dtype=wp.vec3i), width: int, height: int,
            tile_size: int, cull: int, front_ccw: int, snap_even: int, fill_bottom: int,
            vidx: wp.array(dtype=wp.vec3i), sx: wp.array(dtype=wp.vec3i), sy: wp.array(dtype=wp.vec3i),
            bias: wp.array(dtype=wp.vec3i), bbox: wp.array(dtype=wp.vec4i), counts: wp.array(dtype=wp.int32),
            t0: int):
    t = t0 + wp.tid()  # a block of triangles from t0 (blocks may be launched concurrently)
    counts[t] = 0
    bbox[t] = wp.vec4i(0, 0, -1, -1)
    tri = tris[t]
    nv = pos.shape[0]
    if wp.min(tri[0], wp.min(tri[1], tri[2])) < 0 or wp.max(tri[0], wp.max(tri[1], tri[2])) >= nv:
        return
    p0 = pos[tri[0]]
    p1 = pos[tri[1]]
    p2 = pos[tri[2]]
    ok = True
    for k in range(3):
        p = pos[tri[k]]
        if not (wp.abs(p[0]) <= GUARD and wp.abs(p[1]) <= GUARD and wp.isfinite(p[2]) and p[3] > 0.0
                and wp.isfinite(p[3])):
            ok = False
    if not ok:
        return
    x0 = snap(p0[0], snap_even)
    y0 = snap(p0[1], snap_even)
    x1 = snap(p1[0], snap_even)
    y1 = snap(p1[1], snap_even)
    x2 = snap(p2[0], snap_even)
    y2 = snap(p2[1], snap_even)
    area = edge(x0, y0, x1, y1, x2, y2)
    if area == wp.int64(0):
        return
    # area > 0 in y-down coordinates is clockwise as displayed; OpenGL's counter-clockwise (in its
    # y-up window coordinates, which display the same way) is therefore area < 0 here.
    ccw_gl = area < wp.int64(0)
    front = ccw_gl
    if front_ccw == 0:
        front = not ccw_gl
    if cull == CULL_BACK and not front:
        return
    if cull == CULL_FRONT and front:
        return
    i0 = tri[0]
    i1 = tri[1]
    i2 = tri[2]
    if area < wp.int64(0):
        tx = x1
        ty = y1
        x1 = x2
        y1 = y2
        x2 = tx
        y2 = ty
        ti = i1
        i1 = i2
        i2 = ti
    vidx[t] = wp.vec3i(i0, i1, i2)
    sx[t] = wp.vec3i(x0, x1, x2)
    sy[t] = wp.vec3i(y0, y1, y2)
    # edge k is opposite vertex k: e0 = (v1 -> v2), e1 = (v2 -> v0), e2 = (v0 -> v1)
    bias[t] = wp.vec3i(edge_bias(x1, y1, x2, y2, fill_bottom), edge_bias(x2, y2, x0, y0, fill_bottom),
                       edge_bias(x0, y0, x1, y1, fill_bottom))
    h = SUBPIX / 2
    xmin = wp.min(x0, wp.min(x1, x2))
    xmax = wp.max(x0, wp.max(x1, x2))
    ymin = wp.min(y0, wp.min(y1, y2))
    ymax = wp.max(y0, wp.max(y1, y2))
    j0 = wp.max(-floordiv(-(xmin - h), SUBPIX), 0)
    j1 = wp.min(floordiv(xmax - h, SUBPIX), width - 1)
    r0 = wp.max(-floordiv(-(ymin - h), SUBPIX), 0)
    r1 = wp.min(floordiv(ymax - h, SUBPIX), height - 1)
    if j0 > j1 or r0 > r1:
        return
    bbox[t] = wp.vec4i(j0, r0, j1, r1)
    counts[t] = (j1 / tile_size - j0 / tile_size + 1) * (r1 / tile_size - r0 / tile_size + 1)


@wp.kernel
def k_emit(bbox: wp.array(dtype=wp.vec4i), counts: wp.array(dtype=wp.int32), offsets: wp.array(dtype=wp.int32),
           tile_size: int, tiles_x: int, keys: wp.array(dtype=wp.int32), vals: wp.array(dtype=wp.int32), t0: int):
    t = t0 + wp.tid()
    if counts[t] == 0:
        return
    b = bbox[t]
    o = offsets[t]
    for ty in range(b[1] / tile_size, b[3] / tile_size + 1):
        for tx in range(b[0] / tile_size, b[2] / tile_size + 1):
            keys[o] = ty * tiles_x + tx
            vals[o] = t
            o += 1


@wp.kernel
def k_tile_ranges(keys: wp.array(dtype=wp.int32), total: int, start: wp.array(dtype=wp.int32),
                  end: wp.array(dtype=wp.int32)):
    i = wp.tid()
    k = keys[i]
    if i == 0:
        start[k] = i
    elif keys[i - 1] != k:
        start[k] = i
    if i == total - 1:
        end[k] = i + 1
    elif keys[i + 1] != k:
        end[k] = i + 1


vec3l = wp.types.vector(length=3, dtype=wp.int64)


@wp.func
def inside(e: vec3l) -> bool:
    """All three (biased) edge functions >= 0: the pixel centre is covered."""
    return e[0] >= wp.int64(0) and e[1] >= wp.int64(0) and e[2] >= wp.int64(0)


@wp.func
def first_nonneg(e: wp.int64, step: wp.int64, n: int) -> int:
    """Smallest ``k`` in ``[0, n)`` with ``e + k step >= 0`` for an increasing edge function (``step > 0``);
    ``n`` if none. A float64 estimate corrected by the exact int64 test (bit-exact with stepping)."""
    if e >= wp.int64(0):
        return 0
    k = int(wp.ceil(wp.float64(-e) / wp.float64(step)))
    k = wp.clamp(k, 0, n)
    while k > 0 and e + wp.int64(k - 1) * step >= wp.int64(0):
        k -= 1
    while k < n and e + wp.int64(k) * step < wp.int64(0):
        k += 1
    return k


@wp.func
def last_nonneg(e: wp.int64, step: wp.int64, n: int) -> int:
    """Largest ``k`` in ``[0, n)`` with ``e + k step >= 0`` for a decreasing edge function (``step < 0``);
    -1 if none: :func:`first_nonneg` of the row read backwards (``k' = n - 1 - k``)."""
    return n - 1 - first_nonneg(e + wp.int64(n - 1) * step, -step, n)


@wp.func
def row_span(e: vec3l, sj: vec3l, n: int) -> wp.vec2i:
    """The pixels ``k`` in ``[0, n)`` of a row whose (biased) edge functions ``e + k sj`` are all >= 0
    (:func:`inside`): ``(first, last)``, empty when first > last. Each edge function is linear in ``k``, so
    the covered pixels of a row are one run; exact (the same pixels as testing each in turn)."""
    lo = int(0)
    hi = n - 1
    for q in range(3):
        if sj[q] > wp.int64(0):
            lo = wp.max(lo, first_nonneg(e[q], sj[q], n))
        elif sj[q] < wp.int64(0):
            hi = wp.min(hi, last_nonneg(e[q], sj[q], n))
        elif e[q] < wp.int64(0):
            hi = -1
    return wp.vec2i(lo, hi)


@wp.func
def edges_of(x: wp.vec3i, y: wp.vec3i, bi: wp.vec3i, j: int, i: int) -> vec3l:
    """The three edge functions, minus their fill-rule bias ``bi``, of a set-up triangle with snapped
    vertices ``x``, ``y`` at the centre of pixel (row i, column j): covered iff all are >= 0 (:func:`inside`)."""
    px = j * SUBPIX + SUBPIX / 2
    py = i * SUBPIX + SUBPIX / 2
    return vec3l(edge(x[1], y[1], x[2], y[2], px, py) - wp.int64(bi[0]),
                 edge(x[2], y[2], x[0], y[0], px, py) - wp.int64(bi[1]),
                 edge(x[0], y[0], x[1], y[1], px, py) - wp.int64(bi[2]))


@wp.func
def edges_at(s: TriSetup, t: int, j: int, i: int) -> vec3l:
    """:func:`edges_of` triangle ``t`` at pixel (row i, column j). Step them exactly with
    :func:`edge_step_j` / :func:`edge_step_i` to walk a rectangle."""
    return edges_of(s.sx[t], s.sy[t], s.bias[t], j, i)


@wp.func
def edge_step_j(s: TriSetup, t: int) -> vec3l:
    """Change of :func:`edges_at` from one pixel to the next in its row (exact, int64)."""
    y = s.sy[t]
    return vec3l(-wp.int64(y[2] - y[1]) * SUBPIX64, -wp.int64(y[0] - y[2]) * SUBPIX64,
                 -wp.int64(y[1] - y[0]) * SUBPIX64)


@wp.func
def edge_step_i(s: TriSetup, t: int) -> vec3l:
    """Change of :func:`edges_at` from one pixel to the one below it (exact, int64)."""
    x = s.sx[t]
    return vec3l(wp.int64(x[2] - x[1]) * SUBPIX64, wp.int64(x[0] - x[2]) * SUBPIX64,
                 wp.int64(x[1] - x[0]) * SUBPIX64)


@wp.func
def tile_rect(s: TriSetup, tile: int, width: int, height: int) -> wp.vec4i:
    """Pixel range (j0, i0, j1, i1), inclusive, of bin ``tile`` clipped to the viewport."""
    ty = tile / s.tiles_x
    tx = tile - ty * s.tiles_x
    j0 = tx * s.tile_size
    i0 = ty * s.tile_size
    return wp.vec4i(j0, i0, wp.min(j0 + s.tile_size, width) - 1, wp.min(i0 + s.tile_size, height) - 1)


@wp.func
def tile_span(s: TriSetup, t: int, rect: wp.vec4i) -> wp.vec4i:
    """Triangle ``t``'s bounding box clipped to a tile's pixel range ``rect`` (:func:`tile_rect`):
    (j0, i0, j1, i1), empty when j0 > j1 or i0 > i1."""
    b = s.bbox[t]
    return wp.vec4i(wp.max(b[0], rect[0]), wp.max(b[1], rect[1]), wp.min(b[2], rect[2]), wp.min(b[3], rect[3]))


@wp.func
def covers(x: wp.vec3i, y: wp.vec3i, bi: wp.vec3i, j: int, i: int) -> bool:
    """The edge-function test of :func:`coverage` for a set-up triangle's snapped vertices ``x``, ``y``
    and fill-rule ``bias`` at pixel (row i, column j) inside its bounding box."""
    return inside(edges_of(x, y, bi, j, i))


@wp.func
def coverage(s: TriSetup, t: int, j: int, i: int) -> bool:
    """Does triangle ``t`` cover the centre of pixel (row i, column j)? Exact, with the set-up fill rule."""
    b = s.bbox[t]
    if j < b[0] or j > b[2] or i < b[1] or i > b[3]:
        return False
    return covers(s.sx[t], s.sy[t], s.bias[t], j, i)


@wp.func
def bary_from(a: wp.vec4, b: wp.vec4, c: wp.vec4, px: float, py: float) -> wp.vec3:
    """Screen-space barycentrics of point (px, py) in triangle (a, b, c) (fp32, fixed operation order)."""
    l0 = (c[0] - b[0]) * (py - b[1]) - (c[1] - b[1]) * (px - b[0])
    l1 = (a[0] - c[0]) * (py - c[1]) - (a[1] - c[1]) * (px - c[0])
    l2 = (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0])
    ssum = l0 + l1 + l2
    if ssum == 0.0:
        return wp.vec3(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0)
    return wp.vec3(l0 / ssum, l1 / ssum, l2 / ssum)


@wp.func
def screen_bary(pos: wp.array(dtype=wp.vec4), v: wp.vec3i, px: float, py: float) -> wp.vec3:
    """Screen-space barycentrics of point (px, py) from the unsnapped fp32 window positions."""
    return bary_from(pos[v[0]], pos[v[1]], pos[v[2]], px, py)


@wp.func
def persp_bary(pos: wp.array(dtype=wp.vec4), v: wp.vec3i, l: wp.vec3) -> wp.vec3:
    """Perspective-correct weights from screen barycentrics ``l`` (interpolate a/w and 1/w, divide)."""
    q0 = l[0] / pos[v[0]][3]
    q1 = l[1] / pos[v[1]][3]
    q2 = l[2] / pos[v[2]][3]
    s = q0 + q1 + q2
    return wp.vec3(q0 / s, q1 / s, q2 / s)


@wp.func
def fma32(a: float, b: float, c: float) -> float:
    """``a b + c`` rounded once to fp32 (as an FMA): the float64 product of two fp32 values is exact,
    so only the sum is rounded twice (float64, then fp32), which differs from one rounding only when
    the float64 sum falls exactly half-way between two fp32 values."""
    return float(wp.float64(a) * wp.float64(b) + wp.float64(c))


@wp.func
def plane_attr(g0: wp.vec2, g1: wp.vec2, g2: wp.vec2, a0: float, a1: float, a2: float, px: float,
               py: float) -> float:
    """llvmpipe's plane-equation value of attribute (a0, a1, a2) at integer pixel (px, py), vertices in
    GL window coordinates in llvmpipe's order: ``a0' = a0 - (dadx (x0 - .5) + dady (y0 - .5))``, then
    ``fma(dady, py, fma(dadx, px, a0'))`` (its triangle set-up and fragment interpolation, fp32)."""
    x0c = g0[0] - 0.5
    y0c = g0[1] - 0.5
    d01x = g0[0] - g1[0]
    d01y = g0[1] - g1[1]
    d20x = g2[0] - g0[0]
    d20y = g2[1] - g0[1]
    ooa = 1.0 / (d01x * d20y - d01y * d20x)
    da01 = a0 - a1
    da20 = a2 - a0
    dadx = da01 * (d20y * ooa) - da20 * (d01y * ooa)
    dady = da20 * (d01x * ooa) - da01 * (d20x * ooa)
    c0 = a0 - (dadx * x0c + dady * y0c)
    return fma32(dady, py, fma32(dadx, px, c0))


@wp.func
def llvmpipe_order(s: TriSetup, tris: wp.array(dtype=wp.vec3i), t: int) -> wp.vec3i:
    """Vertices in llvmpipe's set-up order: as submitted, with the first two swapped for triangles
    clockwise in GL window coordinates (those :func:`k_setup` reordered; last vertex provoking)."""
    o = tris[t]
    if s.vidx[t][1] != o[1]:
        return wp.vec3i(o[1], o[0], o[2])
    return o


@wp.func
def plane_value(s: TriSetup, pos: wp.array(dtype=wp.vec4), o: wp.vec3i, a0: float, a1: float, a2: float,
                mode: int, j: int, i: int) -> float:
    """Attribute at pixel (row i, column j) under the llvmpipe rule (``linear`` or ``perspective``)."""
    h = float(s.height)
    p0 = pos[o[0]]
    p1 = pos[o[1]]
    p2 = pos[o[2]]
    g0 = wp.vec2(p0[0], h - p0[1])
    g1 = wp.vec2(p1[0], h - p1[1])
    g2 = wp.vec2(p2[0], h - p2[1])
    px = float(j)
    py = float(s.height - 1 - i)
    if mode == INTERP_PERSPECTIVE:
        q0 = 1.0 / p0[3]
        q1 = 1.0 / p1[3]
        q2 = 1.0 / p2[3]
        a = plane_attr(g0, g1, g2, a0 * q0, a1 * q1, a2 * q2, px, py)
        return a * (1.0 / plane_attr(g0, g1, g2, q0, q1, q2, px, py))
    return plane_attr(g0, g1, g2, a0, a1, a2, px, py)


@wp.func
def plane_color(s: TriSetup, pos: wp.array(dtype=wp.vec4), o: wp.vec3i, c0: wp.vec4, c1: wp.vec4, c2: wp.vec4,
                mode: int, j: int, i: int) -> wp.vec4:
    out = wp.vec4()
    for k in range(4):
        out[k] = plane_value(s, pos, o, c0[k], c1[k], c2[k], mode, j, i)
    return out


@wp.func
def depth_pass(func: int, z: float, zbuf: float) -> bool:
    r = True
    if func == DEPTH_LESS:
        r = z < zbuf
    elif func == DEPTH_GREATER:
        r = z > zbuf
    elif func == DEPTH_LEQUAL:
        r = z <= zbuf
    elif func == DEPTH_GEQUAL:
        r = z >= zbuf
    elif func == DEPTH_NEVER:
        r = False
    return r


@wp.func
def interp_depth(pos: wp.array(dtype=wp.vec4), v: wp.vec3i, l: wp.vec3) -> float:
    return l[0] * pos[v[0]][2] + l[1] * pos[v[1]][2] + l[2] * pos[v[2]][2]


@wp.func
def fragment_weights(pos: wp.array(dtype=wp.vec4), v: wp.vec3i, l: wp.vec3, mode: int) -> wp.vec3:
    if mode == INTERP_PERSPECTIVE:
        return persp_bary(pos, v, l)
    return l


@wp.func
def fragment_prologue(s: TriSetup, pos: wp.array(dtype=wp.vec4), t: int, j: int, i: int, px: float, py: float,
                      depth_func: int, depth_write: int, depth_clip: int, zb: float):
    """Per-fragment front end of triangle ``t`` at pixel (row i, column j), centre (px, py): coverage,
    screen barycentrics, depth interpolation, depth clip, depth test and write.

    Returns ``(passed, generated, l, zb)``: whether a fragment survives, whether one was generated
    (pixel centre covered and not depth-clipped: what reaches the depth test; the hardware counters),
    its screen barycentrics, and the depth buffer value after it (``z`` if it passed with depth writes
    on, else ``zb`` unchanged).
    """
    cov = coverage(s, t, j, i)
    ok = cov
    l = wp.vec3(0.0, 0.0, 0.0)
    zn = zb
    if ok:
        v = s.vidx[t]
        l = screen_bary(pos, v, px, py)
        z = interp_depth(pos, v, l)
        if depth_clip != 0 and (z < 0.0 or z > 1.0):
            ok = False
            cov = False
        elif not depth_pass(depth_func, z, zb):
            ok = False
        elif depth_write != 0:
            zn = z
    return ok, cov, l, zn
