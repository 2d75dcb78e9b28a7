"""Rasteriser of the emulated GPU: triangles in window coordinates -> ordered fragments.

Conventions and exactness (snapping to 1/256 pixel, exact int64 edge functions, fill rule,
screen-space linear / perspective-correct / flat interpolation, stable tile binning that keeps
primitive order per pixel) are documented in :mod:`warpvol.kernels.raster`.

Rasterisation rules (named choices, :class:`Rasterizer` parameters ``fill_rule`` and ``snap_ties``):

* ``fill_rule`` says which edges own the pixel centres lying exactly on them, in **GL window
  coordinates (y up)**, for the picture as displayed (warpvol's row 0 is the top row, GL's window
  y = 0 the bottom row: warpvol y = H - GL y). ``"bottom_left"``: left edges and the horizontal
  edge with the smaller GL window y (the triangle's bottom edge as displayed); ``"top_left"``: left
  edges and the horizontal edge with the larger GL y (Direct3D's top-left rule as displayed; the rule
  warpvol used before the conformance suite). Both are watertight: shared edges are owned once.
* ``snap_ties`` says how a vertex exactly half-way between two 1/256-pixel steps snaps:
  ``"even"`` (round half to even) or ``"away"`` (half away from zero).

* ``interp_rule`` says how attributes are interpolated: ``"barycentric"`` (fp32 barycentrics at the
  pixel centre from the unsnapped positions) or ``"llvmpipe"`` (llvmpipe's plane equations
  ``a0 + dadx x + dady y`` in GL window coordinates, from the frame buffer's origin, FMA per pixel;
  :mod:`warpvol.kernels.raster`). They differ only where a value lands within an fp32 rounding of a
  code boundary (exact k + 1/2 ties at 8 bits).

**Defaults, and why**: ``bottom_left`` + ``even``, the rules of Mesa's llvmpipe (:data:`LLVMPIPE_RULES`).
OpenGL ("Polygon Rasterization", 1.x to 4.x) leaves the ownership of pixel centres on edges to the
implementation, asking only that of two polygons sharing an edge exactly one produces the fragment;
NVIDIA (GeForce3/4) and ATI (Radeon 8500) never documented their OpenGL choice or their snapping
ties for the papers' hardware, so warpvol defaults to the one GL implementation it can observe:
llvmpipe, through VTK offscreen. Mesa's GL state tracker picks Gallium's edge rule per buffer
orientation so that, in GL window coordinates, the horizontal edge with the smaller y owns its
centres in window-system buffers and FBOs alike; llvmpipe snaps with ``lrintf`` (ties to even) to
8 sub-pixel bits. ``scripts/gl_conformance.py`` checks both pixel for pixel. Interpolation
defaults to ``barycentric``: its error does not depend on the distance to the frame buffer's origin
(llvmpipe's plane equations lose accuracy far from it, as its own source notes), and the two rules
agree but for exact ties; ``interp_rule="llvmpipe"`` reproduces llvmpipe's fragment values code for code.

Three ways to draw:

* :meth:`Rasterizer.draw` — fused raster + Gouraud (or flat) vertex colours + blending into a
  :class:`~warpvol.gpu.blend.FrameBuffer` (fast path; used by the benchmark);
* :meth:`Rasterizer.fragments` — a fragment list (per pixel, in primitive order, after the depth
  test) with interpolated attributes; run any fragment program over it (a Warp kernel using the
  texture units), then :meth:`BlendUnit.blend_fragments <warpvol.gpu.blend.BlendUnit.blend_fragments>`;
* :meth:`Rasterizer.draw_ids` — flat-shaded 24-bit integer IDs with depth test (ID buffers).

:func:`draw_textured_quads` draws n full-viewport rectangles textured from a 1D texture (hardware
pre-integration).

Per-attribute interpolation modes are available (``interpolation=["perspective", "linear", ...]``);
Kraus et al.'s projected tetrahedra, whose front and back points have different ``w``, pass
``a/w`` and ``1/w`` as attributes with ``"linear"`` and divide in their fragment program.

Example
-------
>>> import numpy as np
>>> from warpvol.gpu.blend import BlendUnit, FrameBuffer
>>> pos = np.array([[0, 0, 0.5, 1], [4, 0, 0.5, 1], [0, 4, 0.5, 1], [4, 4, 0.5, 1]], np.float32)
>>> tris = np.array([[0, 1, 2], [1, 3, 2]])                 # a closed square: two triangles
>>> fb = FrameBuffer(4, 4, "unorm8"); fb.clear((0, 0, 0, 0))
>>> r = Rasterizer(4, 4)
>>> r.draw(pos, tris, np.full((4, 4), 0.5), fb, BlendUnit("one", "one"))
>>> int(fb.codes()[..., 0].max())                           # every pixel blended exactly once
128
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import warp as wp

from warpvol.errors import ConfigError, check_choice, check_number
from warpvol.gpu import counters as _cnt
from warpvol.gpu.blend import FrameBuffer
from warpvol.gpu.texture import Texture1D
from warpvol.kernels import raster as kr
from warpvol.kernels import raster_draw as _krd
from warpvol.kernels import raster_draw as krd
from warpvol.parallel import blocks, launch_blocks, preload

CULL_MODES = {"none": 0, "back": 1, "front": 2}
FRONT_FACES = ("ccw", "cw")
DEPTH_FUNCS = {"always": 0, "less": 1, "greater": 2, "lequal": 3, "gequal": 4, "never": 5}
INTERPOLATIONS = {"linear": 0, "perspective": 1, "flat": 2}
TILE_SIZES = (4, 8, 16, 32, 64)
TRAVERSALS = ("auto", "pixel", "tile")
WALKS = ("pixel", "triangle")
FILL_RULES = ("bottom_left", "top_left")
SNAP_TIES = ("even", "away")
INTERP_RULES = {"barycentric": 0, "llvmpipe": 1}
#: The rules of Mesa's llvmpipe (checked by ``scripts/gl_conformance.py``); the defaults but ``interp_rule``.
LLVMPIPE_RULES = {"fill_rule": "bottom_left", "snap_ties": "even", "interp_rule": "llvmpipe"}
#: the guard band in window pixels: the rasteriser discards a triangle with a vertex beyond it (fixed-point
#: snapping keeps |x|, |y| <= 2^20 px; there is no geometric clipping), see :mod:`warpvol.kernels.raster`
GUARD_PX = float(kr.GUARD)


def guard_band_overflow(window: np.ndarray, prims: np.ndarray, width: int, height: int) -> tuple[int, float]:
    """``(n, extent)``: how many primitives (rows of vertex indices: triangles or tets) the rasteriser
    would discard while they reach into the image, because a vertex in front of the eye (w > 0) lies
    beyond the guard band, and the largest window coordinate (pixels) of those vertices. Primitives
    entirely off one side of the image are not counted (they draw nothing either way).

    Examples
    --------
    >>> win = np.array([[0, 0, 0.5, 1], [8, 0, 0.5, 1], [0, 8, 0.5, 1], [3e6, 4, 0.5, 1]], np.float32)
    >>> guard_band_overflow(win, np.array([[0, 1, 2], [0, 1, 3]]), 8, 8)
    (1, 3000000.0)
    """
    win = np.asarray(window, dtype=np.float64)
    prims = np.asarray(prims, dtype=np.int64)
    if len(prims) == 0:
        return 0, 0.0
    x, y, w = win[:, 0], win[:, 1], win[:, 3]
    with np.errstate(invalid="ignore"):
        beyond = (w > 0) & ~((np.abs(x) <= GUARD_PX) & (np.abs(y) <= GUARD_PX))
    if not beyond.any():  # no vertex beyond the guard band: nothing to count (the usual view)
        return 0, 0.0
    px, py = x[prims], y[prims]
    off = (px < 0).all(1) | (px > width).all(1) | (py < 0).all(1) | (py > height).all(1)
    bad = beyond[prims].any(axis=1) & ~off
    n = int(bad.sum())
    if not n:
        return 0, 0.0
    v = np.unique(prims[bad])
    v = v[beyond[v]]
    ext = np.abs(np.stack([x[v], y[v]], axis=1))
    return n, float(np.nanmax(np.where(np.isfinite(ext), ext, np.inf)))


@dataclass
class Fragments:
    """Fragments of one draw, grouped per pixel in primitive order.

    ``offsets`` (H*W + 1, int32): fragments of pixel ``p = row * W + column`` are
    ``offsets[p] .. offsets[p+1]-1``; ``prim`` (F, int32) triangle index; ``depth`` (F, float32)
    window z; ``attrs`` (F, A, float32) interpolated attributes. All Warp arrays on the draw's device.
    """

    shape: tuple[int, int]
    count: int
    offsets: wp.array
    prim: wp.array
    depth: wp.array
    attrs: wp.array

    def pixel_index(self) -> np.ndarray:
        """(F,) flat pixel index of every fragment (host side)."""
        off = self.offsets.numpy()
        return np.repeat(np.arange(off.shape[0] - 1), np.diff(off))


def depth_order(pix: np.ndarray, depth: np.ndarray, tie: np.ndarray | None = None) -> np.ndarray:
    """The permutation that orders fragments by pixel, then depth, then ``tie`` (bool), stably: the same
    as ``np.lexsort((depth, pix))`` / ``np.lexsort((tie, depth, pix))``, from one 64-bit key per fragment
    (pixel, the float32 depth's bits mapped to an order-preserving unsigned integer, ``tie``) and a stable
    sort, which on fragments already grouped by pixel (:class:`Fragments`) runs in near-linear time
    (SPX filling 512^2, 614 k fragments: 7 ms against lexsort's 64 ms).

    >>> pix = np.array([1, 0, 1, 1, 0]); d = np.array([0.5, 0.2, -0.0, 0.0, 0.2], np.float32)
    >>> depth_order(pix, d).tolist() == np.lexsort((d, pix)).tolist()
    True
    """
    depth = np.asarray(depth)
    pix = np.asarray(pix)
    if depth.dtype != np.float32 or (len(pix) and int(pix.max()) >= 1 << 30):
        return np.lexsort((depth, pix) if tie is None else (tie, depth, pix))
    u = (depth + np.float32(0.0)).view(np.uint32).astype(np.uint64)  # -0 -> +0: equal depths stay equal
    u ^= np.where(u >> np.uint64(31), np.uint64(0xFFFFFFFF), np.uint64(0x80000000))  # negatives reversed
    key = pix.astype(np.uint64) << np.uint64(33) | u << np.uint64(1)
    if tie is not None:
        key |= np.asarray(tie, dtype=bool).astype(np.uint64)
    return np.argsort(key, kind="stable")


class Triangles:
    """Set-up and binned triangles, ready for the per-pixel kernels (made by :meth:`Rasterizer.setup`;
    ``binned=False``: set up only, for the per-triangle walk, which needs no tile lists)."""

    def __init__(self, rast: "Rasterizer", positions: Any, tris: Any, binned: bool = True, threads: int = 1):
        dev = rast.device
        self.positions = _as_vec4(positions, "positions", dev)
        self.tris = _as_tris(tris, self.positions.shape[0], dev)
        t = self.tris.shape[0]
        self.count = t
        ts = rast.tile_size
        tiles_x = -(-rast.width // ts)
        tiles_y = -(-rast.height // ts)
        n_tiles = tiles_x * tiles_y
        # k_setup writes bbox and counts of every triangle; vidx, sx, sy and bias only of those it keeps
        # (non-empty bbox), the only ones any kernel reads them for: no zero fill
        self.vidx = wp.empty(max(t, 1), dtype=wp.vec3i, device=dev)
        self.sx = wp.empty(max(t, 1), dtype=wp.vec3i, device=dev)
        self.sy = wp.empty(max(t, 1), dtype=wp.vec3i, device=dev)
        self.bias = wp.empty(max(t, 1), dtype=wp.vec3i, device=dev)
        self.bbox = wp.zeros(max(t, 1), dtype=wp.vec4i, device=dev)
        counts = wp.zeros(max(t, 1), dtype=wp.int32, device=dev)
        # per-triangle kernels in blocks, concurrently from ``threads`` host threads on the CPU
        tri_blocks = blocks(t, -(-t // threads)) if threads > 1 and t >= 4096 else [(0, t)]
        if len(tri_blocks) > 1:
            preload(dev, kr)
        if t:
            setup = [self.positions, self.tris, rast.width, rast.height, ts, CULL_MODES[rast.cull],
                     1 if rast.front_face == "ccw" else 0, int(rast.snap_ties == "even"),
                     int(rast.fill_rule == "bottom_left"), self.vidx, self.sx, self.sy, self.bias, self.bbox, counts]
            launch_blocks(dev, len(tri_blocks), lambda b: wp.launch(
                kr.k_setup, dim=tri_blocks[b][1], inputs=[*setup, tri_blocks[b][0]], device=dev), threads)
        offsets = wp.zeros(max(t, 1), dtype=wp.int32, device=dev)
        total = 0
        if t and binned:
            wp.utils.array_scan(counts, offsets, inclusive=False)
            total = int(offsets[t - 1:t].numpy()[0] + counts[t - 1:t].numpy()[0])
        self.bin_entries = total
        c = _cnt.active()
        if c is not None:  # triangles with no bin entry were culled or cover no tile
            c.add(primitives=t, primitives_culled=int((counts.numpy()[:t] == 0).sum()) if t else 0)
        keys = wp.zeros(max(2 * total, 2), dtype=wp.int32, device=dev)
        vals = wp.zeros(max(2 * total, 2), dtype=wp.int32, device=dev)
        start = wp.zeros(n_tiles, dtype=wp.int32, device=dev)
        end = wp.zeros(n_tiles, dtype=wp.int32, device=dev)
        if total:
            launch_blocks(dev, len(tri_blocks), lambda b: wp.launch(
                kr.k_emit, dim=tri_blocks[b][1], inputs=[self.bbox, counts, offsets, ts, tiles_x, keys, vals,
                                                         tri_blocks[b][0]], device=dev), threads)
            end_bit = max(1, int(n_tiles - 1).bit_length())
            wp.utils.radix_sort_pairs(keys, vals, total, 0, end_bit)
            wp.launch(kr.k_tile_ranges, dim=total, inputs=[keys, total, start, end], device=dev)
        s = kr.TriSetup()
        s.vidx, s.sx, s.sy, s.bias, s.bbox = self.vidx, self.sx, self.sy, self.bias, self.bbox
        s.tile_start, s.tile_end, s.tri_of = start, end, vals
        s.tile_size, s.tiles_x = ts, tiles_x
        s.interp_rule, s.height = INTERP_RULES[rast.interp_rule], rast.height
        self.struct = s
        self.n_tiles = n_tiles
        self._keys = keys


def _as_vec4(positions: Any, name: str, device) -> wp.array:
    if isinstance(positions, wp.array):
        if positions.dtype != wp.vec4 or positions.ndim != 1:
            raise ConfigError(f"{name}: expected a 1D wp.array of vec4 (x, y, z, w) window coordinates")
        return positions if str(positions.device) == str(wp.get_device(device)) else positions.to(device)
    p = np.asarray(positions, dtype=np.float32)
    if p.ndim != 2 or p.shape[1] not in (3, 4):
        raise ConfigError(f"{name}: expected shape (V, 4) window coordinates (x, y, z, w) or (V, 3), got {p.shape}")
    if p.shape[1] == 3:
        p = np.concatenate([p, np.ones((p.shape[0], 1), np.float32)], axis=1)
    return wp.array(np.ascontiguousarray(p), dtype=wp.vec4, device=device)


def _as_tris(tris: Any, nv: int, device) -> wp.array:
    if isinstance(tris, wp.array):
        if tris.dtype != wp.vec3i:
            raise ConfigError("tris: expected a wp.array of vec3i vertex indices")
        return tris
    t = np.asarray(tris)
    if t.size == 0:
        t = t.reshape(0, 3)
    if t.ndim != 2 or t.shape[1] != 3 or not np.issubdtype(t.dtype, np.integer):
        raise ConfigError(f"tris: expected an integer array of shape (T, 3), got {t.dtype} {t.shape}")
    if t.size and (t.min() < 0 or t.max() >= nv):
        raise ConfigError(f"tris: vertex indices must be in [0, {nv - 1}], got [{t.min()}, {t.max()}]")
    return wp.array(np.ascontiguousarray(t, dtype=np.int32), dtype=wp.vec3i, device=device)


class Rasterizer:
    """Triangle rasteriser with depth test, face culling and ordered per-pixel fragments.

    ===========  ============================================================  =============================
    parameter    meaning                                                       allowed
    ===========  ============================================================  =============================
    width        viewport width in pixels                                      integer in [1, 65536]
    height       viewport height in pixels                                     integer in [1, 65536]
    device       Warp device                                                   ``"cpu"``, ``"cuda:0"``, ...
    tile_size    square bin size in pixels                                     4, 8, 16, 32, 64
    cull         face culling                                                  ``none`` | ``back`` | ``front``
    front_face   winding of front faces as in OpenGL (y up)                    ``ccw`` | ``cw``
    depth_func   depth test                                                    ``always`` ``less`` ``greater``
                                                                               ``lequal`` ``gequal`` ``never``
    depth_write  write passing depths to the depth buffer                      bool
    depth_clip   drop fragments with window z outside [0, 1]                   bool
    traversal    :meth:`draw`: one thread per ``pixel`` or per ``tile``         ``auto`` | ``pixel`` | ``tile``
                 (``auto``: tile on CPU, pixel on CUDA); same result
    fill_rule    edges owning the pixel centres on them, in GL window           ``bottom_left`` | ``top_left``
                 coordinates (y up), as displayed (module docstring)
    snap_ties    vertices half-way between 1/256-pixel steps snap to           ``even`` | ``away``
                 the even step or away from zero
    interp_rule  attribute interpolation: fp32 barycentrics, or llvmpipe's     ``barycentric`` |
                 plane equations in GL window coordinates                      ``llvmpipe``
    ===========  ============================================================  =============================

    The defaults of ``fill_rule`` and ``snap_ties`` are Mesa llvmpipe's (:data:`LLVMPIPE_RULES`;
    the module docstring gives the reason); ``interp_rule`` defaults to ``barycentric``.

    Positions are window coordinates ``(x, y, z, w)`` (see :class:`~warpvol.gpu.vertex.VertexStage`):
    x right, y *down* (row index), z in [0, 1], w the clip-space w (for perspective correction).
    The depth buffer used is the target frame buffer's ``depth`` (or ``depth=`` given explicitly).

    Example
    -------
    >>> r = Rasterizer(8, 8, depth_func="less", depth_write=True)
    >>> frags = r.fragments([[0, 0, .5, 1], [8, 0, .5, 1], [0, 8, .5, 1]], [[0, 1, 2]],
    ...                     attrs=[[0.0], [1.0], [0.0]])
    >>> frags.count                      # 36 centres with x + y <= 8; the 8 on the hypotenuse (a right edge) excluded
    28

    A horizontal edge through the centres of row 2, interior above it (the triangle's bottom edge as
    displayed, the smaller GL window y): owned under ``bottom_left`` (the default), not under ``top_left``:

    >>> tri = [[0, 2.5, .5, 1], [4, 2.5, .5, 1], [0, 0, .5, 1]]
    >>> [Rasterizer(4, 4, fill_rule=f).fragments(tri, [[0, 1, 2]]).count for f in ("bottom_left", "top_left")]
    [7, 3]
    """

    #: the Warp modules its draws launch: what a caller drawing from host threads loads first
    #: (``modules`` of :func:`warpvol.parallel.launch_blocks`)
    KERNEL_MODULES = (kr, krd)

    def __init__(self, width: int, height: int, device: str = "cpu", tile_size: int = 16, cull: str = "none",
                 front_face: str = "ccw", depth_func: str = "always", depth_write: bool = False,
                 depth_clip: bool = True, traversal: str = "auto", fill_rule: str = "bottom_left",
                 snap_ties: str = "even", interp_rule: str = "barycentric"):
        self.width = check_number("width", width, lo=1, hi=65536, integer=True)
        self.height = check_number("height", height, lo=1, hi=65536, integer=True)
        self.device = device
        self.tile_size = check_number("tile_size", tile_size, integer=True)
        if self.tile_size not in TILE_SIZES:
            raise ConfigError(f"tile_size: {tile_size!r} not allowed; allowed: {', '.join(map(str, TILE_SIZES))}")
        self.cull = check_choice("cull", cull, CULL_MODES)
        self.front_face = check_choice("front_face", front_face, FRONT_FACES)
        self.depth_func = check_choice("depth_func", depth_func, DEPTH_FUNCS)
        for nm, val in (("depth_write", depth_write), ("depth_clip", depth_clip)):
            if not isinstance(val, bool):
                raise ConfigError(f"{nm}: expected true or false, got {val!r}")
        self.depth_write, self.depth_clip = depth_write, depth_clip
        self.traversal = check_choice("traversal", traversal, TRAVERSALS)
        self.fill_rule = check_choice("fill_rule", fill_rule, FILL_RULES)
        self.snap_ties = check_choice("snap_ties", snap_ties, SNAP_TIES)
        self.interp_rule = check_choice("interp_rule", interp_rule, INTERP_RULES)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.height, self.width)

    def setup(self, positions: Any, tris: Any, threads: int = 1) -> Triangles:
        """Triangle setup + binning (reusable for several draws of the same geometry); on the CPU
        ``threads`` host threads set up blocks of triangles concurrently (same result)."""
        return Triangles(self, positions, tris, threads=threads)

    def _tris(self, positions: Any, tris: Any, binned: bool = True) -> Triangles:
        if isinstance(positions, Triangles):
            return positions
        return Triangles(self, positions, tris, binned)

    def _depth(self, depth: Any) -> wp.array:
        if depth is None:
            return wp.full(self.shape, 1.0 if self.depth_func in ("less", "lequal") else 0.0, dtype=wp.float32,
                           device=self.device)
        if not isinstance(depth, wp.array) or depth.dtype != wp.float32 or tuple(depth.shape) != self.shape:
            raise ConfigError(f"depth: expected a float32 wp.array of shape {self.shape}")
        return depth

    def _dflags(self) -> list:
        return [DEPTH_FUNCS[self.depth_func], int(self.depth_write), int(self.depth_clip)]

    def _coverage(self, tr: Triangles) -> int:
        """Fragments ``tr`` generates (pixel centres covered, not depth-clipped; before the depth test):
        one counting launch, used by :meth:`fragments` only while counting with a depth test."""
        dev = self.device
        npx = self.width * self.height
        counts = wp.zeros(npx, dtype=wp.int32, device=dev)
        f1 = wp.zeros(1, dtype=wp.float32, device=dev)
        a1 = wp.zeros((1, 1), dtype=wp.float32, device=dev)
        self._fragment_rows([tr.struct, tr.positions, tr.tris, a1, wp.zeros(1, dtype=wp.int32, device=dev), 0,
                             wp.zeros(self.shape, dtype=wp.float32, device=dev), DEPTH_FUNCS["always"], 0,
                             int(self.depth_clip), 0, counts, wp.zeros(npx + 1, dtype=wp.int32, device=dev),
                             wp.zeros(1, dtype=wp.int32, device=dev), f1, a1])
        return int(counts.numpy().sum())

    def _fragment_rows(self, inputs: list) -> None:
        """:func:`~warpvol.kernels.raster_draw.k_fragments` over the image; on the CPU in blocks of rows
        launched concurrently from a host thread per core (a pixel's fragments depend on its own depth
        value and its tile's triangles only: the same lists as one launch)."""
        dev = self.device
        rows = blocks(self.height, -(-self.height // 16)) if str(dev).startswith("cpu") else [(0, self.height)]
        if len(rows) > 1:
            preload(dev, krd)
        launch_blocks(dev, len(rows), lambda b: wp.launch(krd.k_fragments, dim=(rows[b][1], self.width),
                                                          inputs=[*inputs, rows[b][0]], device=dev))

    def _count_slots(self, n: int) -> tuple[int, wp.array]:
        """``(counting flag, per-thread (generated, passed) slots)`` for a fused draw kernel."""
        on = _cnt.active() is not None
        return int(on), wp.zeros(n if on else 1, dtype=wp.vec2i, device=self.device)

    @staticmethod
    def _add_counts(flag: int, slots: wp.array) -> int:
        """Add the kernel's per-thread counts to the active counters; returns the fragments passed."""
        if not flag:
            return 0
        gen, passed = (int(v) for v in slots.numpy().astype(np.int64).sum(axis=0))
        _cnt.active().add(fragments=gen, fragments_passed=passed)
        return passed

    def fragments(self, positions: Any, tris: Any = None, attrs: Any = None,
                  interpolation: str | Sequence[str] = "perspective", depth: Any = None,
                  walk: str = "pixel") -> Fragments:
        """Rasterise into a fragment list with attributes ``attrs`` (V, A) interpolated per fragment.

        ``positions`` may be a :class:`Triangles` from :meth:`setup` (then ``tris`` is ignored).
        ``interpolation``: one of ``linear``, ``perspective``, ``flat`` or one per attribute.
        ``depth``: depth buffer (H, W float32 wp.array) tested/updated in place; default a fresh one.
        ``walk``: ``pixel`` (each pixel walks its tile's triangles in primitive order, the emulated
        hardware) or ``triangle`` (each triangle walks its bounding box, then a stable sort by pixel:
        the same fragment list, faster when triangles are small; only with depth test ``always`` and
        no depth writes, where a pixel's fragments do not depend on each other).
        """
        check_choice("walk", walk, WALKS)
        if walk == "triangle" and (self.depth_func != "always" or self.depth_write):
            raise ConfigError("walk: 'triangle' needs depth_func 'always' and depth_write false")
        tr = self._tris(positions, tris, binned=walk == "pixel")
        nv = tr.positions.shape[0]
        a = np.zeros((nv, 0), np.float32) if attrs is None else np.asarray(attrs, dtype=np.float32)
        if a.ndim == 1:
            a = a[:, None]
        if a.ndim != 2 or a.shape[0] != nv:
            raise ConfigError(f"attrs: expected shape ({nv}, A), got {a.shape}")
        if not np.isfinite(a).all():
            raise ConfigError("attrs: holds NaN or Inf")
        na = a.shape[1]
        modes = [interpolation] * na if isinstance(interpolation, str) else list(interpolation)
        if len(modes) != na:
            raise ConfigError(f"interpolation: expected one mode or {na} modes, got {len(modes)}")
        modes = [INTERPOLATIONS[check_choice("interpolation", m, INTERPOLATIONS)] for m in modes]
        dev = self.device
        a_w = wp.array(a if na else np.zeros((nv, 1), np.float32), dtype=wp.float32, device=dev)
        m_w = wp.array(np.asarray(modes + [0], np.int32), dtype=wp.int32, device=dev)
        if walk == "triangle":
            return self._fragments_by_triangle(tr, a_w, m_w, na)
        dbuf = self._depth(depth)
        npx = self.width * self.height
        counts = wp.zeros(npx, dtype=wp.int32, device=dev)
        offsets = wp.zeros(npx + 1, dtype=wp.int32, device=dev)
        empty_i = wp.zeros(1, dtype=wp.int32, device=dev)
        empty_f = wp.zeros(1, dtype=wp.float32, device=dev)
        empty_a = wp.zeros((1, max(na, 1)), dtype=wp.float32, device=dev)
        d0 = wp.clone(dbuf)  # the counting pass must not change the depth buffer
        self._fragment_rows([tr.struct, tr.positions, tr.tris, a_w, m_w, na, d0, *self._dflags(), 0, counts, offsets,
                             empty_i, empty_f, empty_a])
        wp.utils.array_scan(counts, offsets[:npx], inclusive=False)
        total = int(offsets[npx - 1:npx].numpy()[0] + counts[npx - 1:npx].numpy()[0])
        offsets[npx:].fill_(total)
        c = _cnt.active()
        if c is not None:  # the list holds the fragments that passed; generated ones need a count without the test
            gen = total if self.depth_func == "always" else self._coverage(tr)
            c.add(fragments=gen, fragments_passed=total)
        prim = wp.zeros(max(total, 1), dtype=wp.int32, device=dev)
        fdepth = wp.zeros(max(total, 1), dtype=wp.float32, device=dev)
        fattr = wp.zeros((max(total, 1), max(na, 1)), dtype=wp.float32, device=dev)
        self._fragment_rows([tr.struct, tr.positions, tr.tris, a_w, m_w, na, dbuf, *self._dflags(), 1, counts, offsets,
                             prim, fdepth, fattr])
        return Fragments(self.shape, total, offsets, prim, fdepth, fattr)

    def _fragments_by_triangle(self, tr: Triangles, a_w: wp.array, m_w: wp.array, na: int) -> Fragments:
        """:meth:`fragments` with ``walk="triangle"``: count per triangle, write (pixel, triangle)
        pairs in primitive order, stable radix sort by pixel, then one thread per fragment."""
        dev = self.device
        npx = self.width * self.height
        t = max(tr.count, 1)
        tcounts = wp.zeros(t, dtype=wp.int32, device=dev)
        toff = wp.zeros(t, dtype=wp.int32, device=dev)
        pcounts = wp.zeros(npx, dtype=wp.int32, device=dev)
        offsets = wp.zeros(npx + 1, dtype=wp.int32, device=dev)
        one = wp.zeros(1, dtype=wp.int32, device=dev)
        walk = [tr.struct, tr.positions, self.width, int(self.depth_clip)]
        total = 0
        if tr.count:
            wp.launch(krd.k_tri_walk, dim=tr.count, inputs=[*walk, 0, toff, tcounts, pcounts, one, one], device=dev)
            wp.utils.array_scan(tcounts, toff, inclusive=False)
            total = int(toff[t - 1:t].numpy()[0] + tcounts[t - 1:t].numpy()[0])
        # every element below is written before it is read (the sort's second halves are its scratch)
        keys = wp.empty(max(2 * total, 2), dtype=wp.int32, device=dev)
        vals = wp.empty(max(2 * total, 2), dtype=wp.int32, device=dev)
        prim = wp.empty(max(total, 1), dtype=wp.int32, device=dev)
        fdepth = wp.empty(max(total, 1), dtype=wp.float32, device=dev)
        fattr = wp.empty((max(total, 1), max(na, 1)), dtype=wp.float32, device=dev)
        if total:
            wp.launch(krd.k_tri_walk, dim=tr.count, inputs=[*walk, 1, toff, tcounts, pcounts, keys, vals], device=dev)
            wp.utils.radix_sort_pairs(keys, vals, total, 0, max(1, int(npx - 1).bit_length()))
            wp.launch(krd.k_tri_fragments, dim=total,
                      inputs=[tr.struct, tr.positions, tr.tris, a_w, m_w, na, self.width, keys, vals, prim, fdepth,
                              fattr], device=dev)
        wp.utils.array_scan(pcounts, offsets[:npx], inclusive=False)
        offsets[npx:].fill_(total)
        c = _cnt.active()
        if c is not None:
            c.add(fragments=total, fragments_passed=total)
        return Fragments(self.shape, total, offsets, prim, fdepth, fattr)

    def draw(self, positions: Any, tris: Any, colors: Any, fb, blend, interpolation: str = "perspective",
             depth: Any = None, prim0: int = 0) -> None:
        """Rasterise triangles with vertex colours ``colors`` (V, 4) and blend them into ``fb`` in order.

        ``blend`` is a :class:`~warpvol.gpu.blend.BlendUnit`; ``depth`` defaults to ``fb.depth``.
        ``prim0`` offsets primitive numbers (dither-table indexing) for multi-call sequences.
        """

        if not isinstance(fb, FrameBuffer) or fb.shape != self.shape:
            raise ConfigError(f"fb: expected a FrameBuffer of {self.width}x{self.height}")
        st = blend.state(fb)
        tr = self._tris(positions, tris)
        nv = tr.positions.shape[0]
        c = np.asarray(colors, dtype=np.float32)
        if c.shape != (nv, 4) or not np.isfinite(c).all():
            raise ConfigError(f"colors: expected finite values of shape ({nv}, 4), got {c.shape}")
        mode = INTERPOLATIONS[check_choice("interpolation", interpolation, INTERPOLATIONS)]
        dbuf = fb.depth if depth is None else self._depth(depth)
        per_tile = self.traversal == "tile" or (self.traversal == "auto" and wp.get_device(self.device).is_cpu)
        kern, dim = (krd.k_draw_colors_tiles, tr.n_tiles) if per_tile else (krd.k_draw_colors, self.shape)
        flag, slots = self._count_slots(dim if per_tile else self.width * self.height)
        wp.launch(kern, dim=dim,
                  inputs=[tr.struct, tr.positions, tr.tris, wp.array(c, dtype=wp.vec4, device=self.device), mode,
                          dbuf, *self._dflags(), st, fb.array, int(prim0), flag, slots], device=self.device)
        if flag:
            blend.count(fb, self._add_counts(flag, slots))

    def draw_ids(self, positions: Any, tris: Any, ids: Any, id_buffer: wp.array | None = None,
                 depth: Any = None, clear_id: int = -1) -> tuple[np.ndarray, np.ndarray]:
        """Flat-shaded 24-bit IDs (one per triangle) with depth test; returns ``(ids (H, W), depth (H, W))``.

        ``id_buffer`` (H, W int32 wp.array) is updated in place if given, else a fresh one cleared to
        ``clear_id``. IDs are masked to 24 bits, as an RGB8 colour would carry them.
        """
        tr = self._tris(positions, tris)
        ids_np = np.asarray(ids)
        if ids_np.shape != (tr.count,) or not np.issubdtype(ids_np.dtype, np.integer):
            raise ConfigError(f"ids: expected {tr.count} integers, got {ids_np.dtype} {ids_np.shape}")
        if ids_np.size and (ids_np.min() < 0 or ids_np.max() >= 2**24):
            raise ConfigError("ids: must be 24-bit values in [0, 16777215]")
        if id_buffer is None:
            id_buffer = wp.full(self.shape, int(clear_id), dtype=wp.int32, device=self.device)
        dbuf = self._depth(depth)
        flag, slots = self._count_slots(self.width * self.height)
        wp.launch(krd.k_draw_ids, dim=self.shape,
                  inputs=[tr.struct, tr.positions,
                          wp.array(ids_np.astype(np.int32) if ids_np.size else np.zeros(1, np.int32),
                                   dtype=wp.int32, device=self.device),
                          dbuf, *self._dflags(), id_buffer, flag, slots], device=self.device)
        if flag:  # 24-bit IDs written as RGB8 colours
            _cnt.active().blend("rgb8", self._add_counts(flag, slots), blending=False)
        return id_buffer.numpy(), dbuf.numpy()


def rasterize(positions: Any, tris: Any, width: int, height: int, attrs: Any = None,
              interpolation: str = "perspective", device: str = "cpu", **kw) -> Fragments:
    """Plain function: fragments of triangles (window coordinates) on a ``width`` x ``height`` viewport."""
    return Rasterizer(width, height, device=device, **kw).fragments(positions, tris, attrs, interpolation)


def draw_textured_quads(fb, blend, texture, corners: Any, modulate: Sequence[float] = (1, 1, 1, 1),
                        prim0: int = 0) -> None:
    """Draw n full-viewport rectangles in order, each textured from a 1D texture, blended into ``fb``.

    ``corners`` (n, 4): rectangle k's texture coordinate at the window corners (x, y) = (0, 0),
    (W, 0), (0, H), (W, H) (x right, y down); the coordinate at a pixel centre is their bilinear
    interpolation, sampled from ``texture`` (a :class:`~warpvol.gpu.texture.Texture1D`) and multiplied
    component-wise by ``modulate`` (the primary colour, e.g. (0, 0, 0, 1) for an opacity pass).
    Hardware pre-integration (Roettger & Ertl): ``blend = BlendUnit("one", "one_minus_src_alpha")``
    into an 8- or 12-bit buffer, ``corners[k]`` = ``w_k`` at the slice corners (sf, sb) in {0, 1}^2.

    Example
    -------
    >>> from warpvol.gpu.blend import BlendUnit, FrameBuffer
    >>> from warpvol.gpu.texture import Texture1D
    >>> fb = FrameBuffer(2, 2, "unorm12"); fb.clear((0, 0, 0, 0))
    >>> tex = Texture1D([[0.1, 0.1, 0.1, 0.1]] * 4, fmt="rgba8", filter="nearest")
    >>> draw_textured_quads(fb, BlendUnit("one", "one_minus_src_alpha"), tex, [[0, 1, 0, 1]] * 3)
    >>> int(fb.codes()[0, 0, 0])                              # 418 -> 793 -> 1130 (12-bit rounding)
    1130
    """

    if not isinstance(fb, FrameBuffer):
        raise ConfigError(f"fb: expected a FrameBuffer, got {type(fb).__name__}")
    if not isinstance(texture, Texture1D):
        raise ConfigError(f"texture: expected a Texture1D, got {type(texture).__name__}")
    c = np.asarray(corners, dtype=np.float32)
    if c.ndim != 2 or c.shape[1] != 4 or not np.isfinite(c).all():
        raise ConfigError(f"corners: expected finite values of shape (n, 4), got {c.shape}")
    m = np.asarray(modulate, dtype=np.float32).reshape(-1)
    if m.shape != (4,) or not np.isfinite(m).all():
        raise ConfigError(f"modulate: expected 4 finite numbers, got {modulate!r}")
    st = blend.state(fb)
    if c.shape[0] == 0:
        return
    cnt = _cnt.active()
    if cnt is not None:  # n full-viewport rectangles (two triangles each): every pixel covered n times
        n, npx = c.shape[0], fb.width * fb.height
        cnt.add(vertices=4 * n, primitives=2 * n, fragments=n * npx, fragments_passed=n * npx)
        texture.count(n * npx, cnt)
        blend.count(fb, n * npx, cnt)
    wp.launch(_krd.k_draw_quads_1d, dim=fb.shape,
              inputs=[st, fb.array, texture.struct, wp.array(c, dtype=wp.vec4, device=fb.device),
                      wp.vec4(*map(float, m)), int(prim0)], device=fb.device)
