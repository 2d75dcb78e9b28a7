"""The one cell walk of the ray casters (``raycast`` and ``peel``, ``harc_best``, the faithful HARC presets
``espinha2005_*``) and the Warp structs their kernels take (camera, mesh, walk options, segment output).

:func:`make_walk` builds the walk of one configuration as a ``@wp.func``; its options are fixed when the code
is generated (``wp.static`` conditions, as :func:`warpvol.kernels.harc.make_march` fixes its own), so each
kernel holds only its own paths:

* ``planes`` -- the exit face from the cell's face planes (the paper's Fig. 6 arithmetic on its mesh textures,
  :class:`MeshTex`), scalars from the cell's gradient, the next cell from the adjacency texture; otherwise the
  consistent Plücker walk of :mod:`warpvol.kernels.walk` (:func:`~warpvol.kernels.walk.next_face_from`,
  watertight through vertices and edges).
* ``paper`` -- the paper's rules for the planes walk: ``lambda'`` as computed (a step backwards is flagged, not
  clamped), a zero-length segment integrates nothing.
* ``mode`` -- the segment integration (``INTEG_*`` of :mod:`warpvol.kernels.harc_integ`): the exact
  piecewise-linear integral or a pre-integration table (iso splits for partial pre-integration, composited
  "under" inside :func:`~warpvol.kernels.harc_integ.segment`).
* ``segs`` -- (the exact Plücker walk) the walk also composites the entry's own segment (colour and transmittance from the entry on),
  which a kernel can write out with its front and back depth (:class:`Segments`).

The exact Plücker walk (``raycast``, ``harc_best``) carries the TF value from face to face (one TF evaluation
per face, one linear piece unless a control point is crossed), clips at ``t_clip`` (an eye inside the mesh's
bounding sphere), composites ``rgb += tr c``, ``tr *= e^-tau`` (the state ``acc`` holds ``(rgb, tr)``) and
gives up a ray it cannot resolve (no exit face, :data:`~warpvol.kernels.walk.STALL_STEPS` steps without
progress, a thin layer, an entry or exit through a face seen nearly edge-on, crossing scalars too uncertain for
the transfer function: :func:`~warpvol.kernels.walk.thin_step`, :func:`~warpvol.kernels.walk.grazing_unresolved`,
:func:`~warpvol.kernels.walk.scalar_step`) -- marked failed and redone in float64 by the stage. The other
configurations composite ``(R, G, B, A) += (1 - A)(r, g, b, a)`` (the paper's Fig. 6 line 24; ``acc`` holds
``RGBA``).
"""

import warp as wp

from .harc_integ import INTEG_EXACT, Integ, segment
from .harc_walk import composite
from .integrate import exp_neg, flat_extinction, integrate_piece, integrate_piece_flat, integrate_segment_tf
from .texture import Tex2D, tex2d_texel
from .tf import tf_eval, tf_eval_upper, tf_upper, tf_upper_from
from .walk import (
    STALL_STEPS,
    STEEP_ERR,
    Face,
    Ray,
    grazing_unresolved,
    monotone_exit,
    next_face_from,
    pixel_ray,
    scalar_error_if,
    scalar_step,
    thin_at_exit,
    thin_start,
    thin_step,
)

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.struct
class RayCamera:
    """The camera as the ray set-up takes it (:func:`~warpvol.kernels.walk.pixel_ray`): image size, eye relative
    to the cells' origin and the camera frame in float64, orthographic (1) or perspective, the half height of
    the view (``tan(fov / 2)`` or half the orthographic height), the aspect ratio and the mesh's radius."""

    width: int
    height: int
    eye: wp.vec3d
    fwd: wp.vec3d
    right: wp.vec3d
    up: wp.vec3d
    ortho: int
    half_h: wp.float64
    aspect: wp.float64
    radius: wp.float64


@wp.func
def camera_ray(px: int, py: int, cam: RayCamera):
    """:func:`~warpvol.kernels.walk.pixel_ray` of pixel (px, py): ``(ray, t_clip, t_end)``."""
    return pixel_ray(px, py, cam.width, cam.height, cam.eye, cam.fwd, cam.right, cam.up, cam.ortho, cam.half_h,
                     cam.aspect, cam.radius)


@wp.struct
class CellMesh:
    """The cells as the Plücker walk reads them: vertex records ``(x, y, z, s)``, tets (global vertex indices),
    neighbour records ``4 * neighbour + its local face`` (-1: boundary) and the neighbour's vertex opposite the
    shared face."""

    verts: wp.array(dtype=wp.vec4)
    tets: wp.array(dtype=wp.vec4i)
    nbr: wp.array(dtype=wp.vec4i)
    nbr_vertex: wp.array(dtype=wp.vec4i)


@wp.struct
class WalkOpts:
    """What bounds a walk: the transmittance it stops below (``t_stop``, 0: never), the most cells per entry
    (``max_steps``), the crossings' scalar-error bound on (``scalar_check`` 1) or provably off (0), and the
    tolerance in ``t`` of an entry search beyond the last exit (``t_tol``)."""

    t_stop: float
    max_steps: int
    scalar_check: int
    t_tol: float


@wp.struct
class Segments:
    """Per-entry segments written by a kernel built with ``segs``: ray ``i`` holds ``count[i]`` (at most
    ``cap``) segments at ``i * cap ..``, each its front and back ray parameter (``depth``) and its colour and
    transmittance from its own front on (``color``: ``(r, g, b, tr)``); an unused (empty) struct has ``cap``
    0. Composited front to back they give the ray's pixel."""

    cap: int
    count: wp.array(dtype=wp.int32)
    depth: wp.array(dtype=wp.vec2)
    color: wp.array(dtype=wp.vec4)


@wp.func
def put_segment(sg: Segments, idx: int, t_front: float, t_back: float, c: wp.vec4):
    """Append segment ``(t_front, t_back, c)`` to ray ``idx``'s list (dropped, but counted, past ``cap``)."""
    k = sg.count[idx]
    if k < sg.cap:
        sg.depth[idx * sg.cap + k] = wp.vec2(t_front, t_back)
        sg.color[idx * sg.cap + k] = c
    sg.count[idx] = k + 1


@wp.struct
class MeshTex:
    """The paper's Table 1: four face planes ``(n, o)``, gradient ``(g, g0)`` and adjacency
    (``4 * neighbour + face in neighbour``, -1 on the boundary, exact in float32 below 2^24) per
    tet, each an rgba32f 2D texture of ``width`` texels per row (texel ``t % width, t // width``)."""

    n0: Tex2D
    n1: Tex2D
    n2: Tex2D
    n3: Tex2D
    grad: Tex2D
    adj: Tex2D
    width: int


@wp.func
def cell_texel(mt: MeshTex, tex: Tex2D, c: int) -> wp.vec4:
    """Nearest fetch of tet ``c``'s texel from one of the mesh textures."""
    y = c // mt.width
    return tex2d_texel(tex, float(c - y * mt.width) + 0.5, float(y) + 0.5)


@wp.func
def plane_of(mt: MeshTex, c: int, i: int) -> wp.vec4:
    if i == 0:
        return cell_texel(mt, mt.n0, c)
    if i == 1:
        return cell_texel(mt, mt.n1, c)
    if i == 2:
        return cell_texel(mt, mt.n2, c)
    return cell_texel(mt, mt.n3, c)


@wp.func
def plane_lambda(p: wp.vec4, o: wp.vec3, d: wp.vec3) -> float:
    """Ray parameter where ray ``o + lambda d`` meets plane ``n.x + w = 0``."""
    n = wp.vec3(p[0], p[1], p[2])
    return -(wp.dot(o, n) + p[3]) / wp.dot(d, n)


@wp.func
def plane_exit(mt: MeshTex, c: int, o: wp.vec3, d: wp.vec3):
    """Fig. 6 lines 1-9: ``(lambda', local face)`` of the smallest ``lambda`` among faces with
    ``d . n > 0``; face -1 when none has."""
    best = float(1.0e30)
    f = int(-1)
    for i in range(4):
        p = plane_of(mt, c, i)
        dn = wp.dot(d, wp.vec3(p[0], p[1], p[2]))
        if dn > 0.0:
            lam = -(wp.dot(o, wp.vec3(p[0], p[1], p[2])) + p[3]) / dn
            if lam < best:
                best = lam
                f = i
    return best, f


@wp.func
def grad_scalar(g: wp.vec4, x: wp.vec3) -> float:
    return wp.dot(wp.vec3(g[0], g[1], g[2]), x) + g[3]


@wp.func
def clipped_segment(t_in: float, t_out: float, s_in: float, s_out: float, t_clip: float):
    """The part ``t >= t_clip`` of segment ``[t_in, t_out]`` with linear scalar; ``(t0, s0)``."""
    if t_in >= t_clip:
        return t_in, s_in
    if t_out <= t_clip:
        return t_out, s_out
    return t_clip, s_in + (s_out - s_in) * ((t_clip - t_in) / (t_out - t_in))


@wp.func
def add_under_tr(acc: wp.vec4, seg: wp.vec4, e: float) -> wp.vec4:
    """``(rgb, tr)`` behind a segment of radiance ``seg[0:3]`` and transmittance ``e``: ``rgb + tr c``, ``tr e``."""
    tr = acc[3]
    return wp.vec4(acc[0] + tr * seg[0], acc[1] + tr * seg[1], acc[2] + tr * seg[2], tr * e)


def make_walk(planes: bool, paper: bool, mode: int, segs: bool = False, clip: bool = True):
    """The walk of one configuration (see the module docstring) as a ``@wp.func``:

    ``walk(cell, face_in, fc, t_in, s_in, acc, r, o, d, t_clip, scale, mesh, mt, ig, opts, counters, chunk)``
    walks from the entry (``cell`` through its local face ``face_in`` = :class:`~warpvol.kernels.walk.Face`
    ``fc``, at ray parameter ``t_in`` with scalar ``s_in``; the planes walk uses the ray ``o + t d``) until the
    ray leaves the mesh, its transmittance drops below ``opts.t_stop``, ``opts.max_steps`` cells or a ray it
    cannot resolve. ``acc``: ``(rgb, transmittance)`` for the exact Plücker walk, ``RGBA`` otherwise.

    Returns ``(acc, t, cell, steps, cells, failed, exited, thin, backward, fetches, seg)``: the composited state,
    the last exit's ray parameter and cell, segments integrated (iso sub-steps included), cells visited, failed
    (1), left the mesh (1), failed on a thin layer (1), took a step with ``lambda' < lambda`` (1, the paper's
    walk), texture fetches of the planes walk, and (``segs``) this entry's own ``(rgb, tr)``. ``clip`` (the exact
    Plücker walk): a ray may start inside the mesh's bounding sphere (``t_clip > 0``: ``raycast``), so segments
    are clipped at ``t_clip``; without it (HARC, whose rays start on a rasterised boundary face) ``t_clip`` is not
    read."""
    exact = mode == INTEG_EXACT
    carried = (not planes) and exact  # the exact Plücker walk: TF carried face to face, checks, (rgb, tr) state
    if paper and not planes:
        raise ValueError("make_walk: the paper's set-up walks the face planes")
    if segs and not carried:
        raise ValueError("make_walk: segments are kept by the exact Plücker walk only")

    @wp.func
    def cell_walk(cell: int, face_in: int, fc: Face, t_in: float, s_in: float, acc: wp.vec4, r: Ray, o: wp.vec3,
                  d: wp.vec3, t_clip: float, scale: float, mesh: CellMesh, mt: MeshTex, ig: Integ, opts: WalkOpts,
                  counters: wp.array2d(dtype=wp.int32), chunk: int):
        steps = int(0)
        cells = int(0)
        stall = int(0)
        failed = int(0)
        exited = int(0)
        thin = int(0)
        backward = int(0)
        fetches = int(0)
        own = wp.vec4(0.0, 0.0, 0.0, 1.0)  # this entry's own (rgb, tr)
        thin_mem = thin_start()  # the thin-layer check's memory of the previous segment
        k_in = int(0)
        v_in = wp.vec4(0.0, 0.0, 0.0, 0.0)
        ds_in = float(0.0)
        scal_err = float(0.0)  # bound on the pixel's error from the crossings' scalar errors so far
        gn = int(0)
        if wp.static(carried):
            k_in = tf_upper(s_in, ig.tf_s)
            v_in = tf_eval_upper(s_in, k_in, ig.tf_s, ig.tf_v)
            if (wp.static(not clip) or t_in >= t_clip) and grazing_unresolved(acc[3], v_in, ig.model, fc, r, t_in,
                                                                              scale):
                failed = 1  # entering through a face seen nearly edge-on: the chord's float32 start is too uncertain
            ds_in = scalar_error_if(opts.scalar_check, fc, r)  # the entry crossing's scalar error
        if wp.static(not planes):
            gn = mesh.tets[cell][face_in]
        while cells < opts.max_steps and failed == 0:
            cells += 1
            if wp.static(planes):
                lam, f_out = plane_exit(mt, cell, o, d)
                fetches += 4
                if f_out < 0:
                    failed = 1
                    break
                g = cell_texel(mt, mt.grad, cell)
                a = cell_texel(mt, mt.adj, cell)
                fetches += 2
                t_out = lam
                if wp.static(paper):
                    # Fig. 6: lambda' as computed; a step that does not advance only counts towards
                    # the stall bound (the hardware's loop would run on to its instruction limit)
                    stall = stall + 1
                    if lam > t_in:
                        stall = int(0)
                    elif lam < t_in:
                        backward = 1  # rounding chose an exit behind the entry: the walk is suspect
                else:
                    t_out, stall = monotone_exit(t_in, t_out, stall)
                s_in = grad_scalar(g, o + d * t_in)  # Fig. 6 line 10: sf from this cell's gradient
                s_out = grad_scalar(g, o + d * t_out)
                nb = int(wp.clamp(a[f_out], -1.0, 1.0e8))
                if stall > STALL_STEPS:
                    failed = 1
                    break
            else:
                nrow = mesh.nbr[cell]  # this cell's neighbour records, fetched while the step computes
                vrow = mesh.nbr_vertex[cell]
                fc, f_out, t_out, s_out = next_face_from(mesh.tets[cell], gn, fc, mesh.verts, r)
                t_out, stall = monotone_exit(t_in, t_out, stall)
                if f_out < 0 or stall > STALL_STEPS:
                    failed = 1  # no exit face, or no progress in t for STALL_STEPS steps
                    break
                nb = nrow[f_out]
            if wp.static(carried):
                k_out = tf_upper_from(s_out, k_in, ig.tf_s)
                v_out = tf_eval_upper(s_out, k_out, ig.tf_s, ig.tf_v)
                if wp.static(not clip) or t_out > t_clip:
                    tr = acc[3]
                    ln = t_out - t_in
                    seg = wp.vec4(0.0, 0.0, 0.0, 0.0)
                    if wp.static(not clip) or t_in >= t_clip:
                        if k_in == k_out:  # no control point crossed: one linear piece
                            seg = integrate_piece_flat(ln, v_in, v_out, flat_extinction(k_in, ig.tf_v), ig.model)
                        else:
                            seg = integrate_segment_tf(s_in, s_out, v_in, v_out, ln, ig.tf_s, ig.tf_v, ig.model)
                    else:
                        ta, sa = clipped_segment(t_in, t_out, s_in, s_out, t_clip)
                        ln = t_out - ta
                        seg = integrate_segment_tf(sa, s_out, tf_eval(sa, ig.tf_s, ig.tf_v), v_out, ln, ig.tf_s,
                                                   ig.tf_v, ig.model)
                    # a segment too short for its float32 length next to a density contrast: unresolved
                    thin, thin_mem = thin_step(thin_mem, ln, seg[3], t_out, scale, tr, v_in, v_out, k_in, k_out,
                                               ig.tf_v, ig.model)
                    # the crossings' float32 scalars, too uncertain where the transfer function is that steep
                    ds_out = scalar_error_if(opts.scalar_check, fc, r)
                    scal_err = scalar_step(scal_err, tr, ln, seg[3], s_in, s_out, v_in, v_out, k_in, k_out, ds_in,
                                           ds_out, ig.tf_s, ig.tf_v, ig.model)
                    if thin == 1 or scal_err > STEEP_ERR:
                        failed = 1
                    ds_in = ds_out
                    e = exp_neg(seg[3])
                    acc = add_under_tr(acc, seg, e)
                    if wp.static(segs):
                        own = add_under_tr(own, seg, e)
                if failed == 1:
                    break  # (one break after the block, not one per check inside it: a failed ray's colour is dropped)
                steps += 1
                k_in = k_out
                v_in = v_out
            else:
                if wp.static(exact):
                    # the planes walk's exact integral (sf from the cell's own gradient, so both ends are looked up
                    # per cell), one linear piece unless a control point is crossed
                    k_a = tf_upper(s_in, ig.tf_s)
                    v_a = tf_eval_upper(s_in, k_a, ig.tf_s, ig.tf_v)
                    k_b = tf_upper(s_out, ig.tf_s)
                    v_b = tf_eval_upper(s_out, k_b, ig.tf_s, ig.tf_v)
                    seg = wp.vec4(0.0, 0.0, 0.0, 0.0)
                    seg_l = t_out - t_in
                    if wp.static(paper):
                        if seg_l < 0.0:
                            seg_l = 0.0  # lambda' before lambda: nothing to integrate
                    if k_a == k_b:
                        seg = integrate_piece(seg_l, v_a, v_b, ig.model)
                    else:
                        seg = integrate_segment_tf(s_in, s_out, v_a, v_b, seg_l, ig.tf_s, ig.tf_v, ig.model)
                    c = wp.vec4(seg[0], seg[1], seg[2], 1.0 - exp_neg(seg[3]))
                    acc = composite(acc, c)
                    steps += 1
                else:
                    acc, n_sub = segment(ig, s_in, s_out, t_out - t_in, acc, opts.t_stop, counters, chunk)
                    steps += n_sub
            t_in = t_out
            s_in = s_out
            if wp.static(carried):
                if acc[3] < opts.t_stop:
                    break
            else:
                if 1.0 - acc[3] < opts.t_stop:
                    break
            if nb < 0:
                exited = 1
                if wp.static(carried):
                    if thin_at_exit(thin_mem):
                        failed = 1
                        thin = 1
                    elif (wp.static(not clip) or t_in > t_clip) and grazing_unresolved(acc[3], v_in, ig.model, fc, r,
                                                                                        t_in, scale):
                        failed = 1  # leaving through a face seen nearly edge-on
                break
            if wp.static(not planes):
                gn = vrow[f_out]
            cell = nb >> 2
            face_in = nb & 3
        return acc, t_in, cell, steps, cells, failed, exited, thin, backward, fetches, own

    return cell_walk
