"""Cameras (Contract 1 ``[camera]``, Contract 2 ray convention) and OpenGL-style matrices.

Pixel ``(row i, column j)`` is sampled by the ray through its centre::

    x_ndc = 2 (j + 0.5) / W - 1,     y_ndc = 1 - 2 (i + 0.5) / H

perspective: origin ``eye``, direction ``f + x_ndc tan(fov/2) (W/H) r + y_ndc tan(fov/2) u``;
orthographic: origin ``eye + x_ndc (h/2)(W/H) r + y_ndc (h/2) u``, direction ``f``, with ``h`` the
world-space image height (:attr:`Camera.ortho_height`; the scene file's ``height`` key), ``f`` the
unit view direction, ``r = normalise(f x up)`` and ``u = r x f``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from warpvol.errors import ConfigError, check_choice, check_keys, check_number, check_vec3
from warpvol.scene import interop

PROJECTIONS = ("perspective", "orthographic")
_NO_HEIGHT = object()


def _frozen_vec3(name: str, value: Any) -> np.ndarray:
    v = check_vec3(name, value).copy()
    v.setflags(write=False)
    return v


#: the keys of a scene file's ``[camera]`` table (``height`` is Contract 1's name of ``ortho_height``)
CAMERA_KEYS = ("projection", "eye", "target", "up", "fov_y_deg", "height", "ortho_height", "width_px", "height_px")


@dataclass
class Camera:
    """Pinhole (perspective) or orthographic camera.

    ==============  ================================================  =================
    parameter       meaning                                           allowed
    ==============  ================================================  =================
    projection      ``"perspective"`` or ``"orthographic"``            choice
    eye, target     world-space points                                 distinct
    up              approximate up vector                              not parallel to view
    fov_y_deg       full vertical field of view (perspective)          (0, 180)
    ortho_height    world-space image height (orthographic; the        > 0
                    scene file's ``[camera] height``)
    width_px        image width in pixels                              >= 1
    height_px       image height in pixels                             >= 1
    ==============  ================================================  =================

    ``height`` is no field: a world height is ``ortho_height``, a pixel count ``height_px``
    (``Camera(height=...)`` is an error naming both). :meth:`fit` frames a mesh.

    Examples
    --------
    >>> cam = Camera(eye=[0, 0, 5], target=[0, 0, 0], width_px=4, height_px=2)
    >>> o, d = cam.rays()
    >>> o.shape, d.shape
    ((2, 4, 3), (2, 4, 3))
    """

    projection: str = "perspective"
    eye: Any = (0.0, 0.0, 5.0)
    target: Any = (0.0, 0.0, 0.0)
    up: Any = (0.0, 1.0, 0.0)
    fov_y_deg: float = 30.0
    ortho_height: float = 2.0
    width_px: int = 512
    height_px: int = 512
    where: str = field(default="camera", repr=False)

    def __post_init__(self):
        w = self.where
        self.projection = check_choice(f"{w}.projection", self.projection, PROJECTIONS)
        # read-only copies: the camera never aliases the caller's arrays, and an in-place edit cannot
        # leave the derived frame (forward, right, true_up) stale; use replace() for a changed camera
        self.eye, self.target, self.up = (_frozen_vec3(f"{w}.{k}", getattr(self, k)) for k in ("eye", "target", "up"))
        self.fov_y_deg = check_number(f"{w}.fov_y_deg", self.fov_y_deg, lo=0, hi=180, lo_open=True, hi_open=True)
        self.ortho_height = check_number(f"{w}.ortho_height", self.ortho_height, lo=0, lo_open=True)
        self.width_px = check_number(f"{w}.width_px", self.width_px, lo=1, integer=True)
        self.height_px = check_number(f"{w}.height_px", self.height_px, lo=1, integer=True)
        with np.errstate(over="ignore"):
            d = self.target - self.eye
        if not np.isfinite(d).all():  # coordinates near +-1.8e308: the same direction from halves
            d = 0.5 * self.target - 0.5 * self.eye
        # relative to the coordinates' size, so a scene in nanometres is as valid as one in metres
        m = float(np.abs(d).max())
        if m <= 1e-12 * float(max(np.abs(self.eye).max(), np.abs(self.target).max())) or m == 0:
            raise ConfigError(f"{w}.eye: equals {w}.target ({self.eye.tolist()}) to 12 digits; the view direction "
                              "is undefined")
        f = d / m
        f = f / np.linalg.norm(f)
        r = np.cross(f, self.up)
        rn = np.linalg.norm(r)
        if rn <= 1e-9 * np.linalg.norm(self.up):
            raise ConfigError(f"{w}.up: {self.up.tolist()} is parallel to the view direction {f.tolist()}")
        r = r / rn
        self.forward, self.right, self.true_up = f, r, np.cross(r, f)

    @classmethod
    def from_config(cls, cfg: dict, where: str = "camera") -> "Camera":
        if not isinstance(cfg, dict):
            raise ConfigError(f"{where}: expected a table")
        check_keys(where, cfg, CAMERA_KEYS)
        cfg = dict(cfg)
        if "height" in cfg:  # Contract 1's key: the world-space image height
            if "ortho_height" in cfg:
                raise ConfigError(f"{where}: give either 'height' (the scene file's key) or 'ortho_height', not both")
            h = cfg.pop("height")
            try:
                check_number(f"{where}.height", h, lo=0, lo_open=True)
            except ConfigError as e:
                raise ConfigError(f"{e} (the world-space image height of an orthographic camera; pixels are "
                                  "height_px)") from None
            cfg["ortho_height"] = h
        return cls(**cfg, where=where)

    @classmethod
    def fit(cls, mesh: Any, *, width_px: int = 512, height_px: int = 512, direction: Any = (1.0, 1.0, 1.0),
            up: Any = (0.0, 0.0, 1.0), projection: str = "perspective", fov_y_deg: float = 30.0,
            margin: float = 1.0, where: str = "camera") -> "Camera":
        """A camera that shows the whole of ``mesh``: pyvista's default view (looking at the centre of
        the bounds from the ``(1, 1, 1)`` side, ``z`` up), at the distance where the bounding sphere
        just fits the narrower of the two fields of view (pyvista's ``reset_camera``).

        Parameters
        ----------
        mesh : TetMesh, pyvista data set or bounds
            Anything with ``bounds`` (a TetMesh's ``(min, max)`` or pyvista's six numbers), or
            the bounds themselves: ``(min, max)`` corners or ``(xmin, xmax, ymin, ymax, zmin, zmax)``.
        width_px, height_px : int
            Image size in pixels.
        direction : 3 numbers
            From the centre towards the eye (pyvista's isometric view is ``(1, 1, 1)``).
        up : 3 numbers
            Up vector; ``(0, 1, 0)`` is taken when it is parallel to ``direction``.
        projection : str
            ``"perspective"`` (eye at ``radius / sin(half field of view)``) or ``"orthographic"``
            (``ortho_height`` the sphere's diameter, or more for a portrait image).
        fov_y_deg : float
            Vertical field of view of a perspective camera.
        margin : float
            Radius multiplier (> 0; 1.1 leaves a border of about 10 %).

        Examples
        --------
        >>> cam = Camera.fit(([0, 0, 0], [2, 2, 2]), width_px=64, height_px=48)
        >>> cam.target.tolist(), round(float(np.linalg.norm(cam.eye - cam.target)), 4)  # sqrt(3) / sin(15 deg)
        ([1.0, 1.0, 1.0], 6.6921)
        >>> Camera.fit(([0, 0, 0], [2, 2, 2]), projection="orthographic").ortho_height  # the sphere's diameter
        3.4641016151377544
        """
        lo, hi = _bounds(mesh, where)
        d = check_vec3(f"{where}.direction", direction)
        if not np.linalg.norm(d) > 0:
            raise ConfigError(f"{where}.direction: {d.tolist()} has no length")
        d = d / np.linalg.norm(d)
        u = check_vec3(f"{where}.up", up)
        if np.linalg.norm(np.cross(d, u)) <= 1e-9 * np.linalg.norm(u):
            u = np.array([0.0, 1.0, 0.0])
        margin = check_number(f"{where}.margin", margin, lo=0, lo_open=True)
        width_px = check_number(f"{where}.width_px", width_px, lo=1, integer=True)
        height_px = check_number(f"{where}.height_px", height_px, lo=1, integer=True)
        centre = 0.5 * lo + 0.5 * hi
        radius = 0.5 * float(np.linalg.norm(hi - lo)) * margin
        if not radius > 0:  # a single point: a unit sphere around it
            radius = margin * max(1.0, float(np.abs(centre).max()) * 1e-6)
        aspect = width_px / height_px
        common = dict(projection=projection, target=centre, up=u, width_px=width_px, height_px=height_px, where=where)
        if projection == "orthographic":
            return cls(eye=centre + 2.0 * radius * d, ortho_height=2.0 * radius * max(1.0, 1.0 / aspect), **common)
        fov = check_number(f"{where}.fov_y_deg", fov_y_deg, lo=0, hi=180, lo_open=True, hi_open=True)
        half = min(np.radians(fov) / 2.0, np.arctan(np.tan(np.radians(fov) / 2.0) * aspect))
        return cls(eye=centre + radius / np.sin(half) * d, fov_y_deg=fov, **common)

    @classmethod
    def from_pyvista(cls, plotter_or_camera, window_size=None) -> "Camera":
        """The camera of a pyvista view, so warpvol renders what pyvista shows.

        Parameters
        ----------
        plotter_or_camera : pyvista.Plotter, pyvista.Camera or vtkCamera
            With a plotter, its active renderer's camera (pyvista's default view when none was set,
            as ``show()`` would use) and its window size (times the renderer's viewport).
        window_size : (int, int), optional
            ``(width, height)`` in pixels; required with a bare camera, overrides a plotter's.

        Examples
        --------
        >>> import pyvista as pv
        >>> c = pv.Camera(); c.position = (0, 0, 5); c.focal_point = (0, 0, 0); c.view_angle = 40.0
        >>> cam = Camera.from_pyvista(c, window_size=(64, 48))
        >>> cam.eye.tolist(), cam.fov_y_deg, (cam.width_px, cam.height_px)
        ([0.0, 0.0, 5.0], 40.0, (64, 48))
        """
        return cls(**interop.camera_settings(plotter_or_camera, window_size))

    def to_pyvista(self, plotter=None):
        """This camera as a ``pyvista.Camera``; with ``plotter``, also set as its camera together
        with ``window_size = (width_px, height_px)``, so pyvista shows the view warpvol renders.

        Examples
        --------
        >>> c = Camera(eye=[1, 2, 3], fov_y_deg=25.0).to_pyvista()
        >>> c.position, c.view_angle
        ((1.0, 2.0, 3.0), 25.0)
        """
        return interop.camera_to_pyvista(self, plotter)

    def replace(self, **kw) -> "Camera":
        d = dict(projection=self.projection, eye=self.eye, target=self.target, up=self.up,
                 fov_y_deg=self.fov_y_deg, ortho_height=self.ortho_height, width_px=self.width_px,
                 height_px=self.height_px, where=self.where)
        d.update(kw)
        return Camera(**d)

    @property
    def height(self):
        raise AttributeError("Camera has no 'height': the world-space image height of an orthographic camera is "
                             "'ortho_height', the image height in pixels 'height_px'")

    @property
    def aspect(self) -> float:
        return self.width_px / self.height_px

    def ndc_grid(self) -> tuple[np.ndarray, np.ndarray]:
        """``(x_ndc, y_ndc)`` of all pixel centres, each (H, W), float64."""
        j = np.arange(self.width_px, dtype=np.float64)
        i = np.arange(self.height_px, dtype=np.float64)
        x = 2.0 * (j + 0.5) / self.width_px - 1.0
        y = 1.0 - 2.0 * (i + 0.5) / self.height_px
        return np.meshgrid(x, y)

    def rays(self, normalise: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Ray origins and directions per pixel, each (H, W, 3) float64 (Contract 2).

        With ``normalise`` the directions are unit vectors, so ray parameters are world lengths.
        """
        x, y = self.ndc_grid()
        f, r, u = self.forward, self.right, self.true_up
        if self.projection == "perspective":
            th = np.tan(np.radians(self.fov_y_deg) / 2.0)
            d = f + (x * th * self.aspect)[..., None] * r + (y * th)[..., None] * u
            o = np.broadcast_to(self.eye, d.shape).copy()
        else:
            hh = self.ortho_height / 2.0
            o = self.eye + (x * hh * self.aspect)[..., None] * r + (y * hh)[..., None] * u
            d = np.broadcast_to(f, o.shape).copy()
        if normalise:
            d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        return o, d

    # -- OpenGL-style matrices (column vectors, right-handed eye space looking down -z) --------
    def view_matrix(self) -> np.ndarray:
        """Model-view matrix: world -> eye space."""
        f, r, u = self.forward, self.right, self.true_up
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = r, u, -f
        m[:3, 3] = -m[:3, :3] @ self.eye
        return m

    def projection_matrix(self, near: float, far: float) -> np.ndarray:
        """``glFrustum``/``glOrtho`` equivalent for this camera's frustum."""
        if not (far > near):
            raise ConfigError(f"{self.where}: far ({far}) must exceed near ({near})")
        p = np.zeros((4, 4))
        if self.projection == "perspective":
            if near <= 0:
                raise ConfigError(f"{self.where}: near plane must be > 0 for perspective, got {near}")
            t = 1.0 / np.tan(np.radians(self.fov_y_deg) / 2.0)
            p[0, 0], p[1, 1] = t / self.aspect, t
            p[2, 2] = -(far + near) / (far - near)
            p[2, 3] = -2.0 * far * near / (far - near)
            p[3, 2] = -1.0
        else:
            hh = self.ortho_height / 2.0
            p[0, 0], p[1, 1] = 1.0 / (hh * self.aspect), 1.0 / hh
            p[2, 2] = -2.0 / (far - near)
            p[2, 3] = -(far + near) / (far - near)
            p[3, 3] = 1.0
        return p

    def viewport_matrix(self) -> np.ndarray:
        """NDC -> window coordinates: x in [0, W] left to right, y in [0, H] *top to bottom*
        (row index convention of Contract 2), depth in [0, 1]."""
        v = np.eye(4)
        v[0, 0], v[0, 3] = self.width_px / 2.0, self.width_px / 2.0
        v[1, 1], v[1, 3] = -self.height_px / 2.0, self.height_px / 2.0
        v[2, 2], v[2, 3] = 0.5, 0.5
        return v

    def depth_range(self, bounds_min: np.ndarray, bounds_max: np.ndarray) -> tuple[float, float]:
        """Near/far eye-space distances that enclose an axis-aligned box (near clamped > 0; margins
        relative to the box's size)."""
        corners = np.array([[x, y, z] for x in (bounds_min[0], bounds_max[0])
                            for y in (bounds_min[1], bounds_max[1]) for z in (bounds_min[2], bounds_max[2])])
        dz = (corners - self.eye) @ self.forward
        far = float(dz.max()) * 1.01 + 1e-6 * float(np.linalg.norm(np.asarray(bounds_max) - np.asarray(bounds_min)))
        near = max(float(dz.min()) * 0.99, far * 1e-4)
        return near, far


_dataclass_init = Camera.__init__


@functools.wraps(_dataclass_init)
def _init(self, *args, height: Any = _NO_HEIGHT, **kw):
    if height is not _NO_HEIGHT:
        w = kw.get("where", "camera")
        raise ConfigError(f"{w}.height: Camera takes no 'height' (got {height!r}): give 'ortho_height' for the "
                          "world-space image height of an orthographic camera or 'height_px' for the image height "
                          "in pixels")
    _dataclass_init(self, *args, **kw)


Camera.__init__ = _init


def _bounds(obj: Any, where: str) -> tuple[np.ndarray, np.ndarray]:
    """``(min, max)`` corners of a mesh (its ``bounds``) or of bounds given as two corners or six numbers."""
    b = getattr(obj, "bounds", obj)
    try:
        if isinstance(b, tuple) and len(b) == 2:
            lo, hi = (np.asarray(v, dtype=np.float64).reshape(3) for v in b)
        else:
            a = np.asarray(b, dtype=np.float64)
            if a.shape == (2, 3):
                lo, hi = a[0], a[1]
            elif a.shape == (6,):  # pyvista / VTK: xmin, xmax, ymin, ymax, zmin, zmax
                lo, hi = a[0::2], a[1::2]
            else:
                raise ValueError
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: fit: expected a mesh, (min, max) corners or (xmin, xmax, ymin, ymax, zmin, "
                          f"zmax); got {type(obj).__name__}") from None
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()) or (hi < lo).any():
        raise ConfigError(f"{where}: fit: bounds {lo.tolist()} .. {hi.tolist()} are not finite corners min <= max")
    return lo, hi
