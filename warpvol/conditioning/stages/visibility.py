"""Host step ``visibility``: which cells the transfer function can make visible, from each cell's scalar
range (:func:`warpvol.conditioning.visibility.cell_visibility`), so that the later stages sort, draw,
sweep or integrate only those. An invisible cell adds no colour and leaves the transmittance as it is,
so leaving it out changes no pixel.

Computed once per (mesh, transfer function) and kept in the pipeline's persistent state; its time is
set-up (``setup_s``), apart from the frame. Writes ``ctx.buffers["visible_cells"]``: a bool array, one
entry per tet of the (conditioned) scene's mesh (the pieces of a mesh of convex cells), ``True`` where
the tet can contribute. With skipping off (``skip=False``, ``--no-skip``) the planner skips the stage
and the buffer is absent: the later stages then do all the work. Stats: ``cells``, ``visible``,
``fraction``, ``cached``.
"""

from __future__ import annotations

import weakref

import numpy as np

from warpvol.conditioning.visibility import cell_visibility
from warpvol.stage import Context, Stage, register_stage


def _tetmesh(mesh):
    pieces = getattr(mesh, "pieces", None)
    return pieces if pieces is not None else mesh


@register_stage
class Visibility(Stage):
    """Per-cell visibility under the transfer function, for the stages that leave out invisible cells.

    Example
    -------
    >>> import warpvol
    >>> s = warpvol.builtin_scene("box").with_camera(width_px=8, height_px=8)
    >>> r = warpvol.Pipeline.load("pt_best").render(s, quiet=True)
    >>> {k: r.report["stats"]["visibility"][k] for k in ("cells", "visible")}
    {'cells': 384, 'visible': 384}
    """

    name = "visibility"
    summary = "which cells the transfer function can make visible, from each cell's scalar range (cached)"
    params = ()
    needs = ()  # after ``condition`` where there is one (the mask follows the conditioned mesh's cells)
    provides = ("visible_cells",)
    setup = True  # per (mesh, TF), kept across renders

    def skip_reason(self, ctx: Context) -> str | None:
        if not ctx.skip:
            return "skipping is off (skip=False, --no-skip): every cell is treated as visible"
        return None

    def leaves_out(self, ctx: Context) -> str | None:
        vis = cell_visibility(_tetmesh(ctx.scene.mesh), ctx.scene.transfer)
        n = len(vis)
        k = n - int(np.count_nonzero(vis))
        return (f"{k:,} of {n:,} cells ({100.0 * k / max(n, 1):.1f} %) have a scalar range the transfer function "
                "maps to zero (no colour, no opacity): marked for the later stages to leave out")

    def run(self, ctx: Context) -> None:
        mesh, tf = _tetmesh(ctx.scene.mesh), ctx.scene.transfer
        cache = ctx.persistent.setdefault("visibility", {})
        hit = cache.get("last")  # (weakref to the mesh, TF hash, mask)
        if hit is not None and hit[0]() is mesh and hit[1] == tf.hash:
            vis, cached = hit[2], True
        else:
            vis, cached = cell_visibility(mesh, tf), False
            vis.setflags(write=False)
            cache["last"] = (weakref.ref(mesh), tf.hash, vis)
        n, k = int(len(vis)), int(np.count_nonzero(vis))
        ctx.buffers["visible_cells"] = vis
        ctx.stats["visibility"] = {"cells": n, "visible": k, "fraction": (k / n) if n else 0.0, "cached": cached}
