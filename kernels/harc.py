"""Hardware ray casting (HARC, Weiler et al. 2003) with full and partial pre-integration (Espinha &
Celes 2005), one thread per pixel = one fragment of the ray-casting fragment program.

Two walks; the kernel is generated per configuration (walk, ray set-up, integration: :func:`make_march`,
:func:`march_kernel`), so each holds only its own paths:

* ``WALK_PLANES`` -- the paper's Fig. 6 arithmetic on its 96 bytes/tet mesh textures (read through the
  texture unit, nearest rgba32f texel fetches): exit face = smallest ``lambda = -(e.n + o)/(d.n)``
  among the faces with ``d.n > 0``, scalars ``s = g.x + g0`` from the cell's gradient, next cell from
  the adjacency texture. Rays it cannot resolve (no face with ``d.n > 0``, no progress in ``lambda``
  for :data:`warpvol.kernels.walk.STALL_STEPS` steps, the step bound) are marked failed, counted
  and redone in float64 on the host -- never silently wrong pixels from those cases.
* ``WALK_PLUCKER`` -- the consistent walk of :mod:`warpvol.kernels.walk` (its ``@wp.func`` s
  :func:`~warpvol.kernels.walk.boundary_face`, :func:`~warpvol.kernels.walk.face_hit`,
  :func:`~warpvol.kernels.walk.next_face`; no second copy): watertight on rays through vertices
  and edges. With the robust set-up and exact segments (``harc_best``) it is ``raycast``'s walk.

Both are options of the one cell walk, :func:`warpvol.kernels.cellwalk.make_walk`.

Ray set-up (``SETUP_*``): ``SETUP_ROBUST`` takes the ray from :func:`warpvol.kernels.walk.pixel_ray`
(float64 set-up, origin moved to the mesh; the textures are relative to the cells' origin) and marks
rays it cannot resolve failed, for the float64 redo on the host. ``SETUP_PAPER`` is the paper's
fragment program: the ray starts at the eye, its direction computed in fp32 (:func:`paper_ray`), the
textures hold planes and gradients computed in fp32 in the mesh's own frame, ``lambda'`` is taken as
computed (no clamping to the entry's ``lambda``), and a ray the walk cannot resolve is lost: what it
composited so far goes to the frame buffer and its status is :data:`STATUS_LOST` (counted; no
redo). Ray start: the front-facing boundary faces were rasterised on the host
side (:mod:`warpvol.raycasting.harc`) into per-pixel fragment lists sorted by depth; pass ``k`` takes the
first fragment beyond the ray's last exit -- the depth-peeling test "depth greater than the last
layer's" -- so pass 0 is the plain boundary rasterisation and passes >= 1 are peel layers.

Integration of a segment ``(sf, sb, l)`` (``INTEG_*``, :mod:`warpvol.kernels.harc_integ`): the exact
piecewise-linear integral (:func:`warpvol.kernels.integrate.integrate_segment`, the ceiling), full pre-integration (3D table
through the 3D texture unit, premultiplied ``(C, alpha)``), or partial pre-integration (Moreland &
Angel: ``psi`` table through the 2D texture unit) with the iso-crossing splits of Fig. 6 (iso table,
nearest lookups, the ``next_s_iso`` rule). Front-to-back compositing
``(R,G,B,A) += (1 - A)(r,g,b,a)`` in fp32 registers inside the loop; the pass result is written to
the frame buffer in its number format (:func:`warpvol.kernels.formats.fmt_quantize`).

Counters per row block (``counters[chunk, k]``): 0 entries, 1 fragment-program steps (iso sub-steps
included), 2 cells visited, 3 failed rays, 4 rays stopped by the step bound, 5 iso crossings the
iso table missed (checked against the TF's control points; diagnostic), 6 texture fetches, 7 entries
whose rasterised face the consistent edge test rejected (searched among the face's surface neighbours on a
first entry, over the lists of the pixel and its 8 neighbours on a re-entry), 8 failed
rays of the consistent walk with exact segments that crossed a layer too thin for float32 segment
lengths (:func:`warpvol.kernels.walk.thin_unresolved`; redone in float64 like every failed ray),
9 rays of the paper's set-up that took a step with ``lambda' < lambda`` (an exit chosen by rounding:
the ray is suspect, its pixel possibly wrong; counted, not changed), 10 entries through a face the
rasterised lists left out, found by the exact test of the faces whose open edge passes within 1/64
pixel of the pixel centre (``edge_start`` / ``edge_bf``, :func:`warpvol.shared.thin_cells.edge_pixels`),
11 rays ended by early ray termination (``1 - A`` below ``t_stop``), 12 rays handed to the float64 redo
because the ray starts inside the mesh's bounding sphere (``t_clip > 0``: a perspective eye or orthographic eye
plane there, where a rasterised entry cannot tell rays that begin inside a cell).
"""

import threading

import warp as wp

from .cellwalk import (  # noqa: F401 (MeshTex, cell_texel, plane_exit: re-exported)
    CellMesh,
    MeshTex,
    RayCamera,
    Segments,
    WalkOpts,
    camera_ray,
    cell_texel,
    grad_scalar,
    make_walk,
    plane_exit,
    plane_lambda,
    plane_of,
    put_segment,
)
from .formats import NumFmt, fmt_quantize
from .harc_integ import INTEG_EXACT, Integ, integrate_sub, segment, segments_kernel  # noqa: F401 (re-exported)
from .harc_walk import composite, nearest_in_rings, nearest_listed, ring_search  # noqa: F401 (composite: re-exported)
from .raycast import STATUS_ACTIVE, STATUS_DONE, STATUS_FAILED, depth_before
from .walk import Face, Ray, boundary_face, face_hit

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

WALK_PLANES = wp.constant(0)
WALK_PLUCKER = wp.constant(1)
SETUP_ROBUST = wp.constant(0)
SETUP_PAPER = wp.constant(1)
#: a ray the paper's set-up could not resolve (no exit face, no progress, the step bound): its
#: partial result is in the frame buffer, later peel passes skip it
STATUS_LOST = wp.constant(3)


@wp.struct
class FragLists:
    """The rasterised ray start (:mod:`warpvol.raycasting.harc`): per pixel the depth-sorted front boundary
    faces (``frag_start``, ``frag_bf``), each face's cell, local face, surface neighbours and depth bounds, per
    pixel the bound ``far`` beyond which no re-entry search finds a face, and the faces whose open edge passes
    near the pixel centre (``edge_start``, ``edge_bf``)."""

    frag_start: wp.array(dtype=wp.int32)
    frag_bf: wp.array(dtype=wp.int32)
    bf_tet: wp.array(dtype=wp.int32)
    bf_face: wp.array(dtype=wp.int32)
    bf_nbr: wp.array(dtype=wp.vec3i)
    far: wp.array(dtype=float)
    bf_depth: wp.array(dtype=wp.vec2)
    edge_start: wp.array(dtype=wp.int32)
    edge_bf: wp.array(dtype=wp.int32)


@wp.func
def paper_ray(px: int, py: int, width: int, height: int, eye: wp.vec3, fwd: wp.vec3d, right: wp.vec3d,
              up: wp.vec3d, ortho: int, half_h: wp.float64, aspect: wp.float64):
    """The paper's ray through the centre of pixel (row py, column px), all in fp32: origin the eye
    ``eye`` (orthographic: the eye plane's point), unit direction from the camera frame (cast to
    fp32); returns ``(o, d)`` in the textures' frame."""
    f = wp.vec3(float(fwd[0]), float(fwd[1]), float(fwd[2]))
    rt = wp.vec3(float(right[0]), float(right[1]), float(right[2]))
    u = wp.vec3(float(up[0]), float(up[1]), float(up[2]))
    hh = float(half_h)
    qx = 2.0 * (float(px) + 0.5) / float(width) - 1.0
    qy = 1.0 - 2.0 * (float(py) + 0.5) / float(height)
    sx = qx * hh * float(aspect)
    sy = qy * hh
    o = eye
    d = f
    if ortho == 1:
        o = eye + rt * sx + u * sy
    else:
        d = wp.normalize(f + rt * sx + u * sy)
    return o, d


@wp.func
def no_face_around(px: int, py: int, width: int, height: int, frag_start: wp.array(dtype=wp.int32),
                   edge_start: wp.array(dtype=wp.int32)) -> bool:
    """Whether no front face is listed at pixel (px, py), at its 8 neighbours or among its open-edge faces: then
    no entry search of the pixel (its list, its neighbours', the rings of a face listed there, its open-edge
    faces) has a face to test."""
    idx = py * width + px
    if edge_start[idx] < edge_start[idx + 1]:
        return False
    y0 = wp.max(py - 1, 0)
    y1 = wp.min(py + 1, height - 1)
    x0 = wp.max(px - 1, 0)
    x1 = wp.min(px + 1, width - 1)
    for y in range(y0, y1 + 1):
        if frag_start[y * width + x0] < frag_start[y * width + x1 + 1]:
            return False
    return True


@wp.func
def no_entry_status(idx: int, t_clip: float, status: wp.array(dtype=wp.int32), counters: wp.array2d(dtype=wp.int32),
                    chunk: int):
    """The status of active pixel ``idx`` whose ray has :func:`no_face_around` (the entry search finds no entry):
    done, or failed (counted) when its ray is clipped (``t_clip > 0``: an eye inside the mesh is traced in
    float64, as when a search finds no entry)."""
    if t_clip > 0.0:
        status[idx] = STATUS_FAILED
        wp.atomic_add(counters, chunk, 3, 1)
        wp.atomic_add(counters, chunk, 12, 1)
    else:
        status[idx] = STATUS_DONE


@wp.func
def plucker_start(idx: int, cam: RayCamera, mesh: CellMesh, lists: FragLists, opts: WalkOpts,
                  tcur: wp.array(dtype=float), status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32),
                  counters: wp.array2d(dtype=wp.int32), chunk: int):
    """The ray start of the consistent walk (``WALK_PLUCKER``, robust set-up) for active pixel ``idx``: its float64
    ray, the first rasterised front boundary face it crosses beyond ``tcur[idx]`` (the peel test), found by the
    consistent edge test (see the module docstring: the faces around a rejected one, the 8 neighbours' lists, the
    open-edge faces), counted. Returns ``(ray, t_clip, cell, local face, Face, t, scalar)``; ``cell`` -1: no walk
    (the ray's status is written: done, or failed for the float64 redo). Used by :func:`make_march`'s kernel and
    by the lane march (:mod:`warpvol.kernels.harc_lanes`)."""
    py = idx // cam.width
    px = idx - py * cam.width
    r, t_clip, t_end = camera_ray(px, py, cam)
    if t_end < t_clip:
        status[idx] = STATUS_DONE
        return r, t_clip, -1, -1, Face(), 0.0, 0.0
    t_start = tcur[idx]
    prev = last[idx]
    if no_face_around(px, py, cam.width, cam.height, lists.frag_start, lists.edge_start):
        no_entry_status(idx, t_clip, status, counters, chunk)
        return r, t_clip, -1, -1, Face(), 0.0, 0.0

    # ---- ray start: the first rasterised front boundary face beyond the last exit (peel test) ----
    cell = int(-1)
    face_in = int(-1)
    t_in = float(0.0)
    s_in = float(0.0)
    fc = Face()
    entry_failed = int(0)
    rescan = int(0)
    rejected = int(-1)
    edge_entry = int(0)
    for it in range(lists.frag_start[idx], lists.frag_start[idx + 1]):
        b = int(lists.frag_bf[it])
        c = int(lists.bf_tet[b])
        f = int(lists.bf_face[b])
        if c == prev:
            continue
        cand = boundary_face(mesh.tets[c], f, mesh.verts, r)
        ok, t, s = face_hit(cand)
        if not ok:
            # the rasteriser's snapped coverage and the edge test disagree (pixel centre within
            # 1/256 pixel of a projected edge): the ray crosses a face around this one, found
            # among its edge neighbours and theirs on the front boundary
            wp.atomic_add(counters, chunk, 7, 1)
            if prev >= 0:
                # a re-entry (peel pass): at a crack the faces around belong to other cells,
                # whose surface neighbours do not reach the crossed face; the exact face test over
                # the lists of this pixel and its 8 neighbours and the rejected face's rings decides
                # (below)
                rescan = 1
                rejected = b
            else:
                b2, ok, t, s = ring_search(b, lists.bf_tet, lists.bf_face, lists.bf_nbr, mesh.tets, mesh.verts, r)
                if ok:
                    c = int(lists.bf_tet[b2])
                    f = int(lists.bf_face[b2])
                    cand = boundary_face(mesh.tets[c], f, mesh.verts, r)
        if ok:
            if t > t_start - opts.t_tol and c != prev:
                cell = c
                face_in = f
                t_in = wp.max(t, t_start)
                s_in = s
                fc = cand
                break
        else:
            if rescan == 0:
                entry_failed = 1  # no face around crosses either: resolved in float64 on the host
            break
    # faces wholly before the search's start are left untested (their crossings lie before it)
    z_lo = depth_before(r, wp.vec3(float(cam.fwd[0]), float(cam.fwd[1]), float(cam.fwd[2])), t_start - opts.t_tol,
                        float(cam.radius))
    if cell < 0 and entry_failed == 0:
        # no face of this pixel's list is crossed beyond the last exit: where the snapped coverage of a
        # layer leaves a hole at the pixel centre (an inner silhouette within 1/256 pixel) the crossed
        # face is listed at a neighbouring pixel; the exact (consistent) face test over the 8
        # neighbours' lists finds it
        for nb in range(9):
            qx = px + (nb % 3) - 1
            qy = py + (nb // 3) - 1
            # (this pixel's own list too after a rejected face: its later faces were not tested)
            q = qy * cam.width + qx
            if (nb != 4 or rescan == 1) and qx >= 0 and qy >= 0 and qx < cam.width and qy < cam.height and \
                    lists.frag_start[q] < lists.frag_start[q + 1]:  # (an empty list: no call)
                cell, face_in, t_in, s_in, fc = nearest_listed(
                    lists.frag_start[q], lists.frag_start[q + 1], lists.frag_bf, lists.bf_tet, lists.bf_face, lists.bf_depth, z_lo, mesh.tets, mesh.verts, r,
                    prev, t_start, opts.t_tol, cell, face_in, t_in, s_in, fc)
        if rejected >= 0:
            # a sliver beside the rejected face (the boundary of the visible cells has many) may be listed
            # at no pixel around: its surface rings
            cell, face_in, t_in, s_in, fc = nearest_in_rings(
                rejected, lists.bf_tet, lists.bf_face, lists.bf_nbr, mesh.tets, mesh.verts, r, prev, t_start, opts.t_tol, cell, face_in, t_in,
                s_in, fc)
    if entry_failed == 0 and lists.edge_start[idx] < lists.edge_start[idx + 1]:
        # the faces whose open edge (silhouette, outline of a part) passes within 1/64 pixel of the centre,
        # tested exactly: the snapped coverage can leave such a face out with a deeper layer (or nothing)
        # listed in its place -- a cell smaller than the snapping, a face seen edge-on
        c0 = cell
        t0 = t_in
        cell, face_in, t_in, s_in, fc = nearest_listed(
            lists.edge_start[idx], lists.edge_start[idx + 1], lists.edge_bf, lists.bf_tet, lists.bf_face, lists.bf_depth, z_lo, mesh.tets, mesh.verts, r,
            prev, t_start, opts.t_tol, cell, face_in, t_in, s_in, fc)
        if cell != c0 or t_in != t0:
            edge_entry = 1
    if entry_failed == 1 or t_clip > 0.0:
        status[idx] = STATUS_FAILED
        wp.atomic_add(counters, chunk, 3, 1)
        if t_clip > 0.0:
            wp.atomic_add(counters, chunk, 12, 1)
        return r, t_clip, -1, -1, Face(), 0.0, 0.0
    if cell < 0:
        status[idx] = STATUS_DONE
        return r, t_clip, -1, -1, Face(), 0.0, 0.0
    wp.atomic_add(counters, chunk, 0, 1)
    if edge_entry == 1:
        wp.atomic_add(counters, chunk, 10, 1)
    return r, t_clip, cell, face_in, fc, t_in, s_in


#: the kernels' module options (``fuse_fp`` off: no contraction into fused multiply-adds, the arithmetic as written)
MARCH_OPTIONS = {"enable_backward": False, "fuse_fp": False}


def make_march(walk: int, setup: int, mode: int, segs: bool = False):
    """The march kernel of one configuration: ``walk`` (:data:`WALK_PLANES` | :data:`WALK_PLUCKER`),
    ``setup`` (:data:`SETUP_ROBUST` | :data:`SETUP_PAPER`) and integration ``mode`` (``INTEG_*``, the mode
    of the :class:`Integ` it is launched with) are fixed when the kernel is generated (``wp.static``
    conditions), so the code of the other walks, set-ups and integrations is not in it. Every configuration
    walks in the shared walk of :func:`warpvol.kernels.cellwalk.make_walk` with these options. Each
    configuration is a module of its own (compiled on its first launch); use :func:`march_kernel`.

    One thread per active ray (pixels ``first ..``, or ``ids[first ..]`` when a list of the active rays'
    pixels is given: a re-entry pass): ray set-up, the ray start (entry search), the walk, the
    pass's result to the frame buffer in its number format, the counters (see the module docstring) and
    ``px_work`` (the pixel's cells visited and fragment-program steps in this pass). ``segs`` (the consistent walk
    with exact segments only): each entry also writes its segment (front and back ray parameter, its own colour
    and transmittance) to the :class:`~warpvol.kernels.cellwalk.Segments` it is launched with, as ``raycast``'s
    march does; without it the kernel ignores that argument."""
    planes = walk == WALK_PLANES
    paper = setup == SETUP_PAPER
    exact = mode == INTEG_EXACT
    if paper and not planes:
        raise ValueError("make_march: the paper's set-up walks the face planes (walk = WALK_PLANES)")
    # the consistent walk with exact segments (and its checks) carries (rgb, transmittance) as raycast does; the
    # other walks composite RGBA "under" (the paper's Fig. 6)
    fused = (not planes) and exact
    if segs and not fused:
        raise ValueError("make_march: segments are kept by the consistent walk with exact segments only")

    walk_cells = make_walk(planes, paper, mode, segs=segs, clip=False)  # (a ray starting inside the sphere is failed first)

    @wp.func
    def ray_done(idx: int, r: Ray, acc: wp.vec4, own: wp.vec4, t_front: float, t_in: float, cell: int, steps: int,
                 cells_visited: int, failed: int, exited: int, thin: int, backward: int, fb: NumFmt, opts: WalkOpts,
                 far: wp.array(dtype=float), rgba: wp.array(dtype=wp.vec4), tcur: wp.array(dtype=float),
                 status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32), counters: wp.array2d(dtype=wp.int32),
                 chunk: int, px_work: wp.array(dtype=wp.vec2i), sg: Segments):
        """The write-back of pixel ``idx``'s walked entry (``acc`` as the walk carries it: ``(rgb, tr)`` for the
        exact Plücker walk, ``RGBA`` otherwise; ``t_front`` the entry's ray parameter, the rest the walk's results):
        the counters, ``px_work``, status (failed: the float64 redo; lost; done), the pass's result in the frame
        buffer's format, ray parameter and cell, and (``segs``) the segment. ``far``: the lists' re-entry bound."""
        tr_left = float(0.0)  # the transmittance left (the early-termination test's, as the walk computed it)
        if wp.static(fused):
            tr_left = acc[3]
            acc = wp.vec4(acc[0], acc[1], acc[2], 1.0 - acc[3])
        else:
            tr_left = 1.0 - acc[3]
        wp.atomic_add(counters, chunk, 1, steps)
        wp.atomic_add(counters, chunk, 2, cells_visited)
        px_work[idx] = wp.vec2i(cells_visited, steps)  # this pixel's loop work in this pass (one thread per pixel)
        if wp.static(paper):
            if backward == 1:
                wp.atomic_add(counters, chunk, 9, 1)
            if failed == 1:
                # lost: the fragment program ends, its partial result goes to the frame buffer
                rgba[idx] = wp.vec4(fmt_quantize(fb, acc[0]), fmt_quantize(fb, acc[1]), fmt_quantize(fb, acc[2]),
                                    fmt_quantize(fb, acc[3]))
                status[idx] = STATUS_LOST
                wp.atomic_add(counters, chunk, 3, 1)
                return
        if failed == 1:
            status[idx] = STATUS_FAILED
            wp.atomic_add(counters, chunk, 3, 1)
            if thin == 1:
                wp.atomic_add(counters, chunk, 8, 1)
            return
        if wp.static(segs):
            put_segment(sg, idx, t_front, t_in, own)
        # the pass's result goes to the frame buffer in its number format
        rgba[idx] = wp.vec4(fmt_quantize(fb, acc[0]), fmt_quantize(fb, acc[1]), fmt_quantize(fb, acc[2]),
                            fmt_quantize(fb, acc[3]))
        tcur[idx] = t_in
        last[idx] = cell
        if wp.static((not planes) and (not paper)):
            # every face a re-entry search can reach (this pixel's list, its neighbours' lists, their surface
            # rings) lies within `far` of the eye (host bound with a rounding margin): a ray leaving the mesh
            # beyond it cannot re-enter, so it is done now and no further pass launches it
            if exited == 1 and t_in + wp.dot(r.back, r.d) > far[idx]:
                status[idx] = STATUS_DONE
        if exited == 0:
            status[idx] = STATUS_DONE
            if tr_left >= opts.t_stop:
                wp.atomic_add(counters, chunk, 4, 1)
                if wp.static(paper):
                    status[idx] = STATUS_LOST  # the step bound ended it inside the mesh
            else:
                wp.atomic_add(counters, chunk, 11, 1)  # early ray termination: 1 - A below t_stop

    @wp.kernel(module="unique", module_options=MARCH_OPTIONS)
    def harc_march(
        cam: RayCamera,
        eye_w: wp.vec3,
        mt: MeshTex,
        mesh: CellMesh,
        lists: FragLists,
        ig: Integ,
        fb: NumFmt,
        opts: WalkOpts,
        first: int,
        ids: wp.array(dtype=wp.int32),
        rgba: wp.array(dtype=wp.vec4),
        tcur: wp.array(dtype=float),
        status: wp.array(dtype=wp.int32),
        last: wp.array(dtype=wp.int32),
        counters: wp.array2d(dtype=wp.int32),
        chunk: int,
        px_work: wp.array(dtype=wp.vec2i),
        sg: Segments,
    ):
        tid = wp.tid()
        idx = first + tid  # the pixels first .. (all rays of the image active)
        if ids.shape[0] > 0:
            idx = ids[first + tid]  # the active rays' pixels ids[first ..] (a re-entry pass)
        if status[idx] != STATUS_ACTIVE:
            return
        if wp.static(not planes):
            r, t_clip, cell, face_in, fc, t_in, s_in = plucker_start(idx, cam, mesh, lists, opts, tcur, status, last,
                                                                     counters, chunk)
            if cell < 0:
                return  # (the ray's status is written)
            o = r.o
            d = r.d
        else:
            py = idx // cam.width
            px = idx - py * cam.width
            r, t_clip, t_end = camera_ray(px, py, cam)
            o = r.o
            d = r.d
            if wp.static(paper):
                # the paper's fragment program: the ray from the eye in fp32, nothing clipped or culled
                o, d = paper_ray(px, py, cam.width, cam.height, eye_w, cam.fwd, cam.right, cam.up, cam.ortho, cam.half_h,
                                  cam.aspect)
                t_clip = 0.0
            else:
                if t_end < t_clip:
                    status[idx] = STATUS_DONE
                    return
            t_start = tcur[idx]
            prev = last[idx]
            if no_face_around(px, py, cam.width, cam.height, lists.frag_start, lists.edge_start):
                no_entry_status(idx, t_clip, status, counters, chunk)
                return

            # ---- ray start: the first rasterised front boundary face beyond the last exit (peel test) ----
            cell = int(-1)
            face_in = int(-1)
            t_in = float(0.0)
            s_in = float(0.0)
            fc = Face()
            entry_failed = int(0)
            for it in range(lists.frag_start[idx], lists.frag_start[idx + 1]):
                b = int(lists.frag_bf[it])
                c = int(lists.bf_tet[b])
                f = int(lists.bf_face[b])
                if c == prev:
                    continue
                p = plane_of(mt, c, f)
                lam = plane_lambda(p, o, d)
                if wp.static(paper):
                    if not wp.isfinite(lam):
                        entry_failed = 1  # the entry face's plane gives no ray parameter: the ray is lost
                        break
                if lam > t_start - opts.t_tol:
                    cell = c
                    face_in = f
                    t_in = wp.max(lam, t_start)
                    s_in = grad_scalar(cell_texel(mt, mt.grad, c), o + d * t_in)
                    break
            if wp.static(paper):
                if entry_failed == 1:
                    status[idx] = STATUS_LOST
                    wp.atomic_add(counters, chunk, 3, 1)
                    return
            if entry_failed == 1 or t_clip > 0.0:
                status[idx] = STATUS_FAILED
                wp.atomic_add(counters, chunk, 3, 1)
                if t_clip > 0.0:
                    wp.atomic_add(counters, chunk, 12, 1)
                return
            if cell < 0:
                status[idx] = STATUS_DONE
                return
            wp.atomic_add(counters, chunk, 0, 1)

        # ---- propagation: one cell per fragment-program step (Fig. 6), the shared walk ----
        acc = rgba[idx]
        if wp.static(fused):
            acc = wp.vec4(acc[0], acc[1], acc[2], 1.0 - acc[3])  # the exact Plücker walk carries (rgb, tr)
        t_front = t_in  # the entry's ray parameter (its segment's front)
        acc, t_in, cell, steps, cells_visited, failed, exited, thin, backward, fetches, own = walk_cells(
            cell, face_in, fc, t_in, s_in, acc, r, o, d, t_clip, float(cam.radius), mesh, mt, ig, opts, counters,
            chunk)
        if wp.static(not fused):
            wp.atomic_add(counters, chunk, 6, fetches)
        ray_done(idx, r, acc, own, t_front, t_in, cell, steps, cells_visited, failed, exited, thin, backward, fb, opts,
                 lists.far, rgba, tcur, status, last, counters, chunk, px_work, sg)

    harc_march.ray_done = ray_done  # (for the lane march of warpvol.kernels.harc_lanes)
    return harc_march


_MARCH: dict = {}
_MARCH_LOCK = threading.Lock()


def march_kernel(walk: int, setup: int, mode: int, segs: bool = False):
    """The :func:`make_march` kernel of ``(walk, setup, mode, segs)``, made once per configuration."""
    key = (int(walk), int(setup), int(mode), bool(segs))
    with _MARCH_LOCK:
        if key not in _MARCH:
            _MARCH[key] = make_march(*key)
        return _MARCH[key]


@wp.kernel
def init_state(rgba: wp.array(dtype=wp.vec4), tcur: wp.array(dtype=float), status: wp.array(dtype=wp.int32),
               last: wp.array(dtype=wp.int32)):
    i = wp.tid()
    rgba[i] = wp.vec4(0.0, 0.0, 0.0, 0.0)
    tcur[i] = 0.0
    status[i] = STATUS_ACTIVE
    last[i] = -1
