"""Host step ``table_psi``: the TF-free psi table of partial pre-integration (Moreland & Angel 2004)."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.stages.support import TableStage, output_param


@register_stage
class TablePsi(TableStage):
    """ψ(γf, γb) and ψ1 (emission-density moment); built once, never rebuilt on TF edits.

    ==========  =====  =========  ==================================================
    parameter   type   default    meaning
    ==========  =====  =========  ==================================================
    n           int    128        resolution of both gamma axes
    format      str    fp32       ``fp32`` | ``fp16`` | ``rgba8`` | ``hilo16``
    axis        str    centred    ``centred`` | ``endpoint`` (gamma = 0 a node)
    output      str    psi        ``ctx.buffers`` key
    ==========  =====  =========  ==================================================
    """

    name = "table_psi"
    summary = "partial pre-integration psi(gamma_f, gamma_b) table (TF-independent)"
    needs = ()
    provides = ("{output}",)
    builder = "psi"
    uses_tf = False
    params = (
        Param("n", int, 128, "resolution of the gamma axes", lo=2, hi=4096),
        Param("format", str, "fp32", "stored format", choices=("fp32", "fp16", "rgba8", "hilo16")),
        Param("axis", str, "centred", "gamma node layout", choices=("centred", "endpoint")),
        output_param("psi"),
    )
