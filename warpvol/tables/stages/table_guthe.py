"""Host step ``table_guthe``: Guthe et al. 2002 2D tables (rho_hat, alpha1D, polynomial colour)."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.guthe2d import SLICES
from warpvol.tables.stages.support import LMAX, TableStage, output_param


@register_stage
class TableGuthe(TableStage):
    """ρ̂(sf, sb), 16-bit A/L alpha1D, and colour coefficients of degree 1, 2 or 4 in l.

    ============  =====  =========  ========================================================
    parameter     type   default    meaning
    ============  =====  =========  ========================================================
    n_s           int    512        2D texture resolution
    degree        int    2          polynomial degree (1 linear, 2 GeForce4, 4 Radeon 8500)
    lmax          float  0          thickness at x = 1; 0 = the mesh's longest edge
    n_alpha       int    1024       alpha1D entries
    format        str    snorm8     coefficients: ``snorm8`` | ``fp16`` | ``fp32``
    alpha_format  str    al16       ``al16`` (A/L pair) | ``rgba8`` | ``fp32``
    slices        str    software   colour slices: ``software`` (the paper's m-step build) |
                                    ``pingpong`` (the paper's 12-bit hardware build, emulated) |
                                    ``exact`` (the exact integral: no paper's, an improvement)
    m             int    128        integration steps per slice (software and ping-pong)
    gpu           str    radeon8500 ping-pong overflow: ``radeon8500`` (wrap) | ``geforce4`` (saturate)
    scales        str    free       coefficient scale factors: ``free`` (float constants) |
                                    ``nv_combiner`` (1/2..4) | ``ati_fs`` (1/8..8)
    output        str    guthe      ``ctx.buffers`` key
    ============  =====  =========  ========================================================
    """

    name = "table_guthe"
    summary = "Guthe et al. 2002 2D multi-texturing tables (exact opacity, polynomial colour)"
    needs = ()
    provides = ("{output}",)
    builder = "guthe2d"
    params = (
        Param("n_s", int, 512, "2D texture resolution", lo=2, hi=4096),
        Param("degree", int, 2, "polynomial degree in l", lo=1, hi=6),
        LMAX,
        Param("n_alpha", int, 1024, "alpha1D entries", lo=2, hi=65536),
        Param("format", str, "snorm8", "coefficient format", choices=("snorm8", "fp16", "fp32")),
        Param("alpha_format", str, "al16", "alpha1D format", choices=("al16", "rgba8", "fp32")),
        Param("slices", str, "software", "colour slices: the paper's software or ping-pong build, or exact",
              choices=SLICES),
        Param("m", int, 128, "integration steps per slice (software and ping-pong builds)", lo=1, hi=65536),
        Param("gpu", str, "radeon8500", "ping-pong overflow (Radeon wrap / GeForce saturate)",
              choices=("radeon8500", "geforce4")),
        Param("scales", str, "free", "coefficient scale factors the shader can apply",
              choices=("free", "nv_combiner", "ati_fs")),
        output_param("guthe"),
    )

    def requires_caps(self) -> dict:
        # degree + 1 coefficient textures (rho_hat rides in coefficient 0's alpha) + the dependent alpha1D
        return {"texture_units": self.config["degree"] + 2}
