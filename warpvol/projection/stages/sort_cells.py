"""Host step ``sort``: visibility order of the cells for cell projection (:mod:`warpvol.projection.sort`):
centroid (numeric), MPVO, MPVONC or XMPVO.

Stores the back-to-front order (int32 cell indices) in ``ctx.buffers["order"]`` and what is known
about it in ``ctx.stats["sort"]`` (method run, whether it is exact, why not); counts
``cells_sorted``, ``graph_edges`` and ``cycles_broken`` (XMPVO also ``boundary_fragments`` and
``ray_constraints``).

XMPVO rasterises its whole boundary, as Silva, Mitchell & Williams 1998 and Guthe et al. 2002 ran it.
Two options beyond the papers, which only ``pt_best`` turns on: ``boundary = "off_hull"`` leaves the
boundary faces on the convex hull out of the rasterised boundary (:func:`~warpvol.projection.sort.hull_faces`;
a ray never leaves the mesh and re-enters across one), ``visible_alone = true`` sorts the visible
cells alone (below), and ``lean = true`` (MPVO and XMPVO) computes the same order on per-frame kernels over
arrays kept on the mesh (:func:`~warpvol.projection.sort.mpvo_order`: no per-frame copies of the mesh, the
in-degrees counted by a kernel, XMPVO's off-hull boundary fragments as (face, depth) alone).

With the ``visibility`` stage before it (skipping on) the order keeps only the cells the transfer
function can make visible (``ctx.buffers["visible_cells"]``): the whole mesh is sorted (an invisible
cell can still be what orders two visible ones), then the invisible cells are dropped. A subsequence
of a visibility order is a visibility order of the cells it keeps, and an invisible cell composites
as the identity, so the image is the same; the later stages project, rasterise and integrate only
what is left. With ``visible_alone``, XMPVO sorts the visible cells alone, as a mesh of their own
(:func:`~warpvol.projection.sort.visible_submesh`), where that costs less
(:func:`~warpvol.projection.sort.xmpvo_cost`: its boundary to rasterise, its cells) and meets no cycle;
``stats.sort.sorted`` says which. The report's ``left_out`` counts ``cells_culled``.
"""

from __future__ import annotations

from warpvol.errors import ConfigError
from warpvol.projection.pt_thin import project_points
from warpvol.projection.sort import (
    METHODS,
    METRICS,
    keep_lean_arrays,
    lean_arrays_kept,
    visibility_order,
    visible_submesh,
    xmpvo_cost,
)
from warpvol.stage import Context, Param, Stage, register_stage

BOUNDARY = ("all", "off_hull")


@register_stage
class SortCells(Stage):
    """Centroid, MPVO, MPVONC or XMPVO visibility sort (back to front).

    =============  =====  ========  ========================================  =========================
    parameter      type   default   allowed                                   meaning
    =============  =====  ========  ========================================  =========================
    method         str    auto      ``auto`` ``centroid`` ``mpvo``            ``auto``: MPVO for convex
                                    ``mpvonc`` ``xmpvo``                      meshes, else MPVONC;
                                                                              ``xmpvo``: exact at the
                                                                              pixel centres
    metric         str    distance  ``distance`` | ``view``                   centroid key (perspective)
    applies_to     str    any       ``any`` ``convex`` ``non_convex``         planner: run only for
                                                                              meshes of this kind, else
                                                                              skipped with the reason
    boundary       str    all       ``all`` | ``off_hull``                    XMPVO only: the boundary
                                                                              faces rasterised; ``all``
                                                                              as published,
                                                                              ``off_hull`` leaves the
                                                                              convex hull's faces out
                                                                              (fewer fragments; the
                                                                              same constraints but at
                                                                              float32 depth ties)
    visible_alone  bool   false     ``true`` | ``false``                      XMPVO only, with the
                                                                              visibility stage: sort
                                                                              the visible cells alone
                                                                              where cheaper (same image)
    lean           bool   false     ``true`` | ``false``                      MPVO and XMPVO: the same
                                                                              order on lean per-frame
                                                                              kernels (arrays kept on
                                                                              the mesh)
    =============  =====  ========  ========================================  =========================

    ``boundary = "off_hull"``, ``visible_alone = true`` and ``lean = true`` are improvements beyond the papers
    (``pt_best`` turns them on); a faithful preset keeps the defaults.

    A preset lists ``sort`` twice (``method = "mpvo"``, ``applies_to = "convex"`` and
    ``method = "mpvonc"``, ``applies_to = "non_convex"``): the planner runs one and reports the
    other under ``skipped``.

    Example
    -------
    >>> from warpvol.scene.builtin import builtin_scene
    >>> ctx = Context(scene=builtin_scene("concave"), quiet=True)
    >>> SortCells(method="auto").run(ctx)
    >>> ctx.stats["sort"]["method"], ctx.stats["sort"]["exact"]
    ('mpvonc', False)
    """

    name = "sort"
    summary = "visibility sort of the cells: centroid (numeric), MPVO (convex), MPVONC or XMPVO (non-convex)"
    params = (
        Param("method", str, "auto", "sorting method (auto: MPVO if the mesh is convex, else MPVONC)",
              choices=METHODS),
        Param("metric", str, "distance", "centroid key: distance to the eye or depth along the view",
              choices=METRICS),
        Param("applies_to", str, "any", "planner: run only for convex / non-convex meshes",
              choices=("any", "convex", "non_convex")),
        Param("boundary", str, "all", "XMPVO: boundary faces rasterised (all: as published; off_hull: the convex "
              "hull's faces left out)", choices=BOUNDARY),
        Param("visible_alone", bool, False, "XMPVO with the visibility stage: sort the visible cells alone, as a "
              "mesh of their own, where cheaper"),
        Param("lean", bool, False, "MPVO and XMPVO: the same order on lean per-frame kernels over arrays kept on "
              "the mesh"),
    )
    provides = ("order",)

    def validate(self) -> None:
        if self.config["lean"] and self.config["method"] not in ("mpvo", "xmpvo"):
            raise ConfigError(f"{self.where}.lean: applies to method = 'mpvo' or 'xmpvo' only (method is "
                              f"{self.config['method']!r}); leave it out")
        for name, default in (("boundary", "all"), ("visible_alone", False)):
            if self.config[name] != default and self.config["method"] != "xmpvo":
                raise ConfigError(f"{self.where}.{name}: applies to method = 'xmpvo' only (method is "
                                  f"{self.config['method']!r}); leave it out")

    def skip_reason(self, ctx: Context) -> str | None:
        want = self.config["applies_to"]
        if want == "any":
            return None
        ctx.mesh_setup(ctx.scene.mesh, "is_convex")  # per mesh, kept on it: set-up on first use
        convex = ctx.scene.mesh.is_convex
        if want == "convex" and not convex:
            return f"non-convex boundary: {self.config['method']} applies to convex meshes only"
        if want == "non_convex" and convex:
            return (f"convex boundary: MPVO gives an exact order, {self.config['method']} not needed")
        return None

    def leaves_out(self, ctx: Context) -> str | None:
        return ("with the visibility stage before it: the cells the transfer function makes invisible, "
                "dropped from the order after the sort (not projected, rasterised or integrated)")

    def visible_only(self, ctx: Context, vis):
        """``(sub, cells)`` (:func:`warpvol.projection.sort.visible_submesh`, built as set-up) when XMPVO on
        the visible cells alone costs less than on the whole mesh (:func:`~warpvol.projection.sort.xmpvo_cost`),
        else ``None``."""

        mesh, cam = ctx.scene.mesh, ctx.scene.camera
        off_hull = self.config["boundary"] == "off_hull"
        got = visible_submesh(mesh, vis, cached_only=True)
        if got is None:
            with ctx.setup_work("visible cells as a mesh"):
                got = visible_submesh(mesh, vis, off_hull=off_hull)
        if got[0] is None:
            return None
        proj = project_points(mesh, cam)  # the visible cells' mesh has the same points
        if xmpvo_cost(got[0], cam, off_hull=off_hull, proj=proj) >= xmpvo_cost(mesh, cam, off_hull=off_hull, proj=proj):
            return None
        return got

    def run(self, ctx: Context) -> None:
        mesh = ctx.scene.mesh
        off_hull = self.config["boundary"] == "off_hull"
        if "_sort_centroids" not in vars(mesh) or (off_hull and "_hull_faces" not in vars(mesh)):  # per mesh: set-up
            from warpvol.projection.sort import centroids, hull_faces

            with ctx.setup_work("cell centroids" + (", boundary faces on the hull" if off_hull else "")):
                centroids(mesh)
                if off_hull:
                    hull_faces(mesh)
        vis = ctx.buffers.get("visible_cells") if ctx.skip else None
        sub = (self.visible_only(ctx, vis) if self.config["visible_alone"] and vis is not None
               and 0 < vis.sum() < len(vis) else None)
        lean = self.config["lean"]
        for m in (mesh,) if sub is None else (mesh, sub[0]):
            if lean and not lean_arrays_kept(m, off_hull):  # per mesh (the visible cells: per TF): set-up
                with ctx.setup_work("the lean sort's arrays"):
                    keep_lean_arrays(m, off_hull)
        if sub is not None:  # XMPVO on the visible cells alone: cheaper here than on the whole mesh
            r = visibility_order(sub[0], ctx.scene.camera, "xmpvo", self.config["metric"], off_hull=off_hull,
                                 lean=self.config["lean"])
            kept = sub[1][r.order]
            if r.cycles_broken:  # approximate: the whole mesh's order, exact where that one is
                sub = None
        if sub is None:
            r = visibility_order(mesh, ctx.scene.camera, self.config["method"], self.config["metric"],
                                 off_hull=off_hull, lean=self.config["lean"])
            kept = r.order if vis is None else r.order[vis[r.order]]
        ctx.buffers["order"] = kept
        if vis is not None:
            ctx.left_out(why="cells the transfer function makes invisible (zero extinction and colour over "
                         "their scalar range): dropped from the visibility order, or (XMPVO with visible_alone, "
                         "where cheaper) only the visible cells sorted, as a mesh of their own; not drawn",
                         cells_culled=mesh.n_tets - len(kept))
        info = {"method": r.method, "exact": r.exact}
        if self.config["visible_alone"] and vis is not None:
            info["sorted"] = "visible cells" if sub is not None else "whole mesh"
        if r.note:
            info["approximate"] = r.note
        if self.config["method"] == "auto":
            info["planner"] = ("convex boundary: MPVO" if mesh.is_convex
                               else "non-convex boundary: MPVONC")
        if r.cycles_broken:
            info["cycles_broken"] = int(r.cycles_broken)
            info["warning"] = (f"visibility order approximate: {r.method} broke {int(r.cycles_broken):,} cycle(s) of the "
                               "cells' in-front-of relation; cells in a cycle are drawn in an order that is wrong for "
                               "some pixels")
        ctx.stats["sort"] = info
        ctx.count(cells_sorted=len(r.order), graph_edges=r.edges, cycles_broken=r.cycles_broken, **r.extra)
