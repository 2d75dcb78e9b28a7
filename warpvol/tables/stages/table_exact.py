"""Host step ``table_exact``: exact 3D pre-integration table (:func:`warpvol.tables.exact.build_exact3d`)."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.base import TABLE_FORMATS
from warpvol.tables.stages.support import LMAX, TableStage, output_param


@register_stage
class TableExact(TableStage):
    """Exact 3D table ``T3D(sf, sb, l)`` for a piecewise-linear TF (both emission models).

    ==========  =====  =========  =================================================
    parameter   type   default    meaning
    ==========  =====  =========  =================================================
    n_s         int    64         resolution of the sf and sb axes
    n_l         int    32         resolution of the thickness axis
    lmax        float  0          thickness at l = 1; 0 = the mesh's longest edge
    l_axis      str    centred    ``centred`` | ``endpoint`` | ``log2``
    format      str    fp32       ``fp32`` | ``fp16`` | ``rgba8`` | ``hilo16``
    output      str    table3d    ``ctx.buffers`` key
    ==========  =====  =========  =================================================
    """

    name = "table_exact"
    summary = "exact 3D pre-integration table (piecewise-linear TF integrated exactly)"
    needs = ()
    provides = ("{output}",)
    builder = "exact3d"
    params = (
        Param("n_s", int, 64, "resolution of the sf and sb axes", lo=2, hi=4096),
        Param("n_l", int, 32, "resolution of the thickness axis", lo=1, hi=4096),
        LMAX,
        Param("l_axis", str, "centred", "thickness node layout", choices=("centred", "endpoint", "log2")),
        Param("format", str, "fp32", "stored format", choices=TABLE_FORMATS[:4]),
        output_param("table3d"),
    )
