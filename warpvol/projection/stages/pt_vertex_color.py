"""Stage ``pt_vertex_color``: Shirley & Tuchman / Stein et al. per-vertex colour and opacity, blended
back to front into a frame buffer of the chosen format (the baseline VTK's
``vtkProjectedTetrahedraMapper`` follows).

Per output vertex (:func:`warpvol.projection.programs.vertex_colors`): colour and extinction averaged over the front
and back scalars, ``c̄ = (c(sf) + c(sb)) / 2``, ``τ̄ = (ρ(sf) + ρ(sb)) / 2``, and the thickness ``l``
(0 on silhouette vertices). The rasteriser interpolates ``(c̄, τ̄, l)`` linearly in screen space; the
fragment program computes ``α = 1 - exp(-τ̄ l)`` (Stein et al.'s exponential, evaluated exactly where
they used a 2D texture) and the colour ``c̄ α`` (colour times extinction) or ``c̄ α / τ̄`` (emission
density, ``c̄ l`` as ``τ̄ l -> 0``). The blending unit composites ``(one, one_minus_src_alpha)``.
Writes ``ctx.image``; counts ``fragments`` and ``blends`` (one blend per fragment).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from contextlib import contextmanager

from warpvol.errors import ConfigError
from warpvol.gpu.blend import BlendUnit, FrameBuffer
from warpvol.projection import pt  # (pt.draw looked up per call: the texture-cache observer replaces it)
from warpvol.projection.programs import vertex_color_program, vertex_colors
from warpvol.stage import Context, Param, Stage, register_stage

FB_FORMATS = ("unorm8", "unorm12", "unorm16", "fp16", "fp32")


def fb_param(default: str = "unorm8") -> Param:
    return Param("format", str, default, "frame-buffer format", choices=FB_FORMATS)


BATCH = Param("batch_tets", int, 65536, "tets rasterised per fragment batch (memory bound)", lo=1, hi=1 << 26)
DITHER = Param("dither", bool, False, "alpha dithering (Kraus et al. 2004; fixed-point buffers only)")
# the 3D table lookup's parameters (pt_table3d, vicp)
TABLE3D = Param("table", str, "table3d", "ctx.buffers key of the 3D table")
FILTER = Param("filter", str, "linear", "texture filter", choices=("linear", "nearest"))
WEIGHT_BITS = Param("weight_bits", int, 8, "filter-weight fraction bits (0: fp32 weights)", lo=0, hi=16)


def texel_param(choices: tuple) -> Param:
    return Param("texel_format", str, "auto", "3D texture texel format (auto: holds the table's stored values)",
                 choices=choices)


_FB_POOL: OrderedDict = OrderedDict()  # (width, height, format, device) -> frame buffers not in use
_FB_LOCK = threading.Lock()
_FB_SIZES = 4  # buffer sizes kept (least recently used dropped), at most two buffers each


@contextmanager
def kept_frame_buffer(width: int, height: int, fmt: str, device):
    """A :class:`FrameBuffer` of this size and format kept between frames (allocating 5 MB of colour and
    depth per 512^2 frame, and touching its pages, cost more than a small frame's draw); each caller clears
    it. A buffer in use is not handed out again: concurrent renders get their own."""
    key = (int(width), int(height), str(fmt), str(device))
    with _FB_LOCK:
        free = _FB_POOL.get(key)
        fb = free.pop() if free else None
    if fb is None:
        fb = FrameBuffer(width, height, fmt, device=device)
    try:
        yield fb
    finally:
        with _FB_LOCK:
            free = _FB_POOL.setdefault(key, [])
            _FB_POOL.move_to_end(key)
            if len(free) < 2:
                free.append(fb)
            while len(_FB_POOL) > _FB_SIZES:
                _FB_POOL.popitem(last=False)


def composite(stage: Stage, ctx: Context, attrs, program, bands: int = 1, walk: str = "pixel",
              blend_unit=None, t_min: float = 0.0, skip_zero: bool = False) -> dict:
    """Draw ``pt_geometry`` with per-vertex ``attrs`` and ``program`` into a cleared buffer of the
    stage's format (in ``bands`` concurrent row bands, :func:`warpvol.projection.pt.draw`); set ``ctx.image``
    and count (shared by the ``pt_*`` fragment stages). ``t_min > 0``: front to back ("under") with early
    termination at that remaining transmittance (fused draw only); ``skip_zero``: fragments the transfer
    function maps to zero left out (fused draw only, :func:`warpvol.projection.pt.draw`)."""

    cam = ctx.scene.camera
    fmt = stage.config["format"]
    if stage.config["dither"] and fmt in ("fp16", "fp32"):
        raise ConfigError(f"{stage.where}.dither: alpha dithering needs a fixed-point format, format is {fmt}")
    unit = BlendUnit.over(dither=stage.config["dither"]) if blend_unit is None else blend_unit
    if t_min > 0:
        unit = BlendUnit.under()
    if walk == "fused":  # pt_best's draw: the buffer kept between frames (cleared here; the read-back a copy)
        with kept_frame_buffer(cam.width_px, cam.height_px, fmt, ctx.device) as fb:
            fb.clear((0, 0, 0, 0))
            info = pt.draw(ctx.buffers["pt_geometry"], attrs, program, fb, unit, batch_tets=stage.config["batch_tets"],
                           device=ctx.device, bands=bands, walk=walk, t_min=t_min, skip_zero=skip_zero)
            ctx.image = fb.readback()
    else:
        fb = FrameBuffer(cam.width_px, cam.height_px, fmt, device=ctx.device)
        fb.clear((0, 0, 0, 0))
        info = pt.draw(ctx.buffers["pt_geometry"], attrs, program, fb, unit,
                       batch_tets=stage.config["batch_tets"], device=ctx.device, bands=bands, walk=walk, t_min=t_min,
                       skip_zero=skip_zero)
        ctx.image = fb.readback()
    # fragments and blends are counted by the rasteriser and blending unit themselves; the draw sends each
    # drawn tet as a triangle fan (triangles + 2 vertices) with its position and attributes over the bus
    geo = ctx.buffers["pt_geometry"]
    drawn = sum(v for k, v in geo.classes.items() if k not in ("flat", "culled"))
    nv = geo.live_triangles() + 2 * drawn
    ctx.count(batches=info["batches"], attrs_clamped=info["attrs_clamped"], vertices=nv,
              bytes_up=nv * 4 * (4 + attrs.shape[1]))
    return info


def table_from(stage: Stage, ctx: Context, producer: str):
    """The table ``ctx.buffers[stage.config["table"]]``, or an error naming the stage to add."""

    key = stage.config["table"]
    if key not in ctx.buffers:
        raise ConfigError(f"{stage.where}.table: no table {key!r} in this pipeline; put a {producer} stage "
                          f"with output = {key!r} before this stage")
    return ctx.buffers[key]


@register_stage
class PTVertexColor(Stage):
    """Averaged per-vertex colour, α = 1 − exp(−τ̄ l) per fragment, back-to-front blending.

    ==========  =====  ========  ==========================================  =======================
    parameter   type   default   allowed                                     meaning
    ==========  =====  ========  ==========================================  =======================
    format      str    unorm8    ``unorm8`` ``unorm12`` ``unorm16``          frame-buffer format
                                 ``fp16`` ``fp32``
    dither      bool   false                                                 alpha dithering
    batch_tets  int    65536     [1, 2^26]                                   tets per batch
    ==========  =====  ========  ==========================================  =======================

    Example
    -------
    >>> from warpvol.pipeline import Pipeline
    >>> from warpvol.scene.builtin import builtin_scene
    >>> res = Pipeline.load("pt_vertex_color").render(builtin_scene("box").with_camera(width_px=8, height_px=8), quiet=True)
    >>> res.image.shape, res.report["counters"]["pt_vertex_color"]["fragments"] > 0
    ((8, 8, 4), True)
    """

    name = "pt_vertex_color"
    summary = "PT fragment program: averaged per-vertex colour, opacity 1 - exp(-tau l), back-to-front blending"
    params = (fb_param(), DITHER, BATCH)
    needs = ("pt_geometry",)
    provides = ("image",)

    def run(self, ctx: Context) -> None:
        tf = ctx.scene.transfer
        attrs = vertex_colors(ctx.buffers["pt_geometry"], tf, device=ctx.device)
        composite(self, ctx, attrs, vertex_color_program(tf.emission == "emission_density", device=ctx.device))
