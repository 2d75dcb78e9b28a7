"""Host step ``table_incremental``: incremental pre-integration (Weiler 2003 / Kraus 2004)."""

from __future__ import annotations

from ...pipeline import Param, register_stage
from ...tables.base import TABLE_FORMATS
from ...tables.stage_support import LMAX, TableStage, output_param


@register_stage
class TableIncremental(TableStage):
    """Slices l = 0, Δl, 2Δl, 4Δl ... (log2 axis, Kraus eq. 1) or l = kΔl (uniform), composited.

    ==========  =====  =========  ==========================================================
    parameter   type   default    meaning
    ==========  =====  =========  ==========================================================
    n_s         int    64         resolution of the sf and sb axes
    n_l         int    16         number of thickness slices (>= 3)
    lmax        float  0          largest thickness; 0 = the mesh's longest edge
    axis        str    log2       ``log2`` | ``uniform``
    base        str    exact      the Δl slice: ``exact`` | ``roettger_sw``
    format      str    hilo16     stored format (Kraus: 16-bit HILO)
    output      str    table3d    ``ctx.buffers`` key
    ==========  =====  =========  ==========================================================
    """

    name = "table_incremental"
    summary = "incremental pre-integration with logarithmic or uniform thickness axis"
    needs = ()
    provides = ("{output}",)
    builder = "incremental"
    params = (
        Param("n_s", int, 64, "resolution of the sf and sb axes", lo=2, hi=4096),
        Param("n_l", int, 16, "number of thickness slices", lo=3, hi=64),
        LMAX,
        Param("axis", str, "log2", "thickness axis", choices=("log2", "uniform")),
        Param("base", str, "exact", "integration of the first slice", choices=("exact", "roettger_sw")),
        Param("format", str, "hilo16", "stored format", choices=TABLE_FORMATS[:4]),
        output_param("table3d"),
    )
