"""Stage ``entry_bins``: the boundary faces rays may enter through binned into screen tiles
(:mod:`warpvol.shared.entry_bins`, shared with the sweep's audit and HARC's ray start)."""

from __future__ import annotations

import numpy as np

from warpvol.shared.entry_bins import ENTRY_MESH_PROPERTIES, bin_boundary_faces
from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class EntryBins(Stage):
    """Bin the boundary faces rays may enter through into screen tiles (ray start / re-entry search):
    the mesh's, or the visible sub-mesh's when ``cell_setup`` confines the walk to the visible cells
    (``cells["entry_faces"]``).

    ==========  =====  =======  ======================================
    parameter   type   default  meaning
    ==========  =====  =======  ======================================
    tile        int    8        tile edge in pixels (1 .. 256)
    ==========  =====  =======  ======================================
    """

    name = "entry_bins"
    summary = "bin entry boundary faces into screen tiles for ray entry"
    needs = ()
    provides = ("entry_bins",)
    params = (Param("tile", int, 8, "tile edge in pixels", lo=1, hi=256),)

    def run(self, ctx: Context) -> None:
        import warp as wp

        faces = ctx.buffers.get("cells", {}).get("entry_faces")
        ctx.mesh_setup(ctx.scene.mesh, *ENTRY_MESH_PROPERTIES)
        b = bin_boundary_faces(ctx.scene.mesh, ctx.scene.camera, self.tile, faces)
        ctx.stats["entry_faces"] = int(len(b["bface_tet"]))
        ctx.stats["entry_bin_items"] = int(len(b["tile_items"]))
        ctx.buffers["entry_bins"] = {
            k: (wp.array(v, dtype=wp.vec3 if k == "item_depth" else wp.int32, device=ctx.device)
                if isinstance(v, np.ndarray) else v)
            for k, v in b.items()
        }
