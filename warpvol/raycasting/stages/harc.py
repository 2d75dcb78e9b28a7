"""Stage ``harc``: hardware ray casting, first pass (Weiler et al. 2003; Espinha & Celes 2005 Fig. 6).

Each pixel's ray starts at its first rasterised front boundary face (``harc_raster``) and walks one
cell per fragment-program step (:mod:`warpvol.kernels.harc`): the paper's plane arithmetic on the
96 bytes/tet textures (``walk = "planes"``) or the consistent Plücker walk shared with ``raycast``
(``walk = "plucker"``). Segments are integrated exactly, with a 3D pre-integration table (``full``)
or by partial pre-integration with iso splits (``partial``), composited front to back and written to
the frame buffer in ``format``.

``ray_setup = "robust"``: each ray set up in float64 from an origin moved to the mesh; rays the float32
walk cannot resolve are redone in float64 on the host and counted (``float64_rays``; old name
``unresolved_rays``, still written); with exact segments, so are the rays that may cross a cell too thin
for float32 (``thin_cell_rays``, :func:`warpvol.shared.thin_cells.unresolved_pixels`), before the walk.
``ray_setup = "paper"`` (the paper's fragment program; ``walk = "planes"`` on ``harc_mesh arithmetic =
"fp32"`` textures): the ray starts at the eye in fp32, and a ray the walk cannot resolve is lost --
counted (``lost_rays``), warned in the report, and its pixel shows what it had composited.
"""

from __future__ import annotations

from warpvol.errors import ConfigError
from warpvol.gpu.counters import active
from warpvol.parallel import cpu_threads
from warpvol.raycasting.stages.cell_setup import scalar_check_needed
from warpvol.raycasting.stages.raycast import leaves_out_text, rays_without_cell, report_left_out, stop_transmittance
from warpvol.shared.integration import integ_setup
from warpvol.shared.visible import confined
from warpvol.stage import Context, Param, Stage, register_stage


def count_pass(ctx: Context, c: dict, textures: list, walk: str, integration: str, fmt: str,
               work=None) -> None:
    """Count one propagation pass for the throughput model: the pass, its fragment-program steps
    (``cell_steps``: one per cell, plus the iso sub-steps of partial pre-integration), the texture
    fetches by texture (mesh textures: 6 nearest rgba32f fetches per cell of the plane walk; the 3D
    table one per step; psi and iso one each per sub-step) and one frame-buffer write per ray that
    entered. With ``work`` (a callable giving per pixel the cells and steps of this pass, ``(H, W, 2)``) the loop's issue
    slots per pixel are summed as run (``loop_slots``) and as 32 x 32-pixel lock-step batches run
    them (``loop_slots_batch1024``, :func:`warpvol.gpu.programs.batched_slots`). Diagnostics
    (unresolved rays, iso misses, entry searches) go to ``stats``."""

    ctx.count(passes=1, entries=c["entries"], cell_steps=c["steps"])
    cnt = active()
    if cnt is None:
        return
    tex = [t for t in textures if t.shape != (1, 1) and t.shape != (1, 1, 1)]
    if walk == "planes" and c["texture_fetches"]:
        cnt.add(**{"tex_2d_rgba32f_nearest": c["texture_fetches"], "texels": c["texture_fetches"]})
    tf_tex = [t for t in tex if len(t.shape) == 1]  # partial: the TF's 1D texture, when it is one
    for t in tex:  # full: the 3D table; partial: psi, then iso, one each per step; the TF at both ends
        t.count(2 * c["steps"] if len(t.shape) == 1 else c["steps"])
    if walk == "planes" and integration in ("full", "partial"):  # the fragment program's instructions
        from warpvol.gpu import programs

        sub = programs.FULL if integration == "full" else programs.PARTIAL_SUB
        cnt.add(combiner_ops=c["cells"] * programs.n_alu(programs.WALK) + c["steps"] * programs.n_alu(sub))
        if integration == "partial" and not tf_tex:  # the exact option reads the TF's control points at both
            # ends of each sub-segment: counted as the 8-bit 1D texture fetches it stands in for
            cnt.add(tex_1d_rgba8_linear=2 * c["steps"], texels=4 * c["steps"])
        if work is not None:
            px = work()
            per_cell = programs.n_alu(programs.WALK) + programs.n_tex(programs.WALK)
            per_step = programs.n_alu(sub) + programs.n_tex(sub)
            slots = px[..., 0] * per_cell + px[..., 1] * per_step
            run, batched = programs.batched_slots(slots, px[..., 0] > 0)
            cnt.add(loop_slots=run, loop_slots_batch1024=batched)
    if c["entries"]:
        cnt.blend(fmt, c["entries"], blending=False)


def px_work(state, cam):
    """The last pass's per-pixel loop work ``(H, W, 2)``: cells visited, fragment-program steps."""
    return state.px_work.numpy().reshape(cam.height_px, cam.width_px, 2)


HARC_PARAMS = (
    Param("early_termination", float, 0.0, "stop a ray once no channel of its pixel can change by more than this "
          "(its transmittance 1 - A times the brightest radiance behind below it; 0: off, as in the paper's "
          "measurements)", lo=0.0, hi=1.0),
    Param("max_steps", int, 1_000_000, "cells per ray and pass (bounded passes); a ray reaching it is counted",
          lo=1),
    Param("threads", int, 0, "host threads launching row blocks on the CPU (0: all cores)", lo=0, hi=256),
)


@register_stage
class Harc(Stage):
    """First ray-casting pass: boundary entry, cell-to-cell propagation, front-to-back compositing.

    =================  =====  =========  ==========================================================
    parameter          type   default    meaning
    =================  =====  =========  ==========================================================
    walk               str    planes     ``planes`` (paper's Fig. 6 on the texture layout) |
                                         ``plucker`` (consistent walk of ``raycast``)
    integration        str    exact      ``exact`` | ``full`` (3D table) | ``partial`` (psi + iso)
    table              str    table3d    ``ctx.buffers`` key of the 3D table (``full``)
    psi                str    psi        ``ctx.buffers`` key of the psi table (``partial``)
    iso                str    iso        ``ctx.buffers`` key of the iso table (``partial``)
    iso_rule           str    paper      ``paper`` (``sf == s_iso``) | ``behind`` (edge-anchored table)
    tf_texture         str    exact      ``partial``: the TF as a 1D texture ``rgba8`` | ``rgba16f``
                                         (linear, extinction over its maximum), or ``exact`` (the
                                         control points; no card's format)
    tf_texels          int    256        texels of that 1D texture
    ray_setup          str    robust     ``robust`` (float64 ray from the mesh, float64 redo) |
                                         ``paper`` (fp32 ray from the eye, lost rays stay lost)
    weight_bits        int    8          texture filter-weight bits (0: fp32 weights)
    format             str    fp32       frame-buffer format of each pass's result
    early_termination  float  0          stop a ray once no channel can change by more than this:
                                         1 - A below it over the brightest radiance behind (0: off;
                                         off with skipping off)
    max_steps          int    1000000    cells per ray and pass
    threads            int    0          host threads for CPU row blocks (0: all cores)
    =================  =====  =========  ==========================================================
    """

    name = "harc"
    summary = ("hardware ray casting (HARC): rasterised boundary entry, one cell per fragment-program step, "
               "exact / full / partial pre-integration, front-to-back in the buffer's format")
    needs = ("cells", "harc_mesh", "harc_entry")
    provides = ("harc_state", "image")
    renamed_stats = {"unresolved_rays": "float64_rays"}  # the float64 redo's one name, as in raycast and pt_integrate
    params = (
        Param("walk", str, "planes", "exit-face arithmetic", choices=("planes", "plucker")),
        Param("integration", str, "exact", "segment integration", choices=("exact", "full", "partial")),
        Param("table", str, "table3d", "ctx.buffers key of the 3D table (full)"),
        Param("psi", str, "psi", "ctx.buffers key of the psi table (partial)"),
        Param("iso", str, "iso", "ctx.buffers key of the iso-crossing table (partial)"),
        Param("iso_rule", str, "paper", "next_s_iso rule", choices=("paper", "behind")),
        Param("tf_texture", str, "exact", "partial: the TF's 1D texture format, or exact control points",
              choices=("exact", "rgba8", "rgba16f")),
        Param("tf_texels", int, 256, "partial: texels of the TF's 1D texture", lo=2, hi=4096),
        Param("ray_setup", str, "robust", "ray set-up and unresolved rays", choices=("robust", "paper")),
        Param("weight_bits", int, 8, "texture filter-weight fraction bits (0: fp32)", lo=0, hi=16),
        Param("format", str, "fp32", "frame-buffer format", choices=("unorm8", "unorm12", "unorm16", "fp16", "fp32")),
    ) + HARC_PARAMS

    def requires_caps(self) -> dict:
        caps = {"fragment_loops": True, "float_textures": True}
        if self.integration == "full":
            caps["tex3d"] = True
        return caps

    def leaves_out(self, ctx: Context) -> str | None:
        return leaves_out_text(ctx, self.early_termination)

    def pass_runner(self, ctx: Context, state, *, t_stop: float, segments=None):
        """This stage's propagation pass over ``state`` (a :class:`~warpvol.raycasting.harc.HarcState`), its
        configuration checked and its integration set up: ``(run_pass, keep)``, ``run_pass(max_steps)`` giving a
        pass's counters, ``keep`` the textures it reads. ``t_stop``: the transmittance rays stop below (0:
        never); ``segments`` (:func:`~warpvol.raycasting.stages.raycast.segments_struct`): each entry's segment
        kept there (``walk = "plucker"``, ``integration = "exact"``)."""
        from warpvol.raycasting.harc import march_pass

        mt = ctx.buffers["harc_mesh"]
        if self.walk == "planes" and mt["struct"] is None:
            raise ConfigError(f"{self.where}.walk: 'planes' needs harc_mesh layout = 'paper96'")
        paper = self.ray_setup == "paper"
        if paper and self.walk != "planes":
            raise ConfigError(f"{self.where}.ray_setup: 'paper' needs walk = 'planes' (the paper's Fig. 6 arithmetic)")
        if self.walk == "planes" and mt.get("arithmetic") != ("fp32" if paper else "float64"):
            raise ConfigError(f"{self.where}.ray_setup: {self.ray_setup!r} reads harc_mesh textures with arithmetic = "
                              f"{'fp32' if paper else 'float64'!r} (the ray's frame), not "
                              f"{mt.get('arithmetic')!r}")
        if self.walk == "planes" and confined(ctx):
            raise ConfigError(f"{self.where}.walk: 'planes' reads the mesh's own adjacency texture and cannot walk "
                              "only the visible cells; drop the visibility stage or use walk = 'plucker'")
        if segments is not None and (self.walk, self.integration) != ("plucker", "exact"):
            raise ConfigError(f"{self.where}: segments are kept by walk = 'plucker' with integration = 'exact' only, "
                              f"not {self.walk!r} with {self.integration!r}")
        st = mt["struct"]
        keep_st = None
        if st is None:  # the plucker walk reads the compact layout (the cells' arrays)
            from warpvol.raycasting.harc import empty_mesh_tex

            st, keep_st = empty_mesh_tex(ctx.device)
        tables = {}
        for key in (("table",) if self.integration == "full" else ("psi", "iso") if self.integration == "partial"
                    else ()):
            name = self.config[key]
            if name not in ctx.buffers:
                raise ConfigError(f"{self.where}.{key}: no table {name!r} in this pipeline; put a table stage "
                                  f"with output = {name!r} before this stage")
            tables[key] = ctx.buffers[name]
        ctx.mesh_setup(ctx.scene.mesh, "edge_lengths")  # lmax's; per mesh, kept on it: set-up on first use
        ig, keep = integ_setup(self.integration, ctx.scene.transfer, ctx.device, iso_rule=self.iso_rule,
                               weight_bits=self.weight_bits or None, lmax=ctx.scene.mesh.lmax,
                               cache=ctx.persistent.setdefault("harc_textures", {}), tf_texture=self.tf_texture,
                               tf_texels=self.tf_texels, **tables)
        entry = ctx.buffers["harc_entry"]
        threads = self.threads or cpu_threads()
        # the exact walk's bound on the crossings' scalar errors, off where it provably cannot fire (per frame)
        cells = ctx.buffers["cells"]
        scalar_check = scalar_check_needed(ig.tf_s, ig.tf_v, ig.model, cells["s_span"], cells["radius"])

        def run_pass(max_steps=self.max_steps):
            return march_pass(ctx, state, walk=self.walk, mesh_tex=st, entry=entry, ig=ig, fb_format=self.format,
                              t_stop=t_stop, max_steps=max_steps, threads=threads, scalar_check=scalar_check,
                              setup=self.ray_setup, segments=segments)

        return run_pass, (keep, keep_st)

    def run(self, ctx: Context) -> None:
        from warpvol.kernels.raycast import STATUS_FAILED
        from warpvol.raycasting.harc import HarcState, lost_rays, lost_warning, resolve_failed

        paper = self.ray_setup == "paper"
        cam = ctx.scene.camera
        state = HarcState(cam.width_px * cam.height_px, ctx.device)
        t_stop = stop_transmittance(ctx, self.early_termination)
        bound = self.early_termination if t_stop > 0 else 0.0  # the stated termination bound (0: none)
        run_pass, (keep, keep_st) = self.pass_runner(ctx, state, t_stop=t_stop)

        import time

        thin_rays = thin_tets = 0
        if not paper and self.integration == "exact":  # rays through cells too thin for float32: float64 redo
            from warpvol.shared.thin_cells import mark_unresolved

            thin_rays, thin_tets = mark_unresolved(ctx, state.status, int(STATUS_FAILED))
        t0 = time.perf_counter()
        c = run_pass()
        t1 = time.perf_counter()
        missed = rays_without_cell(state.last, state.status, int(STATUS_FAILED))
        ctx.buffers["harc_state"] = {"state": state, "run_pass": run_pass, "keep": (keep, keep_st), "eps": bound,
                                     "count": lambda c: count_pass(ctx, c, keep, self.walk, self.integration,
                                                                   self.format, lambda: px_work(state, cam)),
                                     "resolve": lambda: resolve_failed(ctx, state, bound),
                                     "lost": (lambda: lost_rays(state)) if paper else None}
        # robust: failed rays are redone whole in float64 now (and then done: later peel passes skip
        # them); paper: none are marked failed, lost rays keep their partial result
        redone = resolve_failed(ctx, state, bound)
        t2 = time.perf_counter()
        count_pass(ctx, c, keep, self.walk, self.integration, self.format, lambda: px_work(state, cam))
        ctx.count(rays=state.n)
        ctx.stats["harc"] = {"walk": self.walk, "integration": self.integration, "ray_setup": self.ray_setup, **c,
                             "float64_rays": redone, "thin_cell_rays": thin_rays, "thin_cells": thin_tets,
                             "pass_s": t1 - t0, "float64_s": t2 - t1}
        if paper:
            lost = lost_rays(state)
            ctx.stats["harc"]["lost_rays"] = lost
            if lost or c["backward_rays"]:
                ctx.stats["harc"]["warning"] = lost_warning(lost, state.n, c["backward_rays"])
        report_left_out(ctx, bound, c["terminated_early"], missed)
        if redone:
            ctx.progress(f"harc: {redone} rays the float32 walk could not resolve were redone in float64")
        if not paper and c["eye_inside_rays"] > 0.25 * state.n:  # correct, but at the float64 tracer's speed: say why
            ctx.stats["harc"]["note"] = (
                f"{c['eye_inside_rays']} of {state.n} rays were redone in float64 on the host: the eye lies inside the mesh's "
                "bounding sphere, where a rasterised ray start cannot tell rays that begin inside a cell; "
                "raycast renders such views in float32")
        ctx.image = state.image(cam.height_px, cam.width_px)
