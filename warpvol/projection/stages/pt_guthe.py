"""Stage ``pt_guthe``: Guthe et al. 2002 fragment program, the 3D table replaced by 2D textures.

Per fragment: ``rho_hat(sf, sb)`` (alpha of coefficient texture 0) and the colour coefficients
``C~_i(sf, sb)`` from bilinear 2D lookups, ``alpha = alpha1D(l rho_hat)`` by a dependent 1D lookup
(8-bit A, or the 16-bit value carried in A and L: whatever ``table_guthe``'s ``alpha_format``
stored), colour ``C = alpha sum_i (l / lmax)^i C~_i`` (linear: ``C~_0 = C0_hat``,
``C~_1 = C_hat(lmax) - C0_hat``; degree 2 on the GeForce4, 4 on the Radeon 8500) with the signed
coefficients scaled back by per-channel constants (:func:`warpvol.projection.programs.guthe_program`). ``gpu``
checks the setup fits the card's texture units: ``degree + 1`` coefficient textures plus the
dependent alpha texture (GeForce4: 4 units, degree <= 2; Radeon 8500: 6, degree <= 4).
``arith`` is the arithmetic after the fetches: ``fp32``, or the card's fixed-point registers
(:mod:`warpvol.kernels.combiners`): ``nv_combiner`` (GeForce3/4 register combiners, signed 9-bit
[-1, 1], coefficient scales from the output scale ops {1/2, 1, 2, 4}) or ``ati_fs`` (Radeon 8500
fragment shader, [-8, 8], scales {1/8, ..., 8}); ``auto`` takes the one the table's ``scales`` were
chosen for. The fixed-point programs report their register format and the table's saturated
coefficient texels in ``stats["pt_guthe"]`` (a warning when any saturated).
With ``pt_perspective`` before it the attributes are perspective-correct. Writes ``ctx.image``.
"""

from __future__ import annotations

from warpvol.errors import ConfigError
from warpvol.gpu.texture import Texture1D, TextureAtlas
from warpvol.projection.programs import _scalar_consts, guthe_lookups, guthe_program
from warpvol.projection.pt import PERSPECTIVE_MODES
from warpvol.projection.stages.pt_perspective import fragment_inputs
from warpvol.projection.stages.pt_vertex_color import BATCH, DITHER, composite, fb_param, table_from
from warpvol.stage import Context, Param, Stage, register_stage
from warpvol.tables.guthe2d import arith_constants

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
    arith        str    auto       ``auto`` ``fp32`` ``nv_combiner``       shader arithmetic
                                   ``ati_fs``
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
        Param("arith", str, "auto", "shader arithmetic after the fetches",
              choices=("auto", "fp32", "nv_combiner", "ati_fs")),
        Param("weight_bits", int, 8, "filter-weight fraction bits (0: fp32 weights)", lo=0, hi=16),
        fb_param(), DITHER, BATCH,
    )
    needs = ("pt_geometry",)
    provides = ("image",)

    def run(self, ctx: Context) -> None:
        table = table_from(self, ctx, "table_guthe")
        deg = table.data.shape[0] - 1
        units = TEXTURE_UNITS[self.config["gpu"]]
        if deg + 2 > units:
            raise ConfigError(f"{self.where}.gpu: degree {deg} needs {deg + 2} texture units ({deg + 1} coefficient "
                              f"textures + alpha1D); the {self.config['gpu']} has {units}")
        arith = self.config["arith"]
        if arith == "auto":
            arith = {"free": "fp32", "nv_combiner": "nv_combiner", "ati_fs": "ati_fs"}[
                table.meta.get("coef_scales", "free")]
        card = {"nv_combiner": "geforce4", "ati_fs": "radeon8500"}.get(arith)
        if card is not None and self.config["gpu"] not in (card, "any"):
            raise ConfigError(f"{self.where}.arith: {arith!r} is the {card}'s arithmetic, gpu is {self.config['gpu']!r}")
        attrs, mode, ortho, z_off = fragment_inputs(ctx)
        wb = self.config["weight_bits"] or None
        if arith == "fp32":
            program = guthe_program(table, mode=mode, ortho=ortho, weight_bits=wb, device=ctx.device, z_off=z_off)
        else:
            program = fixed_program(self, ctx, table, arith, mode=mode, ortho=ortho, weight_bits=wb, z_off=z_off)
        ctx.stats["pt"]["texture_units"] = deg + 2
        info = composite(self, ctx, attrs, program)
        # per fragment: deg + 1 signed 8-bit coefficient lookups (2D) and one dependent alpha lookup (1D,
        # 8-bit A or the A/L pair); register-combiner steps deg + 2 (estimate: polynomial, scale, alpha)
        n = info["fragments"]
        a_fmt = "la8" if table.meta.get("alpha_format", "al16") == "al16" else "a8"
        ctx.count(texture_lookups=(deg + 2) * n, dependent_lookups=n, dependent_fetches=n, combiner_ops=(deg + 2) * n,
                  **{"tex_2d_rgba8s_linear": (deg + 1) * n, f"tex_1d_{a_fmt}_linear": n})


def fixed_program(stage: Stage, ctx: Context, table, arith: str, *, mode: str, ortho: bool,
                  weight_bits: int | None, z_off: float):
    """:func:`warpvol.projection.programs.guthe_program` with the arithmetic after the fetches in the card's
    fixed-point registers (:func:`warpvol.kernels.combiners.k_frag_guthe_fixed`); records the register
    format, the scales and the saturated coefficient texels in ``stats["pt_guthe"]``."""
    import numpy as np
    import warp as wp

    from warpvol.kernels import combiners as kc

    try:
        w, s_acc, rng, unit = arith_constants(table, arith)
    except Exception as e:  # noqa: BLE001 - re-raised naming the stage
        from warpvol.errors import ConfigError

        raise ConfigError(f"{stage.where}.{e}") from None
    device = ctx.device
    deg = table.data.shape[0] - 1
    atlas = TextureAtlas(table.data, fmt="rgba32f", filter="linear", device=device, weight_bits=weight_bits)
    a1 = np.asarray(table.extra["alpha1d"], dtype=np.float32).reshape(-1)
    alpha = Texture1D(a1, fmt="r32f", filter="linear", device=device, weight_bits=weight_bits)
    na = a1.shape[0]
    consts = [*_scalar_consts(table.axes[2]), 1.0 / float(table.meta["lmax"]), 1.0 - 1.0 / na, 0.5 / na, deg]
    w_dev = wp.array(w, dtype=wp.float32, device=device)
    sat = int(table.meta.get("coef_saturated", 0))
    st = ctx.stats.setdefault(stage.name, {})
    st.update(arith=arith, register_range=rng, register_step=1.0 / unit, coef_scales=[float(v) for v in w * s_acc],
              accumulator_scale=s_acc, coef_saturated=sat)
    if sat:
        st["warning"] = (f"{sat} coefficient texel channels lie beyond the largest scale factor of {arith} and "
                         "saturate at +-1 (the hardware's loss)")

    def run(frags, tris):
        out = wp.zeros(frags.count, dtype=wp.vec4, device=device)
        wp.launch(kc.k_frag_guthe_fixed, dim=frags.count,
                  inputs=[frags.attrs, PERSPECTIVE_MODES[mode], int(ortho), float(z_off), atlas.struct, alpha.struct,
                          *consts, w_dev, s_acc, rng, unit, out], device=device)
        return out

    return guthe_lookups(run, atlas, consts, mode=mode, ortho=ortho, z_off=z_off, device=device)
