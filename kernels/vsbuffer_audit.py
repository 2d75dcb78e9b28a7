"""VSBUFFER after the walk: the audit of every (ray, cell) crossing a plane cuts, and the rewalk of
flagged rays (:mod:`warpvol.kernels.vsbuffer` holds the cell geometry and the column walk)."""

import warp as wp

from .vsbuffer import BIG, VsbCells, Walk, cell_interval, integrate_cell

wp.set_module_options({"enable_backward": False, "fuse_fp": False})  # same roundings on CPU and CUDA


@wp.kernel
def audit_pairs(cells: VsbCells, w: Walk, plane: wp.array(dtype=wp.int32), column: wp.array(dtype=wp.int32),
                cell: wp.array(dtype=wp.int32), ray_o: wp.array(dtype=wp.vec3), ray_d: wp.array(dtype=wp.vec3),
                done: wp.array2d(dtype=wp.int32), out: wp.array(dtype=wp.vec4), missed: wp.array(dtype=wp.int32),
                missed_len: wp.array(dtype=float), ray_missed: wp.array(dtype=wp.int32)):
    """Audit after the walk: for a (plane, column, cell) with the cell cut by the plane over that
    column, whether the ray crosses the cell for more than ``eps`` and the cell is missing from the
    ray's list of integrated cells (a loss nothing in the walk could see); rays stopped by early
    termination (transmittance below ``t_min``) are complete. One thread per pair."""
    i = wp.tid()
    p = plane[i]
    col = column[i]
    pix = (w.j0 + p) * w.width + col
    o = ray_o[pix]
    d = ray_d[pix]
    iv = cell_interval(cells, cell[i], o, d, w.eps)
    length = iv[1] - wp.max(iv[0], 0.0)
    missed[i] = 0
    missed_len[i] = 0.0
    if length > w.eps and 1.0 - out[pix][3] >= w.t_min:
        tid = p * w.width + col
        for n in range(w.max_list):
            v = done[tid, n]
            if v == cell[i]:
                return
            if v < 0:
                break
        missed[i] = 1
        missed_len[i] = length
        wp.atomic_add(ray_missed, pix, 1)


@wp.kernel
def rewalk(cells: VsbCells, w: Walk, ray_key: wp.array(dtype=wp.int32), start: wp.array(dtype=wp.int32),
           cand: wp.array(dtype=wp.int32), ray_o: wp.array(dtype=wp.vec3), ray_d: wp.array(dtype=wp.vec3),
           tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), out: wp.array(dtype=wp.vec4),
           counters: wp.array2d(dtype=wp.int32)):
    """Integrate a ray the audit flagged again from all cells its plane cuts over its column, in order
    of entry (ties by cell ID): a per-ray sort of a short list, used only where the walk missed cells."""
    r = wp.tid()
    key = ray_key[r]
    p = key / w.width
    col = key - p * w.width
    pix = (w.j0 + p) * w.width + col
    o = ray_o[pix]
    d = ray_d[pix]
    rgb = wp.vec3(0.0, 0.0, 0.0)
    trans = float(1.0)
    t_last = float(0.0)
    s_last = float(0.0)
    key_last = wp.vec3i(-1, -1, -1)
    t_prev = float(-BIG)
    id_prev = int(-1)
    n = start[r + 1] - start[r]
    for it in range(n):
        best = int(-1)
        bt = float(BIG)
        for e in range(start[r], start[r + 1]):
            c = cand[e]
            iv = cell_interval(cells, c, o, d, w.eps)
            if iv[1] > iv[0]:
                after = iv[0] > t_prev or (iv[0] == t_prev and c > id_prev)
                if after and (iv[0] < bt or (iv[0] == bt and c < best)):
                    bt = iv[0]
                    best = c
        if best < 0 or trans < w.t_min:
            break
        t_prev = bt
        id_prev = best
        counters[key, 1] += 1
        rgb, trans, t_last, s_last, key_last, eq, ef = integrate_cell(
            cells, w, best, o, d, rgb, trans, t_last, s_last, key_last, tf_s, tf_v, counters, key)
    out[pix] = wp.vec4(rgb[0], rgb[1], rgb[2], 1.0 - trans)
