"""Projected tetrahedra on the emulated GPU: decomposition, rasterisation, fragment programs, blending.

Plain functions the ``pt_*`` stages are thin over (tests call them directly):

* :func:`decompose` — Shirley & Tuchman classification and decomposition of every tet, in
  visibility order, on the device (:func:`warpvol.kernels.pt_classify.k_classify`): ``V + M`` output vertices
  (mesh points, then one thick vertex per tet) with ``(sf, sb, l)`` attributes and ``4 M`` triangles
  (triangles ``4k .. 4k+3`` belong to the k-th tet of the order; unused ones are degenerate);
* :func:`draw` — rasterise the triangles in batches of tets (fragments per pixel in primitive
  order, screen-space linear attributes, no depth test), run a fragment program on each batch, and
  blend the fragments into a frame buffer with the blending unit, back to front (optionally in
  concurrent row bands);
* the fragment programs it runs are in :mod:`warpvol.projection.programs`.

Example
-------
>>> import numpy as np
>>> from warpvol.scene.builtin import builtin_scene
>>> from warpvol.gpu.vertex import VertexStage
>>> from warpvol.projection.sort import visibility_order
>>> sc = builtin_scene("box").with_camera(width_px=16, height_px=16)
>>> vs = VertexStage.from_camera(sc.camera, *sc.camera.depth_range(*sc.mesh.bounds))
>>> geo = decompose(sc.mesh, vs.transform(sc.mesh.points), visibility_order(sc.mesh, sc.camera).order)
>>> geo.tris.shape[0] == 4 * sc.mesh.n_tets, sum(geo.classes.values()) == sc.mesh.n_tets
(True, True)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import warp as wp

from warpvol.errors import ConfigError
from warpvol.gpu import counters as cnt
from warpvol.gpu.blend import FrameBuffer
from warpvol.gpu.counters import Counters, active
from warpvol.gpu.raster import Rasterizer
from warpvol.kernels import pt as kpt
from warpvol.kernels import pt_classify, pt_draw
from warpvol.kernels import raster as kraster
from warpvol.parallel import blocks, launch_blocks, preload
from warpvol.progress import detail

#: fragment generation of :func:`draw`: the rasteriser's walks (a fragment list, then the program and
#: the blending unit), or ``fused`` (walk, program and blending in one kernel per bin; exact_program only)
DRAW_WALKS = ("pixel", "triangle", "fused")

#: bin size of the fused draw's rasteriser set-up (pixels), one kernel thread per bin: on the CPU 64-px
#: bins (few bin entries per triangle; host threads take blocks of bins), on CUDA 8-px bins (4,096 threads
#: at 512^2, 16,384 at 1024^2, where 64-px bins would give the GPU 64 and 256)
FUSED_TILE = 64
FUSED_TILE_CUDA = 8
FUSED_TILES = (0, 4, 8, 16, 32, 64)  # 0: by device


def fused_tile(device: str, tile: int = 0) -> int:
    """The fused draw's bin size: ``tile``, or by device when 0 (:data:`FUSED_TILE` on the CPU,
    :data:`FUSED_TILE_CUDA` elsewhere).

    >>> fused_tile("cpu"), fused_tile("cuda:0"), fused_tile("cuda:0", 64)
    (64, 8, 64)
    """
    if tile:
        return int(tile)
    return FUSED_TILE if str(device).startswith("cpu") else FUSED_TILE_CUDA

#: fragments per SIMD span of the fused draw (:mod:`warpvol.kernels.pt_span`): 1 is the one-fragment kernel
#: (:func:`warpvol.kernels.pt_draw.k_pt_exact_tiles`); 0: by device
FUSED_LANES = (0, 1, 4, 8, 16, 32)
FUSED_LANES_CPU = 16  # AVX-512 float32 lanes


def fused_lanes(device: str, lanes: int = 0) -> int:
    """The fused draw's fragments per span: ``lanes``, or by device when 0 (:data:`FUSED_LANES_CPU` on the
    CPU, 1 on CUDA: one fragment per thread, the same source).

    >>> fused_lanes("cpu"), fused_lanes("cuda:0"), fused_lanes("cpu", 1)
    (16, 1, 1)
    """
    if lanes:
        return int(lanes)
    return FUSED_LANES_CPU if str(device).startswith("cpu") else 1

#: "no such scalar" in :func:`~warpvol.projection.programs.zero_interval` (float32 range: the fused draw
#: compares float32 scalars with it)
NO_ZERO = 3.0e38

#: rasteriser rules the decomposition snaps with and :func:`draw` rasterises with (they must agree)
RASTER_RULES = {"snap_ties": "even", "depth_clip": False}

CLASS_NAMES = ("four_triangle", "three_triangle", "flat", "culled", "vertex_on_edge", "vertex_on_vertex")


@dataclass
class PTGeometry:
    """Decomposed tets: ``positions`` (V+M vec4 window coordinates, device), ``attrs`` (V+M, 3)
    ``(sf, sb, l)`` (host), ``tris`` (4M, 3) int32 (host), ``classes`` counts per class name,
    ``moved`` thick vertices moved off the rounded diagonal crossing, ``n_points`` V."""

    positions: wp.array
    attrs: np.ndarray
    tris: np.ndarray
    classes: dict
    moved: int
    n_points: int
    #: per output vertex (V+M, 4) float32: eye-space front / back point (x, y, z) and its clip w
    #: (mesh points: the point itself for both); Kraus et al.'s perspective-correct attributes
    front: np.ndarray | None = None
    back: np.ndarray | None = None
    #: eye-space z of ``front`` / ``back`` is shifted by this (the vertex stage's ``eye_offset``)
    eye_offset: float = 0.0
    #: (V+M) vec4 window positions where the attributes were taken (``decompose(exact_attrs=True)``):
    #: the unsnapped points, and for a 4-triangle tet the crossing of its unsnapped diagonals. The fused
    #: draw sets its attribute planes up from these; coverage stays the snapped ``positions``'
    attr_positions: wp.array | None = None

    @property
    def n_tets(self) -> int:
        return self.tris.shape[0] // 4

    def live_triangles(self) -> int:
        """Triangles whose three vertex indices differ (degenerate padding excluded)."""
        t = self.tris
        return int(((t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])).sum())


#: perspective: a vertex nearer the eye than this fraction of the mesh's farthest vertex depth counts as
#: at the eye plane (its window coordinates would not fit float32; cell projection refuses it)
EYE_PLANE_REL = 1e-5

#: what to use instead when cell projection refuses a view (both walk rays from the eye)
EYE_PLANE_ALTERNATIVES = "raycast or harc_best"


@dataclass
class EyePlane:
    """Result of :func:`eye_plane_check`: ``status`` (``"draw"``, ``"empty"`` or ``"refuse"``), the
    near / far distances for the projection matrix (``"draw"`` only), tet counts (``crossing``: a
    vertex at or behind the eye plane, another in front; ``behind``: every vertex at or behind it;
    ``outside``: entirely outside a side plane of the view volume) and a ``message``."""

    status: str
    near: float | None
    far: float | None
    crossing: int
    behind: int
    outside: int
    message: str


def eye_plane_check(mesh, camera, cells: np.ndarray | None = None) -> EyePlane:
    """Can projected tetrahedra draw ``mesh`` as seen by ``camera``?

    Cell projection draws a tet as the projection of its four vertices, which is only right when the
    whole tet lies in front of the eye plane (perspective: at eye-space depth > :data:`EYE_PLANE_REL`
    times the farthest depth; orthographic: at depth >= 0, the rays start on the eye plane). Depths
    are taken in float64 from the true vertices (not the mesh bounds). Returns ``"empty"`` when no tet
    can be seen (every tet behind the eye plane or entirely outside one side plane of the view
    volume: the image is transparent), ``"refuse"`` when some tet is visible and some tet crosses or
    lies behind the eye plane, else ``"draw"`` with ``near`` = 0.99 x the smallest vertex depth (or
    the bounds' near plane, :meth:`~warpvol.scene.camera.Camera.depth_range`, when that is smaller).
    ``cells``: only these tets count (the ones drawn; the others draw nothing wherever they lie).

    Examples
    --------
    >>> from warpvol.scene.builtin import builtin_scene
    >>> sc = builtin_scene("box")
    >>> eye_plane_check(sc.mesh, sc.camera).status
    'draw'
    >>> eye_plane_check(sc.mesh, sc.camera.replace(target=2 * sc.camera.eye)).status
    'empty'
    >>> r = eye_plane_check(sc.mesh, sc.camera.replace(eye=[0.1, 0.2, 0.3]))
    >>> r.status, r.crossing > 0
    ('refuse', True)
    """
    tets = np.asarray(mesh.tets) if cells is None else np.asarray(mesh.tets)[cells]
    rel = np.asarray(mesh.points, dtype=np.float64) - camera.eye  # per vertex, then gathered per tet
    d, x, y = (rel @ axis for axis in (camera.forward, camera.right, camera.true_up))

    def per_tet(reduce, v):  # reduce over each tet's four vertex values (column-wise: fast)
        g = v[tets]
        return reduce(reduce(g[:, 0], g[:, 1]), reduce(g[:, 2], g[:, 3]))

    dmin, dmax = per_tet(np.minimum, d), per_tet(np.maximum, d)
    behind = dmax <= 0
    if camera.projection == "perspective":
        ty = np.tan(np.radians(camera.fov_y_deg) / 2.0)
        tx = ty * camera.aspect
        sides = (x - tx * d, -x - tx * d, y - ty * d, -y - ty * d)  # > 0: outside that plane through the eye
        crossing = ~behind & (dmin <= EYE_PLANE_REL * max(float(dmax.max(initial=0.0)), 0.0))
    else:
        hy = camera.ortho_height / 2.0
        hx = hy * camera.aspect
        sides = (x - hx, -x - hx, y - hy, -y - hy)
        crossing = ~behind & (dmin < 0)
    code = np.zeros(len(d), dtype=np.uint8)  # per vertex, one bit per side plane it lies outside of
    for k, s in enumerate(sides):
        code |= (s > 0).astype(np.uint8) << np.uint8(k)
    outside = per_tet(np.bitwise_and, code) != 0  # every vertex of the tet outside one plane
    n_cross, n_behind, n_out = int(crossing.sum()), int(behind.sum()), int((outside & ~behind).sum())
    counts = dict(crossing=n_cross, behind=n_behind, outside=n_out)
    if (behind | outside).all():
        return EyePlane("empty", None, None, **counts,
                        message=f"all {len(tets):,} tets lie behind the eye plane or outside the view: "
                                "a transparent image, nothing drawn")
    if n_cross or n_behind:
        why = ("the eye is inside the mesh or the near region cuts cells" if camera.projection == "perspective"
               else "the orthographic eye plane cuts the mesh")
        parts = [f"{n_cross:,} tets cross the eye plane"] if n_cross else []
        parts += [f"{n_behind:,} lie behind it" if n_cross else f"{n_behind:,} tets lie behind the eye plane"
                  ] if n_behind else []
        return EyePlane("refuse", None, None, **counts,
                        message=f"{' and '.join(parts)} ({why}); cell projection cannot draw them — "
                                f"use {EYE_PLANE_ALTERNATIVES}")
    near, far = camera.depth_range(*mesh.bounds)
    near = min(near, 0.99 * float(dmin.min()))  # > 0 in perspective: every tet is in front of the eye
    return EyePlane("draw", near, far, **counts, message="")


def decompose(mesh, vertices, order, device: str = "cpu", exact_attrs: bool = False) -> PTGeometry:
    """Classify and split every tet of ``mesh`` in ``order`` (back to front) into triangles.

    ``vertices`` is the vertex stage's output (:class:`warpvol.gpu.vertex.Vertices`) for
    ``mesh.points``. ``exact_attrs``: a 4-triangle tet's thick vertex carries the attributes of
    where its unsnapped diagonals cross, and :attr:`PTGeometry.attr_positions` says where each
    vertex's attributes were taken (else they are those of the snapped crossing, as the hardware
    draws them).
    """

    order = np.asarray(order, dtype=np.int32)
    m, v = len(order), mesh.n_points
    if vertices.window.shape[0] != v:
        raise ConfigError(f"vertices: expected {v} transformed points, got {vertices.window.shape[0]}")
    even = int(RASTER_RULES["snap_ties"] == "even")
    win = wp.array(vertices.window.astype(np.float32), dtype=wp.vec4, device=device)
    eye = wp.array(vertices.eye.astype(np.float32), dtype=wp.vec4, device=device)
    scal = wp.array(mesh.scalars.astype(np.float32), dtype=wp.float32, device=device)
    # k_classify writes every element of these for each of the m tets: no zero fill
    tp, tfront, tback, ap = (wp.empty(max(m, 1), dtype=wp.vec4, device=device) for _ in range(4))
    ta = wp.empty(max(m, 1), dtype=wp.vec3, device=device)
    tris = wp.empty(max(4 * m, 1), dtype=wp.vec3i, device=device)
    klass, moved = (wp.empty(max(m, 1), dtype=wp.int32, device=device) for _ in range(2))
    if m:
        from warpvol.parallel import blocks, cpu_threads, launch_blocks, preload

        preload(device, pt_classify)
        args = [win, eye, scal, wp.array(mesh.tets.astype(np.int32), dtype=wp.int32, device=device),
                wp.array(order, dtype=wp.int32, device=device), v, even, tp, ta, tris, klass, moved, tfront, tback,
                ap, int(exact_attrs)]
        th = cpu_threads() if str(device).startswith("cpu") and m >= 8192 else 1  # blocks of tets, concurrently
        tb = blocks(m, -(-m // th))
        launch_blocks(device, len(tb), lambda b: wp.launch(pt_classify.k_classify, dim=tb[b][1], inputs=[*args, tb[b][0]],
                                                           device=device), th)
    snapped = wp.zeros(max(v, 1), dtype=wp.vec4, device=device)
    wp.launch(kpt.k_snap_positions, dim=v, inputs=[win, even, snapped], device=device)
    pos = np.concatenate([snapped.numpy()[:v], tp.numpy()[:m]])
    s = mesh.scalars.astype(np.float32)
    attrs = np.concatenate([np.stack([s, s, np.zeros_like(s)], axis=1), ta.numpy()[:m]])
    counts = np.bincount(klass.numpy()[:m], minlength=len(CLASS_NAMES))
    pe = np.concatenate([vertices.eye[:, :3].astype(np.float32), vertices.window[:, 3:4].astype(np.float32)], axis=1)
    front = np.concatenate([pe, tfront.numpy()[:m]])
    back = np.concatenate([pe, tback.numpy()[:m]])
    apos = None
    if exact_attrs:
        apos = wp.array(np.concatenate([vertices.window.astype(np.float32), ap.numpy()[:m]]), dtype=wp.vec4,
                        device=device)
    return PTGeometry(wp.array(pos, dtype=wp.vec4, device=device), attrs, tris.numpy()[:4 * m].reshape(-1, 3),
                      dict(zip(CLASS_NAMES, map(int, counts))), int(moved.numpy()[:m].sum()), v, front, back,
                      float(getattr(vertices, "eye_offset", 0.0)), apos)


def draw(geo: PTGeometry, vertex_attrs: np.ndarray, program: Callable, fb, blend, *, batch_tets: int = 65536,
         device: str = "cpu", bands: int = 1, walk: str = "pixel", t_min: float = 0.0,
         skip_zero: bool = False) -> dict:
    """Rasterise ``geo`` in batches of ``batch_tets`` tets, run ``program(fragments, tris) -> colours``
    (a ``wp.array`` of vec4, premultiplied RGBA; ``tris`` the batch's triangles on the device, indexed
    by ``fragments.prim``) on each batch and blend into ``fb`` in order.

    ``vertex_attrs`` (V+M, A) are interpolated linearly in screen space. ``bands > 1`` draws that many
    row bands of the image concurrently from host threads (:func:`warpvol.parallel.launch_blocks`),
    each with its own rasteriser and frame buffer over its rows and the positions moved up by its first
    row (an exact shift of the 1/256-pixel grid, so coverage, attributes and blending are those of one
    whole-image draw: tested bit-exact); not with alpha dithering (its pattern follows the pixel index).
    ``walk``: the rasteriser's fragment generation (:meth:`warpvol.gpu.raster.Rasterizer.fragments`;
    ``triangle`` gives the same fragments as the emulated ``pixel`` walk, faster), or ``fused``
    (:func:`exact_program` only: no fragment list; one kernel per bin walks the triangles, runs the
    program and blends in registers, :mod:`warpvol.kernels.pt_draw`: the same fragments in the same
    order, attributes from plane equations, values equal to float32 rounding). ``t_min > 0`` (fused
    only, ``blend`` "under"): front to back with early termination at remaining transmittance ``t_min``
    (:mod:`warpvol.kernels.pt_draw`), counted as ``fragments_terminated``, ``bins_terminated``,
    ``triangles_occluded`` (bin entries whose box in the bin was all terminated) and ``cells_occluded``
    (cells with bin entries none of whose triangles was walked), with ``term_at`` ((H, W) int32: the
    draw position of the cell that terminated each pixel, -1 where none did). ``skip_zero`` (fused only):
    fragments whose segment has both ends where the transfer function adds nothing
    (:func:`~warpvol.projection.programs.zero_interval`) integrate to exact zeros and are left out, and
    triangles all of whose fragments do are not walked (``fragments_zero``, ``triangles_zero``).
    Returns counts (``fragments``: those integrated and blended, ``batches``, ``attrs_clamped``).
    """
    if walk not in DRAW_WALKS:
        raise ConfigError(f"walk: {walk!r} not allowed; allowed: {', '.join(DRAW_WALKS)}")
    fused = getattr(program, "fused", None)
    if walk == "fused" and fused is None:
        raise ConfigError("walk: 'fused' needs a fragment program with a fused draw (exact_program)")
    if walk == "fused" and not np.isfinite(vertex_attrs).all():
        raise ConfigError("attrs: holds NaN or Inf")
    if walk == "fused":
        return _draw_fused(geo, vertex_attrs, fused, fb, blend, batch_tets, device, bands, t_min, skip_zero)
    if t_min > 0:
        raise ConfigError("early termination: only the fused draw (walk = 'fused') terminates early")
    if bands > 1 and fb.height > 1 and not getattr(blend, "dither", False):
        return _draw_bands(geo, vertex_attrs, program, fb, blend, batch_tets, device, bands, walk)

    rast = Rasterizer(fb.width, fb.height, device=device, **RASTER_RULES)
    n_frag = n_batch = 0
    m = geo.n_tets
    va = wp.array(np.ascontiguousarray(vertex_attrs, dtype=np.float32), dtype=wp.float32, device=device)
    clamped = wp.zeros(1, dtype=wp.int32, device=device)
    for k0 in range(0, m, batch_tets):
        k1 = min(m, k0 + batch_tets)
        detail("pt draw", k0 / m, f"tets {k0:,} of {m:,}")  # an open progress bar shows it
        tris = geo.tris[4 * k0:4 * k1]
        frags = rast.fragments(geo.positions, tris, vertex_attrs, interpolation="linear", walk=walk)
        n_batch += 1
        if frags.count == 0:
            continue
        n_frag += frags.count
        tris_w = wp.array(tris, dtype=wp.vec3i, device=device)
        wp.launch(kpt.k_clamp_attrs, dim=frags.count, inputs=[frags.prim, tris_w, va, frags.attrs, clamped],
                  device=device)
        blend.blend_fragments(fb, frags, program(frags, tris_w))
    return {"fragments": n_frag, "batches": n_batch, "attrs_clamped": int(clamped.numpy()[0])}


def _draw_fused(geo, vertex_attrs, fused, fb, blend, batch_tets, device, threads, t_min=0.0, skip_zero=False) -> dict:
    """:func:`draw` with ``walk="fused"``: per batch, triangle setup and binning, then one kernel thread
    per tile walks, interpolates, clamps, integrates and blends (:mod:`warpvol.kernels.pt_draw`). Tiles
    own disjoint pixels, so on the CPU blocks of tiles are launched from ``threads`` host threads
    (:func:`warpvol.parallel.launch_blocks`; each batch finishes before the next: blending order)."""

    preload(device, pt_draw, kraster)

    a = np.asarray(vertex_attrs, dtype=np.float32)
    if a.ndim != 2 or a.shape[1] > 8:
        raise ConfigError(f"vertex attributes: the fused draw takes (V, A <= 8), got shape {a.shape}")
    if a.shape[1] < 8:  # one 8-wide load per vertex; unused columns 0
        a = np.concatenate([a, np.zeros((a.shape[0], 8 - a.shape[1]), np.float32)], axis=1)
    va = wp.array(np.ascontiguousarray(a), dtype=pt_draw.vec8f, device=device)
    # on the CPU 64-pixel bins: fewer bin entries per triangle than the default 16 (~5 % faster on Blunt Fin 512^2)
    factors = np.ones((1, 1), np.float32)  # the exact thickness's per-pixel ray factors (else unread)
    if fused["mode"] == PERSPECTIVE_MODES["exact"] and not fused["ortho"]:
        if fused["camera"] is None:
            raise ConfigError("camera: the fused draw's exact thickness needs the camera's pixel rays")
        factors = ray_length_factors(fused["camera"])
    ray_len = wp.array(factors, dtype=wp.float32, device=device)
    apos = geo.positions if geo.attr_positions is None else geo.attr_positions  # attribute planes' vertices
    rast = Rasterizer(fb.width, fb.height, device=device, tile_size=fused_tile(device, fused.get("tile", 0)),
                      **RASTER_RULES)
    st = blend.state(fb)
    cpu = str(device).startswith("cpu")
    n_frag = n_clamped = n_batch = n_skip = n_tail = n_occ = n_zero = n_zt = 0
    zero_lo, zero_hi = fused["zero"] if skip_zero else (-NO_ZERO, NO_ZERO)
    m = geo.n_tets
    starts = list(range(0, m, batch_tets))
    term = t_min > 0
    # early termination: where each pixel terminated (draw position of the cell), which cells were binned / walked
    term_at = wp.full((fb.height, fb.width) if term else (1, 1), -1, dtype=wp.int32, device=device)
    binned, walked = (wp.zeros(max(m, 1) if term else 1, dtype=wp.int32, device=device) for _ in range(2))
    lanes = fused_lanes(device, fused.get("lanes", 0))
    span = None
    if lanes > 1:  # the fragments in SIMD spans: same image and counters as the one-fragment kernel
        from warpvol.kernels import pt_span

        span = pt_span.span_kernel_cached(lanes)
        preload(device, span)
        tf_flat = wp.array(fused["tf_v"].numpy().reshape(-1), dtype=wp.float32, device=device)

        def span_inputs(k0, counts, skipped, occluded, done_rows):
            fi = pt_span.FusedIn()
            fi.pos, fi.vattrs, fi.mode, fi.ortho, fi.ray_len = apos, va, fused["mode"], fused["ortho"], ray_len
            fi.tf_s, fi.tf_v, fi.tf_flat, fi.model = fused["tf_s"], fused["tf_v"], tf_flat, fused["model"]
            fi.t_min, fi.tet0, fi.zero_lo, fi.zero_hi = float(t_min), int(k0), float(zero_lo), float(zero_hi)
            fo = pt_span.FusedOut()
            fo.counts, fo.skipped, fo.occluded, fo.done_rows = counts, skipped, occluded, done_rows
            fo.term_at, fo.binned, fo.walked = term_at, binned, walked
            return fi, fo
    for k0 in starts[::-1] if t_min > 0 else starts:  # early termination: front to back
        k1 = min(m, k0 + batch_tets)
        detail("pt draw", n_batch * batch_tets / m, f"batch {n_batch + 1} of {len(starts)}")  # an open progress bar
        tr = rast.setup(geo.positions, geo.tris[4 * k0:4 * k1], threads=threads if cpu else 1)
        n_batch += 1
        counts = wp.zeros(tr.n_tiles, dtype=wp.vec2i, device=device)
        skipped = wp.zeros(tr.n_tiles, dtype=wp.vec2i, device=device)
        occluded = wp.zeros(tr.n_tiles, dtype=wp.vec3i, device=device)
        done_rows = wp.empty(tr.n_tiles * tr.struct.tile_size if term else 1, dtype=wp.uint64, device=device)
        # 8 blocks per thread: the mesh covers the tiles unevenly
        tile_blocks = blocks(tr.n_tiles, -(-tr.n_tiles // (8 * threads))) if cpu and threads > 1 else [(0, tr.n_tiles)]

        def run(b, tr=tr, counts=counts, skipped=skipped, tile_blocks=tile_blocks, k0=k0, occluded=occluded,
                done_rows=done_rows):
            t0, n = tile_blocks[b]
            if span is not None:
                fi, fo = span_inputs(k0, counts, skipped, occluded, done_rows)
                wp.launch(span, dim=n, inputs=[tr.struct, fi, fo, st, fb.array, t0], device=device)
                return
            wp.launch(pt_draw.k_pt_exact_tiles, dim=n,
                      inputs=[tr.struct, apos, va, fused["mode"], fused["ortho"], ray_len, fused["tf_s"],
                              fused["tf_v"], fused["model"], st, fb.array, t0, counts, float(t_min), skipped,
                              k0, done_rows, term_at, binned, walked, occluded, zero_lo, zero_hi],
                      device=device)

        launch_blocks(device, len(tile_blocks), run, threads=threads)
        nf, nc = (int(x) for x in counts.numpy().astype(np.int64).sum(axis=0))
        ns, nt = (int(x) for x in skipped.numpy().astype(np.int64).sum(axis=0))
        n_skip, n_tail = n_skip + ns, n_tail + nt
        if term or skip_zero:
            no, nz, nzt = (int(x) for x in occluded.numpy().astype(np.int64).sum(axis=0))
            n_occ, n_zero, n_zt = n_occ + no, n_zero + nz, n_zt + nzt
        n_frag += nf
        n_clamped += nc
        c = cnt.active()
        if c is not None:
            c.add(fragments=nf, fragments_passed=nf)
        blend.count(fb, nf)
    out = {"fragments": n_frag, "batches": n_batch, "attrs_clamped": n_clamped}
    if skip_zero:
        out.update(fragments_zero=n_zero, triangles_zero=n_zt)
    if term:
        b, wk = binned.numpy()[:m], walked.numpy()[:m]
        out.update(fragments_terminated=n_skip, bins_terminated=n_tail, triangles_occluded=n_occ,
                   cells_occluded=int(np.count_nonzero((b > 0) & (wk == 0))), term_at=term_at.numpy())
    if threads > 1 and cpu:
        out["threads"] = threads
    return out


def _draw_bands(geo, vertex_attrs, program, fb, blend, batch_tets, device, bands, walk) -> dict:
    import dataclasses


    rows = blocks(fb.height, -(-fb.height // bands))
    counted = [Counters() for _ in rows]  # host threads do not see this thread's active counters
    pos = geo.positions.numpy()
    full = fb.array.numpy().copy()  # emulation bookkeeping, not a modelled read-back
    infos = [None] * len(rows)

    def run(b):
        r0, h = rows[b]
        p = pos.copy()
        p[:, 1] -= np.float32(r0)
        sub = dataclasses.replace(geo, positions=wp.array(p, dtype=wp.vec4, device=device))
        bfb = FrameBuffer(fb.width, h, fb.fmt, device=device)
        bfb.array.assign(wp.array(np.ascontiguousarray(full[r0:r0 + h]), dtype=wp.vec4, device=device))
        with counted[b]:
            infos[b] = draw(sub, vertex_attrs, program, bfb, blend, batch_tets=batch_tets, device=device, walk=walk)
            full[r0:r0 + h] = bfb.array.numpy()

    launch_blocks(device, len(rows), run)
    c = active()
    if c is not None:
        for cb in counted:  # every band set up every triangle: the primitives are counted once, below
            for k in ("primitives", "primitives_culled"):
                cb.store.pop(k, None)
            c.merge(cb)
        from warpvol.gpu.raster import Rasterizer

        # the triangles the hardware would set up, and those it would cull (degenerate, behind the eye,
        # outside the whole image): one set-up of the whole image counts them (binned=False: no bins)
        whole = Rasterizer(fb.width, fb.height, device=device, **RASTER_RULES)
        for k0 in range(0, geo.n_tets, batch_tets):
            whole._tris(geo.positions, geo.tris[4 * k0:4 * min(geo.n_tets, k0 + batch_tets)], binned=False)
    fb.array.assign(wp.array(full, dtype=wp.vec4, device=device))
    out = {k: sum(i[k] for i in infos) for k in ("fragments", "attrs_clamped")}
    out.update(batches=infos[0]["batches"], bands=len(rows))
    return out


#: the perspective modes of the fragment programs (:mod:`warpvol.projection.programs`) and the fused draw
PERSPECTIVE_MODES = {"off": 0, "exact": 1, "approx": 2}


def ray_length_factors(camera) -> np.ndarray:
    """(H, W) float32: ``|v| / |v_z|`` of the eye-space direction ``v`` of the ray through each pixel
    centre (computed in float64 from the projection matrix; 1 for orthographic views): a segment's
    length along the ray is this factor times its eye-space depth extent.

    Examples
    --------
    >>> from warpvol.scene.camera import Camera
    >>> f = ray_length_factors(Camera(eye=[0, 0, 5], target=[0, 0, 0], width_px=2, height_px=2, fov_y_deg=90))
    >>> bool(np.allclose(f, np.sqrt(1.5)))  # centres at (+-1/2, +-1/2) of the unit-slope frustum
    True
    """
    h, w = camera.height_px, camera.width_px
    if camera.projection != "perspective":
        return np.ones((h, w), np.float32)
    p = camera.projection_matrix(1.0, 2.0)
    u = ((np.arange(w) + 0.5) * (2.0 / w) - 1.0) / p[0, 0]  # x_e / -z_e of the column's centre
    v = (1.0 - (np.arange(h) + 0.5) * (2.0 / h)) / p[1, 1]
    return np.sqrt(1.0 + u[None, :] ** 2 + v[:, None] ** 2).astype(np.float32)
