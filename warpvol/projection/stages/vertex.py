"""Stage ``vertex``: the vertex stage of the emulated GPU (model-view / projection / viewport).

First decides with :func:`warpvol.projection.pt.eye_plane_check` whether cell projection can draw the view
(with the ``visibility`` stage before it and skipping on, from the cells the transfer function makes visible):
a tet crossing (or behind) the eye plane while others are seen is an error naming what to use
instead; a mesh entirely behind the eye or outside the view gives a transparent image at once
(``stats.pt.note``; the later stages are skipped). Else transforms the mesh's points with the scene
camera (near/far planes enclosing the mesh, near below the smallest vertex depth) and stores :class:`warpvol.gpu.vertex.Vertices` in
``ctx.buffers["vertices"]`` (eye, clip and window coordinates; ``window_array`` feeds the
rasteriser directly) and the matrices in ``ctx.buffers["vertex_stage"]``.
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError
from warpvol.gpu.raster import GUARD_PX, guard_band_overflow
from warpvol.gpu.vertex import VertexStage
from warpvol.projection.pt import eye_plane_check
from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class Vertex(Stage):
    """Transform mesh points to window coordinates.

    ==========  =====  =======  ===========  ===================================================
    parameter   type   default  allowed      meaning
    ==========  =====  =======  ===========  ===================================================
    near        float  0.0      >= 0         near plane distance; 0: from the mesh bounds
    far         float  0.0      >= 0         far plane distance; 0: from the mesh bounds
    eye_origin  str    eye      ``eye``      eye-space origin of the output: the eye (the
                                ``data``     hardware's), or moved along the view axis to the
                                             depth of the mesh's bounding-box centre, so depth
                                             differences keep float32 precision with the eye far
                                             away (``pt_best``; window coordinates unchanged)
    ==========  =====  =======  ===========  ===================================================

    Example
    -------
    >>> from warpvol.scene.builtin import builtin_scene
    >>> from warpvol.pipeline import Context
    >>> ctx = Context(scene=builtin_scene("box").with_camera(width_px=8, height_px=8), quiet=True)
    >>> Vertex().run(ctx)
    >>> ctx.buffers["vertices"].window.shape[1]
    4
    """

    name = "vertex"
    summary = "vertex stage: model-view / projection transform, perspective division, viewport"
    needs = ()
    provides = ("vertex_stage", "vertices")
    params = (
        Param("near", float, 0.0, "near plane distance (0: enclose the mesh bounds)", lo=0.0),
        Param("far", float, 0.0, "far plane distance (0: enclose the mesh bounds)", lo=0.0),
        Param("eye_origin", str, "eye", "eye-space origin of the output: the eye (hardware) or the data's depth "
              "(float32 depth differences stay accurate with a far eye)", choices=("eye", "data")),
    )

    def validate(self) -> None:
        if self.config["near"] and self.config["far"] and self.config["far"] <= self.config["near"]:
            raise ConfigError(f"{self.where}.far: {self.config['far']} must exceed near ({self.config['near']})")

    def run(self, ctx: Context) -> None:
        cam, mesh = ctx.scene.camera, ctx.scene.mesh
        vis = ctx.buffers.get("visible_cells") if ctx.skip else None  # the cells the later stages draw
        view = eye_plane_check(mesh, cam, None if vis is None or vis.all() else np.flatnonzero(vis))
        if view.status == "refuse":
            raise ConfigError(f"{self.where}: {view.message}")
        if view.status == "empty":  # nothing in view: a transparent image, the later stages skipped
            ctx.image = np.zeros((cam.height_px, cam.width_px, 4), dtype=np.float32)
            ctx.stats["pt"] = {"note": view.message}
            ctx.count(primitives_culled=mesh.n_tets)
            ctx.finished = "nothing in view (every tet behind the eye plane or outside the view)"
            return
        near, far = view.near, view.far
        near = self.config["near"] or near
        far = self.config["far"] or max(far, near * 1.0001 + 1e-6)
        offset = 0.0
        if self.config["eye_origin"] == "data":  # depth of the bounds' centre, in float64
            lo, hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds)
            offset = float(np.dot((lo + hi) / 2.0 - cam.eye, cam.forward))
        vs = VertexStage.from_camera(cam, near, far, device=ctx.device, eye_offset=offset)
        vertices = vs.transform(mesh.points)
        n_over, extent = guard_band_overflow(vertices.window, mesh.tets, cam.width_px, cam.height_px)
        if n_over:  # the rasteriser would drop them: a wrong image, never drawn silently
            raise ConfigError(f"{self.where}: {n_over:,} tets reach {extent:.3g} px from the image, beyond the "
                              f"rasteriser's guard band of {GUARD_PX:.0f} px (fixed-point window coordinates, no "
                              "geometric clipping): cell projection cannot draw them — use raycast, or a view that "
                              "shows more of the mesh (a wider field of view, the eye farther away)")
        ctx.buffers["vertex_stage"] = vs
        ctx.buffers["vertices"] = vertices
