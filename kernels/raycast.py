"""Ray propagation through cell adjacency (HARC-style ray caster, float32), consistent by construction.

One thread per pixel; the walk's building blocks (float64 ray set-up, Plücker edge tests, face crossings,
one step through a tet, the thin-layer check) are :mod:`warpvol.kernels.walk`, shared with HARC.

An entry (:func:`march_ray`) finds the ray's next entry among the front-facing boundary faces binned
to the pixel's screen tile (nearest crossing beyond the current parameter), then walks cell to cell,
integrating each segment exactly for the piecewise-linear transfer function
(:mod:`warpvol.kernels.integrate`) and compositing front to back. A ray the float32 walk cannot
resolve -- a cell with no exit face (float32 signs no real ray can produce), no progress in depth
for :data:`~warpvol.kernels.walk.STALL_STEPS` steps, a segment too short for float32 to know its length beside a density
contrast that makes the difference visible (a thin layer carrying the image, :func:`~warpvol.kernels.walk.thin_unresolved`),
an entry or exit through a face seen so nearly edge-on that the chord's float32 length is visibly uncertain
(:func:`~warpvol.kernels.walk.grazing_unresolved`), or crossings whose float32 scalars are too uncertain for a
transfer function that steep (the bound of :func:`~warpvol.kernels.walk.scalar_step` over
:data:`~warpvol.kernels.walk.STEEP_ERR`; with ``scalar_check`` 0 that bound is skipped where it provably stays
below it: :func:`warpvol.raycasting.stages.cell_setup.scalar_check_needed`) --
is marked ``STATUS_FAILED`` and redone on the host in float64; it is counted, never silently wrong.

A pass (kernel :func:`march`) makes a ray's entries one after the other in its thread: after the walk leaves
the (visible) mesh it searches the next entry beyond the exit and walks on, up to ``reentries`` times.
Per-pixel state (radiance, transmittance, ray parameter, status) lives in device arrays so passes
can be separate launches; a pass launches one thread per active ray: pixels ``first ..`` while every
ray is active, else the pixels ``ids[first ..]`` of the rays still active (a list made by the host).
``counters[chunk]`` (first entries, steps, unfinished, failed, left active, failed on a thin layer, terminated
early, re-entries) has one row per concurrently launched block.
"""

import warp as wp

from .integrate import exp_neg, integrate_piece, integrate_segment_tf
from .tf import tf_eval, tf_eval_upper, tf_upper, tf_upper_from
from .walk import (STALL_STEPS, STEEP_ERR, Face, Ray, boundary_face, face_hit, grazing_unresolved, monotone_exit,
                   next_face_from, pixel_ray, scalar_error_if, scalar_step, thin_at_exit, thin_start, thin_step)

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

STATUS_ACTIVE = wp.constant(1)
STATUS_DONE = wp.constant(0)
STATUS_FAILED = wp.constant(2)
#: consecutive re-entries without progress in ``t`` (cracks, touching pieces) before a ray counts as
#: unresolved
MAX_FLAT_REENTRIES = wp.constant(8)


@wp.func
def clipped_segment(t_in: float, t_out: float, s_in: float, s_out: float, t_clip: float):
    """The part ``t >= t_clip`` of segment ``[t_in, t_out]`` with linear scalar; ``(t0, s0)``."""
    if t_in >= t_clip:
        return t_in, s_in
    if t_out <= t_clip:
        return t_out, s_out
    return t_clip, s_in + (s_out - s_in) * ((t_clip - t_in) / (t_out - t_in))


#: relative margin by which a face's depth bound must clear a ray's depth (in units of the ray's length scale:
#: distance from the eye plus ray parameter plus mesh radius) before the entry search leaves the face untested;
#: float32 rounding of the depths stays below 1e-6 of that scale
DEPTH_MARGIN = wp.constant(1.0e-5)


@wp.func
def depth_slack(zo: float, cz: float, t: float, scale: float) -> float:
    """The margin :data:`DEPTH_MARGIN` in depth units for a ray point at parameter ``t``."""
    return DEPTH_MARGIN * (wp.abs(zo) / cz + wp.abs(t) + scale)


@wp.func
def depth_before(r: Ray, fwd: wp.vec3, t: float, scale: float) -> float:
    """A depth along the view direction ``fwd`` (from the eye) that every point of ray ``r`` at parameter ``t`` or
    beyond lies past, by :func:`depth_slack`: a face whose farthest depth is below it is crossed, if at all,
    before ``t``. ``-1e30`` (nothing ruled out) for a ray more than 84 degrees off ``fwd``. ``scale``: the mesh
    radius."""
    zo = wp.dot(r.back, fwd)  # the ray's depth at t = 0 (r.back = origin - eye) and its growth per unit t
    cz = wp.dot(r.d, fwd)
    if cz > 0.1:
        return zo + cz * t - depth_slack(zo, cz, t, scale)
    return float(-1.0e30)


@wp.func
def tile_entry(px: int, py: int, t_start: float, prev: int, r: Ray, t_tol: float, fwd: wp.vec3, scale: float,
               verts: wp.array(dtype=wp.vec4), tets: wp.array(dtype=wp.vec4i), bface_tet: wp.array(dtype=wp.int32),
               bface_local: wp.array(dtype=wp.int32), bface_box: wp.array(dtype=wp.int32),
               tile_start: wp.array(dtype=wp.int32), tile_items: wp.array(dtype=wp.int32),
               item_depth: wp.array(dtype=wp.vec3), tile: int, tiles_x: int):
    """The ray's next entry: the nearest boundary face of pixel (px, py)'s screen tile that the ray crosses
    (entering) beyond ``t_start``. A face up to ``t_tol`` before ``t_start`` counts (a crack left by a
    dropped sliver, touching pieces: the exit and the re-entry are at the same depth up to rounding),
    except faces of the cell ``prev`` just left (a tet is convex: a ray never re-enters it). Of faces
    crossed at the same ``t`` the one listed first in the bins (lowest face index) wins.

    The tile's faces come sorted by nearest depth along the view direction ``fwd`` with their depth
    bounds (``item_depth``: nearest, farthest, farthest of the tile's faces from this one on;
    :func:`warpvol.raycasting.stages.entry_bins.item_depths`). The ray's depth grows linearly with ``t``,
    ``z(t) = zo + cz t``, so a face wholly before the search's start is skipped untested, and the search
    stops at the first face whose nearest depth lies beyond the best crossing found: it and every later
    face are crossed (if at all) farther on. Both by a margin (:func:`depth_slack`) well above float32
    rounding, so the result is the full search's; ``scale`` is the mesh radius.

    Returns ``(cell, local face, entry Face, t, scalar, far_t)``; ``cell = -1``: none. ``far_t`` bounds the
    crossings beyond ``t_start - t_tol`` of every face of the tile (no re-entry once past it): the farthest
    crossing tested, or the depth bound of the faces left untested. The search's face is a variable of
    its own, not the walk's ``fc``: Warp emits one C++ variable per Python name, and a :class:`Face`
    assigned in both the search loop and the walk loop costs the frame about a fifth more CPU (measured
    at 512^2 on Blunt Fin and SPX); inlined, the function's code is otherwise the same."""
    best_t = float(1.0e30)
    best_s = float(0.0)
    best_bf = int(-1)
    far_t = float(-1.0e30)
    cell = int(-1)
    face_in = int(-1)
    fc = Face()
    zo = wp.dot(r.back, fwd)  # the ray's depth at t = 0 (r.back = origin - eye) and its growth per unit t
    cz = wp.dot(r.d, fwd)
    cull = cz > 0.1  # (a ray within 84 degrees of the view direction: every ray of a camera's image)
    t_lo = t_start - t_tol
    z_lo = depth_before(r, fwd, t_lo, scale)  # faces wholly before it: crossed before t_lo
    z_best = float(1.0e30)  # faces wholly beyond it: crossed beyond best_t
    tile_id = (py // tile) * tiles_x + (px // tile)
    for it in range(tile_start[tile_id], tile_start[tile_id + 1]):
        if cull:
            zr = item_depth[it]
            if zr[0] > z_best:
                # this face and every later one lie beyond the best crossing; they are crossed before depth zr[2]
                t_far = (zr[2] - zo) / cz
                far_t = wp.max(far_t, t_far + depth_slack(zo, cz, t_far, scale) / cz)
                break
            if zr[1] < z_lo:
                continue  # wholly before the search's start: crossed, if at all, before t_start - t_tol
        bf = tile_items[it]
        if px < bface_box[4 * bf] or py < bface_box[4 * bf + 1] or px > bface_box[4 * bf + 2] \
                or py > bface_box[4 * bf + 3]:
            continue  # the pixel lies outside the face's grown projected box (as tiles are binned)
        c = int(bface_tet[bf])
        f = int(bface_local[bf])
        cand = boundary_face(tets[c], f, verts, r)
        ok, t, s = face_hit(cand)
        if ok and t > far_t:
            far_t = t
        if ok and t > t_lo and (t < best_t or (t == best_t and bf < best_bf)) and c != prev:
            best_t = t
            best_s = s
            best_bf = bf
            cell = c
            face_in = f
            fc = cand
            z_best = zo + cz * t + depth_slack(zo, cz, t, scale)
    return cell, face_in, fc, best_t, best_s, far_t


@wp.func
def march_ray(
    idx: int,
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
    verts: wp.array(dtype=wp.vec4),
    tets: wp.array(dtype=wp.vec4i),
    nbr: wp.array(dtype=wp.vec4i),
    nbr_vertex: wp.array(dtype=wp.vec4i),
    bface_tet: wp.array(dtype=wp.int32),
    bface_local: wp.array(dtype=wp.int32),
    bface_box: wp.array(dtype=wp.int32),
    tile_start: wp.array(dtype=wp.int32),
    tile_items: wp.array(dtype=wp.int32),
    item_depth: wp.array(dtype=wp.vec3),
    tile: int,
    tiles_x: int,
    tf_s: wp.array(dtype=float),
    tf_v: wp.array(dtype=wp.vec4),
    model: int,
    scalar_check: int,
    max_steps: int,
    t_min: float,
    t_tol: float,
    rgb: wp.array(dtype=wp.vec3),
    trans: wp.array(dtype=float),
    tcur: wp.array(dtype=float),
    status: wp.array(dtype=wp.int32),
    last: wp.array(dtype=wp.int32),
    counters: wp.array2d(dtype=wp.int32),
    chunk: int,
    entry_col: int,
):
    """One entry of pixel ``idx``'s ray: the search for its next entry beyond ``tcur[idx]``, the walk from
    there to where it leaves the (visible) mesh, the state written back (see :func:`march`). The entry is
    counted in ``counters[chunk, entry_col]``."""
    st = status[idx]
    if (st & 3) != STATUS_ACTIVE:
        return
    py = idx // width
    px = idx - py * width
    r, t_clip, t_end = pixel_ray(px, py, width, height, eye, fwd, right, up, ortho, half_h, aspect, radius)
    if t_end < t_clip:
        status[idx] = STATUS_DONE  # the ray misses the mesh's bounding sphere
        return
    t_start = tcur[idx]

    # ---- next entry: nearest boundary face crossed (entering) beyond t_start in this tile ----
    fwd32 = wp.vec3(float(fwd[0]), float(fwd[1]), float(fwd[2]))
    cell, face_in, fc, best_t, best_s, far_t = tile_entry(px, py, t_start, last[idx], r, t_tol, fwd32, float(radius),
                                                          verts, tets, bface_tet, bface_local, bface_box, tile_start,
                                                          tile_items, item_depth, tile, tiles_x)
    flat = st >> 2
    if cell >= 0 and best_t <= t_start:
        flat += 1
        best_t = t_start
    if cell < 0:
        status[idx] = STATUS_DONE
        return
    if flat > MAX_FLAT_REENTRIES:
        status[idx] = STATUS_FAILED  # re-entering without progress: unresolved, redone in float64
        wp.atomic_add(counters, chunk, 3, 1)
        return
    wp.atomic_add(counters, chunk, entry_col, 1)  # entries made in this pass

    # ---- walk through the cell adjacency ----
    acc = rgb[idx]
    tr = trans[idx]
    t_in = best_t
    s_in = best_s
    k_in = tf_upper(s_in, tf_s)
    v_in = tf_eval_upper(s_in, k_in, tf_s, tf_v)
    steps = int(0)
    stall = int(0)
    exited = int(0)
    failed = int(0)
    thin = int(0)
    scale = float(radius)
    thin_mem = thin_start()  # the thin-layer check's memory of the previous segment
    if t_in >= t_clip and grazing_unresolved(tr, v_in, model, fc, r, t_in, scale):
        failed = 1  # entering through a face seen nearly edge-on: the chord's float32 start is too uncertain
    ds_in = scalar_error_if(scalar_check, fc, r)  # the entry crossing's scalar error
    scal_err = float(0.0)  # bound on the pixel's error from the crossings' scalar errors so far
    gn = tets[cell][face_in]
    while steps < max_steps and failed == 0:
        steps += 1
        nrow = nbr[cell]  # this cell's neighbour records, fetched while the step computes
        vrow = nbr_vertex[cell]
        fc, f_out, t_out, s_out = next_face_from(tets[cell], gn, fc, verts, r)
        t_out, stall = monotone_exit(t_in, t_out, stall)
        if f_out < 0 or stall > STALL_STEPS:
            failed = 1  # no exit face, or no progress in t for STALL_STEPS steps
            break
        k_out = tf_upper_from(s_out, k_in, tf_s)
        v_out = tf_eval_upper(s_out, k_out, tf_s, tf_v)
        if t_out > t_clip:
            ln = t_out - t_in
            if t_in >= t_clip:
                if k_in == k_out:  # no control point crossed: one linear piece
                    seg = integrate_piece(ln, v_in, v_out, model)
                else:
                    seg = integrate_segment_tf(s_in, s_out, v_in, v_out, ln, tf_s, tf_v, model)
            else:
                ta, sa = clipped_segment(t_in, t_out, s_in, s_out, t_clip)
                ln = t_out - ta
                seg = integrate_segment_tf(sa, s_out, tf_eval(sa, tf_s, tf_v), v_out, ln, tf_s, tf_v,
                                           model)
            # a segment too short for its float32 length next to a density contrast: unresolved
            thin, thin_mem = thin_step(thin_mem, ln, seg[3], t_out, scale, tr, v_in, v_out, k_in, k_out, tf_v, model)
            # the crossings' float32 scalars, too uncertain where the transfer function is that steep (a check
            # that provably cannot fire for this TF and mesh is off: scalar_check_needed)
            ds_out = scalar_error_if(scalar_check, fc, r)
            scal_err = scalar_step(scal_err, tr, ln, seg[3], s_in, s_out, v_in, v_out, k_in, k_out, ds_in, ds_out,
                                   tf_s, tf_v, model)
            if thin == 1 or scal_err > STEEP_ERR:
                failed = 1
            ds_in = ds_out
            acc += tr * wp.vec3(seg[0], seg[1], seg[2])
            tr = tr * exp_neg(seg[3])
        if failed == 1:
            break  # (one break after the block, not one per check inside it: a failed ray's colour is dropped)
        nb = nrow[f_out]
        t_in = t_out
        s_in = s_out
        k_in = k_out
        v_in = v_out
        if tr < t_min:
            break
        if nb < 0:
            exited = 1
            if thin_at_exit(thin_mem):
                failed = 1
                thin = 1
            elif t_in > t_clip and grazing_unresolved(tr, v_in, model, fc, r, t_in, scale):
                failed = 1  # leaving through a face seen nearly edge-on
            break
        gn = vrow[f_out]
        cell = nb >> 2
        face_in = nb & 3
    wp.atomic_add(counters, chunk, 1, steps)
    if failed == 1:
        status[idx] = STATUS_FAILED
        wp.atomic_add(counters, chunk, 3, 1)
        if thin == 1:
            wp.atomic_add(counters, chunk, 5, 1)  # of which: a thin layer float32 cannot resolve
        return
    rgb[idx] = acc
    trans[idx] = tr
    tcur[idx] = t_in
    last[idx] = cell
    if t_in > best_t:
        flat = 0  # the walk advanced: only consecutive re-entries without progress count
    status[idx] = STATUS_ACTIVE + 4 * flat
    if exited == 0:
        status[idx] = STATUS_DONE
        if tr >= t_min:
            wp.atomic_add(counters, chunk, 2, 1)  # rays stopped by max_steps
        else:
            wp.atomic_add(counters, chunk, 6, 1)  # early ray termination: transmittance below t_min
    elif t_in >= t_end:
        status[idx] = STATUS_DONE  # left the bounding sphere: no further entry possible
    elif not (far_t > t_in - t_tol):
        # the next search would test these faces (or faces bounded in depth before t_in) with the same
        # float32 numbers and find none beyond t_in - t_tol (it also skips the cell just left): skip it
        status[idx] = STATUS_DONE


@wp.kernel
def march(
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
    verts: wp.array(dtype=wp.vec4),
    tets: wp.array(dtype=wp.vec4i),
    nbr: wp.array(dtype=wp.vec4i),
    nbr_vertex: wp.array(dtype=wp.vec4i),
    bface_tet: wp.array(dtype=wp.int32),
    bface_local: wp.array(dtype=wp.int32),
    bface_box: wp.array(dtype=wp.int32),
    tile_start: wp.array(dtype=wp.int32),
    tile_items: wp.array(dtype=wp.int32),
    item_depth: wp.array(dtype=wp.vec3),
    tile: int,
    tiles_x: int,
    tf_s: wp.array(dtype=float),
    tf_v: wp.array(dtype=wp.vec4),
    model: int,
    scalar_check: int,
    max_steps: int,
    t_min: float,
    t_tol: float,
    first: int,
    ids: wp.array(dtype=wp.int32),
    rgb: wp.array(dtype=wp.vec3),
    trans: wp.array(dtype=float),
    tcur: wp.array(dtype=float),
    status: wp.array(dtype=wp.int32),
    last: wp.array(dtype=wp.int32),
    reentries: int,
    counters: wp.array2d(dtype=wp.int32),
    chunk: int,
):
    """A pass: one thread per ray (pixels ``first ..``, or ``ids[first ..]``), each entering and walking
    (:func:`march_ray`) and then re-entering in the same thread, up to ``reentries`` times, while its ray
    may enter again (``STATUS_ACTIVE``): the same walk as one entry per pass, without a pass per
    re-entry. Counts first entries in ``counters[chunk, 0]``, re-entries in ``counters[chunk, 7]`` and
    the rays still active at the end (a further pass must search them) in ``counters[chunk, 4]``."""
    tid = wp.tid()
    idx = first + tid  # the pixels first .. (all rays of the image active)
    if ids.shape[0] > 0:
        idx = ids[first + tid]  # the active rays' pixels ids[first ..] (a re-entry pass)
    py = idx // width
    tile_id = (py // tile) * tiles_x + (idx - py * width) // tile
    if tile_start[tile_id] == tile_start[tile_id + 1]:
        # no entry face binned to the pixel's tile: the search finds none, the ray is done (as march_ray decides)
        if (status[idx] & 3) == STATUS_ACTIVE:
            status[idx] = STATUS_DONE
        return
    march_ray(idx, width, height, eye, fwd, right, up, ortho, half_h, aspect, radius, verts, tets, nbr, nbr_vertex,
              bface_tet, bface_local, bface_box, tile_start, tile_items, item_depth, tile, tiles_x, tf_s, tf_v, model,
              scalar_check, max_steps, t_min, t_tol, rgb, trans, tcur, status, last, counters, chunk, 0)
    k = int(0)
    while k < reentries and (status[idx] & 3) == STATUS_ACTIVE:
        k += 1
        march_ray(idx, width, height, eye, fwd, right, up, ortho, half_h, aspect, radius, verts, tets, nbr,
                  nbr_vertex, bface_tet, bface_local, bface_box, tile_start, tile_items, item_depth, tile, tiles_x,
                  tf_s, tf_v, model, scalar_check, max_steps, t_min, t_tol, rgb, trans, tcur, status, last, counters,
                  chunk, 7)
    if (status[idx] & 3) == STATUS_ACTIVE:
        wp.atomic_add(counters, chunk, 4, 1)  # rays a further pass must search


@wp.kernel
def init_state(rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float), tcur: wp.array(dtype=float),
               status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32), t0: float):
    i = wp.tid()
    last[i] = -1
    rgb[i] = wp.vec3(0.0, 0.0, 0.0)
    trans[i] = 1.0
    tcur[i] = t0
    status[i] = STATUS_ACTIVE


@wp.kernel
def finish(rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float), out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    c = rgb[i]
    out[i] = wp.vec4(c[0], c[1], c[2], 1.0 - trans[i])
