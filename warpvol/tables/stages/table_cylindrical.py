"""Host step ``table_cylindrical``: cylindrical 2D planes of the 3D table (Roettger & Ertl 2002 §4)."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.base import TABLE_FORMATS
from warpvol.tables.stages.support import LMAX, TableStage, output_param


@register_stage
class TableCylindrical(TableStage):
    """Resample a 3D table into α-planes (eq. 9) tiled into an atlas; two-plane reconstruction.

    ``table`` names the 3D table of an earlier stage (``table_roettger_sw``, ``table_roettger_hw``,
    ``table_exact``): the planes then resample exactly the numbers the 3D presets draw from (its
    resolution, thickness axis and ``lmax``; ``n_s``, ``n_l`` and ``lmax`` here are unused). Empty: an
    exact fp32 3D table is built here and resampled (``source = table``) or the planes are integrated
    exactly (``source = exact``), both analysis set-ups, not a 2002 build.

    ==========  =====  =========  ==========================================================
    parameter   type   default    meaning
    ==========  =====  =========  ==========================================================
    table       str    ""         ``ctx.buffers`` key of the 3D table to resample; "" = none
    n_s         int    64         3D table / plane resolution (no ``table``)
    n_l         int    0          thickness resolution of the 3D table; 0 = n_s (no ``table``)
    lmax        float  0          thickness at l = 1; 0 = the mesh's longest edge (no ``table``)
    planes      str    4x         planes relative to n_s: ``4x`` | ``2x`` | ``1x``
    source      str    table      ``table`` (resample ``table`` or an exact fp32 3D table) |
                                  ``exact`` (exact integrals at the planes' points)
    format      str    rgba8      stored format
    output      str    planes     ``ctx.buffers`` key
    ==========  =====  =========  ==========================================================
    """

    name = "table_cylindrical"
    summary = "cylindrical alpha-planes of the 3D table, tiled atlas (2D texturing)"
    needs = ()
    provides = ("{output}",)
    builder = "cylindrical"
    params = (
        Param("table", str, "", "ctx.buffers key of the 3D table to resample ('' = build an exact one)"),
        Param("n_s", int, 64, "plane resolution", lo=2, hi=4096),
        Param("n_l", int, 0, "3D table thickness resolution; 0 = n_s", lo=0, hi=4096),
        LMAX,
        Param("planes", str, "4x", "number of planes", choices=("4x", "2x", "1x")),
        Param("source", str, "table", "resampled table or exact integrals", choices=("table", "exact")),
        Param("format", str, "rgba8", "stored format", choices=TABLE_FORMATS[:4]),
        output_param("planes"),
    )

    def builder_kwargs(self, ctx):
        kw = super().builder_kwargs(ctx)
        if kw["n_l"] == 0:
            kw["n_l"] = None
        key = kw.pop("table")
        if key:
            from warpvol.errors import ConfigError

            src = ctx.buffers.get(key)
            if src is None:
                raise ConfigError(f"{self.where}.table: no table {key!r} in this pipeline; put a 3D table stage "
                                  f"(table_roettger_sw, table_roettger_hw, table_exact) with output = {key!r} "
                                  "before this stage, or leave table empty")
            if getattr(src, "data", None) is None or src.data.ndim != 4 or src.axes[0].name != "l":
                raise ConfigError(f"{self.where}.table: {key!r} is not a 3D (l, sb, sf) table")
            if self.config["source"] != "table":
                raise ConfigError(f"{self.where}.source: a named table is resampled, so source must be 'table' "
                                  f"(got {self.config['source']!r})")
            kw["table"] = src
            for k in ("n_s", "n_l", "lmax"):  # the table's own
                kw.pop(k)
        return kw
