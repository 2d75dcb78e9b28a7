"""Stage ``pt_project``: Shirley & Tuchman classification and decomposition on the device
(:func:`warpvol.projection.pt.decompose`) of every tet in the visibility order.

Reads ``ctx.buffers["vertices"]`` (stage ``vertex``) and ``ctx.buffers["order"]`` (stage ``sort``);
stores :class:`warpvol.projection.pt.PTGeometry` in ``ctx.buffers["pt_geometry"]``. Counts ``tets_projected``,
one counter per class (``class_four_triangle``, ``class_three_triangle``, the degenerate 3-triangle
cases ``class_vertex_on_edge`` and ``class_vertex_on_vertex``, ``class_flat`` (projection a segment or
a point), ``class_culled``), ``triangles`` (non-degenerate triangles emitted) and ``thick_vertex_moved``.
"""

from __future__ import annotations

from warpvol.stage import Context, Stage, register_stage


@register_stage
class PTProject(Stage):
    """Classify each projected tet (3/4 triangles, degenerate, flat, culled) and split it.

    (no parameters)

    Example
    -------
    >>> from warpvol.scene.builtin import builtin_scene
    >>> from warpvol.projection.stages.vertex import Vertex
    >>> from warpvol.projection.stages.sort_cells import SortCells
    >>> ctx = Context(scene=builtin_scene("sphere").with_camera(width_px=8, height_px=8), quiet=True)
    >>> for st in (Vertex(), SortCells(), PTProject()):
    ...     st.run(ctx)
    >>> ctx.buffers["pt_geometry"].classes["four_triangle"] > 0
    True
    """

    name = "pt_project"
    summary = "projected tetrahedra: Shirley-Tuchman classification and decomposition (thick vertex: sf, sb, l)"
    needs = ("vertices", "order")
    provides = ("pt_geometry",)

    def run(self, ctx: Context) -> None:
        from warpvol.projection.pt import decompose

        geo = decompose(ctx.scene.mesh, ctx.buffers["vertices"], ctx.buffers["order"], device=ctx.device)
        ctx.buffers["pt_geometry"] = geo
        ctx.count(tets_projected=geo.n_tets, triangles=geo.live_triangles(), thick_vertex_moved=geo.moved,
                  **{f"class_{k}": v for k, v in geo.classes.items()})
