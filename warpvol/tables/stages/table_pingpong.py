"""Host step ``table_pingpong``: Guthe et al. 2002 ping-pong filtered slices (12-bit hi/lo split)."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.base import TABLE_FORMATS
from warpvol.tables.stages.support import LMAX, TableStage, output_param


@register_stage
class TablePingPong(TableStage):
    """Slices ``C(sf, sb, l_k)`` by ping-pong filtering, one pass sequence per colour channel.

    ==========  =====  ==========  =========================================================
    parameter   type   default     meaning
    ==========  =====  ==========  =========================================================
    n_s         int    128         slice resolution
    n_slices    int    1           slices at l = k / n_slices (k = 1..n_slices) x lmax
    lmax        float  0           thickness at l = 1; 0 = the mesh's longest edge
    m           int    128         integration steps per slice
    gpu         str    radeon8500  ``radeon8500`` (bit masking) | ``geforce4`` (saturation)
    per_pass    int    4           steps per pass in the pixel shader
    n_tex       int    2048        TF texture resolution
    format      str    fp32        stored format
    output      str    slices      ``ctx.buffers`` key
    ==========  =====  ==========  =========================================================
    """

    name = "table_pingpong"
    summary = "Guthe et al. 2002 ping-pong filtering (12-bit hi/lo split, Radeon masking vs GeForce saturation)"
    needs = ()
    provides = ("{output}",)
    builder = "pingpong"
    params = (
        Param("n_s", int, 128, "slice resolution", lo=2, hi=4096),
        Param("n_slices", int, 1, "number of slices, at l = k / n_slices", lo=1, hi=64),
        LMAX,
        Param("m", int, 128, "integration steps per slice", lo=1, hi=65536),
        Param("gpu", str, "radeon8500", "bit masking or saturation", choices=("radeon8500", "geforce4")),
        Param("per_pass", int, 4, "steps per pass", lo=1, hi=16),
        Param("n_tex", int, 2048, "TF texture resolution", lo=2, hi=65536),
        Param("format", str, "fp32", "stored format", choices=TABLE_FORMATS[:4]),
        output_param("slices"),
    )

    def requires_caps(self) -> dict:
        # the ping texture plus one TF texture per step; the low bits need the Radeon's bit masking
        return {"texture_units": self.config["per_pass"] + 1,
                "fb_overflow": "wrap" if self.config["gpu"] == "radeon8500" else "saturate"}

    def builder_kwargs(self, ctx):
        kw = super().builder_kwargs(ctx)
        n = kw.pop("n_slices")
        kw["lengths"] = tuple((k + 1) / n for k in range(n))
        return kw
