"""Stage ``pt_cylindrical``: the cylindrical 2D-plane fragment program (Roettger & Ertl 2002 §4).

Per vertex, one division maps ``(sf, sb, l)`` to cylinder coordinates ``(α, s, t)`` (eq. 10;
silhouette vertices ``(0, 0, sb)``). Every point of one PT triangle lies on the plane through the
front diagonal with the thick vertex's ``α``, so ``α`` is constant per triangle and ``(s, t)`` are
interpolated linearly in screen space; the fragment program samples the two nearest α-planes from the
atlas through the emulated 2D texture unit (bilinear, 8-bit filter weights) and blends them linearly
in ``α`` (two-pass multi-texturing). The planes come from stage ``table_cylindrical``
(``ctx.buffers[planes]``). Writes ``ctx.image``; counts ``fragments``, ``texture_lookups`` (two per
fragment) and ``blends``.
"""

from __future__ import annotations

from warpvol.projection.stages.pt_vertex_color import BATCH, DITHER, composite, fb_param
from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class PTCylindrical(Stage):
    """Per-vertex (α, s, t), two α-planes from the atlas per fragment, back-to-front blending.

    ============  =====  ========  ===============================================  ==================
    parameter     type   default   allowed                                          meaning
    ============  =====  ========  ===============================================  ==================
    planes        str    planes    ``ctx.buffers`` key                              cylindrical planes
    weight_bits   int    8         [0, 16]; 0 = fp32 filter weights                 filter-weight bits
    format        str    unorm8    ``unorm8`` ``unorm12`` ``unorm16`` ``fp16``     frame-buffer format
                                   ``fp32``
    dither        bool   false                                                      alpha dithering
    batch_tets    int    65536     [1, 2^26]                                        tets per batch
    ============  =====  ========  ===============================================  ==================
    """

    name = "pt_cylindrical"
    summary = "PT fragment program: cylindrical 2D planes, per-vertex (alpha, s, t), two-plane reconstruction"
    params = (
        Param("planes", str, "planes", "ctx.buffers key of the cylindrical planes"),
        Param("weight_bits", int, 8, "filter-weight fraction bits (0: fp32 weights)", lo=0, hi=16),
        fb_param(), DITHER, BATCH,
    )
    needs = ("pt_geometry",)
    provides = ("image",)

    def run(self, ctx: Context) -> None:
        from warpvol.errors import ConfigError
        from warpvol.projection.pt import cylindrical_program

        key = self.config["planes"]
        if key not in ctx.buffers:
            raise ConfigError(f"{self.where}.planes: no planes {key!r} in this pipeline; put table_cylindrical "
                              f"with output = {key!r} before this stage")
        geo = ctx.buffers["pt_geometry"]
        attrs, program = cylindrical_program(ctx.buffers[key], ctx.scene.transfer, geo,
                                             self.config["weight_bits"] or None, device=ctx.device)
        info = composite(self, ctx, attrs, program)
        from warpvol.tables.cylindrical import TEXEL_FORMAT

        # two bilinear fetches (the two nearest planes, two texture units) and one combiner step
        # blending them (estimate) per fragment
        n = info["fragments"]
        ctx.count(texture_lookups=2 * n, combiner_ops=n,
                  **{f"tex_2d_{TEXEL_FORMAT[ctx.buffers[key].format]}_linear": 2 * n})
