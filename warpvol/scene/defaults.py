"""Defaults for a mesh given on its own: a transfer function over its point scalars and a camera that
shows all of it.

* :func:`colormap_transfer`: any matplotlib colour-map name (``"viridis"``, ``"coolwarm"``,
  ``"magma_r"``, ...) or a ParaView preset name (``"Cool to Warm"``, ``"Black-Body Radiation"``,
  ``"Viridis (matplotlib)"``, ... :data:`PARAVIEW_PRESETS`) with ParaView's default opacity
  ramp: extinction rising linearly from 0 at the low end of the scalar range to ``extinction_max``
  at the high end. An unknown name is an error listing the closest names.
* :func:`default_extinction`: the top of the ramp chosen so that an average ray through the mesh
  (its mean chord, ``4 volume / boundary area``) gathers an optical depth of about 6 over the mean of
  its scalars: the brightest parts come near the colour map's own brightness and most of the mesh is
  half transparent, neither an empty nor an opaque image, whatever the mesh's units, shape or scalar
  distribution.
* :func:`default_scene`: the mesh, :func:`default_transfer` and :meth:`Camera.fit`
  (:func:`warpvol.scene.spec.scene_from_spec` reads a scene by name: a built-in, a scene file or a mesh file).

Examples
--------
>>> from warpvol.scene.builtin import builtin_mesh
>>> s = default_scene(builtin_mesh("linear_box"), size=(32, 24))
>>> s.transfer.srange == s.mesh.scalar_range, (s.camera.width_px, s.camera.height_px)
(True, (32, 24))
>>> colormap_transfer("Cool to Warm", (0.0, 1.0), 2.0).evaluate(0.5).round(3).tolist()  # ParaView's mid grey
[0.865, 0.865, 0.865, 1.0]
"""

from __future__ import annotations

import difflib
from typing import Any

import numpy as np

from warpvol.errors import ConfigError, check_number
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh, signed_volumes
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction

#: the colour map of :func:`default_transfer` (pyvista's default)
DEFAULT_COLORMAP = "viridis"
#: image size of :func:`default_scene` (pyvista's default window)
DEFAULT_SIZE = (512, 512)
#: mean optical depth of a ray through the mesh under :func:`default_extinction`
DEFAULT_DEPTH = 6.0
#: control points of a colour-map transfer function (colours sampled uniformly over the range)
COLORMAP_POINTS = 33

#: ParaView presets known by name (values as in ParaView's Remoting/Views/ColorMaps.json, scalar range
#: 0..1 or as there; rescaled to the data range), each compared entry by entry with that file: equal.
#: "Red to Blue Rainbow" is the pre-5.9 entry (ParaView 5.9 dropped it for the reverse of "Blue to Red
#: Rainbow", the same map). ParaView's "(matplotlib)" maps (newer ParaView: plain "Viridis" ...) and
#: "Turbo" are matplotlib's.
PARAVIEW_PRESETS: dict[str, dict] = {
    "Cool to Warm": {"ColorSpace": "Diverging", "RGBPoints": [
        0.0, 0.23137254902, 0.298039215686, 0.752941176471, 0.5, 0.865, 0.865, 0.865,
        1.0, 0.705882352941, 0.0156862745098, 0.149019607843]},
    "Warm to Cool": {"ColorSpace": "Diverging", "RGBPoints": [
        0.0, 0.705882352941, 0.0156862745098, 0.149019607843, 0.5, 0.865, 0.865, 0.865,
        1.0, 0.23137254902, 0.298039215686, 0.752941176471]},
    "Black-Body Radiation": {"ColorSpace": "RGB", "RGBPoints": [
        0.0, 0.0, 0.0, 0.0, 0.4, 0.901960784314, 0.0, 0.0, 0.8, 0.901960784314, 0.901960784314, 0.0,
        1.0, 1.0, 1.0, 1.0]},
    "X Ray": {"ColorSpace": "RGB", "RGBPoints": [0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0]},
    "Grayscale": {"ColorSpace": "RGB", "RGBPoints": [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]},
    "Jet": {"ColorSpace": "RGB", "RGBPoints": [
        -1.0, 0.0, 0.0, 0.5625, -0.777778, 0.0, 0.0, 1.0, -0.269841, 0.0, 1.0, 1.0, -0.015873, 0.5, 1.0, 0.5,
        0.238095, 1.0, 1.0, 0.0, 0.746032, 1.0, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0]},
    "Rainbow Desaturated": {"ColorSpace": "RGB", "RGBPoints": [
        0.0, 0.278431372549, 0.278431372549, 0.858823529412, 0.143, 0.0, 0.0, 0.360784313725,
        0.285, 0.0, 1.0, 1.0, 0.429, 0.0, 0.501960784314, 0.0, 0.571, 1.0, 1.0, 0.0,
        0.714, 1.0, 0.380392156863, 0.0, 0.857, 0.419607843137, 0.0, 0.0,
        1.0, 0.878431372549, 0.301960784314, 0.301960784314]},
    "Blue to Red Rainbow": {"ColorSpace": "HSV", "RGBPoints": [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0]},
    "Red to Blue Rainbow": {"ColorSpace": "HSV", "RGBPoints": [0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]},
}
#: ParaView preset names that are matplotlib's maps
PARAVIEW_MATPLOTLIB = {"Viridis (matplotlib)": "viridis", "Inferno (matplotlib)": "inferno",
                       "Plasma (matplotlib)": "plasma", "Magma (matplotlib)": "magma", "Turbo": "turbo"}


def _matplotlib_names() -> list[str]:
    import matplotlib

    return sorted(matplotlib.colormaps)


def colormap_names() -> list[str]:
    """Every name :func:`colormap_transfer` takes: matplotlib's colour maps, then the ParaView presets."""
    return _matplotlib_names() + sorted(PARAVIEW_PRESETS) + sorted(PARAVIEW_MATPLOTLIB)


def resolve_colormap(name: Any, where: str = "colormap") -> str:
    """The colour map's name as listed (exact, else the one name equal ignoring case); an unknown
    name is an error with the closest names."""
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{where}: expected a colour-map name (matplotlib) or a ParaView preset name, got {name!r}")
    names = colormap_names()
    if name in names:
        return name
    folded = [n for n in names if n.casefold() == name.casefold()]
    if len(folded) == 1:
        return folded[0]
    by_fold = {n.casefold(): n for n in names}
    close = [by_fold[n] for n in difflib.get_close_matches(name.casefold(), list(by_fold), n=6, cutoff=0.5)]
    hint = f"close matches: {', '.join(map(repr, close))}" if close else "no close match"
    raise ConfigError(f"{where}: unknown colour map or ParaView preset {name!r}; {hint} (any matplotlib colour "
                      f"map, or the ParaView presets {', '.join(map(repr, sorted(PARAVIEW_PRESETS)))}, "
                      f"{', '.join(map(repr, sorted(PARAVIEW_MATPLOTLIB)))})")


def colormap_rgb(name: str, t: Any, where: str = "colormap") -> np.ndarray:
    """RGB (float64, ``t.shape + (3,)``) of colour map ``name`` at ``t`` in [0, 1]."""
    name = resolve_colormap(name, where)
    t = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0)
    if name in PARAVIEW_PRESETS:
        p = PARAVIEW_PRESETS[name]
        x = np.asarray(p["RGBPoints"], dtype=np.float64).reshape(-1, 4)[:, 0]
        tf = TransferFunction.from_paraview({"Name": name, **p}, opacity=1.0, where=where)
        return tf.evaluate(x[0] + t * (x[-1] - x[0]))[..., :3]
    import matplotlib

    cmap = matplotlib.colormaps[PARAVIEW_MATPLOTLIB.get(name, name)]
    return np.asarray(cmap(t), dtype=np.float64)[..., :3]


def colormap_transfer(name: str, srange: Any, extinction_max: float, *, points: int = COLORMAP_POINTS,
                      where: str = "transfer") -> TransferFunction:
    """A transfer function with the colours of ``name`` over ``srange`` and ParaView's default
    opacity ramp as extinction: ``rho(s) = extinction_max (s - smin) / (smax - smin)``.

    Examples
    --------
    >>> tf = colormap_transfer("gray", (10.0, 20.0), 3.0, points=3)
    >>> tf.points.round(3).tolist()
    [[10.0, 0.0, 0.0, 0.0, 0.0], [15.0, 0.502, 0.502, 0.502, 1.5], [20.0, 1.0, 1.0, 1.0, 3.0]]
    """
    try:
        lo, hi = (float(v) for v in srange)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: range: expected [smin, smax], got {srange!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ConfigError(f"{where}: range: expected finite [smin, smax] with smin < smax, got {[lo, hi]}")
    rho = check_number(f"{where}: extinction_max", extinction_max, lo=0)
    n = check_number(f"{where}: points", points, lo=2, integer=True)
    t = np.linspace(0.0, 1.0, n)
    s = lo + t * (hi - lo)
    s[-1] = hi
    # a range of a few float64 steps (subnormal scalars) holds fewer distinct points: each once, both ends kept
    keep = (np.diff(s, prepend=-np.inf) > 0) & (s < hi)
    keep[-1] = True
    s, t = s[keep], t[keep]
    return TransferFunction(np.column_stack([s, colormap_rgb(name, t, where), rho * t]), where=where)


def default_extinction(mesh: TetMesh) -> float:
    """The top of the default ramp: ``DEFAULT_DEPTH / (c * t)`` with ``c = 4 V / S`` the mesh's mean
    chord length (Cauchy's formula: volume ``V``, boundary area ``S``) and ``t`` the volume-weighted
    mean of the scalars mapped to [0, 1] over their range (at least 0.05), so an average ray through
    the mesh gathers an optical depth of about ``DEFAULT_DEPTH``, in any units and for thin or
    skewed data alike (see the module docstring)."""

    p = np.asarray(mesh.points, np.float64)
    vol = np.abs(signed_volumes(p, mesh.tets))
    tri = p[mesh.boundary_triangles()]
    area = 0.5 * float(np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum())
    total = float(vol.sum())
    if not (np.isfinite(total) and total > 0 and np.isfinite(area) and area > 0):
        raise ConfigError(f"mesh: {mesh.name}: it has no volume; no default extinction")
    lo, hi = scalar_window(mesh)
    t = np.clip((np.asarray(mesh.scalars, np.float64)[mesh.tets].mean(axis=1) - lo) / (hi - lo), 0.0, 1.0)
    mean_t = max(float((t * vol).sum() / total), 0.05)
    return DEFAULT_DEPTH / (4.0 * total / area * mean_t)


def scalar_window(mesh: TetMesh) -> tuple[float, float]:
    """The mesh's point-scalar range; a constant field gets a window around its value (so the
    ramp gives it half the extinction, not none)."""
    lo, hi = mesh.scalar_range
    if hi > lo:
        return lo, hi
    pad = max(abs(lo), 1.0) * 1e-3
    return lo - pad, lo + pad


def default_transfer(mesh: TetMesh, colormap: str | None = None, *, where: str = "transfer") -> TransferFunction:
    """:func:`colormap_transfer` of ``colormap`` (default :data:`DEFAULT_COLORMAP`) over the mesh's
    scalar range with :func:`default_extinction`."""
    return colormap_transfer(DEFAULT_COLORMAP if colormap is None else colormap, scalar_window(mesh),
                             default_extinction(mesh), where=where)


def pixel_size(size: Any, where: str = "size") -> tuple[int, int]:
    """``(width_px, height_px)`` from an int (square) or a pair; ``None`` gives :data:`DEFAULT_SIZE`."""
    if size is None:
        return DEFAULT_SIZE
    if isinstance(size, (int, np.integer)) and not isinstance(size, bool):
        size = (size, size)
    if not (isinstance(size, (tuple, list)) and len(size) == 2):
        raise ConfigError(f"{where}: expected a pixel count or (width_px, height_px), got {size!r}")
    w = check_number(f"{where}[0] (width_px)", size[0], lo=1, integer=True)
    h = check_number(f"{where}[1] (height_px)", size[1], lo=1, integer=True)
    return int(w), int(h)


def default_scene(mesh: TetMesh, colormap: str | None = None, size: Any = None, *, name: str | None = None,
                  source=None) -> Scene:
    """``mesh`` with :func:`default_transfer` and :meth:`Camera.fit` at ``size`` (default 512 x 512)."""
    w, h = pixel_size(size)
    return Scene(mesh=mesh, transfer=default_transfer(mesh, colormap, where="colormap"),
                 camera=Camera.fit(mesh, width_px=w, height_px=h),
                 name=name or short_name(mesh.name), source=source)


def short_name(name: str) -> str:
    from pathlib import PurePath

    return PurePath(name).stem or "mesh" if ("/" in name or "." in name) else (name or "mesh")
