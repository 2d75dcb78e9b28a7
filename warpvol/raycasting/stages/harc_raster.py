"""Host step ``harc_raster``: ray start by rasterising the front-facing boundary faces."""

from __future__ import annotations

from warpvol.shared.entry_bins import ENTRY_MESH_PROPERTIES
from warpvol.stage import Context, Stage, register_stage


@register_stage
class HarcRaster(Stage):
    """Rasterise the front-facing boundary faces (vertex stage + rasteriser unit) into per-pixel
    fragment lists (entry tet, local face) sorted by depth: the first is the ray's entry, the next
    ones the layers depth peeling goes through (:func:`warpvol.raycasting.harc.entry_fragments`); and
    per pixel the faces whose open edge passes within 1/64 pixel of its centre, which the ray start
    tests exactly (:func:`warpvol.shared.thin_cells.edge_pixels`; ``edge_pixel_faces`` counts the pairs).
    When ``cell_setup`` confines the walk to the cells the transfer function makes visible, the faces are
    the visible sub-mesh's boundary (``cells["entry_faces"]``).

    ==========  =====  =========  ===========================
    parameter   type   default    meaning
    ==========  =====  =========  ===========================
    (none)
    ==========  =====  =========  ===========================
    """

    name = "harc_raster"
    summary = "ray start: rasterise front-facing boundary faces (entry tet and depth order per pixel)"
    needs = ()
    provides = ("harc_entry",)

    def run(self, ctx: Context) -> None:
        from warpvol.raycasting.harc import entry_fragments

        faces = ctx.buffers.get("cells", {}).get("entry_faces")  # the visible sub-mesh's (cell_setup)
        ctx.mesh_setup(ctx.scene.mesh, *ENTRY_MESH_PROPERTIES)
        e = entry_fragments(ctx.scene.mesh, ctx.scene.camera, ctx.device, faces)
        ctx.buffers["harc_entry"] = e
        # the vertex stage and the rasteriser count their own work (vertices, primitives, fragments)
        ctx.stats["harc_raster"] = {"front_faces": e["faces"], "fragments": e["fragments"],
                                    "boundary_layers": e["max_layers"], "edge_pixel_faces": e["edge_pairs"]}
