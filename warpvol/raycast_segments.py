"""The ray casters ``raycast`` and ``harc_best`` rendered into segments (:mod:`warpvol.segments`), for a mesh
in pieces.

The preset's host stages (``condition`` .. ``entry_bins`` or ``harc_raster``) run as in a render; its float32 cell
walk (the same exact Plücker walk in both) then keeps each entry's segment (front and back ray parameter, its own
colour and transmittance: ``march_pass(segments=...)``) over as many passes as rays re-enter (``harc_best``: its
first pass and depth-peel passes), without early ray termination (a piece does not know what lies behind it). Rays the float32 walk cannot resolve (thin cells, a failed walk, more
entries than the segment lists hold, passes exhausted) take the exact reference's segments instead, as the
preset's float64 redo takes the reference's pixel. Depths are turned back into the world ray parameter of
Contract 2 (the walk measures them in the conditioned frame from an origin moved to the mesh).
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError
from warpvol.parallel import cpu_threads
from warpvol.pipeline import Pipeline
from warpvol.raycasting.stages.raycast import MarchState, march_pass, segments_struct
from warpvol.reference.segments import reference_segments
from warpvol.segments import Segments, stack_rows
from warpvol.shared.thin_cells import mark_unresolved
from warpvol.stage import Context

#: segments kept per ray and pass set (a ray with more takes the reference's segments)
SEGMENT_CAP = 32
#: walk passes at most (as the peel stage's ``max_passes``)
MAX_PASSES = 256


def _ray_shift(ctx) -> np.ndarray:
    """Per pixel, the walk's ray-parameter origin ``t0`` (:func:`warpvol.kernels.walk.ray_setup`, float64)."""
    cam = ctx.scene.camera
    cells = ctx.buffers["cells"]
    W, H = int(cam.width_px), int(cam.height_px)
    eye = np.asarray(cam.eye, dtype=np.float64) - np.asarray(cells["origin"], dtype=np.float64)
    fwd, right, up = (np.asarray(v, dtype=np.float64) for v in (cam.forward, cam.right, cam.true_up))
    half_h = float(np.tan(np.radians(cam.fov_y_deg) / 2.0)) if cam.projection == "perspective" else cam.ortho_height / 2
    x = (2.0 * (np.arange(W) + 0.5) / W - 1.0) * half_h * cam.aspect
    y = (1.0 - 2.0 * (np.arange(H) + 0.5) / H) * half_h
    sx, sy = np.meshgrid(x, y)
    if cam.projection == "perspective":
        d = fwd + sx[..., None] * right + sy[..., None] * up
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        o = np.broadcast_to(eye, d.shape)
    else:
        d = np.broadcast_to(fwd, sx.shape + (3,))
        o = eye + sx[..., None] * right + sy[..., None] * up
    tc = -(o * d).sum(axis=-1)
    return (tc - max(float(cells["radius"]), 1e-30) * 1.001).ravel()


def _reference_rows(mesh, tf, camera, pixels: np.ndarray) -> tuple[np.ndarray, Segments]:
    """The exact reference's segments of ``pixels`` (flat indices): ``(pixel of each segment, segments)``."""

    W = int(camera.width_px)
    rows = np.unique(pixels // W)
    runs = np.split(rows, np.flatnonzero(np.diff(rows) > 1) + 1)
    parts = [(int(r[0]), reference_segments(mesh, tf, camera, rows=(int(r[0]), int(r[-1])))) for r in runs]
    pix = np.concatenate([s.pixels() + r0 * W for r0, s in parts])
    segs = stack_rows([s for _, s in parts])
    return pix, segs


def _march_raycast(ctx, pipe, keys, n: int, cap: int, threads: int):
    """``raycast``'s walk over every ray, each entry's segment kept: ``(status, segments, passes, exhausted)``."""
    from warpvol.kernels import raycast as k

    rc = pipe.stages[keys.index("raycast")]
    state = MarchState(n, ctx.device)
    mark_unresolved(ctx, state.status, int(k.STATUS_FAILED))
    sg = segments_struct(n, cap, ctx.device)
    march_pass(ctx, state, max_steps=rc.max_steps, t_min=0.0, threads=threads, reentries=rc.reentries, segments=sg)
    passes = 1
    while state.active:
        if passes == MAX_PASSES:  # rays that may re-enter further: the reference's segments
            return state.status.numpy(), sg, passes, True
        c = march_pass(ctx, state, max_steps=rc.max_steps, t_min=0.0, threads=threads, reentries=rc.reentries,
                       segments=sg)
        passes += 1
        if c[0] == 0:
            break
    return state.status.numpy(), sg, passes, False


def _march_harc(ctx, pipe, keys, n: int, cap: int, threads: int):
    """``harc_best``'s first pass and depth-peel passes over every ray, each entry's segment kept: ``(status,
    segments, passes, exhausted)``; the peel stage's ``max_passes`` bounds the passes."""
    from warpvol.kernels import raycast as k
    from warpvol.raycasting.harc import HarcState

    hc = pipe.stages[keys.index("harc")]
    max_passes = pipe.stages[keys.index("harc_peel")].max_passes if "harc_peel" in keys else 1
    state = HarcState(n, ctx.device)
    sg = segments_struct(n, cap, ctx.device)
    run_pass, _keep = hc.pass_runner(ctx, state, t_stop=0.0, segments=sg)
    mark_unresolved(ctx, state.status, int(k.STATUS_FAILED))
    passes = 0
    while True:
        c = run_pass()
        passes += 1
        if c["entries"] == 0:
            return state.status.numpy(), sg, passes, False
        if passes > max_passes:  # the first pass and max_passes peel passes: the rest take the reference's
            return state.status.numpy(), sg, passes, True


#: per preset: the host stage its walk follows, the stage that walks, and its march into segments
PRESETS = {"raycast": ("entry_bins", "raycast", _march_raycast),
           "harc_best": ("harc_raster", "harc", _march_harc)}


def preset_segments(scene, preset: str = "raycast", *, device: str = "cpu", threads: int = 0,
                    cap: int = SEGMENT_CAP, stats: dict | None = None, frame: dict | None = None) -> Segments:
    """``scene`` rendered by ``preset`` (:data:`PRESETS`: ``raycast`` or ``harc_best``) into segments (one per
    entry of a ray into the mesh); ``stats`` gets ``float64_rays`` (rays given the reference's segments) and
    ``passes``. ``frame`` (:func:`warpvol.conditioning.conditioning.shared_frame`): a piece of a larger mesh is
    conditioned and set up in the whole mesh's frame, so that pieces meet in the same float32 points."""
    from warpvol.kernels import raycast as k

    if preset not in PRESETS:
        raise ConfigError(f"preset: {preset!r} cannot render into segments; presets that can: "
                          f"{', '.join(PRESETS)}")
    last_host, walker, march = PRESETS[preset]
    pipe = Pipeline.load(preset, device=device)
    keys = pipe.stage_keys()
    if last_host not in keys or walker not in keys:
        raise ConfigError(f"{preset}_segments: the {preset} preset lacks its {last_host} or {walker} stage")
    ctx = Context(scene=scene, persistent=pipe.persistent, quiet=True, device=device)
    if frame is not None:
        ctx.buffers["frame"] = frame
    for st in pipe.stages[:keys.index(last_host) + 1]:
        st.run(ctx)
    cam = ctx.scene.camera
    n = int(cam.width_px) * int(cam.height_px)
    status, sg, passes, exhausted = march(ctx, pipe, keys, n, cap, threads or cpu_threads())
    count = sg.count.numpy().astype(np.int64)
    redo = ((status & 3) == int(k.STATUS_FAILED)) | (count > cap)
    if exhausted:
        redo |= (status & 3) == int(k.STATUS_ACTIVE)
    keep = np.minimum(count, cap)
    keep[redo] = 0
    slot = np.arange(cap)[None, :] < keep[:, None]
    depth = sg.depth.numpy().reshape(n, cap, 2)[slot].astype(np.float64)
    color = sg.color.numpy().reshape(n, cap, 4)[slot].astype(np.float64)
    pix = np.repeat(np.arange(n), keep)
    h = float(ctx.stats["condition"]["scale"])
    t0 = _ray_shift(ctx)[pix]
    with np.errstate(divide="ignore"):
        tau = -np.log(np.clip(color[:, 3], 0.0, 1.0))
    front, back, rgb = (depth[:, 0] + t0) * h, (depth[:, 1] + t0) * h, color[:, :3]
    redo_pix = np.flatnonzero(redo)
    if len(redo_pix):  # the preset's float64 redo, as segments: the exact reference's of those rays
        orig = scene
        rp, rs = _reference_rows(orig.mesh, orig.transfer, orig.camera, redo_pix)
        sel = np.isin(rp, redo_pix)
        pix = np.concatenate([pix, rp[sel]])
        front = np.concatenate([front, rs.front[sel]])
        back = np.concatenate([back, rs.back[sel]])
        rgb = np.concatenate([rgb, rs.rgb[sel]])
        tau = np.concatenate([tau, rs.tau[sel]])
    if stats is not None:
        stats.update(float64_rays=int(len(redo_pix)), passes=passes)
    return Segments.from_unsorted(pix, front, back, rgb, tau, (int(cam.height_px), int(cam.width_px)))


def raycast_segments(scene, **kw) -> Segments:
    """:func:`preset_segments` of the ``raycast`` preset."""
    return preset_segments(scene, "raycast", **kw)


def harc_segments(scene, **kw) -> Segments:
    """:func:`preset_segments` of the ``harc_best`` preset."""
    return preset_segments(scene, "harc_best", **kw)
