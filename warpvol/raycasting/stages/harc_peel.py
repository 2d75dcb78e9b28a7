"""Stage ``harc_peel``: depth peeling over the boundary layers for non-convex meshes."""

from __future__ import annotations

from warpvol.raycasting.stages.raycast import report_left_out
from warpvol.shared.visible import confined
from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class HarcPeel(Stage):
    """Further ray-casting passes: each re-rasterises the front boundary faces with the depth test
    "beyond the last exit" (the next boundary layer) and walks on, until no ray re-enters or
    ``max_passes``. Skipped by the planner when the mesh boundary is convex, unless the walk is confined
    to the cells the transfer function makes visible (their boundary is rarely convex).

    ==========  =====  =========  ===================================
    parameter   type   default    meaning
    ==========  =====  =========  ===================================
    max_passes  int    64         upper bound on peel passes (>= 1); robust set-up: rays still
                                  re-entering after it are redone in float64
    ==========  =====  =========  ===================================
    """

    name = "harc_peel"
    summary = "depth peeling: re-enter non-convex meshes at the next boundary layer (skipped when convex)"
    needs = ("harc_state", "harc_entry")
    provides = ("image",)
    renamed_stats = {"unresolved_rays": "float64_rays"}  # the float64 redo's one name, as in raycast and pt_integrate
    params = (Param("max_passes", int, 64, "upper bound on peel passes", lo=1),)

    def skip_reason(self, ctx: Context) -> str | None:
        ctx.mesh_setup(ctx.scene.mesh, "is_convex")  # per mesh, kept on it: set-up on first use
        if ctx.scene.mesh.is_convex and not confined(ctx):
            return "mesh boundary is convex: every ray enters the mesh at most once (no boundary layer to peel)"
        return None

    def run(self, ctx: Context) -> None:
        hs = ctx.buffers["harc_state"]
        entry = ctx.buffers["harc_entry"]
        passes, entries = 0, 0
        total = {}
        for _ in range(self.max_passes):
            c = hs["run_pass"]()
            passes += 1
            # every peel pass rasterises the front boundary faces again (depth test against the last layer)
            ctx.count(fragments=entry["fragments"])
            hs["count"](c)
            for k, v in c.items():
                total[k] = total.get(k, 0) + v
            if c["entries"] == 0:
                break
            entries += c["entries"]
        unfinished = 0
        if passes == self.max_passes and c["entries"] and hs.get("lost") is None:
            # robust set-up: rays that may still re-enter are redone whole in float64, never left half-walked
            from warpvol.kernels.raycast import STATUS_ACTIVE, STATUS_FAILED
            from warpvol.shared.visible import unfinished_to_float64

            unfinished = unfinished_to_float64(hs["state"], int(STATUS_ACTIVE), int(STATUS_FAILED))
        redone = hs["resolve"]()

        report_left_out(ctx, hs.get("eps", 0.0), total.get("terminated_early", 0))
        mesh = ctx.scene.mesh  # interior faces without a neighbour: rays re-enter at the coincident face
        ctx.stats["harc_peel"] = {"passes": passes, "reentries": entries, "float64_rays": redone, **total,
                                  "passes_exhausted_rays": unfinished,
                                  "exhausted": passes == self.max_passes, "crack_faces": len(mesh.crack_faces),
                                  "nonconforming_faces": len(mesh.nonconforming_faces)}
        if hs.get("lost") is not None:  # the paper's set-up: rays lost in the peel passes too
            from warpvol.raycasting.harc import lost_warning

            lost = hs["lost"]()
            before = ctx.stats.get("harc", {}).get("lost_rays", 0)
            ctx.stats["harc_peel"]["lost_rays"] = lost - before
            back = total.get("backward_rays", 0)
            if lost > before or back:
                ctx.stats["harc_peel"]["warning"] = "peel passes: " + lost_warning(lost - before, hs["state"].n, back)
        st = hs["state"]
        cam = ctx.scene.camera
        ctx.image = st.image(cam.height_px, cam.width_px)
