"""Stage ``pt_table3d``: the 3D pre-integration fragment program (Röttger, Kraus & Ertl 2000).

The rasteriser interpolates ``(sf, sb, l)`` linearly in screen space (the thick vertex's front and
back scalars and thickness, ``(s, s, 0)`` on silhouette vertices); the fragment program normalises
them over the table's axes and looks the premultiplied ``(C, α)`` up in the 3D table through the
emulated 3D texture unit (trilinear with 8-bit filter-weight fractions by default); the blending unit
composites back to front. With stage ``pt_perspective`` before it, the fragments' (sf, sb, l)
come from Kraus et al.'s per-fragment perspective division instead. Any 3D table from the table stages (``table_exact``,
``table_roettger_sw``, ``table_roettger_hw``, ``table_incremental``) via ``ctx.buffers[table]``.
``blend``: how fragments reach the buffer: ``unit`` (the blending unit; on an fp16 buffer this is
NV40-style fp16 blending) or ``readback`` (float buffers: the colour buffer bound as a texture and
composited in the fp32 fragment program, written with blending off, the buffer texture rebound and a
fence sent after each triangle fan: Kraus et al. 2004 §4.1 on the Quadro FX 3000, which had no fp16
blending; counted as ``fb_texture_rebinds``, one per drawn tet, and one buffer-texel fetch per fragment).
Writes ``ctx.image``; counts ``texture_lookups``, the fetches by texel format (``rgba16``: two
``hilo16`` fetches, as on the NV3x) and ``combiner_ops`` (Kraus et al. 2004 §5's instruction counts);
the rasteriser and blending unit count fragments and blends.
"""

from __future__ import annotations

from warpvol.projection.programs import table3d_program
from warpvol.projection.stages.pt_perspective import fragment_inputs
from warpvol.projection.stages.pt_vertex_color import (
    BATCH,
    DITHER,
    FILTER,
    TABLE3D,
    WEIGHT_BITS,
    composite,
    fb_param,
    table_from,
    texel_param,
)
from warpvol.stage import Context, Param, Stage, register_stage

TEXELS = ("auto", "rgba8", "rgba12", "rgba16", "rgba16f", "rgba32f")


@register_stage
class PTTable3D(Stage):
    """(sf, sb, l) → 3D table lookup through the texture unit, back-to-front blending.

    ============  =====  ========  ===============================================  ====================
    parameter     type   default   allowed                                          meaning
    ============  =====  ========  ===============================================  ====================
    table         str    table3d   ``ctx.buffers`` key                              the 3D table
    texel_format  str    auto      ``auto`` ``rgba8`` ``rgba12`` ``rgba16``         3D texture format
                                   ``rgba16f`` ``rgba32f``                          (auto: the table's)
    filter        str    linear    ``linear`` | ``nearest``                         texture filter
    weight_bits   int    8         [0, 16]; 0 = fp32 filter weights                 filter-weight bits
    format        str    unorm8    ``unorm8`` ``unorm12`` ``unorm16`` ``fp16``     frame-buffer format
                                   ``fp32``
    dither        bool   false                                                      alpha dithering
    blend         str    unit      ``unit`` | ``readback`` (float buffers)            compositing path
    batch_tets    int    65536     [1, 2^26]                                        tets per batch
    ============  =====  ========  ===============================================  ====================

    Example
    -------
    >>> from warpvol.pipeline import Pipeline
    >>> from warpvol.scene.builtin import builtin_scene
    >>> res = Pipeline.load("roettger2000_3d").render(builtin_scene("box").with_camera(width_px=8, height_px=8),
    ...                                              quiet=True)
    >>> res.report["counters"]["pt_table3d"]["texture_lookups"] == res.report["counters"]["pt_table3d"]["fragments"]
    True
    """

    name = "pt_table3d"
    summary = "PT fragment program: 3D pre-integration table lookup of (sf, sb, l) through the texture unit"
    params = (
        TABLE3D, texel_param(TEXELS), FILTER, WEIGHT_BITS, fb_param(), DITHER, BATCH,
        Param("blend", str, "unit", "compositing: blending unit, or buffer read as a texture in the program",
              choices=("unit", "readback")),
    )
    needs = ("pt_geometry",)
    provides = ("image",)

    def run(self, ctx: Context) -> None:
        table = table_from(self, ctx, "table")
        attrs, mode, ortho, z_off = fragment_inputs(ctx)
        program, texel = table3d_program(table, self.config["texel_format"], self.config["filter"],
                                         self.config["weight_bits"] or None, device=ctx.device, mode=mode, ortho=ortho,
                                         z_off=z_off)
        ctx.stats["pt"]["texel_format"] = texel
        unit = None
        if self.config["blend"] == "readback":
            from warpvol.errors import ConfigError
            from warpvol.gpu.blend import BlendUnit

            if self.config["format"] not in ("fp16", "fp32"):
                raise ConfigError(f"{self.where}.blend: 'readback' composites into a float buffer; format is "
                                  f"{self.config['format']!r} (use blend = 'unit')")
            unit = BlendUnit.over(arithmetic="program")
        info = composite(self, ctx, attrs, program, blend_unit=unit)
        if unit is not None:
            geo = ctx.buffers["pt_geometry"]
            fans = sum(v for k, v in geo.classes.items() if k not in ("flat", "culled"))
            ctx.count(fb_texture_rebinds=fans)
            ctx.stats.setdefault("pt_table3d", {}).update(
                blend="readback", fb_texture_rebinds=fans,
                note="fp16 buffer read as a texture and composited in the fp32 fragment program, one buffer-texture "
                     "rebind and fence per triangle fan (Quadro FX 3000: no fp16 blending)")
        n = info["fragments"]
        flt = self.config["filter"]
        # a 16-bit RGBA table is two HILO16 textures (two fetches); fragment-program instructions:
        # perspective division 11 and logarithmic lookup 7 (Kraus et al. 2004 §5), alpha dithering 10 and
        # two 2D fetches in the random tables (ibid.). Without them the lookup is fixed-function: the
        # normalisation over the table's axes is affine in the interpolated attributes (texture matrix)
        fetch = {f"tex_3d_hilo16_{flt}": 2 * n} if texel == "rgba16" else {f"tex_3d_{texel}_{flt}": n}
        ops = (11 if mode != "off" else 0) + (7 if table.axes[0].kind == "log2" else 0)
        if self.config["dither"]:
            ops += 10
            fetch["tex_2d_rgba8_nearest"] = 2 * n
        ctx.count(texture_lookups=n, combiner_ops=ops * n, **fetch)
