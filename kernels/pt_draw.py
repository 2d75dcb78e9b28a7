"""Projected tetrahedra in one pass per bin: rasteriser walk, ``pt_best``'s exact fragment program and
blending fused in one kernel (``pt_integrate.walk = "fused"``; beyond the papers).

:func:`k_pt_exact_tiles` runs one thread per tile of the rasteriser's bins
(:class:`warpvol.kernels.raster.TriSetup`, triangles in submission order per tile). For each
triangle of its tile it walks the pixels of the triangle's bounding box inside the tile with the
rasteriser's exact int64 edge functions and fill rule (:func:`~warpvol.kernels.raster.edges_at`,
stepped exactly), so it draws exactly the fragments of the fragment list, and for every covered
pixel centre, in registers:

1. the attributes from per-triangle plane equations (:func:`attribute_planes`: set up from ``pos``,
   the positions where the attributes were taken -- with ``pt_project exact_attrs`` the unsnapped
   vertices and diagonal crossings, while coverage follows the snapped ones -- evaluated from the
   first vertex; a pixel centre the snapped coverage takes past an unsnapped edge gets the attributes of
   the triangle's nearest point, :func:`nearest_on_triangle`); the fragment list interpolates with
   per-fragment barycentrics instead;
2. each attribute clamped into its triangle's vertex range (:func:`clamp8`, the test of
   :func:`~warpvol.kernels.pt.clamp_attr`);
3. ``(sf, sb, l)`` by Kraus et al.'s division (:func:`sfsbl_ray`), the exact thickness with the
   ray-length factor of the pixel's own ray (``ray_len``, float64 on the host; read only in that mode:
   a 1x1 array otherwise) instead of the interpolated front point's, and the segment integrated exactly
   (:func:`~warpvol.kernels.pt.exact_color`);
4. blended onto the pixel (:func:`~warpvol.kernels.blend.blend`, batch-local primitive index for dithering).

A pixel belongs to one tile and a tile's triangles are in submission order, so each pixel blends its
fragments in primitive order, as the per-pixel fragment list does, without writing one. The depth
test is ``always`` without depth writes or depth clipping (projected tetrahedra). Counts per tile go
to ``counts[tile]``: (fragments, fragments whose attributes the clamp moved). Launch dimension: a
block of tiles from ``tile0`` (blocks of tiles may run concurrently: they own disjoint pixels).

Early termination (``t_min > 0``): the tile's triangles are taken in reverse, front to back, and the
caller blends with "under" (``one_minus_dst_alpha, one``); a pixel whose remaining transmittance
``1 - alpha`` is at most ``t_min`` takes no more fragments (not walked through the program), and once
every pixel of the tile has, the tile's remaining triangles are left. Each tile keeps one 64-bit row
mask per pixel row (``done_rows``, bit ``j - j0`` set once pixel ``j`` terminated; tiles of at most 64
pixels): a triangle whose bounding box within the tile is all terminated is left before its set-up
(``occluded[tile]`` counts these bin entries), and a row whose covered run is all terminated is stepped
over. The order is front to back, so a pixel's termination is final. ``skipped[tile]``: (fragments left
out at terminated pixels, bin entries left out once the whole tile terminated); ``term_at[i, j]``: the
draw position (``tet0`` + batch triangle / 4) of the cell whose fragment terminated the pixel (left as
it was where none did); ``binned[c]`` / ``walked[c]`` set to 1 for every cell ``c`` (draw position) with a
bin entry here / with a triangle walked here (all three written only with ``t_min > 0``).
"""

import warp as wp

from .blend import BlendState, blend
from .pt import CLAMP_ABS, CLAMP_REL, PERSP_EXACT, PERSP_OFF, exact_color, vec8f
from .raster import TriSetup, edge_step_i, edge_step_j, edges_at, row_span, tile_rect, tile_span

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.func
def clamp8(x: vec8f, lo: vec8f, hi: vec8f, tol: vec8f):
    """Each attribute clamped into its triangle's vertex range, and 1 if that moved one by more than
    rounding, else 0 (the values and the test of :func:`~warpvol.kernels.pt.clamp_attr`). The clamp is
    ``wp.clamp``'s ``fmin(fmax(lo, x), hi)`` on all eight at once; the per-attribute test runs only
    when one moved (a move of more than ``CLAMP_ABS`` leaves a nonzero square)."""
    y = wp.min(wp.max(lo, x), hi)
    m = int(0)
    if not (wp.length_sq(y - x) == 0.0):  # rare: only then the distance test
        for k in range(8):
            if y[k] != x[k]:
                if wp.abs(y[k] - x[k]) > tol[k] + CLAMP_ABS:
                    m = 1
    return y, m


mat28f = wp.types.matrix(shape=(2, 8), dtype=wp.float32)


@wp.func
def attribute_planes(pa: wp.vec4, pb: wp.vec4, pc: wp.vec4, a0: vec8f, a1: vec8f, a2: vec8f) -> mat28f:
    """Screen-space gradients (d/dx, d/dy; rows) of the attributes ``a0..a2`` given at the unsnapped
    window positions ``pa..pc``: ``a(x, y) = a0 + gx (x - xa) + gy (y - ya)``. A triangle of zero
    unsnapped area gets zero gradients (its fragments take ``a0``; the clamp keeps them in range)."""
    ux = pb[0] - pa[0]
    uy = pb[1] - pa[1]
    vx = pc[0] - pa[0]
    vy = pc[1] - pa[1]
    den = ux * vy - vx * uy
    g = mat28f()
    if den == 0.0:
        return g
    inv = 1.0 / den
    d1 = a1 - a0
    d2 = a2 - a0
    gx = (d1 * vy - d2 * uy) * inv
    gy = (d2 * ux - d1 * vx) * inv
    for k in range(8):
        g[0, k] = gx[k]
        g[1, k] = gy[k]
    return g


@wp.func
def edge_nearest(ax: float, ay: float, bx: float, by: float, x: float, y: float) -> wp.vec2:
    """(squared distance, parameter t) of the point of segment a-b nearest ``(x, y)``."""
    ex = bx - ax
    ey = by - ay
    ll = ex * ex + ey * ey
    t = float(0.0)
    if ll > 0.0:
        t = wp.clamp(((x - ax) * ex + (y - ay) * ey) / ll, 0.0, 1.0)
    dx = ax + t * ex - x
    dy = ay + t * ey - y
    return wp.vec2(dx * dx + dy * dy, t)


@wp.func
def nearest_on_triangle(pa: wp.vec4, pb: wp.vec4, pc: wp.vec4, a0: vec8f, a1: vec8f, a2: vec8f, x: float, y: float,
                        planes: vec8f) -> vec8f:
    """The attributes at the window point ``(x, y)``: the plane value ``planes`` where the point lies in
    the triangle of the unsnapped positions ``pa..pc``; where it lies outside (snapped coverage takes
    pixel centres up to the snapping's shift beyond the unsnapped edges) those of the triangle's point
    nearest it, on an edge. Extrapolated past an edge of a sliver triangle the planes would change by
    the steep gradient across it (and a thickness past the tet's outline would turn negative, its
    magnitude a spurious segment); at the nearest point the attributes are what the cell has there,
    continuous with its neighbour along the shared edge, at most the snapping's shift from the pixel
    centre. A triangle of zero unsnapped area keeps ``planes``."""
    ux = pb[0] - pa[0]
    uy = pb[1] - pa[1]
    vx = pc[0] - pa[0]
    vy = pc[1] - pa[1]
    den = ux * vy - vx * uy
    if den == 0.0:
        return planes
    dx = x - pa[0]
    dy = y - pa[1]
    b1 = (dx * vy - dy * vx) / den
    b2 = (dy * ux - dx * uy) / den
    if b1 >= 0.0 and b2 >= 0.0 and 1.0 - b1 - b2 >= 0.0:
        return planes
    eab = edge_nearest(pa[0], pa[1], pb[0], pb[1], x, y)
    ebc = edge_nearest(pb[0], pb[1], pc[0], pc[1], x, y)
    eca = edge_nearest(pc[0], pc[1], pa[0], pa[1], x, y)
    if eab[0] <= ebc[0] and eab[0] <= eca[0]:
        return a0 + (a1 - a0) * eab[1]
    if ebc[0] <= eca[0]:
        return a1 + (a2 - a1) * ebc[1]
    return a2 + (a0 - a2) * eca[1]


@wp.func
def sfsbl_ray(a: vec8f, mode: int, ortho: int, ray_factor: float) -> wp.vec3:
    """(sf, sb, l) of the fused draw: as :func:`~warpvol.kernels.pt.sfsbl_from` (Kraus' per-fragment
    division of ``a/w`` by ``1/w``), but the exact thickness's factor ``|ve_f| / |ze_f|`` is that of
    the pixel's own ray, ``ray_factor`` (computed per pixel in float64 from the camera), not the
    interpolated front point's: no square root or third division per fragment, and the eye-space
    origin's depth offset cancels in ``ze_b - ze_f``."""
    if mode == PERSP_OFF:
        return wp.vec3(a[0], a[1], a[2])
    wf = 1.0 / a[2]
    wb = 1.0 / a[3]
    l = wp.abs(a[7] * wb - a[6] * wf)
    if mode == PERSP_EXACT and ortho == 0:
        l = l * ray_factor
    return wp.vec3(a[0] * wf, a[1] * wb, l)


@wp.func
def zero_segments(lo: vec8f, hi: vec8f, mode: int, zero_lo: float, zero_hi: float) -> bool:
    """Whether every fragment of a triangle whose attributes are clamped into ``[lo, hi]`` (its vertices'
    range, :func:`clamp8`) has both ends of its segment at or below ``zero_lo`` or both at or above
    ``zero_hi``: ``(sf, sb)`` are the attributes themselves (``PERSP_OFF``) or ``a[0] (1 / a[2])``,
    ``a[1] (1 / a[3])`` as :func:`sfsbl_ray` rounds them, monotone in each factor, so their extremes over
    the box are at its corners (``1 / w`` > 0; else no decision)."""
    sf0 = lo[0]
    sf1 = hi[0]
    sb0 = lo[1]
    sb1 = hi[1]
    if mode != PERSP_OFF:
        if not (lo[2] > 0.0 and lo[3] > 0.0):
            return False
        wf0 = 1.0 / hi[2]
        wf1 = 1.0 / lo[2]
        wb0 = 1.0 / hi[3]
        wb1 = 1.0 / lo[3]
        sf0 = wp.min(wp.min(lo[0] * wf0, lo[0] * wf1), wp.min(hi[0] * wf0, hi[0] * wf1))
        sf1 = wp.max(wp.max(lo[0] * wf0, lo[0] * wf1), wp.max(hi[0] * wf0, hi[0] * wf1))
        sb0 = wp.min(wp.min(lo[1] * wb0, lo[1] * wb1), wp.min(hi[1] * wb0, hi[1] * wb1))
        sb1 = wp.max(wp.max(lo[1] * wb0, lo[1] * wb1), wp.max(hi[1] * wb0, hi[1] * wb1))
    return (sf1 <= zero_lo and sb1 <= zero_lo) or (sf0 >= zero_hi and sb0 >= zero_hi)


@wp.func
def span_done(done_rows: wp.array(dtype=wp.uint64), r0: int, r1: int, b0: int, b1: int) -> bool:
    """Whether bits ``b0 .. b1`` (0 <= b0 <= b1 < 64) are set in every row ``r0 .. r1`` of ``done_rows``."""
    w = b1 - b0 + 1
    bits = ~wp.uint64(0)
    if w < 64:
        bits = ((wp.uint64(1) << wp.uint64(w)) - wp.uint64(1)) << wp.uint64(b0)
    for r in range(r0, r1 + 1):
        if (done_rows[r] & bits) != bits:
            return False
    return True


@wp.kernel
def k_pt_exact_tiles(s: TriSetup, pos: wp.array(dtype=wp.vec4), vattrs: wp.array(dtype=vec8f),
                     mode: int, ortho: int, ray_len: wp.array2d(dtype=float), tf_s: wp.array(dtype=float),
                     tf_v: wp.array(dtype=wp.vec4), model: int,
                     bs: BlendState, fb: wp.array2d(dtype=wp.vec4), tile0: int, counts: wp.array(dtype=wp.vec2i),
                     t_min: float, skipped: wp.array(dtype=wp.vec2i), tet0: int, done_rows: wp.array(dtype=wp.uint64),
                     term_at: wp.array2d(dtype=wp.int32), binned: wp.array(dtype=wp.int32),
                     walked: wp.array(dtype=wp.int32), occluded: wp.array(dtype=wp.vec3i), zero_lo: float,
                     zero_hi: float):
    tile = tile0 + wp.tid()
    nfrag = int(0)
    nclamp = int(0)
    rect = tile_rect(s, tile, fb.shape[1], fb.shape[0])
    per_ray = mode == PERSP_EXACT and ortho == 0  # only then ray_len holds a factor per pixel (else 1x1, unread)
    # early termination (front to back only): a pixel whose remaining transmittance 1 - alpha is at most
    # t_min takes no more fragments; once every pixel of the tile has, the tile's other triangles are left
    area = (rect[2] - rect[0] + 1) * (rect[3] - rect[1] + 1)
    term = t_min > 0.0
    done = int(0)
    nskip = int(0)
    ntail = int(0)
    nocc = int(0)
    nzero = int(0)  # fragments whose segment lies where the TF adds nothing
    nzt = int(0)  # bin entries all of whose fragments do
    rows0 = tile * s.tile_size  # this tile's rows of done_rows: bit j - rect[0] set once pixel j terminated
    if term:
        for r in range(s.tile_size):
            done_rows[rows0 + r] = wp.uint64(0)
    e0 = s.tile_start[tile]
    ne = s.tile_end[tile] - e0
    for q in range(ne):
        if term and done >= area:
            ntail = ne - q
            for q2 in range(q, ne):  # the tail's cells were binned here too
                binned[tet0 + s.tri_of[e0 + ne - 1 - q2] / 4] = 1
            break
        e = e0 + q
        if term:  # front to back: the tile's triangles (submitted back to front) in reverse
            e = e0 + ne - 1 - q
        t = s.tri_of[e]
        span = tile_span(s, t, rect)
        j0 = span[0]
        i0 = span[1]
        j1 = span[2]
        i1 = span[3]
        if term:
            binned[tet0 + t / 4] = 1
        if j0 > j1 or i0 > i1:
            continue
        if term and done > 0:  # the triangle's box within the tile all terminated: nothing to walk
            if span_done(done_rows, rows0 + i0 - rect[1], rows0 + i1 - rect[1], j0 - rect[0], j1 - rect[0]):
                nocc += 1
                continue
        if term:
            walked[tet0 + t / 4] = 1
        v = s.vidx[t]
        a0 = vattrs[v[0]]
        a1 = vattrs[v[1]]
        a2 = vattrs[v[2]]
        lo = wp.min(a0, wp.min(a1, a2))
        hi = wp.max(a0, wp.max(a1, a2))
        if zero_segments(lo, hi, mode, zero_lo, zero_hi):  # every fragment's (sf, sb) where the TF adds nothing
            nzt += 1
            continue
        pa = pos[v[0]]
        pb = pos[v[1]]
        pc = pos[v[2]]
        g = attribute_planes(pa, pb, pc, a0, a1, a2)
        gx = g[0]
        gy = g[1]
        tol = CLAMP_REL * (hi - lo)
        row = edges_at(s, t, j0, i0)
        sj = edge_step_j(s, t)
        si = edge_step_i(s, t)
        for i in range(i0, i1 + 1):
            ry = gy * (float(i) + 0.5 - pa[1])  # the row's term, as the sum below adds it last
            run = row_span(row, sj, j1 - j0 + 1)  # the row's covered pixels: one run
            row = row + si
            if term and run[0] <= run[1]:  # the run all terminated: skipped without a fragment
                r = rows0 + i - rect[1]
                if span_done(done_rows, r, r, j0 + run[0] - rect[0], j0 + run[1] - rect[0]):
                    nskip += run[1] - run[0] + 1
                    continue
            for j in range(j0 + run[0], j0 + run[1] + 1):
                d = fb[i, j]
                if term and 1.0 - d[3] <= t_min:
                    nskip += 1
                    continue
                x = nearest_on_triangle(pa, pb, pc, a0, a1, a2, float(j) + 0.5, float(i) + 0.5,
                                        a0 + gx * (float(j) + 0.5 - pa[0]) + ry)
                a, moved = clamp8(x, lo, hi, tol)
                factor = float(1.0)
                if per_ray:
                    factor = ray_len[i, j]
                seg = sfsbl_ray(a, mode, ortho, factor)
                if (seg[0] <= zero_lo and seg[1] <= zero_lo) or (seg[0] >= zero_hi and seg[1] >= zero_hi):
                    nzero += 1  # integrates to exact zeros: blending it changes nothing
                    continue
                nfrag += 1
                nclamp += moved
                c = exact_color(seg, tf_s, tf_v, model)
                d = blend(bs, c, d, j, i, t)
                fb[i, j] = d
                if term and 1.0 - d[3] <= t_min:
                    done += 1
                    r = rows0 + i - rect[1]
                    done_rows[r] = done_rows[r] | (wp.uint64(1) << wp.uint64(j - rect[0]))
                    term_at[i, j] = tet0 + t / 4
    counts[tile] = wp.vec2i(nfrag, nclamp)
    skipped[tile] = wp.vec2i(nskip, ntail)
    occluded[tile] = wp.vec3i(nocc, nzero, nzt)
