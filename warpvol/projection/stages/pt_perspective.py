"""Stage ``pt_perspective``: Kraus, Qiao & Ebert 2004 perspective-correct PT attributes.

Every PT triangle is the projection of a smaller tetrahedron of the cell; each of its vertices has
a front and a back point (equal on silhouette vertices; the thick vertex's two points on the
viewing ray through it). The vertex program (:func:`warpvol.projection.programs.perspective_attrs`) outputs
``a/w`` and ``1/w`` of the front and back points apart (``sf/wf``, ``sb/wb``, ``1/wf``, ``1/wb``,
the front eye point over ``wf`` and ``zb/wb``); the rasteriser interpolates them linearly in screen
space; the fragment programs (``pt_table3d``, ``pt_guthe``) divide per fragment and compute the
thickness ``l = |ve_f| |(ze_b - ze_f) / ze_f|`` (``thickness = "exact"``) or ``|ze_b - ze_f|``
(``"approx"``, the cheaper form the paper mentions). The fragment stages use these attributes
whenever this stage has run (``ctx.buffers["pt_perspective"]``).

Planner: with an orthographic camera every ``w`` is 1 and screen-linear interpolation already is
perspective-correct (same image), so by default (``orthographic = "skip"``) the stage is skipped with
that reason. ``orthographic = "run"`` runs it on every camera, as the paper's vertex and fragment
programs ran whatever the projection (the faithful ``kraus2004_full``): the divisions and their
instructions are counted, the image is the same up to rounding.
"""

from __future__ import annotations

from warpvol.projection.programs import perspective_attrs
from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class PTPerspective(Stage):
    """Per-vertex ``a/w``, ``1/w`` of front and back points for per-fragment perspective division.

    ============  =====  ========  ====================  ==============================================
    parameter     type   default   allowed               meaning
    ============  =====  ========  ====================  ==============================================
    thickness     str    exact     ``exact`` ``approx``  ``|ve_f| |(ze_b - ze_f)/ze_f|`` or
                                                         ``|ze_b - ze_f|``
    orthographic  str    skip      ``skip`` ``run``      on an orthographic camera: skipped (same
                                                         image) or run, as the paper's programs ran
    ============  =====  ========  ====================  ==============================================

    Example
    -------
    >>> from warpvol.pipeline import Pipeline
    >>> from warpvol.scene.builtin import builtin_scene
    >>> sc = builtin_scene("box").with_camera(width_px=8, height_px=8)
    >>> sc.camera.projection
    'orthographic'
    >>> [s["stage"] for s in Pipeline.load("pt_best").render(sc, quiet=True).report["skipped"]
    ...  if s["stage"].startswith("pt_perspective")]
    ['pt_perspective']
    >>> Pipeline.load("kraus2004_full").render(sc, quiet=True).report["stats"]["pt"]["interpolation"]
    'perspective-correct (exact thickness)'
    """

    name = "pt_perspective"
    summary = "Kraus et al. 2004: perspective-correct PT attributes (a/w, 1/w per front/back point), exact thickness"
    params = (Param("thickness", str, "exact", "thickness formula", choices=("exact", "approx")),
              Param("orthographic", str, "skip", "orthographic camera: skip the stage (same image) or run it",
                    choices=("skip", "run")))
    needs = ("pt_geometry",)
    provides = ("pt_perspective",)

    def skip_reason(self, ctx: Context) -> str | None:
        if ctx.scene.camera.projection == "orthographic" and self.config["orthographic"] == "skip":
            return ("orthographic camera: w = 1 at every vertex, screen-linear interpolation is already "
                    "perspective-correct (same image)")
        return None

    def run(self, ctx: Context) -> None:
        attrs = perspective_attrs(ctx.buffers["pt_geometry"], device=ctx.device)
        ctx.buffers["pt_perspective"] = {"attrs": attrs, "thickness": self.config["thickness"],
                                         "ortho": ctx.scene.camera.projection == "orthographic"}
        ctx.count(vertices=attrs.shape[0])


def fragment_inputs(ctx: Context) -> tuple:
    """``(vertex attributes, mode, ortho, z_off)`` for a PT fragment stage: Kraus' perspective
    attributes when ``pt_perspective`` ran, else the screen-linear ``(sf, sb, l)``; says which in
    ``stats.pt.interpolation``. ``z_off``: the eye-space depth offset of the attributes (the vertex
    stage's ``eye_origin``)."""
    p = ctx.buffers.get("pt_perspective")
    st = ctx.stats.setdefault("pt", {})
    geo = ctx.buffers["pt_geometry"]
    if p is None:
        st["interpolation"] = "screen-linear"
        return geo.attrs, "off", False, geo.eye_offset
    st["interpolation"] = f"perspective-correct ({p['thickness']} thickness)"
    return p["attrs"], p["thickness"], p["ortho"], geo.eye_offset
