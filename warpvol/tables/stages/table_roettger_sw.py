"""Host step ``table_roettger_sw``: Roettger & Ertl 2002 software pre-integration (eqs. 5-7)."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.base import TABLE_FORMATS
from warpvol.tables.roettger_sw import SW_STEPS
from warpvol.tables.stages.support import LMAX, TableStage, output_param


@register_stage
class TableRoettgerSw(TableStage):
    """Software 3D table: ``n >= o m |sf - sb|`` samples per voxel, walking from the back.

    ============  =====  =========  ===================================================
    parameter     type   default    meaning
    ============  =====  =========  ===================================================
    n_s           int    64         resolution of the sf and sb axes
    n_l           int    32         resolution of the thickness axis
    lmax          float  0          thickness at l = 1; 0 = the mesh's longest edge
    m             int    0          TF resolution; 0 = the TF's number of points
    oversampling  float  2          o (paper: 2)
    n_min         int    1          lower bound on samples per voxel
    step          str    eq6        ``eq6`` (eq. 6 as printed: the paper's build) | ``stein`` (bounded)
    format        str    fp32       ``fp32`` | ``fp16`` | ``rgba8`` | ``hilo16``
    output        str    table3d    ``ctx.buffers`` key
    ============  =====  =========  ===================================================
    """

    name = "table_roettger_sw"
    summary = "Roettger & Ertl 2002 software pre-integration (eqs. 5-7)"
    needs = ()
    provides = ("{output}",)
    builder = "roettger_sw"
    params = (
        Param("n_s", int, 64, "resolution of the sf and sb axes", lo=2, hi=4096),
        Param("n_l", int, 32, "resolution of the thickness axis", lo=1, hi=4096),
        LMAX,
        Param("m", int, 0, "TF resolution; 0 = number of TF points", lo=0, hi=65536),
        Param("oversampling", float, 2.0, "o of n >= o m |sf - sb|", lo=0.0, hi=64.0, lo_open=True),
        Param("n_min", int, 1, "lower bound on samples per voxel", lo=1, hi=65536),
        Param("step", str, "eq6", "eq. 6 as printed (the paper's build) or Stein et al.'s bounded step",
              choices=SW_STEPS),
        Param("format", str, "fp32", "stored format", choices=TABLE_FORMATS[:4]),
        output_param("table3d"),
    )

    def builder_kwargs(self, ctx):
        kw = super().builder_kwargs(ctx)
        if kw["m"] == 0:
            kw["m"] = None
        return kw
