"""Host step ``table_cylindrical``: cylindrical 2D planes of the 3D table (Roettger & Ertl 2002 §4)."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.base import TABLE_FORMATS
from warpvol.tables.stages.support import LMAX, TableStage, output_param


@register_stage
class TableCylindrical(TableStage):
    """Resample the 3D table into α-planes (eq. 9) tiled into an atlas; two-plane reconstruction.

    ==========  =====  =========  ==========================================================
    parameter   type   default    meaning
    ==========  =====  =========  ==========================================================
    n_s         int    64         3D table / plane resolution
    n_l         int    0          thickness resolution of the 3D table; 0 = n_s
    lmax        float  0          thickness at l = 1; 0 = the mesh's longest edge
    planes      str    4x         planes relative to n_s: ``4x`` | ``2x`` | ``1x``
    source      str    table      ``table`` (resample the exact 3D table) | ``exact``
    format      str    rgba8      stored format
    output      str    planes     ``ctx.buffers`` key
    ==========  =====  =========  ==========================================================
    """

    name = "table_cylindrical"
    summary = "cylindrical alpha-planes of the 3D table, tiled atlas (2D texturing)"
    needs = ()
    provides = ("{output}",)
    builder = "cylindrical"
    params = (
        Param("n_s", int, 64, "plane resolution", lo=2, hi=4096),
        Param("n_l", int, 0, "3D table thickness resolution; 0 = n_s", lo=0, hi=4096),
        LMAX,
        Param("planes", str, "4x", "number of planes", choices=("4x", "2x", "1x")),
        Param("source", str, "table", "resampled table or exact integrals", choices=("table", "exact")),
        Param("format", str, "rgba8", "stored format", choices=TABLE_FORMATS[:4]),
        output_param("planes"),
    )

    def builder_kwargs(self, ctx):
        kw = super().builder_kwargs(ctx)
        if kw["n_l"] == 0:
            kw["n_l"] = None
        return kw
