"""Host step ``vsb_setup``: the scene's mesh as convex cells for the VSBUFFER renderer.

``cells = "tets"``: one cell per tet (the paper's tetrahedralised data sets). ``cells = "native"``:
the cells the mesh was split from, drawn whole (hexahedra, wedges, pyramids: the issue's "rendered
without splitting"), where the loader recorded them (:attr:`warpvol.scene.mesh.TetMesh.cell_start`, set for
structured grids and for unstructured grids of non-tet cells; a tet-only mesh has none and stays one
cell per tet). Source cells that are not convex within float32 resolution (hexahedra with non-planar
faces folded inwards: :attr:`warpvol.vsbuffer.cells.ConvexCellMesh.nonconvex`) are drawn as their tets,
counted in ``stats["nonconvex_cells"]`` and said in ``stats["note"]``. The field is the same either
way (each cell integrated over its tets). Builds and
caches the derived data the sweep needs (cell-boundary triangles, per-cell bounding boxes); reports
the cells, by kind (``cells_by_type``), in ``stats`` (host pre-processing, which the paper's timings leave
out, as they do its octree build).
Buffers: ``ctx.buffers["vsb_cells"]`` (a :class:`warpvol.vsbuffer.cells.ConvexCellMesh`).
"""

from __future__ import annotations

import weakref

import numpy as np

from warpvol.stage import Context, Param, Stage, register_stage
from warpvol.vsbuffer.cells import ConvexCellMesh


@register_stage
class VsbSetup(Stage):
    """Wrap the scene's mesh as convex cells (cached per mesh across renders).

    ==========  =====  =========  ==================================================================
    parameter   type   default    meaning
    ==========  =====  =========  ==================================================================
    cells       str    tets       ``tets`` (one cell per tet) | ``native`` (the source cells whole,
                                  where the mesh records them)
    ==========  =====  =========  ==================================================================

    Example
    -------
    >>> import pyvista as pv, warpvol
    >>> g = pv.ImageData(dimensions=(3, 3, 3)); g.point_data["s"] = g.points[:, 0]
    >>> s = warpvol.builtin_scene("box").with_camera(width_px=8, height_px=8)
    >>> r = warpvol.render(g, s.transfer, s.camera, scalars="s", pipeline="vsbuffer_best", reference=False)
    >>> r.report["stats"]["vsb_setup"]["cells_by_type"]     # 8 hexes, drawn whole
    {'hex': 8}
    """

    name = "vsb_setup"
    summary = "the scene's mesh as convex cells (boundary triangles, bounding boxes) for the VSBUFFER"
    params = (Param("cells", str, "tets", "one cell per tet, or the mesh's source cells whole",
                    choices=("tets", "native")),)
    needs = ()
    provides = ("vsb_cells",)
    setup = True

    def run(self, ctx: Context) -> None:
        mesh = ctx.scene.mesh
        native = self.config["cells"] == "native" and getattr(mesh, "cell_start", None) is not None
        key = ("vsb_cells", native)
        hit = ctx.persistent.get(key)  # (weak reference to the mesh, its cells): an id() may be reused
        cm = mesh if isinstance(mesh, ConvexCellMesh) else hit[1] if hit is not None and hit[0]() is mesh else None
        cached = cm is not None and not isinstance(mesh, ConvexCellMesh)
        if cm is None:
            cm = ConvexCellMesh(mesh, mesh.cell_start) if native else ConvexCellMesh.from_tetmesh(mesh)
            ctx.persistent[key] = (weakref.ref(mesh), cm)
        # cells that are not convex within float32 resolution (a non-planar face folded in) are drawn
        # as their tets: the VSBUFFER's two passes find the cross-sections of convex cells only
        nonconvex = int(cm.nonconvex.sum())
        cm = cm.drawable
        # derived data built here, not in the timed sweep (the pieces' planes and gradients: the walk's cells)
        _ = cm.boundary, cm.cell_bounds, cm.nonconvex, cm.pieces.face_planes, cm.pieces.gradients
        # cell kinds by boundary triangles: tet 4, pyramid 6, wedge 8, hexahedron 12 (else "other")
        nf = np.bincount(cm.face_cell, minlength=cm.n_cells)
        kinds = {k: int((nf == f).sum()) for k, f in (("tet", 4), ("pyramid", 6), ("wedge", 8), ("hex", 12))}
        kinds["other"] = cm.n_cells - sum(kinds.values())
        # pre-processing, outside the paper's timings (like its octree build): nothing for the GPU model
        ctx.stats["vsb_setup"] = {"cells": cm.n_cells, "tets": cm.n_tets, "boundary_triangles": len(cm.boundary),
                                  "cells_by_type": {k: v for k, v in kinds.items() if v},
                                  "native": bool(native or isinstance(mesh, ConvexCellMesh)), "cached": cached,
                                  "nonconvex_cells": nonconvex}
        if nonconvex:
            ctx.stats["vsb_setup"]["note"] = (
                f"{nonconvex} source cells are not convex (non-planar faces folded in, beyond float32 "
                "resolution) and are drawn as their tets")
        ctx.buffers["vsb_cells"] = cm
