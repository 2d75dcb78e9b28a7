"""Stage ``peel``: further ray passes for non-convex meshes (depth peeling of the boundary).

After ``raycast`` a ray that left the mesh through a boundary face may enter it again further on
(concave or disconnected meshes). Each pass searches the next front-facing boundary face beyond the
ray's current parameter and walks on; passes repeat until no ray re-enters. The planner skips the
stage when the mesh boundary is convex (every ray enters at most once).
"""

from __future__ import annotations

from warpvol.parallel import cpu_threads
from warpvol.raycasting.stages.raycast import RAY_PARAMS, march_pass, resolve_failed
from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class Peel(Stage):
    """Re-entry passes for non-convex meshes.

    ==========  =====  =========  =============================================================
    parameter   type   default    meaning
    ==========  =====  =========  =============================================================
    max_passes  int    256        upper bound on re-entry passes (>= 1)
    max_steps   int    1000000    cell steps per ray and pass before giving up
    t_min       float  1e-6       early termination below this transmittance (0: off)
    threads     int    0          host threads launching CPU row blocks (0: all cores)
    ==========  =====  =========  =============================================================
    """

    name = "peel"
    summary = "re-enter non-convex meshes: repeat propagation passes until no ray re-enters"
    needs = ("cells", "entry_bins", "march")
    provides = ("image",)
    params = (Param("max_passes", int, 256, "upper bound on re-entry passes", lo=1),) + RAY_PARAMS

    def skip_reason(self, ctx: Context) -> str | None:
        if ctx.scene.mesh.is_convex:
            return "mesh boundary is convex: every ray enters the mesh at most once"
        return None

    def run(self, ctx: Context) -> None:
        state = ctx.buffers.get("march")
        if state is None:
            raise RuntimeError("stage 'peel' needs the 'raycast' stage before it")
        threads = self.threads or cpu_threads()
        passes, entries = 0, 0
        ctx.count(passes=0)
        thin = 0
        for _ in range(self.max_passes):
            if state.active == 0:
                break  # the last pass left no ray that could re-enter: a pass would find nothing
            c = march_pass(ctx, state, max_steps=self.max_steps, t_min=self.t_min, threads=threads)
            passes += 1
            thin += int(c[5])
            ctx.count(passes=1, entries=int(c[0]), cell_steps=int(c[1]))
            if c[0] == 0:
                break
            entries += int(c[0])
            ctx.progress(f"peel pass {passes}: {int(c[0])} rays re-entered")
        redone = resolve_failed(ctx, state)
        ctx.count(float64_rays=redone)
        mesh = ctx.scene.mesh  # interior faces without a neighbour: rays re-enter at the coincident face
        ctx.stats["peel"] = {"passes": passes, "reentries": entries, "float64_rays": redone, "thin_layer_rays": thin,
                             "crack_faces": len(mesh.crack_faces), "nonconforming_faces": len(mesh.nonconforming_faces)}
        cam = ctx.scene.camera
        ctx.image = state.image(cam.height_px, cam.width_px)
