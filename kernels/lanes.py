"""The pieces of ``raycast``'s march with ``LANES`` rays per thread (:mod:`warpvol.kernels.lanes_march`).

:func:`device_lanes` picks the lane count (16 on a CPU with AVX-512, 8 with AVX2, 1 on CUDA); a lane's walk
between steps is a :class:`LaneState`; :func:`lane_step` is one pass of the exact Plücker walk's loop of
:func:`warpvol.kernels.cellwalk.make_walk` (the same scalar functions, in the same order) for a lane whose step is
rare; :func:`make_lane_io` splits :func:`warpvol.kernels.raycast.make_march`'s ``march_ray`` around its walk;
:class:`FlatMesh` gives the lane loop the cell records and TF values as flat ``int32`` / ``float32`` arrays.
"""

import warp as wp

from .cellwalk import CellMesh, RayCamera, Segments, WalkOpts, add_under_tr, clipped_segment
from .harc_integ import Integ
from .integrate import exp_neg, flat_extinction, integrate_piece_flat, integrate_segment_tf
from .raycast import STATUS_ACTIVE, STATUS_DONE, EntryBins, march_kernel, ray_entry
from .tf import tf_eval, tf_eval_upper, tf_upper, tf_upper_from
from .walk import (
    STALL_STEPS,
    STEEP_ERR,
    Face,
    Ray,
    ThinPrev,
    grazing_unresolved,
    monotone_exit,
    next_face_from,
    scalar_error_if,
    scalar_step,
    thin_at_exit,
    thin_start,
    thin_step,
)

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


def device_lanes(device) -> int:
    """Rays per thread for ``device``: 1 on CUDA, 16 on a CPU with AVX-512, 8 with AVX2, else 4."""
    if str(device).startswith("cuda"):
        return 1
    flags = set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    flags = set(line.split(":", 1)[1].split())
                    break
    except OSError:
        pass
    if "avx512f" in flags:
        return 16
    if "avx2" in flags:
        return 8
    return 4


@wp.struct
class FlatMesh:
    """The cell records and the TF values as flat ``int32`` / ``float32`` arrays (views of
    :class:`~warpvol.kernels.cellwalk.CellMesh`'s and the TF's arrays): the lane loop loads them element by
    element (a ``vec4`` element load is an aggregate the compiler does not vectorise)."""

    verts: wp.array(dtype=float)
    tets: wp.array(dtype=wp.int32)
    nbr: wp.array(dtype=wp.int32)
    nbr_vertex: wp.array(dtype=wp.int32)
    tf_v: wp.array(dtype=float)


def flat_view(a, dtype):
    """``a`` (a contiguous array of 4-vectors) as a flat array of ``dtype`` on the same memory."""
    return wp.array(ptr=a.ptr, dtype=dtype, shape=(a.shape[0] * 4,), device=a.device)


def flat_mesh(mesh, tf_v):
    """:class:`FlatMesh` of a :class:`~warpvol.kernels.cellwalk.CellMesh` and the TF values ``tf_v`` (the caller
    keeps those alive)."""
    fm = FlatMesh()
    fm.verts = flat_view(mesh.verts, float)
    fm.tets = flat_view(mesh.tets, wp.int32)
    fm.nbr = flat_view(mesh.nbr, wp.int32)
    fm.nbr_vertex = flat_view(mesh.nbr_vertex, wp.int32)
    fm.tf_v = flat_view(tf_v, float)
    return fm


@wp.struct
class LaneState:
    """One ray's walk between steps, and what its entry left for the write-back."""

    idx: int
    walking: int
    cell: int
    gn: int
    fc: Face
    t_in: float
    s_in: float
    acc: wp.vec4
    own: wp.vec4
    cells: int
    stall: int
    failed: int
    exited: int
    thin: int
    k_in: int
    v_in: wp.vec4
    ds_in: float
    scal_err: float
    thin_mem: ThinPrev
    r: Ray
    t_clip: float
    t_end: float
    best_t: float
    far_t: float
    flat: int
    entered: int


@wp.func
def lane_step(ls: LaneState, scale: float, mesh: CellMesh, ig: Integ, opts: WalkOpts) -> LaneState:
    """One pass of :func:`~warpvol.kernels.cellwalk.make_walk`'s loop (the exact Plücker walk, clipped) for one
    lane; ``walking`` 0 once the walk has ended (as its ``break`` and loop bound)."""
    if ls.cells >= opts.max_steps or ls.failed != 0:
        ls.walking = 0
        return ls
    cell = ls.cell
    r = ls.r
    t_clip = ls.t_clip
    t_in = ls.t_in
    s_in = ls.s_in
    k_in = ls.k_in
    v_in = ls.v_in
    acc = ls.acc
    ls.cells = ls.cells + 1
    nrow = mesh.nbr[cell]
    vrow = mesh.nbr_vertex[cell]
    fc, f_out, t_out, s_out = next_face_from(mesh.tets[cell], ls.gn, ls.fc, mesh.verts, r)
    t_out, stall = monotone_exit(t_in, t_out, ls.stall)
    ls.stall = stall
    if f_out < 0 or stall > STALL_STEPS:
        ls.failed = 1
        ls.walking = 0
        return ls
    ls.fc = fc
    nb = nrow[f_out]
    k_out = tf_upper_from(s_out, k_in, ig.tf_s)
    v_out = tf_eval_upper(s_out, k_out, ig.tf_s, ig.tf_v)
    failed = int(0)
    if t_out > t_clip:
        tr = acc[3]
        ln = t_out - t_in
        seg = wp.vec4(0.0, 0.0, 0.0, 0.0)
        if t_in >= t_clip:
            if k_in == k_out:
                seg = integrate_piece_flat(ln, v_in, v_out, flat_extinction(k_in, ig.tf_v), ig.model)
            else:
                seg = integrate_segment_tf(s_in, s_out, v_in, v_out, ln, ig.tf_s, ig.tf_v, ig.model)
        else:
            ta, sa = clipped_segment(t_in, t_out, s_in, s_out, t_clip)
            ln = t_out - ta
            seg = integrate_segment_tf(sa, s_out, tf_eval(sa, ig.tf_s, ig.tf_v), v_out, ln, ig.tf_s, ig.tf_v,
                                       ig.model)
        thin, thin_mem = thin_step(ls.thin_mem, ln, seg[3], t_out, scale, tr, v_in, v_out, k_in, k_out, ig.tf_v,
                                   ig.model)
        ls.thin = thin
        ls.thin_mem = thin_mem
        ds_out = scalar_error_if(opts.scalar_check, fc, r)
        scal_err = scalar_step(ls.scal_err, tr, ln, seg[3], s_in, s_out, v_in, v_out, k_in, k_out, ls.ds_in, ds_out,
                               ig.tf_s, ig.tf_v, ig.model)
        ls.scal_err = scal_err
        if thin == 1 or scal_err > STEEP_ERR:
            failed = 1
        ls.ds_in = ds_out
        e = exp_neg(seg[3])
        acc = add_under_tr(acc, seg, e)
        ls.acc = acc
        ls.own = add_under_tr(ls.own, seg, e)
    if failed == 1:
        ls.failed = 1
        ls.walking = 0
        return ls
    ls.k_in = k_out
    ls.v_in = v_out
    ls.t_in = t_out
    ls.s_in = s_out
    if acc[3] < opts.t_stop:
        ls.walking = 0
        return ls
    if nb < 0:
        ls.exited = 1
        if thin_at_exit(ls.thin_mem):
            ls.failed = 1
            ls.thin = 1
        elif t_out > t_clip and grazing_unresolved(acc[3], v_out, ig.model, fc, r, t_out, scale):
            ls.failed = 1
        ls.walking = 0
        return ls
    ls.gn = vrow[f_out]
    ls.cell = nb >> 2
    return ls


@wp.func
def thin_prev(d: float, is_short: int, dmax: float, tr: float, u: float) -> ThinPrev:
    """:class:`~warpvol.kernels.walk.ThinPrev` of its fields (the lane kernel keeps them apart)."""
    p = ThinPrev()
    p.d = d
    p.is_short = is_short
    p.dmax = dmax
    p.tr = tr
    p.u = u
    return p


@wp.func
def lane_step_at(scratch: wp.array(dtype=LaneState), slot: int, scale: float, mesh: CellMesh, ig: Integ,
                 opts: WalkOpts):
    """:func:`lane_step` of the lane kept in ``scratch[slot]``, in place (the lane kernel keeps no
    :class:`LaneState` variable of its own: one assigned in its loops is copied on every pass)."""
    scratch[slot] = lane_step(scratch[slot], scale, mesh, ig, opts)


@wp.func
def lane_exit_at(scratch: wp.array(dtype=LaneState), slot: int, scale: float, model: int):
    """The end of :func:`lane_step` for the lane in ``scratch[slot]`` whose step (taken in the lane loop) left the
    mesh: ``exited``, and its checks (a thin layer at the exit, an exit through a face seen nearly edge-on)."""
    ls = scratch[slot]
    scratch[slot].exited = 1
    if thin_at_exit(ls.thin_mem):
        scratch[slot].failed = 1
        scratch[slot].thin = 1
    elif ls.t_in > ls.t_clip and grazing_unresolved(ls.acc[3], ls.v_in, model, ls.fc, ls.r, ls.t_in, scale):
        scratch[slot].failed = 1


#: rays per lane of a thread: a lane whose ray has ended takes the thread's next one (the lanes stay busy until the
#: thread's last rays)
LANE_RUNS = 8


def lane_threads(count: int, lanes: int) -> int:
    """Threads of a :func:`~warpvol.kernels.lanes_march.make_march_lanes` launch over ``count`` rays."""
    return (count + lanes * LANE_RUNS - 1) // (lanes * LANE_RUNS)


def lane_scratch(end: int, blocks: int, lanes: int) -> int:
    """Size of the ``scratch`` of :func:`~warpvol.kernels.lanes_march.make_march_lanes` launches over the rays ``first .. first + count`` up to
    ``end``, ``blocks`` launches (``chunk`` 0 .. blocks - 1): one :class:`~warpvol.kernels.lanes.LaneState` per
    lane, thread ``tid`` of a launch holding ``(first // (lanes LANE_RUNS) + tid + chunk) lanes ..`` (disjoint
    between launches of consecutive ray ranges)."""
    return (end // (lanes * LANE_RUNS) + blocks + 1) * lanes


#: the lane kernels' module options: no FMA contraction (the scalar functions' roundings); loops unrolled at most
#: once, so that the lane loops stay loops LLVM vectorises; the host CPU's features with 512-bit vectors preferred
#: (LLVM's default for these CPUs is 256: 8 lanes of a loop per instruction instead of 16; about 8-10 % of the lane
#: march on dense Blunt Fin; the lanes' arithmetic is element by element, so the bits do not change)
LANE_OPTIONS = {"enable_backward": False, "fuse_fp": False, "max_unroll": 1,
                "cpu_compiler_flags": (wp.config.cpu_compiler_flags if wp.config.cpu_compiler_flags is not None
                                       else "-march=native") + " -mprefer-vector-width=512"}


def make_lane_io(segs: bool = False, LANES: int = 1):
    """``(lane_next, lane_done)`` of the lane kernel with ``LANES`` rays per pass: :func:`warpvol.kernels.raycast.
    make_march`'s ``march_ray`` split around its walk -- ``lane_next`` makes a lane's next entries (the entry
    search and the walk's set-up into a :class:`LaneState` in ``scratch``) until one has a walk, ``lane_done``
    writes a walked entry back (``segs``: its segment too) and makes the ray's re-entries (scalar)."""
    march_ray = march_kernel(segs).march_ray  # the scalar entry and walk, for the re-entries
    ray_done = march_kernel(segs).ray_done  # its write-back

    @wp.func
    def lane_entry(idx: int, cam: RayCamera, mesh: CellMesh, bins: EntryBins, ig: Integ, opts: WalkOpts,
                   st_rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float), tcur: wp.array(dtype=float),
                   status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32),
                   counters: wp.array2d(dtype=wp.int32), chunk: int) -> LaneState:
        """``march_ray``'s entry and the walk's set-up; ``walking`` 0: the ray's status is written, no walk."""
        ls = LaneState()
        ls.idx = idx
        ls.walking = 0
        r, t_clip, t_end, cell, face_in, fc, best_t, best_s, far_t, flat = ray_entry(
            idx, cam, mesh, bins, opts, tcur, status, last, counters, chunk, 0)
        if cell < 0:
            return ls  # (the ray's status is written)
        c = st_rgb[idx]
        ls.walking = 1
        ls.cell = cell
        ls.fc = fc
        ls.t_in = best_t
        ls.s_in = best_s
        ls.acc = wp.vec4(c[0], c[1], c[2], trans[idx])
        ls.own = wp.vec4(0.0, 0.0, 0.0, 1.0)
        ls.r = r
        ls.t_clip = t_clip
        ls.t_end = t_end
        ls.best_t = best_t
        ls.far_t = far_t
        ls.flat = flat
        ls.thin_mem = thin_start()
        ls.k_in = tf_upper(best_s, ig.tf_s)
        ls.v_in = tf_eval_upper(best_s, ls.k_in, ig.tf_s, ig.tf_v)
        if best_t >= t_clip and grazing_unresolved(ls.acc[3], ls.v_in, ig.model, fc, r, best_t, float(cam.radius)):
            ls.failed = 1
        ls.ds_in = scalar_error_if(opts.scalar_check, fc, r)
        ls.gn = mesh.tets[cell][face_in]
        return ls

    @wp.func
    def lane_entry_at(scratch: wp.array(dtype=LaneState), slot: int, idx: int, cam: RayCamera, mesh: CellMesh,
                      bins: EntryBins, ig: Integ, opts: WalkOpts, st_rgb: wp.array(dtype=wp.vec3),
                      trans: wp.array(dtype=float), tcur: wp.array(dtype=float), status: wp.array(dtype=wp.int32),
                      last: wp.array(dtype=wp.int32), counters: wp.array2d(dtype=wp.int32), chunk: int):
        """``lane_entry`` of ray ``idx`` into ``scratch[slot]``: ``entered`` 1 when the entry was made (its
        write-back is ``lane_finish_at``'s), ``walking`` 1 when there is a walk to take."""
        ls = lane_entry(idx, cam, mesh, bins, ig, opts, st_rgb, trans, tcur, status, last, counters, chunk)
        ls.idx = idx
        ls.entered = ls.walking
        if ls.failed != 0:
            ls.walking = 0  # (entered through a face seen nearly edge-on: no step, failed)
        scratch[slot] = ls

    @wp.func
    def lane_finish_at(scratch: wp.array(dtype=LaneState), slot: int, opts: WalkOpts,
                       st_rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float), tcur: wp.array(dtype=float),
                       status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32),
                       counters: wp.array2d(dtype=wp.int32), chunk: int, sg: Segments) -> int:
        """``march_ray``'s write-back (``ray_done``) of the lane in ``scratch[slot]`` if its entry was made, its
        fields read one by one (no :class:`LaneState` copy); its ray's pixel."""
        idx = scratch[slot].idx
        if scratch[slot].entered == 1:
            ray_done(idx, scratch[slot].acc, scratch[slot].t_in, scratch[slot].cell, scratch[slot].cells,
                     scratch[slot].failed, scratch[slot].exited, scratch[slot].thin, scratch[slot].own,
                     scratch[slot].best_t, scratch[slot].t_clip, scratch[slot].t_end, scratch[slot].far_t,
                     scratch[slot].flat, opts, st_rgb, trans, tcur, status, last, counters, chunk, sg)
        return idx

    @wp.func
    def lane_done(scratch: wp.array(dtype=LaneState), slot: int, cam: RayCamera, mesh: CellMesh, bins: EntryBins,
                  ig: Integ, opts: WalkOpts, rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float),
                  tcur: wp.array(dtype=float), status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32),
                  reentries: int, counters: wp.array2d(dtype=wp.int32), chunk: int, sg: Segments):
        """The end of the ray in ``scratch[slot]``: its write-back, then its re-entries (scalar, up to
        ``reentries``), and whether a further pass must search it (``counters[chunk, 4]``)."""
        idx = lane_finish_at(scratch, slot, opts, rgb, trans, tcur, status, last, counters, chunk, sg)
        k = int(0)
        while k < reentries and (status[idx] & 3) == STATUS_ACTIVE:
            k += 1
            march_ray(idx, cam, mesh, bins, ig, opts, rgb, trans, tcur, status, last, counters, chunk, 7, sg)
        if (status[idx] & 3) == STATUS_ACTIVE:
            wp.atomic_add(counters, chunk, 4, 1)

    @wp.func
    def lane_next(scratch: wp.array(dtype=LaneState), ln: int, slot: int, lim: int, ids: wp.array(dtype=wp.int32),
                  cam: RayCamera, mesh: CellMesh, bins: EntryBins, ig: Integ, opts: WalkOpts,
                  rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float), tcur: wp.array(dtype=float),
                  status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32), reentries: int,
                  counters: wp.array2d(dtype=wp.int32), chunk: int, sg: Segments) -> int:
        """Lane ``scratch[ln]``'s next ray to walk from the pass's ray ``slot`` on (every ``LANES``-th below
        ``lim``): the entries of rays with nothing to walk are made and ended here; its slot, or -1."""
        while slot < lim:
            idx = slot
            if ids.shape[0] > 0:
                idx = ids[slot]
            if (status[idx] & 3) == STATUS_ACTIVE:
                py = idx // cam.width
                tile_id = (py // bins.tile) * bins.tiles_x + (idx - py * cam.width) // bins.tile
                if bins.tile_start[tile_id] == bins.tile_start[tile_id + 1]:
                    status[idx] = STATUS_DONE  # (no entry face binned to the pixel's tile: as lane_entry decides)
                else:
                    lane_entry_at(scratch, ln, idx, cam, mesh, bins, ig, opts, rgb, trans, tcur, status, last,
                                  counters, chunk)
                    if scratch[ln].walking == 1:
                        return slot
                    lane_done(scratch, ln, cam, mesh, bins, ig, opts, rgb, trans, tcur, status, last, reentries,
                              counters, chunk, sg)
            slot += LANES
        return -1

    return lane_next, lane_done
