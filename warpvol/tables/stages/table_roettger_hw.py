"""Host step ``table_roettger_hw``: hardware per-slice pre-integration (Roettger & Ertl 2002 §3) on the
emulated texture and blending units."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.base import TABLE_FORMATS
from warpvol.tables.stages.support import LMAX, TableStage, output_param


@register_stage
class TableRoettgerHw(TableStage):
    """n textured rectangles per slice blended into an 8- or 12-bit frame buffer.

    ==========  =====  =========  ==========================================================
    parameter   type   default    meaning
    ==========  =====  =========  ==========================================================
    n_s         int    64         slice resolution (frame buffer n_s x n_s)
    n_l         int    32         number of slices
    lmax        float  0          thickness at l = 1; 0 = the mesh's longest edge
    steps       int    0          rectangles per slice (n = o m, o = 1); 0 = TF points
    n_tex       int    0          TF (1D texture) entries m; 0 = TF points
    bits        int    12         frame-buffer depth: 8 | 12
    passes      str    two        ``two`` (RGB + opacity pass) | ``one`` (constant colour)
    variant     str    blend      ``blend`` | ``geforce3`` (4 combiner steps per blend, 8 bit)
    gl_dither   bool   false      OpenGL's default GL_DITHER: blends rounded by a 4x4 ordered dither
    format      str    fp32       stored format of the read-back table
    output      str    table3d    ``ctx.buffers`` key
    ==========  =====  =========  ==========================================================
    """

    name = "table_roettger_hw"
    summary = "Roettger & Ertl 2002 hardware pre-integration (emulated blending into 8/12-bit buffers)"
    needs = ()
    provides = ("{output}",)
    builder = "roettger_hw"
    params = (
        Param("n_s", int, 64, "slice resolution", lo=2, hi=4096),
        Param("n_l", int, 32, "number of slices", lo=1, hi=4096),
        LMAX,
        Param("steps", int, 0, "rectangles per slice; 0 = number of TF points", lo=0, hi=65536),
        Param("n_tex", int, 0, "TF texture entries m; 0 = number of TF points", lo=0, hi=65536),
        Param("bits", int, 12, "frame-buffer depth", choices=(8, 12)),
        Param("passes", str, "two", "RGB + opacity passes, or one with constant blend colour", choices=("two", "one")),
        Param("variant", str, "blend", "plain blending or GeForce3 register combiners", choices=("blend", "geforce3")),
        Param("gl_dither", bool, False, "GL_DITHER: ordered 4x4 dither of every blend result"),
        Param("format", str, "fp32", "stored format", choices=TABLE_FORMATS[:4]),
        output_param("table3d"),
    )

    def validate(self) -> None:
        if self.config["variant"] == "geforce3" and self.config["bits"] != 8:
            from warpvol.errors import ConfigError

            raise ConfigError(f"{self.where}.bits: variant 'geforce3' stores into an 8-bit buffer; set bits = 8")

    def requires_caps(self) -> dict:
        c = self.config
        caps: dict = {"fb_formats": f"unorm{c['bits']}"}
        if c["passes"] == "one" and c["bits"] == 12:
            caps["rgba12_visual"] = True  # one pass keeps transparency in alpha
        if c["variant"] == "geforce3":
            caps.update(texture_units=4, combiner_stages=3)
        return caps

    def builder_kwargs(self, ctx):
        kw = super().builder_kwargs(ctx)
        for k in ("steps", "n_tex"):
            if kw[k] == 0:
                kw[k] = None
        return kw
