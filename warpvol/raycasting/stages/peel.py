"""Stage ``peel``: further ray passes for non-convex meshes (depth peeling of the boundary).

After ``raycast`` a ray that left the mesh through a boundary face may enter it again further on
(concave or disconnected meshes); ``raycast``'s threads re-enter up to ``reentries`` times themselves, and
this stage takes the rays still re-entering after that. Each pass searches the next front-facing boundary
face beyond the ray's current parameter and walks on (again up to ``reentries`` times per ray); passes
repeat until no ray re-enters. The planner skips the
stage when the mesh boundary is convex (every ray enters at most once), unless the walk is confined to
the cells the transfer function makes visible (their boundary is rarely convex).
"""

from __future__ import annotations

from warpvol.parallel import cpu_threads
from warpvol.raycasting.stages.raycast import (
    RAY_PARAMS,
    march_pass,
    report_left_out,
    resolve_failed,
    stop_transmittance,
)
from warpvol.shared.visible import confined
from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class Peel(Stage):
    """Re-entry passes for non-convex meshes.

    =================  =====  =========  =============================================================
    parameter          type   default    meaning
    =================  =====  =========  =============================================================
    max_passes         int    256        upper bound on re-entry passes (>= 1); rays still
                                         re-entering after it are redone in float64
    max_steps          int    1000000    cell steps per ray and entry before giving up
    early_termination  float  1e-6       the most a channel may change (0: off; old name ``t_min``)
    threads            int    0          host threads launching CPU row blocks (0: all cores)
    reentries          int    256        re-entries per ray within a pass (>= 0; 0: one entry per pass)
    =================  =====  =========  =============================================================

    The stats' ``reentries`` count every re-entry of the frame, those the ``raycast`` pass made in its
    threads (``raycast``'s ``reentries``) and this stage's; ``passes`` this stage's passes.
    """

    name = "peel"
    summary = "re-enter non-convex meshes: repeat propagation passes until no ray re-enters"
    needs = ("cells", "entry_bins", "march")
    provides = ("image",)
    params = (Param("max_passes", int, 256, "upper bound on re-entry passes", lo=1),) + RAY_PARAMS

    def skip_reason(self, ctx: Context) -> str | None:
        ctx.mesh_setup(ctx.scene.mesh, "is_convex")  # per mesh, kept on it: set-up on first use
        if ctx.scene.mesh.is_convex and not confined(ctx):
            return "mesh boundary is convex: every ray enters the mesh at most once"
        return None

    def run(self, ctx: Context) -> None:
        state = ctx.buffers.get("march")
        if state is None:
            raise RuntimeError("stage 'peel' needs the 'raycast' stage before it")
        threads = self.threads or cpu_threads()
        t_min = stop_transmittance(ctx, self.t_min)
        bound = self.t_min if t_min > 0 else 0.0  # the stated termination bound (0: none)
        passes, entries = 0, 0
        ctx.count(passes=0)
        thin, early = 0, 0
        for _ in range(self.max_passes):
            if state.active == 0:
                break  # the last pass left no ray that could re-enter: a pass would find nothing
            c = march_pass(ctx, state, max_steps=self.max_steps, t_min=t_min, threads=threads,
                           reentries=self.reentries)
            passes += 1
            thin += int(c[5])
            early += int(c[6])
            ctx.count(passes=1, entries=int(c[0] + c[7]), cell_steps=int(c[1]))
            if c[0] == 0:
                break
            entries += int(c[0] + c[7])
            ctx.progress(f"peel pass {passes}: {int(c[0])} rays re-entered")
        unfinished = 0
        if state.active and passes == self.max_passes:  # rays that may re-enter further: redone whole
            from warpvol.kernels import raycast as k
            from warpvol.shared.visible import unfinished_to_float64

            unfinished = unfinished_to_float64(state, int(k.STATUS_ACTIVE), int(k.STATUS_FAILED))
        redone = resolve_failed(ctx, state, bound)
        ctx.count(float64_rays=redone)
        report_left_out(ctx, bound, early)
        mesh = ctx.scene.mesh  # interior faces without a neighbour: rays re-enter at the coincident face
        entries += ctx.stats.get("raycast", {}).get("reentries", 0)  # made in the first pass's threads
        ctx.stats["peel"] = {"passes": passes, "reentries": entries, "float64_rays": redone, "thin_layer_rays": thin,
                             "terminated_early": early, "passes_exhausted_rays": unfinished,
                             "crack_faces": len(mesh.crack_faces), "nonconforming_faces": len(mesh.nonconforming_faces)}
        if passes or redone or ctx.image is None:  # (no pass and no redo: the raycast stage's image stands)
            cam = ctx.scene.camera
            ctx.image = state.image(cam.height_px, cam.width_px)
