"""Stage ``pt_cylindrical``: the cylindrical 2D-plane fragment program (Roettger & Ertl 2002 §4).

Per vertex, one division maps ``(sf, sb, l)`` to cylinder coordinates ``(α, s, t)`` (eq. 10;
silhouette vertices ``(0, 0, sb)``). Every point of one PT triangle lies on the plane through the
front diagonal with the thick vertex's ``α``, so ``α`` is constant per triangle and ``(s, t)`` are
interpolated linearly in screen space. ``path``:

* ``multitexture`` (the PC cards of the paper's Fig. 8): the two nearest α-planes are sampled from the
  atlas by two texture units (bilinear, 8-bit filter weights) and blended linearly in ``α`` by one
  combiner step, ``t0 (1 - w) + t1 w``. The host computes ``w`` per tetrahedron and hands it over
  as the primary colour's alpha, an 8-bit colour value (``plane_weight = unorm8``; the combiner's
  ``1 - w`` input mapping is exact for that code); a constant-colour register would be 8-bit too but
  needs a combiner state change per tetrahedron. ``plane_weight = fp32`` is an analysis option.
* ``sgi`` (the SGI platforms of Fig. 8, "single 2D texture with nearest neighbour interpolation"):
  one texture, the nearest α-plane, sampled with nearest-texel filtering; no blend between planes.

The planes come from stage ``table_cylindrical`` (``ctx.buffers[planes]``). Writes ``ctx.image``;
counts ``fragments``, ``texture_lookups`` (two per fragment, one on the SGI path), the 2D fetches by
format and filter, ``combiner_ops`` (the plane blend, none on the SGI path) and ``blends``.
"""

from __future__ import annotations

from warpvol.errors import ConfigError
from warpvol.projection.programs import cylindrical_program
from warpvol.projection.stages.pt_vertex_color import BATCH, DITHER, composite, fb_param
from warpvol.stage import Context, Param, Stage, register_stage
from warpvol.tables.cylindrical import TEXEL_FORMAT


@register_stage
class PTCylindrical(Stage):
    """Per-vertex (α, s, t), two α-planes from the atlas per fragment, back-to-front blending.

    ============  =====  ========  ===============================================  ==================
    parameter     type   default   allowed                                          meaning
    ============  =====  ========  ===============================================  ==================
    planes        str    planes    ``ctx.buffers`` key                              cylindrical planes
    path          str    multi-    ``multitexture`` | ``sgi``                       two planes blended /
                           texture                                                    nearest plane, texel
    plane_weight  str    unorm8    ``unorm8`` | ``fp32``                            weight between planes
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
        Param("path", str, "multitexture", "two planes blended (PC) or one texture, nearest (SGI)",
              choices=("multitexture", "sgi")),
        Param("plane_weight", str, "unorm8", "weight between the two planes: the combiner's 8-bit colour or fp32",
              choices=("unorm8", "fp32")),
        Param("weight_bits", int, 8, "filter-weight fraction bits (0: fp32 weights)", lo=0, hi=16),
        fb_param(), DITHER, BATCH,
    )
    needs = ("pt_geometry",)
    provides = ("image",)

    def requires_caps(self) -> dict:
        return {"texture_units": 1 if self.config["path"] == "sgi" else 2}

    def run(self, ctx: Context) -> None:
        key = self.config["planes"]
        if key not in ctx.buffers:
            raise ConfigError(f"{self.where}.planes: no planes {key!r} in this pipeline; put table_cylindrical "
                              f"with output = {key!r} before this stage")
        geo = ctx.buffers["pt_geometry"]
        sgi = self.config["path"] == "sgi"
        attrs, program = cylindrical_program(ctx.buffers[key], ctx.scene.transfer, geo,
                                             self.config["weight_bits"] or None, device=ctx.device,
                                             plane_weight=self.config["plane_weight"], path=self.config["path"])
        info = composite(self, ctx, attrs, program)

        texel = TEXEL_FORMAT[ctx.buffers[key].format]
        n = info["fragments"]
        if sgi:  # one nearest fetch per fragment, no combiner
            ctx.count(texture_lookups=n, **{f"tex_2d_{texel}_nearest": n})
        else:  # two bilinear fetches (two texture units) and one combiner step blending them (estimate)
            ctx.count(texture_lookups=2 * n, combiner_ops=n, **{f"tex_2d_{texel}_linear": 2 * n})
        ctx.stats.setdefault("pt_cylindrical", {}).update(
            path=self.config["path"], plane_weight=None if sgi else self.config["plane_weight"],
            planes=int(ctx.buffers[key].data.shape[0]), source_table=ctx.buffers[key].meta.get("source_table"))
