"""Ray propagation through cell adjacency (HARC-style ray caster, float32), consistent by construction.

One thread per pixel; the walk is the one cell walk of :func:`warpvol.kernels.cellwalk.make_walk` (exact
Plücker configuration), shared with HARC, on the building blocks of :mod:`warpvol.kernels.walk` (float64 ray
set-up, Plücker edge tests, face crossings, one step through a tet, the thin-layer check).

An entry (``march_ray`` in :func:`make_march`) finds the ray's next entry among the front-facing boundary faces binned
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

A pass (the kernel of :func:`march_kernel`) makes a ray's entries one after the other in its thread: after the walk leaves
the (visible) mesh it searches the next entry beyond the exit and walks on, up to ``reentries`` times.
Per-pixel state (radiance, transmittance, ray parameter, status) lives in device arrays so passes
can be separate launches; a pass launches one thread per active ray: pixels ``first ..`` while every
ray is active, else the pixels ``ids[first ..]`` of the rays still active (a list made by the host).
``counters[chunk]`` (first entries, steps, unfinished, failed, left active, failed on a thin layer, terminated
early, re-entries) has one row per concurrently launched block. Inputs travel as structs
(:class:`~warpvol.kernels.cellwalk.RayCamera`, :class:`~warpvol.kernels.cellwalk.CellMesh`, :class:`EntryBins`,
the TF as an :class:`~warpvol.kernels.harc_integ.Integ`, :class:`~warpvol.kernels.cellwalk.WalkOpts`); with
``segs`` each entry's segment goes to a :class:`~warpvol.kernels.cellwalk.Segments`.
"""

import threading

import warp as wp

from .cellwalk import CellMesh, MeshTex, RayCamera, Segments, WalkOpts, camera_ray, make_walk, put_segment
from .harc_integ import INTEG_EXACT, Integ
from .walk import Face, Ray, boundary_face, face_hit

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

STATUS_ACTIVE = wp.constant(1)
STATUS_DONE = wp.constant(0)
STATUS_FAILED = wp.constant(2)
#: consecutive re-entries without progress in ``t`` (cracks, touching pieces) before a ray counts as
#: unresolved
MAX_FLAT_REENTRIES = wp.constant(8)


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


@wp.struct
class EntryBins:
    """The front boundary faces binned to screen tiles (:mod:`warpvol.raycasting.stages.entry_bins`): each
    face's cell and local face, its grown projected pixel box (4 ints), the tiles' item ranges and items (face
    indices sorted by nearest depth), each item's depth bounds, the tile size and tiles per row."""

    bface_tet: wp.array(dtype=wp.int32)
    bface_local: wp.array(dtype=wp.int32)
    bface_box: wp.array(dtype=wp.int32)
    tile_start: wp.array(dtype=wp.int32)
    tile_items: wp.array(dtype=wp.int32)
    item_depth: wp.array(dtype=wp.vec3)
    tile: int
    tiles_x: int


@wp.func
def tile_entry(px: int, py: int, t_start: float, prev: int, r: Ray, t_tol: float, fwd: wp.vec3, scale: float,
               mesh: CellMesh, bins: EntryBins):
    """The ray's next entry: the nearest boundary face of pixel (px, py)'s screen tile that the ray crosses
    (entering) beyond ``t_start``. A face up to ``t_tol`` before ``t_start`` counts (a crack left by a
    dropped sliver, touching pieces: the exit and the re-entry are at the same depth up to rounding),
    except faces of the cell ``prev`` just left (a tet is convex: a ray never re-enters it). Of faces
    crossed at the same ``t`` the one listed first in the bins (lowest face index) wins.

    The tile's faces come sorted by nearest depth along the view direction ``fwd`` with their depth
    bounds (``item_depth``: nearest, farthest, farthest of the tile's faces from this one on;
    :func:`warpvol.shared.entry_bins.item_depths`). The ray's depth grows linearly with ``t``,
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
    tile_id = (py // bins.tile) * bins.tiles_x + (px // bins.tile)
    for it in range(bins.tile_start[tile_id], bins.tile_start[tile_id + 1]):
        if cull:
            zr = bins.item_depth[it]
            if zr[0] > z_best:
                # this face and every later one lie beyond the best crossing; they are crossed before depth zr[2]
                t_far = (zr[2] - zo) / cz
                far_t = wp.max(far_t, t_far + depth_slack(zo, cz, t_far, scale) / cz)
                break
            if zr[1] < z_lo:
                continue  # wholly before the search's start: crossed, if at all, before t_start - t_tol
        bf = bins.tile_items[it]
        if px < bins.bface_box[4 * bf] or py < bins.bface_box[4 * bf + 1] or px > bins.bface_box[4 * bf + 2] \
                or py > bins.bface_box[4 * bf + 3]:
            continue  # the pixel lies outside the face's grown projected box (as tiles are binned)
        c = int(bins.bface_tet[bf])
        f = int(bins.bface_local[bf])
        cand = boundary_face(mesh.tets[c], f, mesh.verts, r)
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
def ray_entry(idx: int, cam: RayCamera, mesh: CellMesh, bins: EntryBins, opts: WalkOpts, tcur: wp.array(dtype=float),
              status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32), counters: wp.array2d(dtype=wp.int32),
              chunk: int, entry_col: int):
    """Pixel ``idx``'s next entry beyond ``tcur[idx]`` (:func:`tile_entry`), as a pass makes it (``march_ray`` of
    :func:`make_march` and the lane march's): ``(ray, t_clip, t_end, cell, local face, Face, t, scalar, far_t,
    flat re-entries)``; ``cell`` -1: no walk, the ray's status is written (done: no entry; failed: re-entering
    without progress). An entry made is counted in ``counters[chunk, entry_col]``."""
    st = status[idx]
    r = Ray()
    t_clip = float(0.0)
    t_end = float(0.0)
    if (st & 3) != STATUS_ACTIVE:
        return r, t_clip, t_end, -1, -1, Face(), 0.0, 0.0, 0.0, 0
    py = idx // cam.width
    px = idx - py * cam.width
    r, t_clip, t_end = camera_ray(px, py, cam)
    if t_end < t_clip:
        status[idx] = STATUS_DONE  # the ray misses the mesh's bounding sphere
        return r, t_clip, t_end, -1, -1, Face(), 0.0, 0.0, 0.0, 0
    t_start = tcur[idx]
    # ---- next entry: nearest boundary face crossed (entering) beyond t_start in this tile ----
    fwd32 = wp.vec3(float(cam.fwd[0]), float(cam.fwd[1]), float(cam.fwd[2]))
    cell, face_in, fc, best_t, best_s, far_t = tile_entry(px, py, t_start, last[idx], r, opts.t_tol, fwd32,
                                                          float(cam.radius), mesh, bins)
    flat = st >> 2
    if cell >= 0 and best_t <= t_start:
        flat += 1
        best_t = t_start
    if cell < 0:
        status[idx] = STATUS_DONE
    elif flat > MAX_FLAT_REENTRIES:
        status[idx] = STATUS_FAILED  # re-entering without progress: unresolved, redone in float64
        wp.atomic_add(counters, chunk, 3, 1)
        cell = -1
    else:
        wp.atomic_add(counters, chunk, entry_col, 1)  # entries made in this pass
    return r, t_clip, t_end, cell, face_in, fc, best_t, best_s, far_t, flat


#: the march kernels' module options (``fuse_fp`` off: no contraction into fused multiply-adds, the arithmetic as
#: written)
MARCH_OPTIONS = {"enable_backward": False, "fuse_fp": False}


def make_march(segs: bool = False):
    """The pass kernel :func:`march` (one ray per thread) on the exact Plücker walk of
    :func:`~warpvol.kernels.cellwalk.make_walk`; with ``segs`` each entry also writes its segment (front and
    back ray parameter, its own colour and transmittance) to the :class:`~warpvol.kernels.cellwalk.Segments`
    it is launched with. A module of its own per configuration; use :func:`march_kernel`."""
    walk = make_walk(False, False, INTEG_EXACT, segs)

    @wp.func
    def ray_done(idx: int, acc: wp.vec4, t_in: float, cell: int, cells: int, failed: int, exited: int, thin: int,
                 own: wp.vec4, best_t: float, t_clip: float, t_end: float, far_t: float, flat: int, opts: WalkOpts,
                 st_rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float), tcur: wp.array(dtype=float),
                 status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32), counters: wp.array2d(dtype=wp.int32),
                 chunk: int, sg: Segments):
        """The write-back of a walked entry of pixel ``idx`` (``march_ray``'s and the lane march's): colour and
        transmittance ``acc``, ray parameter, cell and status (failed: redone in float64; done: stopped, or no
        further entry possible), the counters (steps, failed, thin, stopped), and (``segs``) its segment."""
        tr = acc[3]
        wp.atomic_add(counters, chunk, 1, cells)
        if failed == 1:
            status[idx] = STATUS_FAILED
            wp.atomic_add(counters, chunk, 3, 1)
            if thin == 1:
                wp.atomic_add(counters, chunk, 5, 1)  # of which: a thin layer float32 cannot resolve
            return
        if wp.static(segs):
            put_segment(sg, idx, wp.max(best_t, t_clip), t_in, own)
        st_rgb[idx] = wp.vec3(acc[0], acc[1], acc[2])
        trans[idx] = tr
        tcur[idx] = t_in
        last[idx] = cell
        if t_in > best_t:
            flat = 0  # the walk advanced: only consecutive re-entries without progress count
        status[idx] = STATUS_ACTIVE + 4 * flat
        if exited == 0:
            status[idx] = STATUS_DONE
            if tr >= opts.t_stop:
                wp.atomic_add(counters, chunk, 2, 1)  # rays stopped by max_steps
            else:
                wp.atomic_add(counters, chunk, 6, 1)  # early ray termination: transmittance below t_stop
        elif t_in >= t_end:
            status[idx] = STATUS_DONE  # left the bounding sphere: no further entry possible
        elif not (far_t > t_in - opts.t_tol):
            # the next search would test these faces (or faces bounded in depth before t_in) with the same
            # float32 numbers and find none beyond t_in - t_tol (it also skips the cell just left): skip it
            status[idx] = STATUS_DONE

    @wp.func
    def march_ray(idx: int, cam: RayCamera, mesh: CellMesh, bins: EntryBins, ig: Integ, opts: WalkOpts,
                  st_rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float), tcur: wp.array(dtype=float),
                  status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32), counters: wp.array2d(dtype=wp.int32),
                  chunk: int, entry_col: int, sg: Segments):
        """One entry of pixel ``idx``'s ray: the search for its next entry beyond ``tcur[idx]``, the walk from
        there to where it leaves the (visible) mesh, the state written back (see :func:`march`). The entry is
        counted in ``counters[chunk, entry_col]``."""
        r, t_clip, t_end, cell, face_in, fc, best_t, best_s, far_t, flat = ray_entry(
            idx, cam, mesh, bins, opts, tcur, status, last, counters, chunk, entry_col)
        if cell < 0:
            return  # (the ray's status is written)

        # ---- walk through the cell adjacency ----
        c = st_rgb[idx]
        acc, t_in, cell, steps, cells, failed, exited, thin, backward, fetches, own = walk(
            cell, face_in, fc, best_t, best_s, wp.vec4(c[0], c[1], c[2], trans[idx]), r, r.o, r.d, t_clip,
            float(cam.radius), mesh, MeshTex(), ig, opts, counters, chunk)
        ray_done(idx, acc, t_in, cell, cells, failed, exited, thin, own, best_t, t_clip, t_end, far_t, flat, opts, st_rgb,
                 trans, tcur, status, last, counters, chunk, sg)

    @wp.kernel(module="unique", module_options=MARCH_OPTIONS)
    def march(cam: RayCamera, mesh: CellMesh, bins: EntryBins, ig: Integ, opts: WalkOpts, first: int,
              ids: wp.array(dtype=wp.int32), rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float),
              tcur: wp.array(dtype=float), status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32),
              reentries: int, counters: wp.array2d(dtype=wp.int32), chunk: int, sg: Segments):
        """A pass: one thread per ray (pixels ``first ..``, or ``ids[first ..]``), each entering and walking
        (``march_ray``) and then re-entering in the same thread, up to ``reentries`` times, while its ray
        may enter again (``STATUS_ACTIVE``): the same walk as one entry per pass, without a pass per
        re-entry. Counts first entries in ``counters[chunk, 0]``, re-entries in ``counters[chunk, 7]`` and
        the rays still active at the end (a further pass must search them) in ``counters[chunk, 4]``."""
        tid = wp.tid()
        idx = first + tid  # the pixels first .. (all rays of the image active)
        if ids.shape[0] > 0:
            idx = ids[first + tid]  # the active rays' pixels ids[first ..] (a re-entry pass)
        py = idx // cam.width
        tile_id = (py // bins.tile) * bins.tiles_x + (idx - py * cam.width) // bins.tile
        if bins.tile_start[tile_id] == bins.tile_start[tile_id + 1]:
            # no entry face binned to the pixel's tile: the search finds none, the ray is done (as march_ray decides)
            if (status[idx] & 3) == STATUS_ACTIVE:
                status[idx] = STATUS_DONE
            return
        march_ray(idx, cam, mesh, bins, ig, opts, rgb, trans, tcur, status, last, counters, chunk, 0, sg)
        k = int(0)
        while k < reentries and (status[idx] & 3) == STATUS_ACTIVE:
            k += 1
            march_ray(idx, cam, mesh, bins, ig, opts, rgb, trans, tcur, status, last, counters, chunk, 7, sg)
        if (status[idx] & 3) == STATUS_ACTIVE:
            wp.atomic_add(counters, chunk, 4, 1)  # rays a further pass must search

    march.march_ray = march_ray  # (for the lane kernels of warpvol.kernels.lanes)
    march.ray_done = ray_done
    return march


_MARCH: dict = {}
_MARCH_LOCK = threading.Lock()


def march_kernel(segs: bool = False):
    """The :func:`make_march` kernel of ``segs``, made once per configuration."""
    key = bool(segs)
    with _MARCH_LOCK:
        if key not in _MARCH:
            _MARCH[key] = make_march(key)
        return _MARCH[key]


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
