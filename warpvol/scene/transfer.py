"""Piecewise-linear transfer functions (Contract 1, ``[transfer]``).

A transfer function maps a scalar ``s`` to colour ``c(s) = (r, g, b)`` and extinction ``rho(s)``
(per world unit of length). Values are linear between control points and clamped to the end values
outside them. Two emission models are supported:

=====================  ==========================================================
``color_extinction``   radiance ``C = int c(s) rho(s) T dt``  (Guthe, Moreland & Angel, VTK)
``emission_density``   radiance ``C = int c(s) T dt``         (Roettger & Ertl eq. 2, kappa = c)
=====================  ==========================================================
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from warpvol.errors import ConfigError, check_choice, check_keys, check_number

EMISSION_MODELS = ("color_extinction", "emission_density")

#: VTK/ParaView opacity above this is taken as this when converted to extinction (an opacity of 1
#: would be an infinite extinction): ``rho <= -ln(1e-6) / unit_distance = 13.8 / unit_distance``
OPACITY_MAX = 1.0 - 1e-6
#: ParaView preset ``ColorSpace`` -> vtkColorTransferFunction setter suffix
PARAVIEW_COLOR_SPACES = {"RGB": "RGB", "HSV": "HSV", "Lab": "Lab", "Lab/CIEDE2000": "LabCIEDE2000",
                         "Diverging": "Diverging", "Step": "Step", "Prolab": "Prolab"}
#: samples taken of a colour/opacity function that is not piecewise-linear RGB (see from_vtk)
DEFAULT_RESAMPLE = 256


def opacity_to_extinction(opacity: Any, unit_distance: float) -> np.ndarray:
    """VTK scalar opacity per ``unit_distance`` -> extinction per unit length.

    ``rho = -ln(1 - a) / unit_distance`` (so ``1 - exp(-rho d)`` is VTK's opacity of a segment of
    length ``d = unit_distance``); ``a`` above :data:`OPACITY_MAX` is taken as ``OPACITY_MAX``.

    Examples
    --------
    >>> opacity_to_extinction([0.0, 1 - np.exp(-2.0)], 0.5).round(12).tolist()
    [0.0, 4.0]
    """
    a = np.minimum(np.asarray(opacity, dtype=np.float64), OPACITY_MAX)
    return -np.log1p(-a) / float(unit_distance)


def extinction_to_opacity(extinction: Any, unit_distance: float) -> np.ndarray:
    """Inverse of :func:`opacity_to_extinction`: ``a = 1 - exp(-rho d)``; extinctions at or above
    the cap of :data:`OPACITY_MAX` map to opacity 1."""
    tau = np.asarray(extinction, dtype=np.float64) * float(unit_distance)
    cap = -np.log1p(-OPACITY_MAX)
    return np.where(tau >= cap * (1.0 - 1e-12), 1.0, -np.expm1(-tau))


#: the keys of a scene file's ``[transfer]`` table, its ``table`` and its ``paraview`` table
TRANSFER_KEYS = ("emission", "points", "table", "paraview")
TRANSFER_TABLE_KEYS = ("file", "range")
TRANSFER_PARAVIEW_KEYS = ("file", "name", "range", "unit_distance", "opacity")


class TransferFunction:
    """Piecewise-linear transfer function.

    Parameters
    ----------
    points : array_like, shape (K, 5)
        Rows ``[s, r, g, b, extinction]``, ``s`` strictly ascending, ``K >= 2``, extinction finite
        and non-negative.
    emission : str
        ``"color_extinction"`` or ``"emission_density"``.
    where : str
        Name used in error messages (e.g. the scene file and key).

    Examples
    --------
    >>> tf = TransferFunction([[0, 0, 0, 0, 0], [1, 1, 0.5, 0.2, 2.0]])
    >>> tf.evaluate(0.5).round(3).tolist()
    [0.5, 0.25, 0.1, 1.0]
    """

    def __init__(self, points: Any, emission: str = "color_extinction", where: str = "transfer"):
        self.where = where
        self.emission = check_choice(f"{where}.emission", emission, EMISSION_MODELS)
        try:
            pts = np.array(points, dtype=np.float64)
        except (TypeError, ValueError):
            raise ConfigError(f"{where}.points: expected rows of 5 numbers [s, r, g, b, extinction]") from None
        if pts.ndim != 2 or pts.shape[1] != 5:
            raise ConfigError(
                f"{where}.points: expected rows of 5 numbers [s, r, g, b, extinction], got shape {pts.shape}"
            )
        if pts.shape[0] < 2:
            raise ConfigError(f"{where}.points: need at least 2 control points, got {pts.shape[0]}")
        if not np.isfinite(pts).all():
            r = int(np.argwhere(~np.isfinite(pts))[0][0])
            raise ConfigError(f"{where}.points[{r}]: non-finite value in {pts[r].tolist()}")
        d = np.diff(pts[:, 0])
        if (d <= 0).any():
            k = int(np.argmax(d <= 0))
            raise ConfigError(
                f"{where}.points: s must be strictly ascending; points[{k}].s = {float(pts[k, 0])!r} "
                f">= points[{k + 1}].s = {float(pts[k + 1, 0])!r}"
            )
        if (pts[:, 4] < 0).any():
            k = int(np.argmax(pts[:, 4] < 0))
            raise ConfigError(f"{where}.points[{k}]: extinction {float(pts[k, 4])!r} is negative; expected >= 0")
        if (pts[:, 1:4] < 0).any():
            k = int(np.argmax((pts[:, 1:4] < 0).any(axis=1)))
            raise ConfigError(f"{where}.points[{k}]: colour {pts[k, 1:4].tolist()} has a negative channel")
        self.points = pts
        self.points.setflags(write=False)

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def from_table(cls, values: Any, srange: tuple[float, float], emission: str = "color_extinction",
                   where: str = "transfer.table") -> "TransferFunction":
        """``m`` uniformly spaced entries ``[r, g, b, extinction]`` over ``srange`` (ends included)."""
        v = np.asarray(values, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != 4:
            raise ConfigError(f"{where}: expected m rows of [r, g, b, extinction], got shape {v.shape}")
        lo, hi = (float(x) for x in srange)
        if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
            raise ConfigError(f"{where}.range: expected [smin, smax] with smin < smax, got {list(srange)}")
        s = np.linspace(lo, hi, v.shape[0])
        return cls(np.column_stack([s, v]), emission, where=where)

    @classmethod
    def from_config(cls, cfg: dict, base_dir: Path | str = ".", where: str = "transfer") -> "TransferFunction":
        """Build from the ``[transfer]`` table of a scene file (Contract 1): exactly one of
        ``points``, ``table`` or ``paraview`` (a preset file name, or ``{ file, name, range,
        unit_distance, opacity }`` as in :meth:`from_paraview`)."""
        if not isinstance(cfg, dict):
            raise ConfigError(f"{where}: expected a table")
        check_keys(where, cfg, TRANSFER_KEYS)
        emission = cfg.get("emission", "color_extinction")
        if sum(k in cfg for k in ("points", "table", "paraview")) != 1:
            raise ConfigError(f"{where}: give exactly one of 'points', 'table' or 'paraview'")
        if "points" in cfg:
            return cls(cfg["points"], emission, where=where)
        if "paraview" in cfg:
            return cls._from_paraview_config(cfg["paraview"], emission, base_dir, f"{where}.paraview")
        tab = cfg["table"]
        if not isinstance(tab, dict):
            raise ConfigError(f"{where}.table: expected {{ file = ..., range = [smin, smax] }}")
        check_keys(f"{where}.table", tab, TRANSFER_TABLE_KEYS)
        if "file" not in tab or "range" not in tab:
            raise ConfigError(f"{where}.table: needs both 'file' and 'range'")
        path = Path(base_dir) / tab["file"]
        if not path.is_file():
            raise ConfigError(f"{where}.table.file: file not found: {path}")
        try:
            data = np.loadtxt(path, delimiter="," if path.suffix == ".csv" else None, ndmin=2, comments="#")
        except ValueError as e:
            raise ConfigError(f"{where}.table.file: cannot parse {path}: {e}") from None
        rng = tab["range"]
        if not (isinstance(rng, (list, tuple)) and len(rng) == 2):
            raise ConfigError(f"{where}.table.range: expected [smin, smax], got {rng!r}")
        if data.shape[1] == 5:  # s column present: ignore it but require it to be uniform over range
            s = data[:, 0]
            if not np.allclose(s, np.linspace(rng[0], rng[1], len(s)), rtol=0, atol=1e-6 * (rng[1] - rng[0])):
                raise ConfigError(f"{where}.table.file: the s column of {path} is not uniform over range {rng}")
            data = data[:, 1:]
        return cls.from_table(data, rng, emission, where=f"{where}.table")

    @classmethod
    def _from_paraview_config(cls, pv_cfg: Any, emission: str, base_dir: Path | str, where: str):
        """``paraview = "preset.json"`` or ``paraview = { file = ..., name = ..., range = [a, b],
        unit_distance = d, opacity = a }`` (keys as in :meth:`from_paraview`)."""
        if emission != "color_extinction":
            raise ConfigError(f"{where}: a ParaView preset gives the 'color_extinction' model; "
                              f"emission = {emission!r} does not apply")
        if isinstance(pv_cfg, str):
            pv_cfg = {"file": pv_cfg}
        if not isinstance(pv_cfg, dict):
            raise ConfigError(f"{where}: expected a file name or {{ file = ..., name = ..., range = [smin, smax], "
                              f"unit_distance = ... }}, got {pv_cfg!r}")
        check_keys(where, pv_cfg, TRANSFER_PARAVIEW_KEYS)
        if not isinstance(pv_cfg.get("file"), str) or not pv_cfg["file"]:
            raise ConfigError(f"{where}.file: expected a file name, got {pv_cfg.get('file')!r}")
        path = Path(base_dir) / Path(pv_cfg["file"]).expanduser()
        if not path.is_file():
            raise ConfigError(f"{where}.file: file not found: {path}")
        kw = {k: pv_cfg[k] for k in ("name", "range", "unit_distance", "opacity") if k in pv_cfg}
        return cls.from_paraview(path, where=where, **kw)

    # -- VTK and ParaView ---------------------------------------------------------------------
    @classmethod
    def from_vtk(cls, color: Any, opacity: Any, *, unit_distance: float = 1.0, resample: int | None = None,
                 where: str = "transfer") -> "TransferFunction":
        """From a ``vtkColorTransferFunction`` and a scalar-opacity ``vtkPiecewiseFunction``.

        Conversion (VTK's volume property, ``color_extinction`` model): VTK's opacity ``a(s)`` is
        the opacity of a segment of length ``unit_distance`` (``ScalarOpacityUnitDistance``), so the
        extinction per unit length is ``rho(s) = -ln(1 - a(s)) / unit_distance`` (``a`` capped at
        ``1 - 1e-6``: ``rho <= 13.8 / unit_distance``). The colour is ``c(s)``.

        Control points are the union of both functions' nodes, each function evaluated there.
        Between control points warpvol interpolates *extinction* linearly and VTK *opacity*; the
        two agree at the nodes and wherever the opacity is constant or zero. A function that is not
        piecewise-linear RGB (another colour space, a node midpoint other than 0.5 or a sharpness
        other than 0) is sampled with VTK at ``resample`` uniform points (default 256) plus its
        nodes; ``resample`` given also samples linear functions (closer to VTK's opacity curve).

        Parameters
        ----------
        color : vtkColorTransferFunction
        opacity : vtkPiecewiseFunction
        unit_distance : float
            VTK's scalar-opacity unit distance, world units, > 0.
        resample : int, optional
            Uniform samples of each function (>= 2).

        Examples
        --------
        >>> from vtkmodules.vtkRenderingCore import vtkColorTransferFunction
        >>> from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
        >>> c, o = vtkColorTransferFunction(), vtkPiecewiseFunction()
        >>> nodes = c.AddRGBPoint(0, 1, 0, 0), c.AddRGBPoint(2, 0, 0, 1), o.AddPoint(0, 0.0), o.AddPoint(2, 0.5)
        >>> TransferFunction.from_vtk(c, o, unit_distance=0.5).points.round(4).tolist()
        [[0.0, 1.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 1.0, 1.3863]]
        """
        from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
        from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

        if not isinstance(color, vtkColorTransferFunction):
            raise ConfigError(f"{where}: color: expected a vtkColorTransferFunction, got {type(color).__name__}")
        if not isinstance(opacity, vtkPiecewiseFunction):
            raise ConfigError(f"{where}: opacity: expected a vtkPiecewiseFunction, got {type(opacity).__name__}")
        d = check_number(f"{where}: unit_distance", unit_distance, lo=0, lo_open=True)
        if resample is not None:
            resample = int(check_number(f"{where}: resample", resample, lo=2, integer=True))
        cn = _vtk_nodes(color, 6, f"{where}: color")
        on = _vtk_nodes(opacity, 4, f"{where}: opacity")
        if np.any(on[:, 1] < 0) or np.any(on[:, 1] > 1):
            raise ConfigError(f"{where}: opacity: values must lie in [0, 1], got {on[:, 1].tolist()}")
        c_linear = color.GetColorSpace() == 0 and _linear_nodes(cn[:, 4:6])  # 0: VTK_CTF_RGB
        c_s, c_v = _function_samples(cn[:, 0], cn[:, 1:4], lambda x: color.GetColor(x), c_linear, resample)
        o_s, o_v = _function_samples(on[:, 0], on[:, 1:2], lambda x: (opacity.GetValue(x),),
                                     _linear_nodes(on[:, 2:4]), resample)
        s = np.union1d(c_s, o_s)
        rgb = np.column_stack([np.interp(s, c_s, c_v[:, k]) for k in range(3)])
        rho = opacity_to_extinction(np.interp(s, o_s, o_v[:, 0]), d)
        return cls(np.column_stack([s, rgb, rho]), "color_extinction", where=where)

    def to_vtk(self, unit_distance: float = 1.0):
        """``(vtkColorTransferFunction, vtkPiecewiseFunction)`` with one node per control point;
        opacity ``a = 1 - exp(-rho * unit_distance)`` (the inverse of :meth:`from_vtk`). Only the
        ``color_extinction`` model has a VTK counterpart.

        Examples
        --------
        >>> c, o = TransferFunction([[0, 1, 0, 0, 0.0], [2, 0, 0, 1, 2.0]]).to_vtk(unit_distance=0.5)
        >>> c.GetColor(1.0), round(o.GetValue(2.0), 6)
        ((0.5, 0.0, 0.5), 0.632121)
        """
        from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
        from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

        self._check_vtk_model()
        d = check_number("unit_distance", unit_distance, lo=0, lo_open=True)
        color, opacity = vtkColorTransferFunction(), vtkPiecewiseFunction()
        color.SetColorSpaceToRGB()
        for (s, r, g, b), a in zip(self.points[:, :4], extinction_to_opacity(self.extinction, d)):
            color.AddRGBPoint(s, r, g, b)
            opacity.AddPoint(s, a)
        return color, opacity

    @classmethod
    def from_paraview(cls, preset: Any, *, name: str | None = None, range: Any = None,
                      unit_distance: float = 1.0, opacity: float | None = None, resample: int | None = None,
                      where: str = "transfer") -> "TransferFunction":
        """From a ParaView colour-map preset (JSON as ParaView exports it: ``RGBPoints`` and the
        opacity ``Points``), converted as in :meth:`from_vtk` (ParaView builds the same VTK
        functions, interpolating colours in the preset's ``ColorSpace``).

        Parameters
        ----------
        preset : str, path, dict or list of dicts
            A ``.json`` file or its parsed content; a file may hold several presets.
        name : str, optional
            Which preset (its ``Name``); needed when there are several.
        range : (float, float), optional
            Rescale the preset's scalar range (that of ``RGBPoints``) to this data range, as
            ParaView does when it applies a preset; the opacity points move with it.
        unit_distance : float
            Scalar-opacity unit distance (ParaView's volume property of the same name).
        opacity : float, optional
            Constant opacity for a preset without opacity ``Points`` (a colour map only).
        resample : int, optional
            See :meth:`from_vtk`.

        Examples
        --------
        >>> p = {"Name": "ramp", "ColorSpace": "RGB", "RGBPoints": [0, 0, 0, 1, 1, 1, 1, 0],
        ...      "Points": [0, 0.0, 0.5, 0.0, 1, 0.5, 0.5, 0.0]}
        >>> tf = TransferFunction.from_paraview(p, range=(10, 20))
        >>> tf.points.round(4).tolist()
        [[10.0, 0.0, 0.0, 1.0, 0.0], [20.0, 1.0, 1.0, 0.0, 0.6931]]
        >>> [round(v, 12) for v in tf.to_paraview()["Points"]]  # back out: x, opacity, midpoint, sharpness
        [10.0, 0.0, 0.5, 0.0, 20.0, 0.5, 0.5, 0.0]
        """
        from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
        from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

        p, w = _select_preset(preset, name, where)
        rgbp = _preset_points(p, "RGBPoints", 4, w)
        if rgbp is None:
            raise ConfigError(f"{w}: RGBPoints: missing (indexed/categorical colour maps are not supported)")
        op = _preset_points(p, "Points", 4, w)
        if op is None:
            if opacity is None:
                raise ConfigError(f"{w}: has no opacity 'Points' (a colour map only); pass opacity=A "
                                  "(a constant opacity per unit_distance) or use a preset with opacity")
            a = check_number(f"{where}: opacity", opacity, lo=0, hi=1)
            op = np.array([[rgbp[0, 0], a, 0.5, 0.0], [rgbp[-1, 0], a, 0.5, 0.0]])
        elif opacity is not None:
            raise ConfigError(f"{where}: opacity: the preset has opacity 'Points'; opacity= is only for presets without")
        if range is not None:
            try:
                lo, hi = (float(x) for x in range)
            except (TypeError, ValueError):
                raise ConfigError(f"{where}: range: expected [smin, smax], got {range!r}") from None
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise ConfigError(f"{where}: range: expected [smin, smax] with smin < smax, got {range!r}")
            x0, x1 = rgbp[0, 0], rgbp[-1, 0]
            if not x1 > x0:
                raise ConfigError(f"{w}: RGBPoints span no range ({x0} .. {x1}); cannot rescale")
            rgbp[:, 0] = lo + (rgbp[:, 0] - x0) * ((hi - lo) / (x1 - x0))
            op[:, 0] = lo + (op[:, 0] - x0) * ((hi - lo) / (x1 - x0))
        space = p.get("ColorSpace", "RGB")
        if space not in PARAVIEW_COLOR_SPACES:
            raise ConfigError(f"{w}: ColorSpace: unknown value {space!r}; allowed: "
                              f"{', '.join(map(repr, PARAVIEW_COLOR_SPACES))}")
        color, opac = vtkColorTransferFunction(), vtkPiecewiseFunction()
        getattr(color, f"SetColorSpaceTo{PARAVIEW_COLOR_SPACES[space]}")()
        color.SetHSVWrap(bool(p.get("HSVWrap", False)))
        for x, r, g, b in rgbp:
            color.AddRGBPoint(x, r, g, b)
        for x, a, mid, sharp in op:
            opac.AddPoint(x, a, mid, sharp)
        return cls.from_vtk(color, opac, unit_distance=unit_distance, resample=resample, where=w)

    def to_paraview(self, path: str | Path | None = None, *, name: str = "warpvol",
                    unit_distance: float = 1.0) -> dict:
        """This transfer function as a ParaView preset (``RGBPoints``, opacity ``Points`` with
        ``a = 1 - exp(-rho * unit_distance)``); with ``path``, also written as a ``.json`` file
        ParaView imports (a list of one preset)."""
        self._check_vtk_model()
        d = check_number("unit_distance", unit_distance, lo=0, lo_open=True)
        a = extinction_to_opacity(self.extinction, d)
        preset = {
            "Name": str(name),
            "ColorSpace": "RGB",
            "RGBPoints": [float(v) for v in self.points[:, :4].ravel()],
            "Points": [float(v) for row in zip(self.s, a) for v in (row[0], row[1], 0.5, 0.0)],
        }
        if path is not None:
            import json

            from warpvol.io import atomic_write_text

            atomic_write_text(path, json.dumps([preset], indent=1) + "\n")
        return preset

    def _check_vtk_model(self) -> None:
        if self.emission != "color_extinction":
            raise ConfigError(f"{self.where}.emission: {self.emission!r} has no VTK/ParaView counterpart; "
                              "VTK's volume model is 'color_extinction'")

    # -- properties ---------------------------------------------------------------------------
    @property
    def s(self) -> np.ndarray:
        return self.points[:, 0]

    @property
    def rgb(self) -> np.ndarray:
        return self.points[:, 1:4]

    @property
    def extinction(self) -> np.ndarray:
        return self.points[:, 4]

    @property
    def srange(self) -> tuple[float, float]:
        return float(self.points[0, 0]), float(self.points[-1, 0])

    @property
    def hash(self) -> str:
        """Content hash (emission model + control points); tables are cached by it."""
        h = hashlib.sha256(self.emission.encode())
        h.update(np.ascontiguousarray(self.points).tobytes())
        return h.hexdigest()[:16]

    def evaluate(self, s: Any) -> np.ndarray:
        """``[r, g, b, extinction]`` at ``s`` (any shape), float64; clamped outside the range."""
        s = np.asarray(s, dtype=np.float64)
        out = np.empty(s.shape + (4,), dtype=np.float64)
        for c in range(4):
            out[..., c] = np.interp(s, self.points[:, 0], self.points[:, c + 1])
        bad = ~np.isfinite(out).all(axis=-1)
        if bad.any():  # np.interp's slope overflows on segments narrower than ~1e-308 (subnormal scalars)
            out[bad] = self._interpolate(s[bad])
        return out

    def _interpolate(self, s: np.ndarray) -> np.ndarray:
        """``evaluate`` through the weight ``(s - s0) / (s1 - s0)`` of each segment, which no segment width
        overflows (float64 subnormal scalars)."""
        xs, v = self.points[:, 0], self.points[:, 1:5]
        k = np.clip(np.searchsorted(xs, s, side="right") - 1, 0, len(xs) - 2)
        w = np.clip((np.clip(s, xs[0], xs[-1]) - xs[k]) / (xs[k + 1] - xs[k]), 0.0, 1.0)[..., None]
        return v[k] * (1.0 - w) + v[k + 1] * w

    def normalise(self, s: Any) -> np.ndarray:
        """Scalar mapped to [0, 1] over the TF range (table coordinate convention), clamped."""
        lo, hi = self.srange
        return np.clip((np.asarray(s, dtype=np.float64) - lo) / (hi - lo), 0.0, 1.0)

    def to_warp(self, device: str, merge: bool = True):
        """Device arrays ``(s: float32[K], values: vec4[K])`` for :func:`warpvol.kernels.tf.tf_eval`:
        the control points with collinear runs merged to within float32 rounding
        (:func:`warpvol.kernels.tf.device_points`), so a densely sampled TF costs what its shape needs;
        ``merge=False``: every control point as given (a pipeline whose work depends on the points, such as
        partial pre-integration's iso-surface splits)."""
        import warp as wp

        from warpvol.kernels.tf import device_points

        p = device_points(self.points) if merge else np.asarray(self.points, dtype=np.float64)
        s = wp.array(p[:, 0].astype(np.float32), dtype=wp.float32, device=device)
        v = wp.array(p[:, 1:5].astype(np.float32), dtype=wp.vec4, device=device)
        return s, v

    def __repr__(self) -> str:
        return f"TransferFunction({len(self.points)} points, {self.emission!r}, range={self.srange})"


# -- helpers for the VTK / ParaView conversions ------------------------------------------------------
def _vtk_nodes(func: Any, width: int, where: str) -> np.ndarray:
    """(K, width) node values of a vtkColorTransferFunction (x r g b mid sharp) or a
    vtkPiecewiseFunction (x a mid sharp)."""
    n = func.GetSize()
    if n < 1:
        raise ConfigError(f"{where}: the VTK function has no nodes")
    if not func.GetClamping():
        raise ConfigError(f"{where}: clamping is off (zero outside the nodes); warpvol clamps to the end values")
    out = np.empty((n, width))
    for i in range(n):
        v = [0.0] * width
        func.GetNodeValue(i, v)
        out[i] = v
    return out


def _linear_nodes(mid_sharp: np.ndarray) -> bool:
    """Whether every interval (the last node's settings are unused) is plain linear."""
    m = mid_sharp[:-1]
    return bool(np.all(m[:, 0] == 0.5) and np.all(m[:, 1] == 0.0))


def _function_samples(x: np.ndarray, values: np.ndarray, evaluate, linear: bool, resample: int | None):
    """Nodes as they are when ``linear`` and no ``resample``; else VTK's values at the nodes plus
    ``resample`` (default :data:`DEFAULT_RESAMPLE`) uniform points over the node range."""
    if linear and resample is None:
        return x, values
    n = DEFAULT_RESAMPLE if resample is None else resample
    xs = np.union1d(x, np.linspace(x[0], x[-1], n)) if x[-1] > x[0] else x
    return xs, np.array([evaluate(float(v)) for v in xs], dtype=np.float64)


def _select_preset(preset: Any, name: str | None, where: str) -> tuple[dict, str]:
    import json

    src = "preset"
    if isinstance(preset, (str, Path)):
        path = Path(preset)
        if not path.is_file():
            raise ConfigError(f"{where}: paraview preset file not found: {path}")
        try:
            preset = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as e:
            raise ConfigError(f"{where}: {path} is not a JSON file: {e}") from None
        src = str(path)
    presets = preset if isinstance(preset, list) else [preset]
    if not presets or not all(isinstance(p, dict) for p in presets):
        raise ConfigError(f"{where}: {src}: expected a ParaView preset (a JSON object) or a list of them")
    names = [p.get("Name") for p in presets]
    if name is not None:
        if name not in names:
            raise ConfigError(f"{where}: name: no preset {name!r} in {src}; available: {names}")
        p = presets[names.index(name)]
    elif len(presets) == 1:
        p = presets[0]
    else:
        raise ConfigError(f"{where}: {src} holds {len(presets)} presets; pass name= one of {names}")
    return p, f"{where}: paraview preset {p.get('Name', '')!r}"


def _preset_points(p: dict, key: str, width: int, where: str) -> np.ndarray | None:
    if key not in p:
        return None
    try:
        v = np.array(p[key], dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: {key}: expected a flat list of numbers") from None
    if v.ndim != 1 or len(v) < width or len(v) % width:
        raise ConfigError(f"{where}: {key}: expected a flat list of {width}-tuples, got {np.shape(p[key])} values")
    if not np.isfinite(v).all():
        raise ConfigError(f"{where}: {key}: non-finite value")
    v = v.reshape(-1, width)
    if (np.diff(v[:, 0]) < 0).any():
        raise ConfigError(f"{where}: {key}: scalar values must be ascending")
    return v
