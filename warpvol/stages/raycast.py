"""Stage ``raycast``: float32 ray propagation through the cell adjacency (first pass).

Each pixel's ray enters at the nearest front-facing boundary face of its screen tile (from
``entry_bins``), walks cell to cell (exit face = smallest positive plane distance among faces the ray
leaves through; next cell = neighbour across it), integrates each segment exactly for the
piecewise-linear transfer function and composites front to back. The pass ends where the ray leaves
the mesh; for non-convex meshes the ``peel`` stage continues from there.

On the CPU a Warp launch runs its threads serially, so the image is cut into row blocks that a pool
of host threads launches concurrently (``threads``); Warp releases the GIL while a CPU kernel runs.
"""

from __future__ import annotations

import numpy as np

from ..parallel import blocks, cpu_threads, launch_blocks
from ..pipeline import Context, Param, Stage, register_stage


class MarchState:
    """Per-pixel ray state on the device: radiance, transmittance, ray parameter, status."""

    def __init__(self, n: int, device: str):
        import warp as wp

        from ..kernels import raycast as k

        self.n, self.device = n, device
        self.rgb = wp.zeros(n, dtype=wp.vec3, device=device)
        self.trans = wp.zeros(n, dtype=wp.float32, device=device)
        self.tcur = wp.zeros(n, dtype=wp.float32, device=device)
        self.status = wp.zeros(n, dtype=wp.int32, device=device)
        wp.launch(k.init_state, dim=n, inputs=[self.rgb, self.trans, self.tcur, self.status, 0.0], device=device)

    def image(self, height: int, width: int) -> np.ndarray:
        import warp as wp

        from ..kernels import raycast as k

        out = wp.zeros(self.n, dtype=wp.vec4, device=self.device)
        wp.launch(k.finish, dim=self.n, inputs=[self.rgb, self.trans, out], device=self.device)
        return out.numpy().reshape(height, width, 4)


def locate_point(mesh, p: np.ndarray) -> int:
    """Index of a tet containing point ``p`` (float64, boundary inclusive up to rounding), -1 if none."""
    fp = mesh.face_planes
    dist = fp[..., :3] @ np.asarray(p, dtype=np.float64) + fp[..., 3]  # (M, 4), <= 0 inside
    tol = 1e-12 * float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
    inside = np.nonzero((dist <= tol).all(axis=1))[0]
    return int(inside[0]) if len(inside) else -1


def march_pass(ctx: Context, state: MarchState, *, max_steps: int, t_min: float, threads: int,
               start_cell: int = -1, rows_per_block: int = 16) -> np.ndarray:
    """One propagation pass over all active rays; returns summed counters (entries, steps, stuck).

    ``start_cell >= 0`` (first pass of a perspective view whose eye lies in that cell): rays start
    walking there at ``t = 0`` instead of searching the boundary."""
    import warp as wp

    from ..kernels import raycast as k

    cam, mesh = ctx.scene.camera, ctx.scene.mesh
    cells, bins = ctx.buffers["cells"], ctx.buffers["entry_bins"]
    w, h = cam.width_px, cam.height_px
    if cam.projection == "perspective":
        half_h = float(np.tan(np.radians(cam.fov_y_deg) / 2.0))
    else:
        half_h = cam.height / 2.0
    diam = float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
    # the kernel works relative to the cell origin; float32 rounding of a point on the ray is a
    # couple of ulps of the largest coordinate in play there
    origin = cells["origin"]
    eye = cam.eye - origin
    coord = max(float(np.abs(eye).max()), float(np.abs(mesh.bounds[0] - origin).max()),
                float(np.abs(mesh.bounds[1] - origin).max()))
    on_cpu = str(ctx.device).startswith("cpu")
    rows = blocks(h, rows_per_block if on_cpu else h)
    counters = wp.zeros((len(rows), 3), dtype=wp.int32, device=ctx.device)
    common = [w, h, wp.vec3(*eye), wp.vec3(*cam.forward), wp.vec3(*cam.right), wp.vec3(*cam.true_up),
              int(cam.projection == "orthographic"), half_h, float(cam.aspect),
              cells["planes"], cells["grad"], cells["adj"], bins["bface_tet"], bins["bface_local"],
              bins["tile_start"], bins["tile_items"], bins["tile"], bins["tiles_x"],
              cells["tf_s"], cells["tf_v"], cells["model"], max_steps,
              1e-6 * (diam + float(np.linalg.norm(eye))), 2.5e-7 * coord, 1e-6 * diam, t_min, start_cell]

    def launch(b: int) -> None:
        r0, nr = rows[b]
        wp.launch(k.march, dim=nr * w, device=ctx.device,
                  inputs=common + [r0, state.rgb, state.trans, state.tcur, state.status, counters, b])

    launch_blocks(ctx.device, len(rows), launch, threads)
    return counters.numpy().sum(axis=0)


RAY_PARAMS = (
    Param("max_steps", int, 1_000_000, "cell steps per ray and pass before giving up", lo=1),
    Param("t_min", float, 1e-6, "early ray termination below this transmittance (0: off)", lo=0.0, hi=1.0),
    Param("threads", int, 0, "host threads launching row blocks on the CPU (0: all cores)", lo=0, hi=256),
)


@register_stage
class Raycast(Stage):
    """First ray-propagation pass (entry at the nearest boundary face, walk to the boundary exit).

    A perspective eye inside the mesh starts every ray in the cell that contains it (point location
    on the host). An orthographic eye plane that cuts the mesh is reported as a warning in the
    report's ``stats`` (rays then start at the boundary in front of the plane).

    ==========  =====  =========  =============================================================
    parameter   type   default    meaning
    ==========  =====  =========  =============================================================
    max_steps   int    1000000    cell steps per ray and pass before giving up (>= 1)
    t_min       float  1e-6       early termination below this transmittance, [0, 1] (0: off)
    threads     int    0          host threads launching CPU row blocks (0: all cores)
    ==========  =====  =========  =============================================================

    Needs ``cell_setup`` and ``entry_bins`` before it; writes ``ctx.image``.
    """

    name = "raycast"
    summary = "float32 ray propagation through cell adjacency, exact piecewise-linear segment integrals"
    needs = ("cells", "entry_bins")
    provides = ("march", "image")
    params = RAY_PARAMS

    def run(self, ctx: Context) -> None:
        cam = ctx.scene.camera
        state = MarchState(cam.width_px * cam.height_px, ctx.device)
        ctx.buffers["march"] = state
        threads = self.threads or cpu_threads()
        start = -1
        if cam.projection == "perspective":
            lo, hi = ctx.scene.mesh.bounds
            if (cam.eye >= lo).all() and (cam.eye <= hi).all():
                start = locate_point(ctx.scene.mesh, cam.eye)
        elif self._eye_plane_cuts_mesh(ctx):
            ctx.stats["warning"] = ("orthographic eye plane cuts the mesh: rays start at the boundary "
                                    "faces in front of it, the part of the mesh the eye plane lies in is missed")
            ctx.progress("warning: " + ctx.stats["warning"])
        c = march_pass(ctx, state, max_steps=self.max_steps, t_min=self.t_min, threads=threads, start_cell=start)
        ctx.count(rays=cam.width_px * cam.height_px, entries=int(c[0]), cell_steps=int(c[1]))
        ctx.stats["raycast"] = {"entries": int(c[0]), "cell_steps": int(c[1]), "unfinished_rays": int(c[2]),
                                "eye_cell": start}
        ctx.image = state.image(cam.height_px, cam.width_px)

    @staticmethod
    def _eye_plane_cuts_mesh(ctx: Context) -> bool:
        cam, mesh = ctx.scene.camera, ctx.scene.mesh
        depth = (mesh.points - cam.eye) @ cam.forward
        return bool(depth.min() < 0.0 < depth.max())
