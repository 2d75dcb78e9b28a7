"""Draw kernels of the emulated rasteriser (set-up, binning, coverage and interpolation are
:mod:`warpvol.kernels.raster`; the host side is :class:`warpvol.gpu.raster.Rasterizer`).

* fragment lists: :func:`k_fragments` (per pixel over its tile's triangles, the emulated hardware
  walk; a counting and a writing pass), :func:`k_tri_walk` + :func:`k_tri_fragments` (per triangle
  over its bounding box, then the (pixel, triangle) pairs sorted by pixel: the same list);
* fused draws into a frame buffer: :func:`k_draw_colors` (per pixel) and :func:`k_draw_colors_tiles`
  (per tile, the CPU's choice) with Gouraud / flat colours and blending, :func:`k_draw_ids` (24-bit
  IDs with depth test), :func:`k_draw_quads_1d` (full-viewport quads textured from a 1D texture).
"""

import warp as wp

from .blend import BlendState, blend
from .raster import (
    INTERP_FLAT,
    INTERP_PERSPECTIVE,
    INTERP_RULE_LLVMPIPE,
    TriSetup,
    bary_from,
    coverage,
    covers,
    depth_pass,
    edge_step_i,
    edge_step_j,
    edges_at,
    fragment_prologue,
    fragment_weights,
    inside,
    interp_depth,
    llvmpipe_order,
    persp_bary,
    plane_color,
    plane_value,
    screen_bary,
    tile_rect,
    tile_span,
)
from .texture import Tex1D, tex1d

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


# ------------------------------------------------------------------------------------------------
# per-pixel kernels (launch dim = (H, W))
# ------------------------------------------------------------------------------------------------


@wp.func
def write_fragment(s: TriSetup, pos: wp.array(dtype=wp.vec4), tris: wp.array(dtype=wp.vec3i),
                   attrs: wp.array2d(dtype=wp.float32), modes: wp.array(dtype=wp.int32), na: int, t: int,
                   v: wp.vec3i, l: wp.vec3, z: float, j: int, i: int, o: int, frag_prim: wp.array(dtype=wp.int32),
                   frag_depth: wp.array(dtype=wp.float32), frag_attrs: wp.array2d(dtype=wp.float32)):
    """Store fragment ``o`` of triangle ``t`` at pixel (row i, column j): primitive, depth ``z`` and the
    attributes interpolated from screen barycentrics ``l`` (per-attribute ``modes``)."""
    frag_prim[o] = t
    frag_depth[o] = z
    wl = l
    wpc = l
    for a in range(na):  # perspective weights only when an attribute uses them
        if modes[a] == INTERP_PERSPECTIVE:
            wpc = persp_bary(pos, v, l)
    last = tris[t][2]
    for a in range(na):
        m = modes[a]
        val = float(0.0)
        if m == INTERP_FLAT:
            val = attrs[last, a]
        elif s.interp_rule == INTERP_RULE_LLVMPIPE:
            ov = llvmpipe_order(s, tris, t)
            val = plane_value(s, pos, ov, attrs[ov[0], a], attrs[ov[1], a], attrs[ov[2], a], m, j, i)
        else:
            w = wl
            if m == INTERP_PERSPECTIVE:
                w = wpc
            val = w[0] * attrs[v[0], a] + w[1] * attrs[v[1], a] + w[2] * attrs[v[2], a]
        frag_attrs[o, a] = val


@wp.kernel
def k_fragments(s: TriSetup, pos: wp.array(dtype=wp.vec4), tris: wp.array(dtype=wp.vec3i),
                attrs: wp.array2d(dtype=wp.float32), modes: wp.array(dtype=wp.int32), na: int,
                depth: wp.array2d(dtype=wp.float32), depth_func: int, depth_write: int, depth_clip: int,
                write: int, counts: wp.array(dtype=wp.int32), offsets: wp.array(dtype=wp.int32),
                frag_prim: wp.array(dtype=wp.int32), frag_depth: wp.array(dtype=wp.float32),
                frag_attrs: wp.array2d(dtype=wp.float32), row0: int):
    """Pass ``write=0`` counts the fragments of each pixel; ``write=1`` writes them at ``offsets``.
    Launch dimension: a block of rows from ``row0`` (blocks of rows may run concurrently: every pixel's
    fragments depend on its own depth value and tile only)."""
    ii, j = wp.tid()
    i = row0 + ii
    width = depth.shape[1]
    tile = (i / s.tile_size) * s.tiles_x + j / s.tile_size
    zb = depth[i, j]
    n = int(0)
    o = int(0)
    if write != 0:
        o = offsets[i * width + j]
    px = float(j) + 0.5
    py = float(i) + 0.5
    for e in range(s.tile_start[tile], s.tile_end[tile]):
        t = s.tri_of[e]
        if coverage(s, t, j, i):
            v = s.vidx[t]
            l = screen_bary(pos, v, px, py)
            z = interp_depth(pos, v, l)
            if depth_clip != 0 and (z < 0.0 or z > 1.0):
                continue
            if not depth_pass(depth_func, z, zb):
                continue
            if depth_write != 0:
                zb = z
            if write != 0:
                write_fragment(s, pos, tris, attrs, modes, na, t, v, l, z, j, i, o, frag_prim, frag_depth, frag_attrs)
                o += 1
            n += 1
    if write == 0:
        counts[i * width + j] = n
    else:
        depth[i, j] = zb


@wp.kernel
def k_tri_walk(s: TriSetup, pos: wp.array(dtype=wp.vec4), width: int, depth_clip: int, write: int,
               offsets: wp.array(dtype=wp.int32), counts: wp.array(dtype=wp.int32),
               pixel_counts: wp.array(dtype=wp.int32), keys: wp.array(dtype=wp.int32),
               vals: wp.array(dtype=wp.int32)):
    """Triangle-order fragment generation (launch dim = triangles): triangle ``t`` walks its bounding
    box with the exact :func:`coverage` test. ``write=0`` counts its fragments (covered pixel centres,
    not depth-clipped) into ``counts[t]``; ``write=1`` writes (pixel index, ``t``) pairs from
    ``offsets[t]`` and counts them per pixel."""
    t = wp.tid()
    b = s.bbox[t]
    n = int(0)
    o = int(0)
    if write != 0:
        o = offsets[t]
    x = s.sx[t]
    y = s.sy[t]
    bi = s.bias[t]
    for i in range(b[1], b[3] + 1):
        for j in range(b[0], b[2] + 1):
            if covers(x, y, bi, j, i):  # = coverage(s, t, j, i) inside the bounding box
                if depth_clip != 0:
                    z = interp_depth(pos, s.vidx[t], screen_bary(pos, s.vidx[t], float(j) + 0.5, float(i) + 0.5))
                    if z < 0.0 or z > 1.0:
                        continue
                if write != 0:
                    keys[o + n] = i * width + j
                    vals[o + n] = t
                    wp.atomic_add(pixel_counts, i * width + j, 1)
                n += 1
    if write == 0:
        counts[t] = n


@wp.kernel
def k_tri_fragments(s: TriSetup, pos: wp.array(dtype=wp.vec4), tris: wp.array(dtype=wp.vec3i),
                    attrs: wp.array2d(dtype=wp.float32), modes: wp.array(dtype=wp.int32), na: int, width: int,
                    keys: wp.array(dtype=wp.int32), vals: wp.array(dtype=wp.int32),
                    frag_prim: wp.array(dtype=wp.int32), frag_depth: wp.array(dtype=wp.float32),
                    frag_attrs: wp.array2d(dtype=wp.float32)):
    """Fragment ``o`` of the (pixel, triangle) pairs sorted by pixel (stable: primitive order within a
    pixel): the values :func:`k_fragments` writes for it (depth test ``always``, no depth writes)."""
    o = wp.tid()
    p = keys[o]
    t = vals[o]
    i = p / width
    j = p - i * width
    v = s.vidx[t]
    l = screen_bary(pos, v, float(j) + 0.5, float(i) + 0.5)
    z = interp_depth(pos, v, l)
    write_fragment(s, pos, tris, attrs, modes, na, t, v, l, z, j, i, o, frag_prim, frag_depth, frag_attrs)


@wp.kernel
def k_draw_colors(s: TriSetup, pos: wp.array(dtype=wp.vec4), tris: wp.array(dtype=wp.vec3i),
                  colors: wp.array(dtype=wp.vec4), mode: int,
                  depth: wp.array2d(dtype=wp.float32), depth_func: int, depth_write: int, depth_clip: int,
                  bs: BlendState, fb: wp.array2d(dtype=wp.vec4), prim0: int, counting: int,
                  cnt: wp.array(dtype=wp.vec2i)):
    """Fused raster + Gouraud/flat colour + blend, in primitive order per pixel. ``counting``: write
    the pixel's (fragments generated, passed) to ``cnt[row * W + column]`` (hardware counters)."""
    i, j = wp.tid()
    tile = (i / s.tile_size) * s.tiles_x + j / s.tile_size
    zb = depth[i, j]
    d = fb[i, j]
    px = float(j) + 0.5
    py = float(i) + 0.5
    ng = int(0)
    npass = int(0)
    for e in range(s.tile_start[tile], s.tile_end[tile]):
        t = s.tri_of[e]
        ok, cov, l, zb = fragment_prologue(s, pos, t, j, i, px, py, depth_func, depth_write, depth_clip, zb)
        if cov:
            ng += 1
        if ok:
            npass += 1
            c = colors[tris[t][2]]
            if mode != INTERP_FLAT and s.interp_rule == INTERP_RULE_LLVMPIPE:
                ov = llvmpipe_order(s, tris, t)
                c = plane_color(s, pos, ov, colors[ov[0]], colors[ov[1]], colors[ov[2]], mode, j, i)
            elif mode != INTERP_FLAT:
                v = s.vidx[t]
                w = fragment_weights(pos, v, l, mode)
                c = w[0] * colors[v[0]] + w[1] * colors[v[1]] + w[2] * colors[v[2]]
            d = blend(bs, c, d, j, i, prim0 + t)
    fb[i, j] = d
    depth[i, j] = zb
    if counting != 0:
        cnt[i * fb.shape[1] + j] = wp.vec2i(ng, npass)


@wp.kernel
def k_draw_colors_tiles(s: TriSetup, pos: wp.array(dtype=wp.vec4), tris: wp.array(dtype=wp.vec3i),
                        colors: wp.array(dtype=wp.vec4), mode: int,
                        depth: wp.array2d(dtype=wp.float32), depth_func: int, depth_write: int, depth_clip: int,
                        bs: BlendState, fb: wp.array2d(dtype=wp.vec4), prim0: int, counting: int,
                        cnt: wp.array(dtype=wp.vec2i)):
    """Same result as :func:`k_draw_colors`, one thread per *tile*: each bin entry visits only the
    pixels of the triangle's bounding box inside the tile (far fewer coverage tests; the better
    choice on the CPU, where launches run serially anyway). Pixels are owned by one thread, and a
    tile's entries are in submission order, so per-pixel primitive order is kept. ``counting``: the
    tile's (fragments generated, passed) go to ``cnt[tile]``."""
    tile = wp.tid()
    ng = int(0)
    npass = int(0)
    rect = tile_rect(s, tile, fb.shape[1], fb.shape[0])
    for e in range(s.tile_start[tile], s.tile_end[tile]):
        t = s.tri_of[e]
        span = tile_span(s, t, rect)
        j0 = span[0]
        i0 = span[1]
        j1 = span[2]
        i1 = span[3]
        v = s.vidx[t]
        pa = pos[v[0]]
        pb = pos[v[1]]
        pc = pos[v[2]]
        ca = colors[v[0]]
        cb = colors[v[1]]
        cc = colors[v[2]]
        cflat = colors[tris[t][2]]
        ov = llvmpipe_order(s, tris, t)
        # edge functions at the first pixel centre, stepped exactly (int64) along rows and columns
        row = edges_at(s, t, j0, i0)
        sj = edge_step_j(s, t)
        si = edge_step_i(s, t)
        for i in range(i0, i1 + 1):
            ee = row
            for j in range(j0, j1 + 1):
                if inside(ee):
                    l = bary_from(pa, pb, pc, float(j) + 0.5, float(i) + 0.5)
                    z = l[0] * pa[2] + l[1] * pb[2] + l[2] * pc[2]
                    ok = True
                    if depth_clip != 0 and (z < 0.0 or z > 1.0):
                        ok = False
                    else:
                        ng += 1
                    if ok and depth_func != 0:
                        ok = depth_pass(depth_func, z, depth[i, j])
                    if ok:
                        npass += 1
                        if depth_write != 0:
                            depth[i, j] = z
                        c = cflat
                        if mode != INTERP_FLAT and s.interp_rule == INTERP_RULE_LLVMPIPE:
                            c = plane_color(s, pos, ov, colors[ov[0]], colors[ov[1]], colors[ov[2]], mode, j, i)
                        elif mode != INTERP_FLAT:
                            w = l
                            if mode == INTERP_PERSPECTIVE:
                                q0 = l[0] / pa[3]
                                q1 = l[1] / pb[3]
                                q2 = l[2] / pc[3]
                                qs = q0 + q1 + q2
                                w = wp.vec3(q0 / qs, q1 / qs, q2 / qs)
                            c = w[0] * ca + w[1] * cb + w[2] * cc
                        fb[i, j] = blend(bs, c, fb[i, j], j, i, prim0 + t)
                ee = ee + sj
            row = row + si
    if counting != 0:
        cnt[tile] = wp.vec2i(ng, npass)


@wp.kernel
def k_draw_ids(s: TriSetup, pos: wp.array(dtype=wp.vec4), ids: wp.array(dtype=wp.int32),
               depth: wp.array2d(dtype=wp.float32), depth_func: int, depth_write: int, depth_clip: int,
               idbuf: wp.array2d(dtype=wp.int32), counting: int, cnt: wp.array(dtype=wp.vec2i)):
    """Flat-shaded integer IDs (24-bit) with depth test: the ID buffer of VSBUFFER-style passes.
    ``counting``: the pixel's (fragments generated, passed) go to ``cnt[row * W + column]``."""
    i, j = wp.tid()
    tile = (i / s.tile_size) * s.tiles_x + j / s.tile_size
    zb = depth[i, j]
    idv = idbuf[i, j]
    px = float(j) + 0.5
    py = float(i) + 0.5
    ng = int(0)
    npass = int(0)
    for e in range(s.tile_start[tile], s.tile_end[tile]):
        t = s.tri_of[e]
        ok, cov, l, zb = fragment_prologue(s, pos, t, j, i, px, py, depth_func, depth_write, depth_clip, zb)
        if cov:
            ng += 1
        if ok:
            npass += 1
            idv = ids[t] & 16777215
    idbuf[i, j] = idv
    depth[i, j] = zb
    if counting != 0:
        cnt[i * idbuf.shape[1] + j] = wp.vec2i(ng, npass)


@wp.kernel
def k_draw_quads_1d(bs: BlendState, fb: wp.array2d(dtype=wp.vec4), tex: Tex1D, corners: wp.array(dtype=wp.vec4),
                    modulate: wp.vec4, prim0: int):
    """Draw n full-viewport rectangles in order, rectangle k textured from a 1D texture.

    ``corners[k] = (c00, c10, c01, c11)`` are rectangle k's texture coordinates at window corners
    (x, y) = (0, 0), (W, 0), (0, H), (W, H); the coordinate at a pixel centre is their bilinear
    interpolation (equal to the two-triangle screen-space interpolation whenever the corner values
    are affine, as in hardware pre-integration). Fragment colour = texel * ``modulate``.
    """
    i, j = wp.tid()
    h = fb.shape[0]
    w = fb.shape[1]
    fx = (float(j) + 0.5) / float(w)
    fy = (float(i) + 0.5) / float(h)
    d = fb[i, j]
    for k in range(corners.shape[0]):
        c = corners[k]
        top = c[0] + fx * (c[1] - c[0])
        bot = c[2] + fx * (c[3] - c[2])
        u = top + fy * (bot - top)
        texel = tex1d(tex, u)
        src = wp.cw_mul(texel, modulate)
        d = blend(bs, src, d, j, i, prim0 + k)
    fb[i, j] = d
