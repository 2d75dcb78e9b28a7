"""Stage ``raycast``: float32 ray propagation through the cell adjacency (first pass).

Each pixel's ray (origin moved to the mesh in float64) enters at the nearest boundary face of its
screen tile (from ``entry_bins``) and walks cell to cell with consistent Plücker edge tests (see
:mod:`warpvol.kernels.raycast`), integrates each segment exactly for the piecewise-linear transfer
function and composites front to back. Where the ray leaves the (visible) mesh its thread searches the
next entry beyond the exit and walks on, up to ``reentries`` times; for non-convex meshes the ``peel``
stage continues the rays still re-entering after that. Rays the float32 walk cannot resolve are redone in
float64 on the host (:func:`redo_pixels_float64`) and counted.

On the CPU a Warp launch runs its threads serially, so the image is cut into row blocks that a pool
of host threads launches concurrently (``threads``); Warp releases the GIL while a CPU kernel runs.
"""

from __future__ import annotations

import numpy as np

from warpvol.conditioning.visibility import termination_threshold
from warpvol.parallel import blocks, cpu_threads, launch_blocks
from warpvol.reference.pixels import redo_mesh_properties, redo_pixels_float64
from warpvol.shared.thin_cells import mark_unresolved
from warpvol.shared.visible import confined, skipping
from warpvol.stage import Context, Param, Stage, register_stage


def on_host(device) -> bool:
    """Whether ``device``'s arrays live in host memory: their ``numpy()`` is a view the host may write."""
    return str(device).startswith("cpu")


def host_view(arr) -> np.ndarray:
    """The host's view of a CPU array (:func:`on_host`), not counted as a device read
    (:class:`warpvol.timing.ReadCounter` counts what a GPU frame would wait for; a CPU-only path reads
    nothing a GPU frame would)."""
    numpy = type(arr).numpy
    return getattr(numpy, "__wrapped__", numpy)(arr)


def write_back(arr, values: np.ndarray, dtype):
    """``arr`` holding ``values`` (its ``numpy()`` edited on the host): the same array on the CPU, where that
    was a view of it; a new device array elsewhere."""
    import warp as wp

    return arr if on_host(arr.device) else wp.array(values, dtype=dtype, device=arr.device)


class MarchState:
    """Per-pixel ray state on the device: radiance, transmittance, ray parameter, status."""

    def __init__(self, n: int, device: str):
        import warp as wp

        from warpvol.kernels import raycast as k

        self.n, self.device = n, device
        host = on_host(device)
        # radiance and ray parameter start at 0: on the CPU over calloc'd host memory (zero pages until written;
        # the image reads the written pixels only), no memset of the window
        self.rgb = (wp.array(np.zeros((n, 3), np.float32), dtype=wp.vec3, device=device, copy=False) if host
                    else wp.empty(n, dtype=wp.vec3, device=device))
        self.trans = wp.empty(n, dtype=wp.float32, device=device)
        self.tcur = (wp.array(np.zeros(n, np.float32), dtype=wp.float32, device=device, copy=False) if host
                     else wp.empty(n, dtype=wp.float32, device=device))
        self.status = wp.empty(n, dtype=wp.int32, device=device)
        self.last = wp.empty(n, dtype=wp.int32, device=device)  # cell each ray last left
        self.active = n  # rays a further pass must search (set by each pass)
        self.candidates = None  # the pixels a further pass looks at (the last pass's launched rays; None: all)
        #: the pixels whose radiance or transmittance a kernel or the host may have written (the first pass's
        #: launched rays, each float64 redo's); None: any pixel (a pass launched every ray)
        self.touched: list | None = []
        if host:  # the host fills its views: a few memsets, no kernel over every pixel
            host_view(self.trans).fill(1.0)
            host_view(self.status).fill(int(k.STATUS_ACTIVE))
            host_view(self.last).fill(-1)
        else:
            wp.launch(k.init_state, dim=n, inputs=[self.rgb, self.trans, self.tcur, self.status, self.last, 0.0],
                      device=device)

    def image(self, height: int, width: int) -> np.ndarray:
        import warp as wp

        from warpvol.kernels import raycast as k

        if on_host(self.device) and self.touched is not None:
            # every other pixel keeps its initial radiance 0 and transmittance 1: RGBA 0 (as the kernel gives)
            out = np.zeros((self.n, 4), np.float32)
            if self.touched:
                idx = np.concatenate(self.touched)
                out[idx, :3] = host_view(self.rgb)[idx]
                out[idx, 3] = np.float32(1.0) - host_view(self.trans)[idx]
            return out.reshape(height, width, 4)
        out = wp.empty(self.n, dtype=wp.vec4, device=self.device)  # (the kernel writes every pixel)
        wp.launch(k.finish, dim=self.n, inputs=[self.rgb, self.trans, out], device=self.device)
        return out.numpy().reshape(height, width, 4)

    def touch(self, pixels: np.ndarray) -> None:
        """Note ``pixels`` (indices) as written; :meth:`image` reads those only."""
        if self.touched is not None:
            if len(pixels) == self.n:
                self.touched = None
            elif len(pixels):
                self.touched.append(np.asarray(pixels))


def camera_struct(ctx: Context):
    """The camera of a per-pixel ray kernel (``raycast``'s march and the HARC walker) as a
    :class:`warpvol.kernels.cellwalk.RayCamera`: image size, float64 eye relative to the cells' origin (the kernel
    moves each ray's origin to the mesh) and camera frame, projection, half height, aspect, mesh radius. The
    launch blocks come from :func:`ray_blocks`."""
    import warp as wp

    from warpvol.kernels.cellwalk import RayCamera

    cam = ctx.scene.camera
    cells = ctx.buffers["cells"]
    if cam.projection == "perspective":
        half_h = float(np.tan(np.radians(cam.fov_y_deg) / 2.0))
    else:
        half_h = cam.ortho_height / 2.0
    eye = np.asarray(cam.eye, dtype=np.float64) - cells["origin"]
    v3 = wp.vec3d
    rc = RayCamera()
    rc.width, rc.height = cam.width_px, cam.height_px
    rc.eye, rc.fwd, rc.right, rc.up = v3(*eye), v3(*cam.forward), v3(*cam.right), v3(*cam.true_up)
    rc.ortho = int(cam.projection == "orthographic")
    rc.half_h, rc.aspect = wp.float64(half_h), wp.float64(cam.aspect)
    rc.radius = wp.float64(max(cells["radius"], 1e-30))
    return rc


def cell_mesh_struct(cells: dict):
    """The cells (``ctx.buffers["cells"]``) as the walk reads them: a :class:`warpvol.kernels.cellwalk.CellMesh`."""
    from warpvol.kernels.cellwalk import CellMesh

    m = CellMesh()
    m.verts, m.tets, m.nbr, m.nbr_vertex = cells["verts"], cells["tets"], cells["nbr"], cells["nbr_vertex"]
    return m


def walk_opts(t_stop: float, max_steps: int, scalar_check: int, t_tol: float):
    """A :class:`warpvol.kernels.cellwalk.WalkOpts`."""
    from warpvol.kernels.cellwalk import WalkOpts

    o = WalkOpts()
    o.t_stop, o.max_steps, o.scalar_check, o.t_tol = float(t_stop), int(max_steps), int(scalar_check), float(t_tol)
    return o


def segments_struct(n: int, cap: int, device):
    """A :class:`warpvol.kernels.cellwalk.Segments` for ``n`` rays of ``cap`` segments each (``cap`` 0: none
    kept, the struct the kernels without segments take)."""
    import warp as wp

    from warpvol.kernels.cellwalk import Segments

    sg = Segments()
    sg.cap = int(cap)
    sg.count = wp.zeros(n if cap else 0, dtype=wp.int32, device=device)
    sg.depth = wp.zeros(n * cap, dtype=wp.vec2, device=device)
    sg.color = wp.zeros(n * cap, dtype=wp.vec4, device=device)
    return sg


def ray_blocks(ctx: Context, active: np.ndarray, threads: int, rows_per_block: int = 16) -> tuple:
    """The launch blocks of a pass over the rays with ``active`` (a boolean per pixel, or the active pixels'
    indices in increasing order): ``(ids, blocks)``,
    ``blocks`` a list of ``(first, count)``. While every ray is active, ``ids`` is empty and a block is the
    pixels ``first .. first + count`` (row blocks of ``rows_per_block`` rows on the CPU); otherwise ``ids``
    lists the active rays' pixels (in pixel order, so neighbouring threads walk neighbouring rays) and a block
    is ``ids[first .. first + count]``: a re-entry pass launches its few active rays, not the whole image (on
    the CPU a thread that only finds its ray inactive costs 10-50 ns, as much as a cell step). On the CPU
    the list is cut into at least 4 blocks per launching thread, each at most ``rows_per_block`` rows' worth
    of rays; no blocks when no ray is active."""
    import warp as wp

    cam = ctx.scene.camera
    w, h = cam.width_px, cam.height_px
    on_cpu = on_host(ctx.device)
    act = (np.flatnonzero(active) if active.dtype == bool else active).astype(np.int32)
    if len(act) == w * h:
        rows = blocks(h, rows_per_block if on_cpu else h)
        return wp.zeros(0, dtype=wp.int32, device=ctx.device), [(r0 * w, nr * w) for r0, nr in rows]
    size = min(rows_per_block * w, max(64, -(-len(act) // (4 * max(1, threads))))) if on_cpu else len(act)
    ids = wp.array(act, dtype=wp.int32, device=ctx.device) if len(act) else wp.zeros(0, dtype=wp.int32,
                                                                                     device=ctx.device)
    return ids, blocks(len(act), size)


def drop_unreached(status: np.ndarray, active: np.ndarray, reach: np.ndarray | None, done: int) -> np.ndarray:
    """The rays a pass launches: ``active`` (bool per pixel) where ``reach`` (bool per pixel: the pass's entry
    search has a face to test there) holds; the active rays outside ``reach`` are set to ``done`` in ``status``
    (the host's view of a CPU array) without a launch, as the kernel would set them. On the CPU a thread that
    only finds its pixel without a face costs about 30 ns (measured on SPX at 512^2: 8 ms of a 31 ms frame where
    5 % of the pixels see the mesh). ``reach`` None: every active ray is launched."""
    if reach is None:
        return active
    gone = active & ~reach
    if gone.any():
        status[gone] = done
        return active & reach
    return active


def pass_rays(status: np.ndarray, active_code: int, done_code: int, reach: np.ndarray | None,
              candidates: np.ndarray | None, mask: int = -1) -> np.ndarray:
    """The indices of the rays a pass launches (``status & mask == active_code``), in increasing order.
    ``candidates`` (None: every pixel): the pixels that may still be active, the previous pass's launched rays
    -- a ray no pass launched stays as it was, and the host's edits between passes (the float64 redo, rays given
    up) only end rays. The first pass (no candidates) scans the window and sets the active rays outside
    ``reach`` done (:func:`drop_unreached`); a later one looks at its candidates only."""
    if candidates is None:
        return np.flatnonzero(drop_unreached(status, (status & mask) == active_code, reach, done_code))
    return candidates[(status[candidates] & mask) == active_code]


def tile_reach(ctx: Context) -> np.ndarray | None:
    """Per pixel (bool, flat), whether ``entry_bins`` binned a face to its screen tile: the march's entry search
    (:func:`warpvol.kernels.raycast.make_march`) finds nothing elsewhere and sets the ray done. Per frame (the
    bins depend on the camera), kept in ``ctx.buffers["entry_bins"]``; None off the CPU (one launch fills a
    GPU, and the host holds no view of its status array)."""
    if not on_host(ctx.device):
        return None
    bins = ctx.buffers["entry_bins"]
    if "reach" not in bins:
        cam = ctx.scene.camera
        tile, tx = int(bins["tile"]), int(bins["tiles_x"])
        start = host_view(bins["tile_start"])
        full = (np.diff(start) > 0).reshape(-1, tx)
        bins["reach"] = np.repeat(np.repeat(full, tile, axis=0), tile, axis=1)[:cam.height_px, :cam.width_px].ravel()
    return bins["reach"]


#: counters of a pass (columns of :func:`march_pass`'s result)
PASS_COUNTERS = ("entries", "steps", "unfinished", "failed", "left active", "failed on a thin layer",
                 "terminated early", "re-entries")


#: rays per thread of the march (None: :func:`warpvol.kernels.lanes.device_lanes` of the device: 16 with AVX-512,
#: 8 with AVX2, 1 on CUDA; the same images and counters bit for bit, tests/test_march_lanes.py)
MARCH_LANES: int | None = None


def march_lanes(device) -> int:
    """The march's rays per thread on ``device`` (:data:`MARCH_LANES`; always 1 on CUDA)."""
    if str(device).startswith("cuda"):
        return 1
    if MARCH_LANES is None:
        from warpvol.kernels.lanes import device_lanes

        return device_lanes(device)
    return int(MARCH_LANES)


def march_pass(ctx: Context, state: MarchState, *, max_steps: int, t_min: float, threads: int, reentries: int = 0,
               rows_per_block: int = 16, segments=None) -> np.ndarray:
    """One propagation pass over all active rays (one thread per active ray: :func:`ray_blocks`), each ray
    re-entering up to ``reentries`` times within it; returns summed counters :data:`PASS_COUNTERS`
    (entries: the rays' first entries in the pass; re-entries: those after it in the same thread) and sets
    ``state.active`` to the rays left active (they may re-enter: 0 means a further pass would find nothing).
    Failed rays keep ``STATUS_FAILED`` for :func:`resolve_failed`. ``segments`` (:func:`segments_struct`): each
    entry's segment is kept there (front and back ray parameter, its own colour and transmittance)."""
    import warp as wp

    from warpvol.kernels import raycast as k
    from warpvol.kernels.harc_integ import Integ

    cells, bins = ctx.buffers["cells"], ctx.buffers["entry_bins"]
    cam = camera_struct(ctx)
    status = state.status.numpy()
    active = pass_rays(status, int(k.STATUS_ACTIVE), int(k.STATUS_DONE), tile_reach(ctx), state.candidates, 3)
    if state.candidates is None:
        state.touch(active)  # (a later pass launches some of these)
    state.candidates = active if len(active) < state.n else None  # the next pass looks at these only
    ids, parts = ray_blocks(ctx, active, threads, rows_per_block)
    if not parts:
        state.active = 0
        return np.zeros(len(PASS_COUNTERS), np.int64)
    counters = wp.zeros((len(parts), len(PASS_COUNTERS)), dtype=wp.int32, device=ctx.device)
    eb = k.EntryBins()
    for name in ("bface_tet", "bface_local", "bface_box", "tile_start", "tile_items", "item_depth", "tile", "tiles_x"):
        setattr(eb, name, bins[name])
    ig = Integ()  # the TF as the exact walk reads it (no tables)
    ig.mode, ig.model, ig.tf_s, ig.tf_v = 0, int(cells["model"]), cells["tf_s"], cells["tf_v"]
    opts = walk_opts(t_min, max_steps, cells["scalar_check"], 1e-6 * cells["radius"])
    if segments is None:
        segments = segments_struct(0, 0, ctx.device)
    lanes = march_lanes(ctx.device)
    common = [cam, cell_mesh_struct(cells), eb, ig, opts]
    if lanes > 1:
        from warpvol.kernels import lanes as kl
        from warpvol.kernels.lanes_march import march_lanes_kernel

        kernel = march_lanes_kernel(lanes, segments.cap > 0)
        scratch = wp.empty(kl.lane_scratch(max(f + c for f, c in parts), len(parts), lanes), dtype=kl.LaneState,
                           device=ctx.device)
        fm = kl.flat_mesh(common[1], ig.tf_v)

        def launch(b: int) -> None:
            first, count = parts[b]
            wp.launch(kernel, dim=kl.lane_threads(count, lanes), device=ctx.device,
                      inputs=common + [first, ids, state.rgb, state.trans, state.tcur, state.status, state.last,
                                       reentries, counters, b, segments, count, scratch, fm])
    else:
        kernel = k.march_kernel(segments.cap > 0)

        def launch(b: int) -> None:
            first, count = parts[b]
            wp.launch(kernel, dim=count, device=ctx.device,
                      inputs=common + [first, ids, state.rgb, state.trans, state.tcur, state.status, state.last,
                                       reentries, counters, b, segments])

    launch_blocks(ctx.device, len(parts), launch, threads, modules=[kernel])
    c = counters.numpy().sum(axis=0)
    state.active = int(c[4])
    return c


def resolve_failed(ctx: Context, state: MarchState, terminate: float = 0.0) -> int:
    """Redo the rays marked ``STATUS_FAILED`` in float64 on the host (whole ray; with skipping on, through
    the visible cells only, as the float32 walk), store them as done; returns how many. ``terminate`` > 0:
    the redo stops a ray once no channel can change by more than that (the walk's stated bound, ``t_min``)."""
    import warp as wp

    from warpvol.kernels import raycast as k

    status = state.status.numpy()
    failed = np.flatnonzero(status == int(k.STATUS_FAILED))
    if len(failed) == 0:
        return 0
    sc = ctx.scene
    ctx.mesh_setup(sc.mesh, *redo_mesh_properties(sc.camera))
    val = redo_pixels_float64(sc.mesh, sc.transfer, sc.camera, failed, visible=skipping(ctx)[0],
                              terminate=terminate or None)
    rgb, trans = state.rgb.numpy(), state.trans.numpy()
    rgb[failed] = val[:, :3]
    trans[failed] = 1.0 - val[:, 3]
    status[failed] = int(k.STATUS_DONE)
    state.touch(failed)
    state.rgb = write_back(state.rgb, rgb, wp.vec3)
    state.trans = write_back(state.trans, trans, wp.float32)
    state.status = write_back(state.status, status, wp.int32)
    return int(len(failed))


def stop_transmittance(ctx: Context, max_change: float) -> float:
    """Early ray termination with a stated bound: the transmittance below which a ray stops so that no
    channel of its pixel changes by more than ``max_change`` (``max_change`` over the brightest radiance
    that could lie behind: :func:`warpvol.conditioning.visibility.termination_threshold`, with the mesh's
    diagonal as the longest path); 0 (no termination) with skipping off or ``max_change`` 0."""
    if not ctx.skip or max_change <= 0:
        return 0.0

    return termination_threshold(ctx.scene.transfer, ctx.buffers["cells"]["diameter"], max_change)


def termination_bound(max_change: float) -> str:
    """The stated bound of early ray termination, in words."""
    return (f"a ray stops once its transmittance times the brightest radiance that could lie behind is below "
            f"{max_change:g}: no channel of its pixel changes by more than {max_change:g}")


def leaves_out_text(ctx: Context, t_min: float) -> str | None:
    """The planner's words for what a ray caster leaves out (cells the TF makes invisible, depth behind
    an opaque front); ``None``: nothing."""

    parts = []
    if confined(ctx):
        parts.append("walks only the cells the transfer function makes visible: rays enter and re-enter at the "
                     "visible cells' boundary, a pixel whose ray meets none costs only its entry search")
    if t_min > 0:
        parts.append(termination_bound(t_min))
    return "; ".join(parts) or None


def rays_without_cell(last, status, failed_code: int) -> int:
    """Rays that walked no cell in the first pass and were not handed to the float64 redo (``last`` still
    -1): with the walk confined to the visible cells, the rays that meet no visible cell."""
    return int(np.count_nonzero((last.numpy() < 0) & (status.numpy() != failed_code)))


def report_left_out(ctx: Context, t_min: float, early: int, missed: int | None = None) -> None:
    """Count what a ray-casting pass left out (``report["left_out"]``): rays terminated early (``t_min``:
    the bound on a channel's change, 0: no termination) and, on the first pass (``missed`` given) of a
    walk confined to the visible cells, the cells it never walks and the rays that met no visible
    cell."""
    if not ctx.skip:
        return
    cells = ctx.buffers.get("cells", {})
    amounts = {"rays_terminated": early} if t_min > 0 else {}
    why = []
    if missed is not None and cells.get("confined", False):
        amounts.update(cells_not_walked=int(cells.get("cells_not_walked", 0)), rays_without_visible_cell=missed)
        why.append("cells the transfer function makes invisible are not walked (rays enter and re-enter at "
                   "the visible cells' boundary)")
    if t_min > 0:
        why.append(termination_bound(t_min))
    if amounts:
        ctx.left_out(why="; ".join(why) if missed is not None else None, **amounts)


RAY_PARAMS = (
    Param("max_steps", int, 1_000_000, "cell steps per ray and entry before giving up", lo=1),
    Param("early_termination", float, 1e-6, "early ray termination: the most any channel of a pixel may change by "
          "it (the transmittance times the brightest radiance behind; 0: off)", lo=0.0, hi=1.0, aliases=("t_min",)),
    Param("threads", int, 0, "host threads launching row blocks on the CPU (0: all cores)", lo=0, hi=256),
    Param("reentries", int, 256, "re-entries of a ray within one pass, in its thread (0: one entry per pass, each "
          "further entry a peel pass)", lo=0),
)


@register_stage
class Raycast(Stage):
    """First ray-propagation pass (entry at the nearest boundary face, walk to the boundary exit).

    Every ray's origin is moved in float64 to just before the mesh's bounding sphere. A perspective
    eye or orthographic eye plane inside the mesh is handled by walking from the boundary behind it
    and integrating only from the ray's true start (``t_clip``); a mesh behind or beside the camera
    gives a transparent image. Rays the float32 walk cannot resolve -- among them rays through a
    layer too thin for float32 segment lengths whose extinction makes that visible -- are redone in
    float64 on the host (:func:`redo_pixels_float64`) and counted (``float64_rays`` in the stats and
    counters; ``thin_layer_rays`` of them for thin layers). The rays that may cross a cell too thin for
    float32 to resolve -- at its extinction, or seen edge-on (:func:`warpvol.shared.thin_cells.unresolved_pixels`)
    -- are not walked but traced in float64 from the start (``thin_cell_rays``, among ``float64_rays``).

    =================  =====  =========  =============================================================
    parameter          type   default    meaning
    =================  =====  =========  =============================================================
    max_steps          int    1000000    cell steps per ray and entry before giving up (>= 1)
    early_termination  float  1e-6       the most a channel may change, [0, 1] (0: off; old name ``t_min``)
    threads            int    0          host threads launching CPU row blocks (0: all cores)
    reentries          int    256        re-entries per ray within the pass (>= 0; 0: one entry per pass)
    =================  =====  =========  =============================================================

    A ray that leaves the (visible) mesh searches its next entry beyond the exit and walks on in the same
    thread, up to ``reentries`` times (``reentries`` in the stats; ``entries`` counts the first entries):
    the walk of one entry per pass without a pass per re-entry. The ``peel`` stage's passes take the rays
    still re-entering after that.

    Early ray termination with a stated bound: a ray stops once no channel of its pixel can change by more
    than ``t_min`` = 1e-6 (:func:`stop_transmittance`: at transmittance ``t_min`` with colours in [0, 1]
    under ``color_extinction``, lower for brighter colours or ``emission_density``), half the RMSE
    tolerance of ``raycast/fp32`` in ``tests/tolerances.py`` and 1 % of its max-abs tolerance. Skipping
    off (``skip=False``, ``--no-skip``) turns it off. Rays ended so are counted (``terminated_early``;
    ``report["left_out"]``).

    Needs ``cell_setup`` and ``entry_bins`` before it; writes ``ctx.image``.
    """

    name = "raycast"
    summary = ("float32 ray propagation through cell adjacency (consistent Plücker walk, unresolved rays redone "
               "in float64), exact piecewise-linear segment integrals")
    needs = ("cells", "entry_bins")
    provides = ("march", "image")
    params = RAY_PARAMS

    def leaves_out(self, ctx: Context) -> str | None:
        return leaves_out_text(ctx, self.t_min)

    def run(self, ctx: Context) -> None:
        cam = ctx.scene.camera
        state = MarchState(cam.width_px * cam.height_px, ctx.device)
        ctx.buffers["march"] = state
        threads = self.threads or cpu_threads()
        from warpvol.kernels import raycast as k

        thin_rays, thin_tets = mark_unresolved(ctx, state.status, int(k.STATUS_FAILED))  # traced in float64
        t_min = stop_transmittance(ctx, self.t_min)
        bound = self.t_min if t_min > 0 else 0.0  # the stated termination bound (0: none)
        c = march_pass(ctx, state, max_steps=self.max_steps, t_min=t_min, threads=threads, reentries=self.reentries)

        missed = rays_without_cell(state.last, state.status, int(k.STATUS_FAILED))
        redone = resolve_failed(ctx, state, bound)
        ctx.count(rays=cam.width_px * cam.height_px, entries=int(c[0] + c[7]), cell_steps=int(c[1]),
                  float64_rays=redone)
        ctx.stats["raycast"] = {"entries": int(c[0]), "reentries": int(c[7]), "cell_steps": int(c[1]),
                                "unfinished_rays": int(c[2]),
                                "float64_rays": redone, "thin_layer_rays": int(c[5]), "terminated_early": int(c[6]),
                                "thin_cell_rays": thin_rays, "thin_cells": thin_tets}
        report_left_out(ctx, bound, int(c[6]), missed)
        if redone:
            ctx.progress(f"raycast: {redone} rays the float32 walk could not resolve were redone in float64")
        ctx.image = state.image(cam.height_px, cam.width_px)
