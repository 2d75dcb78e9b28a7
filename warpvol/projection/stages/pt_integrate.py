"""Stage ``pt_integrate``: projected tetrahedra without a table (beyond the papers; ``pt_best``).

The fragment program integrates each fragment's ray segment ``(sf, sb, l)`` exactly for the
piecewise-linear TF (:func:`warpvol.kernels.integrate.integrate_segment`, the reference's closed
form, in fp32): no table resolution, quantisation or filtering error. Row bands of the image are drawn
concurrently from the host thread pool (``row_bands``; the same image as one draw); with ``walk =
"fused"`` (``pt_best``) the host threads take blocks of the rasteriser's tiles instead (one triangle
set-up, no fragment list). With ``pt_perspective``
before it the segment is perspective-correct. Writes ``ctx.image``; counts ``fragments``,
``blends`` and ``segment_integrals``.

Pixels float32 cannot draw right are redone in float64 (:meth:`PTIntegrate.redo_unresolved`); after
``pt_project exact_attrs`` (attribute planes at the unsnapped positions) these include the pixels
beside the projected edges of tets the transfer function changes steeply across, and a transfer
function steep enough that float32 rounding of the fragments' scalars may cost more than pt_best's
stated max abs is reported with the estimated bound (``stats.pt_integrate.rounding_bound``,
:func:`warpvol.projection.pt_thin.rounding_bound`).
"""

from __future__ import annotations

import numpy as np

from warpvol.projection.programs import exact_program
from warpvol.projection.pt import DRAW_WALKS, FUSED_LANES, FUSED_TILES
from warpvol.projection.pt_thin import drawn_faces, missing_parts, prepare_parts, rounding_bound, unresolved_pixels
from warpvol.projection.stages.pt_perspective import fragment_inputs
from warpvol.projection.stages.pt_vertex_color import BATCH, DITHER, composite, fb_param
from warpvol.reference.pixels import redo_mesh_properties, redo_pixels_float64
from warpvol.shared.visible import skipping
from warpvol.stage import Context, Param, Stage, register_stage

#: pt_best's stated largest error against the float64 reference (README; tests/tolerances.py row pt_best)
PT_BEST_MAX_ABS = 4e-3

#: what the fused draw leaves out where the transfer function adds nothing (``fragments_zero``, ``triangles_zero``)
ZERO_WHY = ("fragments whose segment has both ends where the transfer function adds nothing (exact zeros: blending "
            "them changes nothing), and the triangles all of whose fragments are such (not walked)")


@register_stage
class PTIntegrate(Stage):
    """Exact per-fragment segment integral of the TF (no table), back-to-front blending.

    =================  =====  ========  ==========================================  =======================
    parameter          type   default   allowed                                     meaning
    =================  =====  ========  ==========================================  =======================
    format             str    fp32      ``unorm8`` ``unorm12`` ``unorm16``          frame-buffer format
                                        ``fp16`` ``fp32``
    dither             bool   false                                                 alpha dithering
    batch_tets         int    65536     [1, 2^26]                                   tets per batch
    row_bands          int    0         [0, 256]; 0 = one per CPU core (1 on       image row bands drawn
                                        other devices)                              concurrently (``fused``:
                                                                                    host threads over tiles)
    early_termination  float  0         [0, 0.01]; applies with ``fused``          front to back with early
                                        and ``fp32`` (else none)                    termination: a pixel stops
                                                                                    once what could still come
                                                                                    from behind changes no
                                                                                    channel by more than this
    fused_tile         int    0         ``0`` ``4`` ``8`` ``16`` ``32`` ``64``      bin size of the fused walk
                                                                                    (one thread per bin; 0: 64
                                                                                    on the CPU, 8 on CUDA)
    lanes              int    0         ``0`` ``1`` ``4`` ``8`` ``16`` ``32``       fragments per SIMD span
                                                                                    of the fused walk (0: 16
                                                                                    on the CPU, 1 on CUDA;
                                                                                    same image and counters)
    walk               str    pixel     ``pixel`` ``triangle`` ``fused``            fragment generation:
                                                                                    emulated per-pixel tile
                                                                                    walk, or per-triangle
                                                                                    bounding-box walk + sort
                                                                                    (same fragments, faster),
                                                                                    or one kernel per bin
                                                                                    doing walk, program and
                                                                                    blend (same fragments;
                                                                                    plane-equation
                                                                                    attributes, the pixel's
                                                                                    ray in the thickness)
    =================  =====  ========  ==========================================  =======================

    Example
    -------
    >>> from warpvol.pipeline import Pipeline
    >>> from warpvol.scene.builtin import builtin_scene
    >>> res = Pipeline.load("pt_best").render(builtin_scene("box").with_camera(width_px=8, height_px=8), quiet=True)
    >>> c = res.report["counters"]["pt_integrate"]
    >>> c["segment_integrals"] == c["fragments"] > 0
    True
    """

    name = "pt_integrate"
    renamed_stats = {"float64_pixels": "float64_rays"}  # the float64 redo's one name, as in the ray casters
    summary = "PT fragment program: exact per-fragment segment integral of the TF (no table; beyond the papers)"
    params = (fb_param("fp32"), DITHER, BATCH,
              Param("row_bands", int, 0, "row bands drawn concurrently (0: one per CPU core; 1: off)", lo=0, hi=256),
              Param("walk", str, "pixel", "fragment generation: per-pixel tile walk (emulated hardware) or "
                    "per-triangle bounding-box walk + stable sort by pixel (same fragments), or fused: walk, program "
                    "and blend in one kernel per bin (same fragments, no fragment list; plane-equation attributes)",
                    choices=DRAW_WALKS),
              Param("early_termination", float, 0.0, "front to back with early termination: a pixel stops once "
                    "what could still come from behind changes no channel by more than this (0: off; applies to "
                    "the fused walk into fp32, no termination otherwise)", lo=0.0, hi=0.01),
              Param("fused_tile", int, 0, "bin size of the fused walk, one kernel thread per bin (0: by device, "
                    "64 px on the CPU, 8 px on CUDA)", choices=FUSED_TILES),
              Param("lanes", int, 0, "fragments per SIMD span of the fused walk (0: by device, 16 on the CPU, 1 on "
                    "CUDA; 1: one fragment at a time); the same image and counters for every value",
                    choices=FUSED_LANES))
    needs = ("pt_geometry",)

    def _terminates(self) -> bool:
        """Early termination applies to the fused draw into an fp32 buffer (front to back, "under")."""
        return self.config["early_termination"] > 0 and self.config["walk"] == "fused" and self.config["format"] == "fp32"

    def _skips_zero(self) -> bool:
        """Fragments the transfer function maps to zero are left out of the fused draw into an fp32 buffer."""
        return self.config["walk"] == "fused" and self.config["format"] == "fp32" and not self.config["dither"]

    def leaves_out(self, ctx: Context) -> str | None:
        parts = [ZERO_WHY] if self._skips_zero() else []
        if self._terminates():
            parts.append(f"fragments behind an opaque front: drawn front to back, a pixel stops once its remaining "
                         f"transmittance times the brightest radiance behind is at most "
                         f"{self.config['early_termination']:g} (the largest change of any channel it allows)")
        return "; ".join(parts) or None
    provides = ("image",)

    def run(self, ctx: Context) -> None:
        attrs, mode, ortho, z_off = fragment_inputs(ctx)
        program = exact_program(ctx.scene.transfer, mode=mode, ortho=ortho, device=ctx.device, z_off=z_off,
                                camera=ctx.scene.camera, tile=self.config["fused_tile"],
                                lanes=self.config["lanes"])
        bands = self.config["row_bands"]
        if bands == 0:
            from warpvol.parallel import cpu_threads

            bands = cpu_threads() if str(ctx.device).startswith("cpu") else 1
        eps = self.config["early_termination"] if ctx.skip and self._terminates() else 0.0
        t_min = 0.0
        if eps > 0:
            from warpvol.conditioning.visibility import termination_threshold

            lo, hi = (np.asarray(b, dtype=np.float64) for b in ctx.scene.mesh.bounds)
            t_min = termination_threshold(ctx.scene.transfer, float(np.linalg.norm(hi - lo)), eps)
        skip_zero = ctx.skip and self._skips_zero()
        info = composite(self, ctx, attrs, program, bands=bands, walk=self.config["walk"], t_min=t_min,
                         skip_zero=skip_zero)
        ctx.count(segment_integrals=info["fragments"])
        why, counts = ([ZERO_WHY], {k: info[k] for k in ("fragments_zero", "triangles_zero")}) if skip_zero else ([], {})
        if t_min > 0:
            why.append(f"fragments behind an opaque front (drawn front to back; a pixel stops at remaining "
                       f"transmittance {t_min:.3g}, so no channel changes by more than {eps:g}; a triangle whose "
                       "box in a bin is all terminated is not set up, a cell none of whose triangles is is "
                       "occluded; pixels float32 cannot resolve are redone in float64 only where the cell "
                       "concerned came before the pixel terminated)")
            counts.update(fragments_terminated=info["fragments_terminated"], bins_terminated=info["bins_terminated"],
                          triangles_occluded=info["triangles_occluded"], cells_occluded=info["cells_occluded"],
                          pixels_terminated=int(np.count_nonzero(1.0 - ctx.image[..., 3] <= t_min)))
        if why:
            ctx.left_out(why="; ".join(why), **counts)
        self.redo_unresolved(ctx, info.get("term_at"), eps)

    def redo_unresolved(self, ctx: Context, term_at: np.ndarray | None = None, eps: float = 0.0) -> None:
        """Pixels covered by tets float32 cannot draw right (thin cells that carry the image, faces seen
        edge-on from the eye or narrower than the rasteriser's snapping resolves;
        :func:`warpvol.projection.pt_thin.unresolved_pixels`): redone with the float64 ray
        tracer in an fp32 frame buffer, counted; in a lower-precision buffer (a format's rounding is
        its artifact) counted and reported as a warning. Only tets in the draw order count, and with
        ``term_at`` (the fused draw's early termination: the draw position that terminated each pixel) only
        the pixels that had not terminated when their fragments came (``occluded_pixels`` counts those left
        out, reported under ``left_out``). ``eps`` > 0: the draw's early-termination bound, which the float64
        redo stops at too."""


        sc = ctx.scene
        geo = ctx.buffers["pt_geometry"]  # attributes of the unsnapped positions: rough TFs show where coverage parts
        rough = geo.attr_positions is not None
        missing = missing_parts(sc.mesh, sc.transfer, rough=rough)
        if missing:  # per mesh and TF, kept on the mesh: set-up, not frame time
            with ctx.setup_work(f"thin-cell {', '.join(missing)}"):
                prepare_parts(sc.mesh, sc.transfer, missing)
        order = ctx.buffers["order"]
        rank = np.full(sc.mesh.n_tets, -1, dtype=np.int64)
        rank[order] = np.arange(len(order))
        if drawn_faces(sc.mesh, rank >= 0, cached_only=True) is None:  # per mesh and TF: set-up
            with ctx.setup_work("faces of the drawn cells"):
                drawn_faces(sc.mesh, rank >= 0)
        u = unresolved_pixels(sc.mesh, sc.transfer, sc.camera, rough=rough, rank=rank, term_at=term_at)
        if u["occluded_pixels"]:
            ctx.left_out(why=None, float64_pixels_occluded=u["occluded_pixels"])
        px = u["pixels"]
        st = {"thin_tets": u["thin_tets"], "edge_on_faces": u["edge_on_faces"], "sliver_faces": u["sliver_faces"],
              "silhouette_edges": u["silhouette_edges"], "rough_tets": u["rough_tets"], "float64_rays": 0}
        if len(px) and self.config["format"] == "fp32":
            ctx.mesh_setup(sc.mesh, *redo_mesh_properties(sc.camera))
            val = redo_pixels_float64(sc.mesh, sc.transfer, sc.camera, px, visible=skipping(ctx)[0],
                                      terminate=eps or None)  # the draw's own termination bound
            img = ctx.image.reshape(-1, 4)
            img[px] = val.astype(img.dtype)
            ctx.image = img.reshape(ctx.image.shape)
            st["float64_rays"] = int(len(px))
            ctx.count(float64_rays=int(len(px)))
            ctx.progress(f"pt_integrate: {len(px)} pixels covered by {u['thin_tets']} thin tets, "
                         f"{u['edge_on_faces']} faces seen edge-on, {u['sliver_faces']} faces narrower than the "
                         f"snapping resolves, {u['silhouette_edges']} silhouette edges and the edges of "
                         f"{u['rough_tets']} tets the transfer function changes steeply across were redone in float64")
        elif len(px):
            st["warning"] = (f"{len(px)} pixels are covered by {u['thin_tets']} tets thinner than float32 resolves "
                             f"with significant extinction, {u['edge_on_faces']} faces seen edge-on from "
                             f"the eye, {u['sliver_faces']} faces narrower than the snapping resolves or "
                             f"{u['silhouette_edges']} silhouette edges whose snapping changes the "
                             f"thickness visibly; drawn in the {self.config['format']} buffer as computed (may be "
                             "wrong)")
        if geo.attr_positions is not None:
            self.check_rounding(sc, st)
        ctx.stats["pt_integrate"] = st

    @staticmethod
    def check_rounding(sc, st: dict) -> None:
        """The estimated colour error float32 rounding of the fragments' ``(sf, sb)`` causes on a steep
        transfer function (:func:`warpvol.projection.pt_thin.rounding_bound`) as ``rounding_bound``; a
        warning saying so where it exceeds pt_best's stated max abs (:data:`PT_BEST_MAX_ABS`)."""

        bound, n = rounding_bound(sc.mesh, sc.transfer)
        st["rounding_bound"] = bound
        if bound > PT_BEST_MAX_ABS:
            text = (f"the transfer function is so steep over the scalars of {n:,} tets that float32 rounding of their "
                    f"fragments' front and back scalars can move a pixel by up to about {bound:.2g} (pt_best states "
                    f"{PT_BEST_MAX_ABS:g}); raycast and harc_best carry each scalar from cell to cell")
            st["warning"] = f"{st['warning']}; {text}" if st.get("warning") else text
