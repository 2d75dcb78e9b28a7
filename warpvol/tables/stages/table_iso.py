"""Host step ``table_iso``: iso-crossing table of partial pre-integration (Espinha & Celes 2005 §4.2)."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.stages.support import TableStage, output_param


@register_stage
class TableIso(TableStage):
    """(s_iso, next_s_iso) over (sf, sb) for the TF's control points; rebuilt on TF edits only when
    the control-point positions change.

    ==========  =====  =========  ==========================================================
    parameter   type   default    meaning
    ==========  =====  =========  ==========================================================
    n           int    256        resolution of both axes
    limit       str    segment    ``segment`` (iso within sb + 1 texel) | ``direction``
    format      str    fp32       ``fp32`` | ``fp16``
    anchor      str    centre     ``centre`` (paper) | ``edge`` (no control point missed)
    output      str    iso        ``ctx.buffers`` key
    ==========  =====  =========  ==========================================================
    """

    name = "table_iso"
    summary = "iso-crossing table (first and next TF control point between sf and sb)"
    needs = ()
    provides = ("{output}",)
    builder = "isocross"
    params = (
        Param("n", int, 256, "resolution of both axes", lo=2, hi=4096),
        Param("limit", str, "segment", "report isos within sb or in the direction of sb", choices=("segment", "direction")),
        Param("format", str, "fp32", "stored format", choices=("fp32", "fp16")),
        Param("anchor", str, "centre", "search from the texel centre (paper) or its edge behind sf",
              choices=("centre", "edge")),
        output_param("iso"),
    )
