"""Host step ``table_incremental``: incremental pre-integration (Weiler 2003 / Kraus 2004)."""

from __future__ import annotations

from warpvol.stage import Param, register_stage
from warpvol.tables.base import TABLE_FORMATS
from warpvol.tables.incremental import check_n_l
from warpvol.tables.stages.support import LMAX, TableStage, output_param


@register_stage
class TableIncremental(TableStage):
    """Slices l = 0, Δl, 2Δl, 4Δl ... (log2 axis, Kraus eq. 1) or l = kΔl (uniform), composited.

    ==========  =====  =========  ==========================================================
    parameter   type   default    meaning
    ==========  =====  =========  ==========================================================
    n_s         int    64         resolution of the sf and sb axes
    n_l         int    16         number of thickness slices: 3 to 64; log2: 3 to 18
    lmax        float  0          largest thickness; 0 = the mesh's longest edge
    axis        str    log2       ``log2`` | ``uniform``
    base        str    exact      the Δl slice: ``exact`` | ``roettger_sw``
    format      str    hilo16     stored format (Kraus: 16-bit HILO)
    applies_to  str    any        planner: ``any`` | ``wide_range`` | ``narrow_range``
    output      str    table3d    ``ctx.buffers`` key
    ==========  =====  =========  ==========================================================

    Planner (``applies_to``): a preset lists the stage twice, ``axis = "uniform"`` for
    ``narrow_range`` and then ``axis = "log2"`` for ``wide_range`` meshes; the other is reported under
    ``skipped`` (forced on, it builds its table but keeps the chosen one in the pipeline). The uniform axis' first slice ``Δl = lmax / (n_l - 1)`` is no longer than the
    mesh's shortest edge when ``lmax / lmin <= n_l - 1`` (``lmin``: the shortest edge): then no
    cell is much thinner than one slice and the uniform axis suffices (Kraus et al. 2004 §3: the
    logarithmic axis is for meshes with a very high longest/shortest edge ratio).
    """

    name = "table_incremental"
    summary = "incremental pre-integration with logarithmic or uniform thickness axis"
    needs = ()
    provides = ("{output}",)
    builder = "incremental"
    params = (
        Param("n_s", int, 64, "resolution of the sf and sb axes", lo=2, hi=4096),
        Param("n_l", int, 16, "number of thickness slices (log2 axis: at most 18)", lo=3, hi=64),
        LMAX,
        Param("axis", str, "log2", "thickness axis", choices=("log2", "uniform")),
        Param("base", str, "exact", "integration of the first slice", choices=("exact", "roettger_sw")),
        Param("format", str, "hilo16", "stored format", choices=TABLE_FORMATS[:4]),
        Param("applies_to", str, "any", "planner: meshes with a wide / narrow thickness range",
              choices=("any", "wide_range", "narrow_range")),
        output_param("table3d"),
    )

    def validate(self) -> None:
        # log2: float32 doublings limit n_l (warpvol.tables.incremental.LOG2_MAX_N_L says why)
        check_n_l(f"{self.where}.n_l", self.config["n_l"], self.config["axis"])

    def builder_kwargs(self, ctx):
        kw = super().builder_kwargs(ctx)
        kw.pop("applies_to")
        return kw

    def _alternative_reason(self, ctx) -> str | None:
        want = self.config["applies_to"]
        if want == "any":
            return None
        lmax, n_l = self.resolve_lmax(ctx), self.config["n_l"]
        e = ctx.scene.mesh.edge_lengths
        ratio = lmax / float(e[e > 0].min())
        narrow = ratio <= n_l - 1
        if want == "wide_range" and narrow:
            return (f"lmax / shortest edge = {ratio:.3g} <= n_l - 1 = {n_l - 1}: the uniform thickness axis "
                    f"suffices (first slice no longer than the shortest edge)")
        if want == "narrow_range" and not narrow:
            return (f"lmax / shortest edge = {ratio:.3g} > n_l - 1 = {n_l - 1}: thin cells need the "
                    f"logarithmic thickness axis")
        return None

    def skip_reason(self, ctx):
        if self.config["applies_to"] != "any":
            # one of two alternatives: the planner's choice runs (its table from the cache when there,
            # stats.tables says so), the other is skipped with the reason
            return self._alternative_reason(ctx)
        return super().skip_reason(ctx)

    def run(self, ctx):
        out = self.config["output"]
        if self._alternative_reason(ctx) and out in ctx.buffers:
            # forced on although the planner chose the other axis: build it (its cost shows in the
            # report) but keep the chosen table, so forcing it changes nothing in the image
            keep = ctx.buffers[out]
            super().run(ctx)
            ctx.buffers[out] = keep
            return
        super().run(ctx)
