"""Projected tetrahedra in one pass per bin: rasteriser walk, ``pt_best``'s exact fragment program and
blending fused in one kernel (``pt_integrate.walk = "fused"``).

:func:`k_pt_exact_tiles` runs one thread per tile of the rasteriser's bins
(:class:`warpvol.kernels.raster.TriSetup`, triangles in submission order per tile). For each
triangle of its tile it walks the pixels of the triangle's bounding box inside the tile with the
rasteriser's exact int64 edge functions and fill rule (:func:`~warpvol.kernels.raster.edges_at`,
stepped exactly), and for every covered pixel centre, in registers:

1. screen barycentrics from the unsnapped positions (:func:`~warpvol.kernels.raster.bary_from`) and
   the attributes interpolated linearly in screen space (``l0 a0 + l1 a1 + l2 a2``, the operation
   order of the fragment list's :func:`~warpvol.kernels.raster.write_fragment`);
2. each attribute clamped into its triangle's vertex range (:func:`~warpvol.kernels.pt.clamp_attr`);
3. ``(sf, sb, l)`` (:func:`~warpvol.kernels.pt.sfsbl_from`) and the segment integrated exactly
   (:func:`~warpvol.kernels.pt.exact_color`);
4. blended onto the pixel (:func:`~warpvol.kernels.blend.blend`, primitive index for dithering).

A pixel belongs to one tile and a tile's triangles are in submission order, so each pixel blends its
fragments in primitive order, as the per-pixel fragment list does: the image is the same bit for bit
(``tests/test_pt2_render.py``), without writing a fragment list. The depth test is ``always``
without depth writes or depth clipping (projected tetrahedra). Counts per tile go to
``counts[tile]``: (fragments, fragments whose attributes the clamp moved). Launch dimension: a block
of tiles from ``tile0`` (blocks of tiles may run concurrently: they own disjoint pixels).
"""

import warp as wp

from .blend import BlendState, blend
from .pt import CLAMP_ABS, CLAMP_REL, exact_color, sfsbl_from, vec8f
from .raster import TriSetup, bary_from, edge_step_i, edge_step_j, edges_at, inside, tile_rect

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.func
def clamp8(x: vec8f, lo: vec8f, hi: vec8f, tol: vec8f):
    """Each attribute clamped into its triangle's vertex range, and 1 if that moved one by more than
    rounding, else 0 (the values and the test of :func:`~warpvol.kernels.pt.clamp_attr`)."""
    y = vec8f()
    m = int(0)
    for k in range(8):  # constant trip count: unrolled, register indexing
        v = wp.clamp(x[k], lo[k], hi[k])
        if v != x[k]:  # rare: only then the distance test
            if wp.abs(v - x[k]) > tol[k] + CLAMP_ABS:
                m = 1
        y[k] = v
    return y, m


@wp.kernel
def k_pt_exact_tiles(s: TriSetup, pos: wp.array(dtype=wp.vec4), vattrs: wp.array(dtype=vec8f),
                     mode: int, ortho: int, z_off: float, tf_s: wp.array(dtype=float),
                     tf_v: wp.array(dtype=wp.vec4), model: int,
                     bs: BlendState, fb: wp.array2d(dtype=wp.vec4), tile0: int, counts: wp.array(dtype=wp.vec2i)):
    tile = tile0 + wp.tid()
    nfrag = int(0)
    nclamp = int(0)
    rect = tile_rect(s, tile, fb.shape[1], fb.shape[0])
    for e in range(s.tile_start[tile], s.tile_end[tile]):
        t = s.tri_of[e]
        b = s.bbox[t]
        j0 = wp.max(b[0], rect[0])
        j1 = wp.min(b[2], rect[2])
        i0 = wp.max(b[1], rect[1])
        i1 = wp.min(b[3], rect[3])
        if j0 > j1 or i0 > i1:
            continue
        v = s.vidx[t]
        pa = pos[v[0]]
        pb = pos[v[1]]
        pc = pos[v[2]]
        a0 = vattrs[v[0]]
        a1 = vattrs[v[1]]
        a2 = vattrs[v[2]]
        lo = wp.min(a0, wp.min(a1, a2))
        hi = wp.max(a0, wp.max(a1, a2))
        tol = CLAMP_REL * (hi - lo)
        row = edges_at(s, t, j0, i0)
        sj = edge_step_j(s, t)
        si = edge_step_i(s, t)
        for i in range(i0, i1 + 1):
            ee = row
            for j in range(j0, j1 + 1):
                if inside(ee):
                    l = bary_from(pa, pb, pc, float(j) + 0.5, float(i) + 0.5)
                    x = l[0] * a0 + l[1] * a1 + l[2] * a2
                    a, moved = clamp8(x, lo, hi, tol)
                    nfrag += 1
                    nclamp += moved
                    c = exact_color(sfsbl_from(a, mode, ortho, z_off), tf_s, tf_v, model)
                    fb[i, j] = blend(bs, c, fb[i, j], j, i, t)
                ee = ee + sj
            row = row + si
    counts[tile] = wp.vec2i(nfrag, nclamp)
