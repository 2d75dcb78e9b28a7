"""Host step ``condition``: the scene moved to the mesh's centre, scaled to unit size and its scalars
mapped by the transfer function's range, in float64, before any stage casts it to float32
(:func:`warpvol.conditioning.conditioning.condition_scene`). The image is the same; float32 then keeps its 24 bits
for the data's variation, not for its offset (georeferenced coordinates, pressures in pascal, meshes
in nanometres or light years), and later thresholds act relative to the mesh's size. The scalars'
offset is chosen so that float32 keeps every transfer-function segment the data reaches apart (a
log-scaled field is mapped about its smallest decade); points no cell uses take no part in any frame.

A mesh whose cells come in an incoherent order (a Delaunay tetrahedralisation of scattered points)
has its cells and points renumbered along a Morton curve (:mod:`warpvol.conditioning.reorder`), so a
ray's next cell is usually in cache; meshes numbered coherently (meshers' output, grids) are left as
they are.

The conditioned mesh is built once per (mesh, scalar mapping) and kept in the pipeline's persistent
state, so the per-mesh caches of the later stages (``cell_setup``, ``vsb_setup``, ...) keep hitting
across renders with a new camera or a transfer function of the same range. Stats: ``origin`` and
``scale`` (world point and length that become 0 and 1), ``scalar_offset`` and ``scalar_scale``
(``s' = (s - offset) / scale``), ``reordered``, ``cached``, ``scalar_resolution``, ``unused_points`` and,
where float32 resolves a transfer-function segment too coarsely for the preset's tolerance, ``warning``.
"""

from __future__ import annotations

from warpvol.conditioning.conditioning import condition_scene
from warpvol.conditioning.reorder import REORDER_CHOICES
from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class Condition(Stage):
    """Replace ``ctx.scene`` by the same scene in unit-size, float32-friendly coordinates and scalars.

    ==========  =====  =========  ==============================================================
    parameter   type   default    meaning
    ==========  =====  =========  ==============================================================
    reorder     str    ``auto``   renumber cells and points along a Morton curve: ``auto`` (when
                                  over half the neighbour pairs lie 4,096+ records apart),
                                  ``morton`` (always), ``none``
    ==========  =====  =========  ==============================================================

    Example
    -------
    >>> import warpvol
    >>> s = warpvol.builtin_scene("box").with_camera(width_px=8, height_px=8)
    >>> r = warpvol.Pipeline.load("raycast").render(s, quiet=True)
    >>> r.report["stats"]["condition"]["scale"], r.report["stats"]["condition"]["scalar_offset"]
    (1.0, 1.0)
    """

    name = "condition"
    summary = "scene moved to the mesh centre, scaled to unit size, scalars mapped by the TF range (float64)"
    params = (Param("reorder", str, "auto", "renumber cells and points along a Morton curve (auto: when the "
                    "mesh's order is incoherent)", choices=REORDER_CHOICES),)
    needs = ()
    provides = ("conditioned",)
    setup = True  # per-mesh work kept across renders (see the module docstring)

    def run(self, ctx: Context) -> None:
        ctx.scene, info = condition_scene(ctx.scene, cache=ctx.persistent.setdefault("condition", {}),
                                          reorder=self.reorder, frame=ctx.buffers.get("frame"))
        ctx.buffers["conditioned"] = True
        ctx.buffers.pop("visible_cells", None)  # per cell of the scene before: its cells may be renumbered
        ctx.stats["condition"] = info
