"""Thin stage wrapper shared by ``warpvol/tables/stages/table_*.py``: each stage validates its parameters,
then fetches its table from the pipeline's :class:`~warpvol.tables.cache.TableCache`
(``ctx.persistent["table_cache"]``, created on first use and kept across renders of the same
pipeline, so a TF edit rebuilds only the TF-dependent tables) and stores it in ``ctx.buffers[output]``.

``lmax = 0`` (the default everywhere) means the mesh's longest edge (``scene.mesh.lmax``).
"""

from __future__ import annotations

from typing import Any, ClassVar

from warpvol.stage import Context, Param, Stage
from warpvol.tables.cache import TableCache
from warpvol.tables.common import progress_to

LMAX = Param("lmax", float, 0.0, "thickness at l = 1 (world units); 0 = the mesh's longest edge", lo=0.0)


def output_param(default: str) -> Param:
    return Param("output", str, default, "ctx.buffers key the table is stored under")


class TableStage(Stage):
    """Base class: subclasses set ``builder`` and map their config to builder keyword arguments."""

    builder: ClassVar[str] = ""
    setup = True  # tables are kept in the pipeline's cache across renders
    uses_tf: ClassVar[bool] = True

    def builder_kwargs(self, ctx: Context) -> dict[str, Any]:
        kw = {k: v for k, v in self.config.items() if k != "output"}
        if "lmax" in kw:
            kw["lmax"] = self.resolve_lmax(ctx)
        return kw

    def resolve_lmax(self, ctx: Context) -> float:
        if self.config.get("lmax", 0.0) > 0:
            return float(self.config["lmax"])
        mesh = getattr(ctx.scene, "mesh", None)
        if mesh is None:
            raise ValueError(f"{self.where}: lmax = 0 needs a scene with a mesh (or give lmax > 0)")
        return float(mesh.lmax)

    def skip_reason(self, ctx: Context) -> str | None:
        """Planner: a table already in the pipeline's cache for this TF and these parameters is not
        rebuilt; it is put into ``ctx.buffers`` here and the stage is reported as skipped."""
        cache = ctx.persistent.get("table_cache")
        tf = getattr(ctx.scene, "transfer", None) if self.uses_tf else None
        if cache is None or (self.uses_tf and tf is None):
            return None
        if cache.key(self.builder, tf, **self.builder_kwargs(ctx)) not in cache:
            return None
        self.run(ctx)
        return "transfer function and parameters unchanged: table reused from the pipeline's cache"

    def run(self, ctx: Context) -> None:
        cache = ctx.persistent.setdefault("table_cache", TableCache())
        tf = getattr(ctx.scene, "transfer", None) if self.uses_tf else None
        if self.uses_tf and tf is None:
            raise ValueError(f"{self.where}: the scene has no transfer function")
        n_before = len(cache.builds)
        with progress_to(lambda msg: ctx.progress(f"{self.where}: {msg}")):
            table = cache.get(self.builder, tf, device=ctx.device, **self.builder_kwargs(ctx))
        ctx.buffers[self.config["output"]] = table
        ctx.stats.setdefault("tables", {})[self.config["output"]] = {
            "builder": self.builder, "shape": list(table.data.shape), "format": table.format,
            "built": len(cache.builds) > n_before, "build_s": table.meta.get("build_s")}
