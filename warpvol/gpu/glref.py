"""A real OpenGL beside the emulated GPU: Mesa llvmpipe through VTK offscreen (EGL), and the conformance soups.

:class:`GLCanvas` draws triangle soups with per-vertex RGBA8 colours through VTK's
``vtkPolyDataMapper2D`` in GL window coordinates (x right, y up; the mapper's orthographic matrix
maps them back to themselves), multisampling off, an RGBA8 colour buffer, the blend function set
with ``glBlendFuncSeparate`` through VTK's ``vtkOpenGLState`` just before the draw, depth test off,
and reads the buffer back (GL memory order: row 0 is the bottom row, GL window y in [0, 1)).

:func:`conformance_soup` builds the triangle soups of the conformance suite (random triangles,
vertices on pixel centres and pixel edges, exact tilings, slivers, sub-pixel triangles, off-grid
vertices, snapping ties, horizontal edges through pixel centres) in warpvol's window coordinates
(y down); :func:`to_gl` maps them to GL window coordinates for either orientation.

Limits of the route, all measured by ``scripts/gl_conformance.py``: VTK's 2D fragment shader
discards fragments with alpha 0 (the soups use alpha codes >= 1); the vertex path multiplies by
VTK's orthographic matrix in fp32, exact for power-of-two canvas sides (the snapping-tie soups need
it), within about 1e-6 px otherwise.
"""

from __future__ import annotations

import re
import subprocess
import sys
from functools import lru_cache
from typing import Any

import numpy as np

from warpvol.errors import ConfigError
from warpvol.gpu.blend import BlendUnit, FrameBuffer
from warpvol.gpu.raster import LLVMPIPE_RULES, Rasterizer

GL_BLEND_FACTORS = {
    "zero": 0, "one": 1, "src_color": 0x0300, "one_minus_src_color": 0x0301, "src_alpha": 0x0302,
    "one_minus_src_alpha": 0x0303, "dst_alpha": 0x0304, "one_minus_dst_alpha": 0x0305, "dst_color": 0x0306,
    "one_minus_dst_color": 0x0307,
}
_GL_BLEND = 0x0BE2
_GL_DEPTH_TEST = 0x0B71


_PROBE_TAG = "glref-probe:"


def _probe() -> None:
    """Make a context, draw one triangle, print the renderer (run in a child process by the check)."""
    c = GLCanvas(4, 4)
    img = c.draw(np.array([[[0, 0], [4, 0], [0, 4]]], np.float32), np.full((1, 3, 4), 255, np.uint8))
    print(_PROBE_TAG + (c.renderer if img[0, 0, 0] == 255 else "drew nothing"), flush=True)


@lru_cache(maxsize=1)
def gl_unavailable_reason() -> str | None:
    """``None`` if VTK can make an offscreen (EGL) context on Mesa llvmpipe here and draw with it, else why not.

    The probe runs in a child process, so a VTK or driver that crashes without a display costs a
    skip, not the test run; a GL other than llvmpipe (a hardware driver) is a reason too, as the
    conformance figures are llvmpipe's.
    """
    cmd = [sys.executable, "-c", "from warpvol.gpu.glref import _probe; _probe()"]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as e:
        return f"offscreen GL probe did not finish: {e}"
    found = [ln[len(_PROBE_TAG):] for ln in r.stdout.splitlines() if ln.startswith(_PROBE_TAG)]
    if r.returncode != 0 or not found:
        tail = re.sub(r"\x1b\[[0-9;]*m", "", (r.stderr.strip().splitlines() or ["no message"])[-1])
        return f"VTK cannot create an offscreen OpenGL context (probe exit {r.returncode}): {tail}"
    if "llvmpipe" not in found[0]:
        return f"the offscreen GL is {found[0]!r}, not Mesa llvmpipe"
    return None


class GLCanvas:
    """An offscreen RGBA8 GL frame buffer of ``width`` x ``height`` (VTK, EGL; Mesa llvmpipe here)."""

    def __init__(self, width: int, height: int):
        from vtkmodules.vtkCommonCore import vtkCommand
        from vtkmodules.vtkRenderingCore import vtkActor2D, vtkPolyDataMapper2D, vtkRenderer
        from vtkmodules.vtkRenderingOpenGL2 import vtkEGLRenderWindow

        self.width, self.height = int(width), int(height)
        rw = vtkEGLRenderWindow()
        rw.SetOffScreenRendering(1)
        rw.SetSize(self.width, self.height)
        rw.SetMultiSamples(0)
        rw.SetAlphaBitPlanes(1)
        ren = vtkRenderer()
        ren.SetBackground(0.0, 0.0, 0.0)
        ren.SetBackgroundAlpha(0.0)
        rw.AddRenderer(ren)
        self._mapper = vtkPolyDataMapper2D()
        self._mapper.SetColorModeToDirectScalars()
        self._mapper.ScalarVisibilityOn()
        actor = vtkActor2D()
        actor.SetMapper(self._mapper)
        ren.AddViewProp(actor)
        self._blend = (1, 0, 1, 0)
        ren.AddObserver(vtkCommand.StartEvent, self._set_state)  # after the window's Start() set VTK's blend
        self._rw, self._ren = rw, ren

    def _set_state(self, *_):
        st = self._rw.GetState()
        st.vtkglEnable(_GL_BLEND)
        st.vtkglBlendFuncSeparate(*self._blend)
        st.vtkglDisable(_GL_DEPTH_TEST)

    @property
    def renderer(self) -> str:
        """The GL renderer string (e.g. ``llvmpipe (LLVM 15.0.6, 256 bits)``) and version."""
        lines = self._rw.ReportCapabilities().splitlines()
        keep = [ln.split(":", 1)[1].strip() for ln in lines if ln.startswith(("OpenGL renderer", "OpenGL version"))]
        return ", ".join(keep)

    def draw(self, xy: Any, colors: Any, blend: tuple = ("one", "zero"), background: Any = None) -> np.ndarray:
        """Draw triangles ``xy`` (T, 3, 2) in GL window coordinates with vertex colours (T, 3, 4) uint8.

        ``blend``: (src, dst) or (src_rgb, dst_rgb, src_alpha, dst_alpha) factor names; ``background``:
        (H, W, 4) uint8 codes in GL memory order written first (replace), else a clear to 0.
        Returns the RGBA8 buffer (H, W, 4) uint8, GL memory order (row 0 = bottom).
        """
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

        names = tuple(blend) * (2 if len(blend) == 2 else 1)
        if len(names) != 4 or any(n not in GL_BLEND_FACTORS for n in names):
            raise ConfigError(f"blend: expected 2 or 4 of {', '.join(GL_BLEND_FACTORS)}, got {blend!r}")
        self._ren.SetPreserveColorBuffer(0)
        if background is not None:
            bxy, bcol = pixel_quads(self.width, self.height, np.asarray(background, np.uint8))
            self._render(bxy, bcol, (1, 0, 1, 0))
            self._ren.SetPreserveColorBuffer(1)
        self._render(np.asarray(xy, np.float32), np.asarray(colors, np.uint8),
                     tuple(GL_BLEND_FACTORS[n] for n in names))
        arr = vtkUnsignedCharArray()
        self._rw.GetRGBACharPixelData(0, 0, self.width - 1, self.height - 1, 0, arr)
        return vtk_to_numpy(arr).reshape(self.height, self.width, 4).copy()

    def _render(self, xy: np.ndarray, colors: np.ndarray, blend: tuple) -> None:
        from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

        t = xy.shape[0]
        pts = np.zeros((3 * t, 3), np.float32)
        pts[:, :2] = xy.reshape(-1, 2)
        p = vtkPoints()
        p.SetData(numpy_to_vtk(pts, deep=True))
        cells = vtkCellArray()
        cells.SetData(numpy_to_vtkIdTypeArray(np.arange(0, 3 * t + 1, 3, dtype=np.int64), deep=True),
                      numpy_to_vtkIdTypeArray(np.arange(3 * t, dtype=np.int64), deep=True))
        pd = vtkPolyData()
        pd.SetPoints(p)
        pd.SetPolys(cells)
        pd.GetPointData().SetScalars(numpy_to_vtk(np.ascontiguousarray(colors.reshape(-1, 4)), deep=True))
        self._mapper.SetInputData(pd)
        self._blend = blend
        self._rw.Render()

    def coverage(self, xy: Any) -> np.ndarray:
        """Per-triangle coverage (T, H, W) bool, GL memory order: additive blending of one bit per
        triangle (24 triangles per draw in R, G, B; alpha counts hits)."""
        xy = np.asarray(xy, np.float32)
        out = np.zeros((xy.shape[0], self.height, self.width), bool)
        for b0 in range(0, xy.shape[0], 24):
            n = min(24, xy.shape[0] - b0)
            col = np.zeros((n, 3, 4), np.uint8)
            k = np.arange(n)
            col[k, :, k // 8] = (1 << (k % 8))[:, None]
            col[:, :, 3] = 1
            img = self.draw(xy[b0:b0 + n], col, ("one", "one")).astype(np.int64)
            for i in range(n):
                out[b0 + i] = (img[..., i // 8] >> (i % 8)) & 1 == 1
        return out


def pixel_quads(width: int, height: int, codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two flat-coloured triangles per pixel (pixel (row r, column c) = [c, c+1] x [r, r+1]) with colours ``codes``."""
    r, c = np.meshgrid(np.arange(height, dtype=np.float32), np.arange(width, dtype=np.float32), indexing="ij")
    r, c = r.ravel(), c.ravel()
    a, b, d, e = (np.stack([c + dx, r + dy], -1) for dx, dy in ((0, 0), (1, 0), (0, 1), (1, 1)))
    xy = np.concatenate([np.stack([a, b, d], 1), np.stack([b, e, d], 1)])
    col = np.repeat(codes.reshape(-1, 1, 4), 3, axis=1)
    return xy, np.concatenate([col, col])


def to_gl(xy: np.ndarray, height: int, orientation: str = "display") -> np.ndarray:
    """warpvol window coordinates (y down) -> GL window coordinates (y up).

    ``display``: the same picture as displayed (GL y = H - y; compare with the GL buffer's rows
    reversed); ``memory``: the same numbers (GL y = y; compare row r with GL's memory row r, a
    mirrored picture).
    """
    g = np.array(xy, np.float32, copy=True)
    if orientation == "display":
        g[..., 1] = np.float32(height) - g[..., 1]
    elif orientation != "memory":
        raise ConfigError(f"orientation: unknown value {orientation!r}; allowed: 'display', 'memory'")
    return g


def conformance_soup(seed: int, width: int, height: int) -> tuple[np.ndarray, np.ndarray, list]:
    """The conformance suite's triangle soup on a ``width`` x ``height`` canvas (warpvol coordinates).

    Returns ``xy`` (T, 3, 2) float32, ``group`` (T,) int and the group names: random triangles,
    vertices on pixel centres, vertices on pixel edges, an exact tiling of a rectangle (vertices on
    the 1/256 grid, shared edges), slivers (< 0.1 px wide), sub-pixel triangles, off-grid vertices
    (arbitrary fp32), snapping ties (every coordinate half-way between 1/256 steps) and horizontal
    edges through pixel centres. All vertices lie inside the canvas.

    Example
    -------
    >>> xy, group, names = conformance_soup(0, 64, 48)
    >>> xy.shape, int((group == names.index("snap_tie")).sum())
    ((262, 3, 2), 24)
    >>> bool(np.all((xy[group == names.index("snap_tie")] * 512) % 2 == 1))   # odd multiples of 1/512
    True
    """
    rng = np.random.default_rng(seed)
    w, h = float(width), float(height)
    names = ["random", "pixel_centres", "pixel_edges", "tiling", "sliver", "subpixel", "off_grid", "snap_tie",
             "horizontal"]
    tris: list = []
    groups: list = []

    def add(g, t):
        t = np.asarray(t, np.float64)
        t[..., 0] = np.clip(t[..., 0], 0, w)
        t[..., 1] = np.clip(t[..., 1], 0, h)
        tris.extend(t)
        groups.extend([names.index(g)] * len(t))

    def pts(n, grid):
        return np.stack([rng.integers(0, int(w * grid), n) / grid, rng.integers(0, int(h * grid), n) / grid], -1)

    add("random", pts(3 * 40, 256).reshape(40, 3, 2))
    add("pixel_centres", (np.floor(pts(3 * 30, 1)) + 0.5).reshape(30, 3, 2))
    add("pixel_edges", pts(3 * 30, 1).reshape(30, 3, 2))
    # a tiling of an nx x ny grid of cells with jittered interior vertices (1/256 grid), two triangles per cell
    nx, ny = 6, 4
    x0, y0 = np.floor(rng.uniform(0, w / 3)), np.floor(rng.uniform(0, h / 3))
    gx = x0 + np.linspace(0, np.floor(w / 2), nx + 1)
    gy = y0 + np.linspace(0, np.floor(h / 2), ny + 1)
    X, Y = np.meshgrid(gx, gy)
    inner = np.zeros_like(X, bool)
    inner[1:-1, 1:-1] = True
    X = X + inner * np.round(rng.uniform(-1.5, 1.5, X.shape) * 4) / 4
    Y = Y + inner * np.round(rng.uniform(-1.5, 1.5, Y.shape) * 256) / 256
    tl = []
    for r in range(ny):
        for c in range(nx):
            a, b = (X[r, c], Y[r, c]), (X[r, c + 1], Y[r, c + 1])
            d, e = (X[r + 1, c], Y[r + 1, c]), (X[r + 1, c + 1], Y[r + 1, c + 1])
            tl += [[a, b, e], [a, e, d]] if rng.random() < 0.5 else [[a, b, d], [b, e, d]]
    add("tiling", tl)
    # slivers: long, under 0.1 px wide, any direction
    p = pts(20, 256)
    ang = rng.uniform(0, np.pi, 20)
    ln = rng.uniform(4, 0.5 * min(w, h), 20)
    q = p + ln[:, None] * np.stack([np.cos(ang), np.sin(ang)], -1)
    m = (p + q) / 2 + rng.uniform(0.01, 0.1, (20, 1)) * np.stack([-np.sin(ang), np.cos(ang)], -1)
    add("sliver", np.stack([p, q, m], 1))
    # sub-pixel triangles: inside one pixel, around its centre
    c = np.floor(pts(20, 1)) + 0.5
    add("subpixel", c[:, None, :] + rng.uniform(-0.5, 0.5, (20, 3, 2)))
    add("off_grid", rng.uniform(0, 1, (30, 3, 2)) * [w, h])
    # snapping ties: every coordinate an odd multiple of 1/512, near pixel centres
    t = np.floor(pts(3 * 24, 1)) + 0.5 + (2 * rng.integers(-3, 3, (3 * 24, 2)) + 1) / 512
    add("snap_tie", t.reshape(24, 3, 2))
    # horizontal edges through pixel centres (both with interior above and below)
    yc = np.floor(rng.uniform(1, h - 1, 20)) + 0.5
    xa = rng.uniform(0, w / 2, 20)
    xb = xa + rng.uniform(1, w / 2, 20)
    ya = yc + rng.choice([-1, 1], 20) * rng.uniform(1, 8, 20)
    add("horizontal", np.stack([np.stack([xa, yc], -1), np.stack([xb, yc], -1),
                                np.stack([rng.uniform(0, w, 20), ya], -1)], 1))
    xy = np.asarray(tris, np.float32)
    return xy, np.asarray(groups), names


# ------------------------------------------------------------------------------------------------
# the conformance comparison: llvmpipe (through GLCanvas) vs the emulated rasteriser + blending unit
# ------------------------------------------------------------------------------------------------

BLEND_MODES = {"premultiplied": ("one", "one_minus_src_alpha", "one", "one_minus_src_alpha"),
               "straight": ("src_alpha", "one_minus_src_alpha", "one", "one_minus_src_alpha")}


def _positions(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = xy.shape[0]
    pos = np.zeros((3 * t, 4), np.float32)
    pos[:, :2] = xy.reshape(-1, 2)
    pos[:, 2], pos[:, 3] = 0.5, 1.0
    return pos, np.arange(3 * t).reshape(t, 3)


def emulated_coverage(xy: np.ndarray, width: int, height: int, **rules) -> np.ndarray:
    """Per-triangle coverage (T, H, W) bool of the emulated rasteriser (warpvol rows, row 0 = top)."""

    pos, tris = _positions(xy)
    fr = Rasterizer(width, height, **rules).fragments(pos, tris)
    cov = np.zeros((xy.shape[0], height * width), bool)
    cov[fr.prim.numpy()[:fr.count], fr.pixel_index()] = True
    return cov.reshape(xy.shape[0], height, width)


def emulated_draw(xy: np.ndarray, colors: np.ndarray, width: int, height: int, blend: tuple, background: np.ndarray,
                  arithmetic: str, interpolation: str, **rules) -> np.ndarray:
    """The emulated units' RGBA8 codes (H, W, 4) after drawing ``xy`` with vertex colour codes over ``background``."""

    pos, tris = _positions(xy)
    fb = FrameBuffer(width, height, "unorm8")
    fb.write(background.astype(np.float32) / 255)
    bu = BlendUnit(blend[0], blend[1], src_alpha=blend[2], dst_alpha=blend[3], arithmetic=arithmetic)
    # vertex colours as GL's fetch of normalised bytes delivers them: code * fp32(1/255)
    rgba = colors.reshape(-1, 4).astype(np.float32) * np.float32(1 / 255)
    Rasterizer(width, height, **rules).draw(pos, tris, rgba, fb, bu, interpolation=interpolation)
    return fb.codes().astype(np.int64)


def _last_fragment_values(xy: np.ndarray, colors: np.ndarray, width: int, height: int) -> np.ndarray:
    """fp32 barycentric Gouraud colour (H, W, 4) of the last fragment at each pixel (NaN where none)."""

    pos, tris = _positions(xy)
    rgba = colors.reshape(-1, 4).astype(np.float32) * np.float32(1 / 255)
    fr = Rasterizer(width, height).fragments(pos, tris, rgba, interpolation="linear")
    off = fr.offsets.numpy()
    out = np.full((height * width, 4), np.nan)
    has = np.diff(off) > 0
    out[has] = fr.attrs.numpy()[off[1:][has] - 1]
    return out.reshape(height, width, 4)


def conformance_figures(canvas: GLCanvas, seed: int) -> dict:
    """Draw the soup of ``seed`` through llvmpipe and through the emulated units; count differences.

    Keys: ``coverage_display`` / ``coverage_memory`` {rule set: differing (triangle, pixel) pairs}
    outside the snapping-tie group, ``*_tris`` the triangles involved, ``snap_tie_*`` {rule set:
    (pairs, triangles)} in the snapping-tie group,
    ``tiling_hits`` (GL, emulated) max hits per pixel in the tiling, ``tiling_diff`` pixels whose
    hit counts differ, ``blend`` {mode/arithmetic: (pixels differing, max code difference)},
    ``gouraud`` {interp_rule/arithmetic: (codes differing, max difference, codes, how many of the
    differing were within 1e-3 code of an exact k + 1/2 tie in the barycentric fp32 value)}.
    """

    w, h = canvas.width, canvas.height
    xy, group, names = conformance_soup(seed, w, h)
    tie = group == names.index("snap_tie")
    rng = np.random.default_rng(1000 + seed)
    fig: dict = {"triangles": int(xy.shape[0]), "snap_tie_triangles": int(tie.sum())}
    rule_sets = {"llvmpipe": LLVMPIPE_RULES, "top_left+even": {"fill_rule": "top_left", "snap_ties": "even"},
                 "top_left+away": {"fill_rule": "top_left", "snap_ties": "away"},
                 "bottom_left+away": {"fill_rule": "bottom_left", "snap_ties": "away"}}
    for orient in ("display", "memory"):
        gl = canvas.coverage(to_gl(xy, h, orient))
        if orient == "display":
            gl = gl[:, ::-1]
        pairs, tris, tie_pairs = {}, {}, {}
        for name, rules in rule_sets.items():
            emu = emulated_coverage(xy, w, h, **rules)
            d = emu != gl
            pairs[name], tris[name] = int(d[~tie].sum()), int(d[~tie].any((1, 2)).sum())
            tie_pairs[name] = (int(d[tie].sum()), int(d[tie].any((1, 2)).sum()))
            if orient == "display" and name == "llvmpipe":
                tiling = group == names.index("tiling")
                gcount, ecount = gl[tiling].sum(0), emu[tiling].sum(0)
                fig["tiling_hits"] = (int(gcount.max()), int(ecount.max()), int((gcount > 0).sum()))
                fig["tiling_diff"] = int((gcount != ecount).sum())
        fig[f"coverage_{orient}"], fig[f"coverage_{orient}_tris"] = pairs, tris
        fig[f"snap_tie_{orient}"] = tie_pairs
    # blended buffers: flat colours (alpha >= 1: VTK's 2D shader discards alpha 0) over a random background.
    # Unless both canvas sides are powers of two, VTK's fp32 matrix moves tie vertices off their ties
    # before llvmpipe snaps them: the tie group is left out of the buffers there (its coverage is above).
    exact_ties = all(n & (n - 1) == 0 for n in (w, h))
    fig["ties_in_buffers"] = exact_ties
    if not exact_ties:
        xy = xy[~tie]
    t = xy.shape[0]
    bg = rng.integers(1, 256, (h, w, 4)).astype(np.uint8)
    alpha = rng.integers(1, 256, t)
    straight = np.zeros((t, 3, 4), np.uint8)
    straight[:, :, :3] = rng.integers(0, 256, (t, 1, 3))
    straight[:, :, 3] = alpha[:, None]
    premult = straight.copy()
    premult[:, :, :3] = (straight[:, :, :3].astype(np.int64) * alpha[:, None, None] // 255).astype(np.uint8)
    gxy = to_gl(xy, h, "display")
    fig["blend"] = {}
    for mode, col in (("premultiplied", premult), ("straight", straight)):
        gl_img = canvas.draw(gxy, col, BLEND_MODES[mode], background=bg[::-1])[::-1].astype(np.int64)
        for arith in ("exact", "llvmpipe"):
            d = np.abs(emulated_draw(xy, col, w, h, BLEND_MODES[mode], bg, arith, "flat", **LLVMPIPE_RULES) - gl_img)
            fig["blend"][f"{mode}/{arith}"] = (int((d.max(-1) > 0).sum()), int(d.max()))
    # fragment codes: Gouraud colours, blending off (the last fragment per pixel stays)
    gcol = rng.integers(0, 256, (t, 3, 4)).astype(np.uint8)
    gcol[..., 3] = np.maximum(gcol[..., 3], 1)
    zero = np.zeros((h, w, 4), np.uint8)
    gl_img = canvas.draw(gxy, gcol, ("one", "zero"))[::-1].astype(np.int64)
    val = _last_fragment_values(xy, gcol, w, h) * 255
    near_tie = np.abs(val - np.floor(val) - 0.5) < 1e-3
    fig["gouraud"] = {}
    for interp, arith in (("barycentric", "exact"), ("barycentric", "llvmpipe"), ("llvmpipe", "llvmpipe")):
        rules = dict(LLVMPIPE_RULES, interp_rule=interp)
        d = np.abs(emulated_draw(xy, gcol, w, h, ("one", "zero", "one", "zero"), zero, arith, "linear", **rules)
                   - gl_img)
        fig["gouraud"][f"{interp}/{arith}"] = (int((d > 0).sum()), int(d.max()), int(d.size),
                                               int((near_tie & (d > 0)).sum()))
    return fig
