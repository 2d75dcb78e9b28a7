"""``harc_best``'s march pass with ``LANES`` rays per thread: the lane kernel of :mod:`warpvol.kernels.lanes_march`
with HARC's ray start and write-back.

:func:`make_harc_lane_io` gives :func:`~warpvol.kernels.lanes_march.make_march_lanes` (``harc=True``) the pair
``(lane_next, lane_done)`` it calls around its lane loop, as :func:`warpvol.kernels.lanes.make_lane_io` does for
``raycast``: the entry is :func:`warpvol.kernels.harc.plucker_start` (the first rasterised front boundary face beyond
the last exit), the write-back the ``ray_done`` of :func:`warpvol.kernels.harc.make_march`'s kernel (the consistent
walk with exact segments), so one pass makes what that kernel makes -- images, counters and float64 redo marks, bit
for bit (tests/test_march_lanes.py). HARC's rays start on a boundary face (a ray starting inside the mesh's bounding
sphere is failed at its start), so the walk is not clipped: the lanes' ``t_clip`` is :data:`NO_CLIP`. One entry per
ray and pass (the peel passes are launches of their own).
"""

import warp as wp

from .cellwalk import CellMesh, RayCamera, Segments, WalkOpts
from .formats import NumFmt
from .harc import INTEG_EXACT, SETUP_ROBUST, WALK_PLUCKER, FragLists, march_kernel, plucker_start
from .harc_integ import Integ
from .lanes import LaneState
from .raycast import STATUS_ACTIVE
from .tf import tf_eval_upper, tf_upper
from .walk import grazing_unresolved, scalar_error_if, thin_start

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

#: the lanes' ``t_clip`` for HARC's unclipped walk: below every ray parameter, so that the lane step's clip tests
#: (``t_in >= t_clip``, ``t_out > t_clip``) always pass, as the walk of ``make_walk(clip=False)`` reads none
NO_CLIP = wp.constant(-3.0e38)


def make_harc_lane_io(segs: bool = False, LANES: int = 1):
    """``(lane_next, lane_done)`` of the lane kernel with ``LANES`` rays per pass for ``harc_best``'s pass (see the
    module docstring); ``segs``: each entry's segment is kept."""
    ray_done = march_kernel(WALK_PLUCKER, SETUP_ROBUST, INTEG_EXACT, segs).ray_done  # the scalar kernel's write-back

    @wp.func
    def lane_entry_at(scratch: wp.array(dtype=LaneState), slot: int, idx: int, cam: RayCamera, mesh: CellMesh,
                      lists: FragLists, ig: Integ, opts: WalkOpts, rgba: wp.array(dtype=wp.vec4),
                      tcur: wp.array(dtype=float), status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32),
                      counters: wp.array2d(dtype=wp.int32), chunk: int):
        """Ray ``idx``'s start and the walk's set-up into ``scratch[slot]``: ``entered`` 1 when an entry was made
        (its write-back is ``lane_done``'s), ``walking`` 1 when there is a walk to take."""
        ls = LaneState()
        ls.idx = idx
        r, t_clip, cell, face_in, fc, t_in, s_in = plucker_start(idx, cam, mesh, lists, opts, tcur, status, last,
                                                                 counters, chunk)
        if cell >= 0:
            a = rgba[idx]
            ls.entered = 1
            ls.walking = 1
            ls.cell = cell
            ls.fc = fc
            ls.t_in = t_in
            ls.s_in = s_in
            ls.acc = wp.vec4(a[0], a[1], a[2], 1.0 - a[3])  # the exact Plücker walk carries (rgb, tr)
            ls.own = wp.vec4(0.0, 0.0, 0.0, 1.0)
            ls.r = r
            ls.t_clip = NO_CLIP
            ls.best_t = t_in  # the entry's ray parameter (its segment's front)
            ls.thin_mem = thin_start()
            ls.k_in = tf_upper(s_in, ig.tf_s)
            ls.v_in = tf_eval_upper(s_in, ls.k_in, ig.tf_s, ig.tf_v)
            if grazing_unresolved(ls.acc[3], ls.v_in, ig.model, fc, r, t_in, float(cam.radius)):
                ls.failed = 1  # entered through a face seen nearly edge-on: no step, failed
                ls.walking = 0
            ls.ds_in = scalar_error_if(opts.scalar_check, fc, r)
            ls.gn = mesh.tets[cell][face_in]
        scratch[slot] = ls

    @wp.func
    def lane_done(scratch: wp.array(dtype=LaneState), slot: int, cam: RayCamera, mesh: CellMesh, lists: FragLists,
                  ig: Integ, opts: WalkOpts, rgba: wp.array(dtype=wp.vec4), px_work: wp.array(dtype=wp.vec2i),
                  tcur: wp.array(dtype=float), status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32),
                  fb: NumFmt, counters: wp.array2d(dtype=wp.int32), chunk: int, sg: Segments):
        """The write-back of the ray in ``scratch[slot]`` if its entry was made (``ray_done``), its fields read one
        by one. The walk's ``steps`` (segments integrated) are its cells but for a step that failed before its
        integral was kept (no exit face, no progress, a thin layer, a steep scalar error: not at the exit)."""
        if scratch[slot].entered == 1:
            cells = scratch[slot].cells
            failed = scratch[slot].failed
            exited = scratch[slot].exited
            steps = cells
            if failed == 1 and exited == 0 and cells > 0:
                steps = cells - 1
            ray_done(scratch[slot].idx, scratch[slot].r, scratch[slot].acc, scratch[slot].own, scratch[slot].best_t,
                     scratch[slot].t_in, scratch[slot].cell, steps, cells, failed, exited, scratch[slot].thin, 0, fb,
                     opts, lists.far, rgba, tcur, status, last, counters, chunk, px_work, sg)

    @wp.func
    def lane_next(scratch: wp.array(dtype=LaneState), ln: int, slot: int, lim: int, ids: wp.array(dtype=wp.int32),
                  cam: RayCamera, mesh: CellMesh, lists: FragLists, ig: Integ, opts: WalkOpts,
                  rgba: wp.array(dtype=wp.vec4), px_work: wp.array(dtype=wp.vec2i), tcur: wp.array(dtype=float),
                  status: wp.array(dtype=wp.int32), last: wp.array(dtype=wp.int32), fb: NumFmt,
                  counters: wp.array2d(dtype=wp.int32), chunk: int, sg: Segments) -> int:
        """Lane ``scratch[ln]``'s next ray to walk from the pass's ray ``slot`` on (every ``LANES``-th below
        ``lim``): the starts of rays with nothing to walk are made and written back here; its slot, or -1."""
        while slot < lim:
            idx = slot
            if ids.shape[0] > 0:
                idx = ids[slot]
            if status[idx] == STATUS_ACTIVE:
                lane_entry_at(scratch, ln, idx, cam, mesh, lists, ig, opts, rgba, tcur, status, last, counters, chunk)
                if scratch[ln].walking == 1:
                    return slot
                lane_done(scratch, ln, cam, mesh, lists, ig, opts, rgba, px_work, tcur, status, last, fb, counters,
                          chunk, sg)
            slot += LANES
        return -1

    return lane_next, lane_done
