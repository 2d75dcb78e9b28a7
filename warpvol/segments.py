"""Segments: what a piece of a mesh contributes to each pixel's ray, kept apart so pieces compose exactly.

Along one ray the intervals that disjoint pieces of a mesh cover never overlap, so each piece can be
integrated on its own and the results composited by depth afterwards: for each entry of the ray into a
piece one **segment** holds its front and back depth, its own premultiplied colour (radiance with
transmittance 1 at its front) and its optical depth (its transmittance is ``exp(-tau)``). The segments of
all pieces, merged by depth front to back and composited, give the whole ray's value for pieces of any
shape, non-convex and interleaved (:func:`merge`, :meth:`Segments.flatten`). This is OpenEXR's deep
volumetric image (samples with ``Z`` and ``ZBack``), written by :func:`warpvol.deep.write_deep`.

The lists are flat NumPy arrays: ``offsets`` (one more than the pixels) delimits each pixel's segments,
sorted front to back, in ``front``, ``back``, ``rgb`` and ``tau``. Depths are the ray parameter of
Contract 2 (world distance along the unit ray from the eye, or from the eye plane of an orthographic
camera).

Examples
--------
>>> a = Segments.from_unsorted([0], [1.0], [2.0], [[0.5, 0, 0]], [np.log(2.0)], (1, 1))
>>> b = Segments.from_unsorted([0], [0.0], [1.0], [[0, 0.5, 0]], [np.log(2.0)], (1, 1))
>>> merge([a, b]).flatten()[0, 0].round(6).tolist()
[0.25, 0.5, 0.0, 0.75]
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from warpvol.errors import ConfigError
from warpvol.reference.integrate import segmented_exclusive_cumsum


class Segments:
    """Per-pixel lists of segments of an ``(H, W)`` image, front to back (see the module docstring).

    Attributes
    ----------
    shape : (int, int)
        Image height and width.
    offsets : (H*W + 1,) int64
        Pixel ``p`` (``row * W + col``) owns entries ``offsets[p]:offsets[p + 1]``.
    front, back : (n,) float64
        Front and back depth of each segment (``front <= back``).
    rgb : (n, 3) float64
        Premultiplied radiance of each segment on its own.
    tau : (n,) float64
        Optical depth of each segment (may be ``inf``: an opaque segment).
    """

    __slots__ = ("shape", "offsets", "front", "back", "rgb", "tau")

    def __init__(self, shape, offsets, front, back, rgb, tau):
        self.shape = (int(shape[0]), int(shape[1]))
        self.offsets = np.asarray(offsets, dtype=np.int64)
        self.front = np.asarray(front, dtype=np.float64)
        self.back = np.asarray(back, dtype=np.float64)
        self.rgb = np.asarray(rgb, dtype=np.float64).reshape(-1, 3)
        self.tau = np.asarray(tau, dtype=np.float64)
        n = len(self.front)
        if (len(self.offsets) != self.shape[0] * self.shape[1] + 1 or self.offsets[0] != 0 or self.offsets[-1] != n
                or not (len(self.back) == len(self.rgb) == len(self.tau) == n)):
            raise ConfigError(f"segments: offsets ({len(self.offsets)}) and arrays ({n} segments) do not match an "
                              f"image of {self.shape[0]}x{self.shape[1]} pixels")

    # ------------------------------------------------------------------------------------------------
    @classmethod
    def empty(cls, shape) -> "Segments":
        """No segment in any pixel."""
        h, w = int(shape[0]), int(shape[1])
        return cls((h, w), np.zeros(h * w + 1, dtype=np.int64), [], [], np.zeros((0, 3)), [])

    @classmethod
    def from_unsorted(cls, pixel, front, back, rgb, tau, shape) -> "Segments":
        """Segments given in any order (``pixel``: flat index ``row * W + col``), sorted by pixel, then
        front depth, then back depth (a zero-length segment before the one that starts where it ends)."""
        h, w = int(shape[0]), int(shape[1])
        pixel = np.asarray(pixel, dtype=np.int64)
        front = np.asarray(front, dtype=np.float64)
        back = np.asarray(back, dtype=np.float64)
        if len(pixel) and (pixel.min() < 0 or pixel.max() >= h * w):
            raise ConfigError(f"segments: pixel index outside an image of {h}x{w} pixels")
        order = np.lexsort((back, front, pixel))
        offsets = np.zeros(h * w + 1, dtype=np.int64)
        np.cumsum(np.bincount(pixel, minlength=h * w), out=offsets[1:])
        return cls((h, w), offsets, front[order], back[order], np.asarray(rgb, dtype=np.float64).reshape(-1, 3)[order],
                   np.asarray(tau, dtype=np.float64)[order])

    @classmethod
    def entries(cls, pixel, front, back, rgb, tau, shape) -> "Segments":
        """One segment per entry of the ray into the mesh from the segments of its cells (any order):
        cells that follow each other along a ray (the back of one is the front of the next, exactly, as the
        exact reference's watertight traversal gives them) join into one segment, composited front to back.
        A gap (the ray leaves the mesh and re-enters) starts a new segment."""
        cells = cls.from_unsorted(pixel, front, back, rgb, tau, shape)
        n = len(cells.front)
        if n == 0:
            return cells
        pix = cells.pixels()
        start = np.ones(n, dtype=bool)
        start[1:] = (pix[1:] != pix[:-1]) | (cells.front[1:] != cells.back[:-1])
        group = np.cumsum(start) - 1
        trans = np.exp(-segmented_exclusive_cumsum(cells.tau, group))
        ng = int(group[-1]) + 1
        out_rgb = np.stack([np.bincount(group, weights=trans * cells.rgb[:, c], minlength=ng) for c in range(3)], axis=1)
        out_tau = np.bincount(group, weights=cells.tau, minlength=ng)
        first = np.flatnonzero(start)
        last = np.append(first[1:], n) - 1
        h, w = cells.shape
        offsets = np.zeros(h * w + 1, dtype=np.int64)
        np.cumsum(np.bincount(pix[first], minlength=h * w), out=offsets[1:])
        return cls(cells.shape, offsets, cells.front[first], cells.back[last], out_rgb, out_tau)

    # ------------------------------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self.front)

    @property
    def transmittance(self) -> np.ndarray:
        """``exp(-tau)`` of each segment."""
        return np.exp(-self.tau)

    @property
    def nbytes(self) -> int:
        return sum(getattr(self, k).nbytes for k in ("offsets", "front", "back", "rgb", "tau"))

    def counts(self) -> np.ndarray:
        """Segments per pixel, ``(H*W,)``."""
        return np.diff(self.offsets)

    def pixels(self) -> np.ndarray:
        """Flat pixel index of each segment."""
        return np.repeat(np.arange(len(self.offsets) - 1, dtype=np.int64), self.counts())

    def rows(self, first: int, last: int) -> "Segments":
        """The segments of image rows ``first..last`` (inclusive), as an image of those rows."""
        w = self.shape[1]
        a, b = int(self.offsets[first * w]), int(self.offsets[(last + 1) * w])
        return Segments((last - first + 1, w), self.offsets[first * w:(last + 1) * w + 1] - a, self.front[a:b],
                        self.back[a:b], self.rgb[a:b], self.tau[a:b])

    def flatten(self) -> np.ndarray:
        """The image, ``(H, W, 4)`` float64 premultiplied RGBA composited front to back over transparent black:
        ``RGB = sum_k exp(-sum_{j<k} tau_j) rgb_k``, ``A = 1 - exp(-sum_k tau_k)`` per pixel."""
        h, w = self.shape
        out = np.zeros((h * w, 4), dtype=np.float64)
        if len(self):
            pix = self.pixels()
            with np.errstate(invalid="ignore"):
                trans = np.exp(-segmented_exclusive_cumsum(self.tau, pix))
            for c in range(3):
                out[:, c] = np.bincount(pix, weights=trans * self.rgb[:, c], minlength=h * w)
            out[:, 3] = -np.expm1(-np.bincount(pix, weights=self.tau, minlength=h * w))
        return out.reshape(h, w, 4)


def merge(parts: Sequence[Segments]) -> Segments:
    """The segments of several pieces of one image in one list per pixel, front to back by depth (ties: the
    shorter segment first, then the pieces' order). Flattened, they give the image of the pieces together."""
    parts = list(parts)
    if not parts:
        raise ConfigError("merge: no segments given")
    shape = parts[0].shape
    for p in parts:
        if p.shape != shape:
            raise ConfigError(f"merge: segments of a {p.shape[0]}x{p.shape[1]} image cannot join those of a "
                              f"{shape[0]}x{shape[1]} image")
    if len(parts) == 1:
        return parts[0]
    pix = np.concatenate([p.pixels() for p in parts])
    front = np.concatenate([p.front for p in parts])
    back = np.concatenate([p.back for p in parts])
    order = np.lexsort((back, front, pix), axis=0)  # stable: equal keys keep the pieces' order
    offsets = np.zeros(shape[0] * shape[1] + 1, dtype=np.int64)
    np.cumsum(np.bincount(pix, minlength=shape[0] * shape[1]), out=offsets[1:])
    return Segments(shape, offsets, front[order], back[order], np.concatenate([p.rgb for p in parts])[order],
                    np.concatenate([p.tau for p in parts])[order])


def stack_rows(parts: Sequence[Segments]) -> Segments:
    """Segments of consecutive bands of image rows (top band first) as those of the image they tile."""
    parts = list(parts)
    w = parts[0].shape[1]
    if any(p.shape[1] != w for p in parts):
        raise ConfigError("stack_rows: bands of different widths")
    offs, base = [np.zeros(1, dtype=np.int64)], 0
    for p in parts:
        offs.append(p.offsets[1:] + base)
        base += len(p)
    return Segments((sum(p.shape[0] for p in parts), w), np.concatenate(offs),
                    np.concatenate([p.front for p in parts]), np.concatenate([p.back for p in parts]),
                    np.concatenate([p.rgb for p in parts]), np.concatenate([p.tau for p in parts]))
