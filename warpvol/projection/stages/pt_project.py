"""Stage ``pt_project``: Shirley & Tuchman classification and decomposition on the device
(:func:`warpvol.projection.pt.decompose`) of every tet in the visibility order.

Reads ``ctx.buffers["vertices"]`` (stage ``vertex``) and ``ctx.buffers["order"]`` (stage ``sort``);
stores :class:`warpvol.projection.pt.PTGeometry` in ``ctx.buffers["pt_geometry"]``. Counts ``tets_projected``,
one counter per class (``class_four_triangle``, ``class_three_triangle``, the degenerate 3-triangle
cases ``class_vertex_on_edge`` and ``class_vertex_on_vertex``, ``class_flat`` (projection a segment or
a point), ``class_culled``), ``triangles`` (non-degenerate triangles emitted) and ``thick_vertex_moved``.
"""

from __future__ import annotations

from warpvol.projection.pt import decompose
from warpvol.projection.pt_thin import unresolved_pixels
from warpvol.stage import Context, Param, Stage, register_stage

#: optical-depth error bound of a thin cell above which a preset without a float64 redo reports its pixels
#: as possibly wrong: 0.1, far above a frame buffer's rounding (the bound is conservative: on the Blunt Fin
#: the thin cells it flags at 2e-3 are wrong by at most 1.4e-3 in pt_best's fp32 buffer)
WARN_TAU = 0.1


@register_stage
class PTProject(Stage):
    """Classify each projected tet (3/4 triangles, degenerate, flat, culled) and split it.

    ==============  =====  =========  ==============================================================
    parameter       type   default    meaning
    ==============  =====  =========  ==============================================================
    check_float32   bool   true       find the cells float32 cannot draw right (thin cells that carry
                                      the image) and report their pixels as a warning; off where a
                                      later stage redoes them (``pt_integrate`` in fp32)
    exact_attrs     bool   false      attributes where they belong: a 4-triangle tet's thick vertex
                                      carries those of its unsnapped diagonals' crossing, and the
                                      fused draw (``pt_integrate walk = "fused"``) sets its attribute
                                      planes up from the unsnapped positions; coverage stays the
                                      snapped one. Off: the attributes of the snapped positions, as
                                      the hardware draws them
    ==============  =====  =========  ==============================================================

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
    params = (Param("check_float32", bool, True, "report pixels of cells float32 cannot draw right "
                    "(thin cells) as a warning"),
              Param("exact_attrs", bool, False, "attributes of the unsnapped positions (the thick vertex's at "
                    "the unsnapped diagonals' crossing) for the fused draw's attribute planes"))

    def run(self, ctx: Context) -> None:
        geo = decompose(ctx.scene.mesh, ctx.buffers["vertices"], ctx.buffers["order"], device=ctx.device,
                        exact_attrs=self.config["exact_attrs"])
        ctx.buffers["pt_geometry"] = geo
        ctx.count(tets_projected=geo.n_tets, triangles=geo.live_triangles(), thick_vertex_moved=geo.moved,
                  **{f"class_{k}": v for k, v in geo.classes.items()})
        if self.config["check_float32"]:
            self.check_float32(ctx)

    def check_float32(self, ctx: Context) -> None:
        """A faithful preset draws what its arithmetic gives; where that may be visibly wrong (a thin
        cell's thickness error worth more than :data:`WARN_TAU` of optical depth) the report says how
        many pixels."""

        sc = ctx.scene
        u = unresolved_pixels(sc.mesh, sc.transfer, sc.camera, tau=WARN_TAU, silhouettes=False, edge_on=False)
        st = {"thin_tets": u["thin_tets"], "pixels": int(len(u["pixels"]))}
        if len(u["pixels"]):
            st["warning"] = (f"{len(u['pixels'])} pixels are covered by {u['thin_tets']} cells thinner than float32 "
                             "resolves at their extinction: drawn as the emulated hardware computes them (may be "
                             "visibly wrong; pt_best redoes such pixels in float64)")
        ctx.stats["pt_project"] = st
