"""Stage ``pt_guthe``: Guthe et al. 2002 fragment program, the 3D table replaced by 2D textures.

Per fragment: ``rho_hat(sf, sb)`` (alpha of coefficient texture 0) and the colour coefficients
``C~_i(sf, sb)`` from bilinear 2D lookups, ``alpha = alpha1D(l rho_hat)`` by a dependent 1D lookup
(8-bit A, or the 16-bit value carried in A and L: whatever ``table_guthe``'s ``alpha_format``
stored), colour ``C = alpha sum_i (l / lmax)^i C~_i`` (linear: ``C~_0 = C0_hat``,
``C~_1 = C_hat(lmax) - C0_hat``; degree 2 on the GeForce4, 4 on the Radeon 8500) with the signed
coefficients scaled back by per-channel constants (:func:`warpvol.projection.pt.guthe_program`). ``gpu``
checks the setup fits the card's texture units: ``degree + 1`` coefficient textures plus the
dependent alpha texture (GeForce4: 4 units, degree <= 2; Radeon 8500: 6, degree <= 4).
With ``pt_perspective`` before it the attributes are perspective-correct. Writes ``ctx.image``.
"""

from __future__ import annotations

from warpvol.projection.stages.pt_perspective import fragment_inputs
from warpvol.projection.stages.pt_vertex_color import BATCH, DITHER, composite, fb_param, table_from
from warpvol.stage import Context, Param, Stage, register_stage

#: texture units per card (NV25 GeForce4 Ti: 4; R200 Radeon 8500: 6)
TEXTURE_UNITS = {"geforce4": 4, "radeon8500": 6, "any": 64}


@register_stage
class PTGuthe(Stage):
    """ρ̂(sf, sb) 2D lookup, α = α1D(l·ρ̂) dependent 1D lookup, polynomial colour in l.

    ===========  =====  =========  ======================================  ==========================
    parameter    type   default    allowed                                 meaning
    ===========  =====  =========  ======================================  ==========================
    table        str    guthe      ``ctx.buffers`` key                     Guthe tables
    gpu          str    any        ``geforce4`` ``radeon8500`` ``any``     texture-unit budget
    weight_bits  int    8          [0, 16]; 0 = fp32 filter weights        filter-weight bits
    format       str    unorm8     ``unorm8`` ... ``fp32``                 frame-buffer format
    dither       bool   false                                              alpha dithering
    batch_tets   int    65536      [1, 2^26]                               tets per batch
    ===========  =====  =========  ======================================  ==========================

    Example
    -------
    >>> from warpvol.pipeline import Pipeline
    >>> from warpvol.scene.builtin import builtin_scene
    >>> p = Pipeline.load("guthe2002_linear")
    >>> res = p.render(builtin_scene("box").with_camera(width_px=8, height_px=8), quiet=True)
    >>> c = res.report["counters"]["pt_guthe"]  # linear: 2 coefficient textures + the dependent alpha
    >>> c["texture_lookups"] == 3 * c["fragments"] > 0
    True
    """

    name = "pt_guthe"
    summary = "PT fragment program: Guthe et al. 2002 2D multi-texturing (rho_hat, dependent alpha1D, polynomial colour)"
    params = (
        Param("table", str, "guthe", "ctx.buffers key of the Guthe tables"),
        Param("gpu", str, "any", "texture-unit budget", choices=tuple(TEXTURE_UNITS)),
        Param("weight_bits", int, 8, "filter-weight fraction bits (0: fp32 weights)", lo=0, hi=16),
        fb_param(), DITHER, BATCH,
    )
    needs = ("pt_geometry",)
    provides = ("image",)

    def run(self, ctx: Context) -> None:
        from warpvol.errors import ConfigError
        from warpvol.projection.pt import guthe_program

        table = table_from(self, ctx, "table_guthe")
        deg = table.data.shape[0] - 1
        units = TEXTURE_UNITS[self.config["gpu"]]
        if deg + 2 > units:
            raise ConfigError(f"{self.where}.gpu: degree {deg} needs {deg + 2} texture units ({deg + 1} coefficient "
                              f"textures + alpha1D); the {self.config['gpu']} has {units}")
        attrs, mode, ortho, z_off = fragment_inputs(ctx)
        program = guthe_program(table, mode=mode, ortho=ortho, weight_bits=self.config["weight_bits"] or None,
                                device=ctx.device, z_off=z_off)
        ctx.stats["pt"]["texture_units"] = deg + 2
        info = composite(self, ctx, attrs, program)
        # per fragment: deg + 1 signed 8-bit coefficient lookups (2D) and one dependent alpha lookup (1D,
        # 8-bit A or the A/L pair); register-combiner steps deg + 2 (estimate: polynomial, scale, alpha)
        n = info["fragments"]
        a_fmt = "la8" if table.meta.get("alpha_format", "al16") == "al16" else "a8"
        ctx.count(texture_lookups=(deg + 2) * n, dependent_lookups=n, dependent_fetches=n, combiner_ops=(deg + 2) * n,
                  **{"tex_2d_rgba8s_linear": (deg + 1) * n, f"tex_1d_{a_fmt}_linear": n})
