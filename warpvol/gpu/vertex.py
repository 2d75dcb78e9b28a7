"""Vertex stage of the emulated GPU: object -> eye -> clip -> window coordinates.

Example
-------
>>> from warpvol.scene.camera import Camera
>>> cam = Camera(eye=[0, 0, 5], target=[0, 0, 0], width_px=4, height_px=4, fov_y_deg=90)
>>> vs = VertexStage.from_camera(cam, near=1.0, far=10.0)
>>> out = vs.transform([[0.0, 0.0, 0.0]])
>>> out.window[0, :2].tolist(), float(out.window[0, 3])        # image centre; clip w = distance 5
([2.0, 2.0], 5.0)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from warpvol.errors import ConfigError, check_number
from warpvol.gpu import counters as _cnt
from warpvol.kernels import vertex as kv


@dataclass
class Vertices:
    """Output of :meth:`VertexStage.transform`: NumPy (V, 4) ``eye``, ``clip``, ``window`` plus the
    device array ``window_array`` (vec4) that :class:`~warpvol.gpu.raster.Rasterizer` takes as is."""

    eye: np.ndarray
    clip: np.ndarray
    window: np.ndarray
    window_array: wp.array
    #: ``eye`` holds eye-space z plus this (0: the hardware's eye space; see :class:`VertexStage`)
    eye_offset: float = 0.0


def _mat(m: Any, name: str) -> np.ndarray:
    try:
        a = np.asarray(m, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"{name}: expected a 4x4 matrix, got {type(m).__name__}") from None
    if a.shape != (4, 4) or not np.isfinite(a).all():
        raise ConfigError(f"{name}: expected a finite 4x4 matrix, got shape {a.shape}")
    return a


def viewport_matrix(width: int, height: int) -> np.ndarray:
    """NDC -> window: x in [0, W] left to right, y in [0, H] top to bottom, z in [0, 1]."""
    width = check_number("width", width, lo=1, integer=True)
    height = check_number("height", height, lo=1, integer=True)
    v = np.eye(4)
    v[0, 0], v[0, 3] = width / 2.0, width / 2.0
    v[1, 1], v[1, 3] = -height / 2.0, height / 2.0
    v[2, 2], v[2, 3] = 0.5, 0.5
    return v


class VertexStage:
    """Transforms object-space points to window coordinates (column vectors, OpenGL conventions).

    ==========  ===================================================  ============================
    parameter   meaning                                              allowed
    ==========  ===================================================  ============================
    modelview   object -> eye space                                  finite 4x4
    projection  eye -> clip space (``glFrustum`` / ``glOrtho``)      finite 4x4
    viewport    NDC -> window (see :func:`viewport_matrix`)          finite 4x4
    device      Warp device                                          ``"cpu"``, ``"cuda:0"``, ...
    eye_offset  added to eye-space z (0: the hardware's eye space)   finite
    ==========  ===================================================  ============================

    ``eye_offset`` d moves the eye-space origin along the view axis: the stage outputs eye-space
    points ``e + (0, 0, d)`` (from ``T(d) MV``, the product taken in float64) and clip coordinates
    ``P T(-d)`` of them, which are those of ``e``. With d the depth of the data, eye-space z near the
    data is small and keeps float32 precision however far the eye is (depth differences, thicknesses);
    clip and window coordinates are unchanged up to rounding.
    """

    def __init__(self, modelview: Any, projection: Any, viewport: Any, device: str = "cpu", eye_offset: float = 0.0):
        self.modelview = _mat(modelview, "modelview")
        self.projection = _mat(projection, "projection")
        self.viewport = _mat(viewport, "viewport")
        self.device = device
        self.eye_offset = float(check_number("eye_offset", eye_offset))

    @classmethod
    def from_camera(cls, camera, near: float, far: float, model: Any = None, device: str = "cpu",
                    eye_offset: float = 0.0) -> "VertexStage":
        """Matrices of a :class:`~warpvol.scene.camera.Camera` (``model`` defaults to identity)."""
        near = check_number("near", near)
        far = check_number("far", far)
        mv = camera.view_matrix() @ (np.eye(4) if model is None else _mat(model, "model"))
        return cls(mv, camera.projection_matrix(near, far), camera.viewport_matrix(), device=device,
                   eye_offset=eye_offset)

    def transform(self, points: Any) -> Vertices:
        p = np.asarray(points, dtype=np.float32)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ConfigError(f"points: expected shape (V, 3), got {p.shape}")
        if not np.isfinite(p).all():
            raise ConfigError("points: holds NaN or Inf")
        n = p.shape[0]
        dev = self.device
        eye = wp.zeros(n, dtype=wp.vec4, device=dev)
        clip = wp.zeros(n, dtype=wp.vec4, device=dev)
        win = wp.zeros(n, dtype=wp.vec4, device=dev)
        if n:
            mv, pr = self.modelview, self.projection
            if self.eye_offset:
                shift = np.eye(4)
                shift[2, 3] = self.eye_offset
                mv, pr = shift @ mv, pr @ np.linalg.inv(shift)
            m = [wp.mat44(*a.astype(np.float32).ravel()) for a in (mv, pr, self.viewport)]
            wp.launch(kv.k_transform, dim=n, inputs=[wp.array(p, dtype=wp.vec3, device=dev), *m, eye, clip, win],
                      device=dev)
            _cnt.count(vertices=n, bytes_up=12 * n)  # (x, y, z) float32 per vertex
        return Vertices(eye.numpy(), clip.numpy(), win.numpy(), win, self.eye_offset)


def transform_vertices(points: Any, modelview: Any, projection: Any, viewport: Any, device: str = "cpu") -> Vertices:
    """Plain function form of :meth:`VertexStage.transform`."""
    return VertexStage(modelview, projection, viewport, device).transform(points)
