"""HARC's consistent walk (``walk = plucker``) outside the march kernel body: the entry face search
around a rasterised face (:func:`ring_search`), the whole cell-to-cell loop of the exact robust case
(:func:`exact_walk`, ``harc_best``) on the ``@wp.func`` s of :mod:`warpvol.kernels.walk`, and the
front-to-back compositing every HARC loop uses (:func:`composite`).

The loop is a function of its own, not inline in :func:`warpvol.kernels.harc.make_march`'s kernel: the
CPU code generated for the loop is faster without the entry search and the ray set-up beside it in the
same function body (same arithmetic, same images).
"""

import warp as wp

from .integrate import exp_neg, integrate_piece, integrate_segment_tf
from .tf import tf_eval_upper, tf_upper, tf_upper_from
from .walk import (STALL_STEPS, STEEP_ERR, Face, Ray, boundary_face, face_hit, grazing_unresolved, monotone_exit,
                   next_face_from, scalar_error_if, scalar_step, thin_at_exit, thin_start, thin_step)

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


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
            ok, t, s = face_hit(boundary_face(tets[bf_tet[n1]], bf_face[n1], verts, r))
            if ok:
                return n1, True, t, s
    for k in range(3):
        n1 = nb[k]
        if n1 >= 0:
            nb2 = bf_nbr[n1]
            for j in range(3):
                n2 = nb2[j]
                if n2 >= 0 and n2 != b:
                    ok, t, s = face_hit(boundary_face(tets[bf_tet[n2]], bf_face[n2], verts, r))
                    if ok:
                        return n2, True, t, s
    return int(-1), False, float(0.0), float(0.0)


@wp.func
def nearest_listed(lo: int, hi: int, items: wp.array(dtype=wp.int32), bf_tet: wp.array(dtype=wp.int32),
                   bf_face: wp.array(dtype=wp.int32), bf_depth: wp.array(dtype=wp.vec2), z_lo: float,
                   tets: wp.array(dtype=wp.vec4i), verts: wp.array(dtype=wp.vec4), r: Ray, prev: int, t_start: float,
                   t_tol: float, cell: int, face_in: int, t_in: float, s_in: float, fc: Face):
    """The nearer of the entry ``(cell, face_in, t_in, s_in, fc)`` (``cell < 0``: none yet) and the first crossing
    beyond ``t_start - t_tol`` of the front faces ``items[lo:hi]`` (consistent edge test), faces of ``prev`` (the
    cell just left) skipped; the ray parameter is clamped to ``t_start``. A face whose farthest depth
    (``bf_depth[b][1]``) is below ``z_lo`` (:func:`warpvol.kernels.raycast.depth_before` of ``t_start - t_tol``)
    is crossed, if at all, before that: skipped untested."""
    for it in range(lo, hi):
        b = int(items[it])
        if bf_depth[b][1] < z_lo:
            continue
        c = int(bf_tet[b])
        f = int(bf_face[b])
        if c != prev:
            cand = boundary_face(tets[c], f, verts, r)
            ok, t, s = face_hit(cand)
            if ok and t > t_start - t_tol and (cell < 0 or t < t_in):
                cell = c
                face_in = f
                t_in = wp.max(t, t_start)
                s_in = s
                fc = cand
    return cell, face_in, t_in, s_in, fc


@wp.func
def nearest_in_rings(b: int, bf_tet: wp.array(dtype=wp.int32), bf_face: wp.array(dtype=wp.int32),
                     bf_nbr: wp.array(dtype=wp.vec3i), tets: wp.array(dtype=wp.vec4i), verts: wp.array(dtype=wp.vec4),
                     r: Ray, prev: int, t_start: float, t_tol: float, cell: int, face_in: int, t_in: float,
                     s_in: float, fc: Face):
    """As :func:`nearest_listed` over the two rings of front faces around face ``b`` (its edge neighbours and
    theirs, :func:`ring_search`'s faces): a re-entry whose listed face the edge test rejects, where the face
    the ray crosses is a sliver beside it that no pixel near this one lists."""
    nb = bf_nbr[b]
    for k in range(3):
        n1 = nb[k]
        if n1 >= 0:
            nb2 = bf_nbr[n1]
            for j in range(4):
                n2 = n1
                if j < 3:
                    n2 = nb2[j]
                if n2 >= 0 and n2 != b:
                    c = int(bf_tet[n2])
                    if c != prev:
                        cand = boundary_face(tets[c], int(bf_face[n2]), verts, r)
                        ok, t, s = face_hit(cand)
                        if ok and t > t_start - t_tol and (cell < 0 or t < t_in):
                            cell = c
                            face_in = int(bf_face[n2])
                            t_in = wp.max(t, t_start)
                            s_in = s
                            fc = cand
    return cell, face_in, t_in, s_in, fc


@wp.func
def composite(acc: wp.vec4, c: wp.vec4) -> wp.vec4:
    """Front-to-back "under": ``(R, G, B, A) + (1 - A) (r, g, b, a)`` (Fig. 6 line 24)."""
    return acc + (1.0 - acc[3]) * c


@wp.func
def exact_walk(cell: int, face_in: int, fc: Face, t_in: float, s_in: float, acc: wp.vec4, r: Ray,
               verts: wp.array(dtype=wp.vec4), tets: wp.array(dtype=wp.vec4i), nbr: wp.array(dtype=wp.vec4i),
               nbr_vertex: wp.array(dtype=wp.vec4i), tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4),
               model: int, t_stop: float, max_steps: int, scale: float, scalar_check: int):
    """The consistent walk with exact segment integrals from the entry (``cell`` through its local face
    ``face_in`` = :class:`~warpvol.kernels.walk.Face` ``fc`` at ray parameter ``t_in``, scalar ``s_in``),
    compositing front to back into ``acc``: one cell per step (:func:`~warpvol.kernels.walk.next_face_from`,
    the neighbour's new vertex taken from ``nbr_vertex``), the TF value carried from face to face (one TF
    evaluation per face, one linear piece unless a control point is crossed), the thin-layer check of
    ``raycast``'s march, its check of entries and exits through faces seen nearly edge-on and its bound on the
    crossings' scalar errors (:func:`~warpvol.kernels.walk.scalar_step`; skipped with ``scalar_check`` 0, where it
    provably cannot fire: :func:`warpvol.raycasting.stages.cell_setup.scalar_check_needed`). Stops when
    ``1 - A < t_stop``, at the mesh boundary, after ``max_steps`` cells, or
    on a ray it cannot resolve (no exit face, :data:`~warpvol.kernels.walk.STALL_STEPS` steps without
    progress, a thin layer, crossing scalars too uncertain for the transfer function).

    Returns ``(acc, t_in, cell, steps, cells, failed, exited, thin)``: the composited colour, the last exit's
    ray parameter, the last cell, integrated segments, cells visited, failed (1: redo in float64), left the
    mesh (1), failed on a thin layer (1)."""
    steps = int(0)
    cells = int(0)
    stall = int(0)
    failed = int(0)
    exited = int(0)
    thin = int(0)
    thin_mem = thin_start()  # the thin-layer check's memory of the previous segment
    k_in = tf_upper(s_in, tf_s)
    v_in = tf_eval_upper(s_in, k_in, tf_s, tf_v)
    if grazing_unresolved(1.0 - acc[3], v_in, model, fc, r, t_in, scale):
        failed = 1  # entering through a face seen nearly edge-on: the chord's float32 start is too uncertain
    ds_in = scalar_error_if(scalar_check, fc, r)  # the entry crossing's scalar error
    scal_err = float(0.0)  # bound on the pixel's error from the crossings' scalar errors so far
    gn = tets[cell][face_in]
    while cells < max_steps and failed == 0:
        cells += 1
        nrow = nbr[cell]  # this cell's neighbour records, fetched while the step computes
        vrow = nbr_vertex[cell]
        fc, f_out, t_out, s_out = next_face_from(tets[cell], gn, fc, verts, r)
        t_out, stall = monotone_exit(t_in, t_out, stall)
        if f_out < 0 or stall > STALL_STEPS:
            failed = 1  # no exit face, or no progress in t for STALL_STEPS steps
            break
        k_out = tf_upper_from(s_out, k_in, tf_s)
        v_out = tf_eval_upper(s_out, k_out, tf_s, tf_v)
        seg = wp.vec4(0.0, 0.0, 0.0, 0.0)
        if k_in == k_out:
            seg = integrate_piece(t_out - t_in, v_in, v_out, model)
        else:
            seg = integrate_segment_tf(s_in, s_out, v_in, v_out, t_out - t_in, tf_s, tf_v, model)
        thin, thin_mem = thin_step(thin_mem, t_out - t_in, seg[3], t_out, scale, 1.0 - acc[3], v_in, v_out, k_in, k_out,
                                   tf_v, model)
        # the crossings' float32 scalars, too uncertain where the transfer function is that steep
        ds_out = scalar_error_if(scalar_check, fc, r)
        scal_err = scalar_step(scal_err, 1.0 - acc[3], t_out - t_in, seg[3], s_in, s_out, v_in, v_out, k_in, k_out,
                               ds_in, ds_out, tf_s, tf_v, model)
        if thin == 1 or scal_err > STEEP_ERR:
            failed = 1  # (one break for both checks: Warp adds a select of every loop variable per break)
            break
        ds_in = ds_out
        acc = composite(acc, wp.vec4(seg[0], seg[1], seg[2], 1.0 - exp_neg(seg[3])))
        steps += 1
        k_in = k_out
        v_in = v_out
        t_in = t_out
        s_in = s_out
        nb = nrow[f_out]
        if 1.0 - acc[3] < t_stop:
            break
        if nb < 0:
            exited = 1
            if thin_at_exit(thin_mem):
                failed = 1
                thin = 1
            elif grazing_unresolved(1.0 - acc[3], v_in, model, fc, r, t_in, scale):
                failed = 1  # leaving through a face seen nearly edge-on
            break
        gn = vrow[f_out]
        cell = nb >> 2
        face_in = nb & 3
    return acc, t_in, cell, steps, cells, failed, exited, thin
