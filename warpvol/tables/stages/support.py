"""Thin stage wrapper shared by ``warpvol/tables/stages/table_*.py``: each stage validates its parameters,
then fetches its table from the pipeline's :class:`~warpvol.tables.cache.TableCache`
(``ctx.persistent["table_cache"]``, created on first use and kept across renders of the same
pipeline, so a TF edit rebuilds only the TF-dependent tables) and stores it in ``ctx.buffers[output]``.

``lmax = 0`` (the default everywhere) means the mesh's longest edge (``scene.mesh.lmax``).
"""

from __future__ import annotations

from typing import Any, ClassVar

from warpvol.scene.tf_ranges import density_max
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
        note = thickness_axis_note(ctx.scene, table, tf)
        if note is not None:
            ctx.stats[self.name] = note


#: optical depth below which cells thinner than the first thickness step are not reported: five 8-bit steps
THICKNESS_TAU = 5.0 / 255.0


def thickness_axis_note(scene, table, tf) -> dict | None:
    """A uniform thickness axis spans ``[0, lmax]`` with ``lmax`` the mesh's longest edge, so the cells of
    a small object beside a large one are thinner than its first step and read a table interpolated
    between l = 0 and the first texel centre: the paper's arithmetic, reported (``warning``) when such
    cells carry more than :data:`THICKNESS_TAU` of optical depth in one step. ``None`` for tables
    without a uniform ``l`` axis."""
    import numpy as np


    ax = next((a for a in table.axes if a.name == "l"), None)
    mesh = getattr(scene, "mesh", None)
    if ax is None or ax.kind not in ("centred", "endpoint") or tf is None \
            or not all(hasattr(mesh, k) for k in ("points", "tets", "scalars")):
        return None
    step = float(ax.scale) / (ax.n if ax.kind == "centred" else ax.n - 1)
    cache = mesh.__dict__.setdefault("_tet_longest_edge", {})
    if "l" not in cache:
        p = np.asarray(mesh.points, dtype=np.float64)[np.asarray(mesh.tets)]
        cache["l"] = np.max([np.linalg.norm(p[:, a] - p[:, b], axis=1)
                             for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))], axis=0)
    thin = np.flatnonzero(cache["l"] < step)
    if len(thin) == 0:
        return None
    sc = np.asarray(mesh.scalars, dtype=np.float64)[np.asarray(mesh.tets)[thin]]
    dens = density_max(tf, sc.min(axis=1), sc.max(axis=1))
    n = int((dens * step > THICKNESS_TAU).sum())
    if n == 0:
        return None
    return {"thin_cells": n, "step": step, "warning": (
        f"uniform thickness axis of {ax.n} texels over lmax = {ax.scale:.3g} (the mesh's longest edge): {n:,} cells "
        f"carrying extinction are shorter than one step ({step:.3g}) and read the table between l = 0 and the "
        "first texel (the paper's arithmetic: their segments are integrated as if thicker or thinner, most where "
        "small cells sit beside large ones)")}
