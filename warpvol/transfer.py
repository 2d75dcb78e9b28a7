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

from .errors import ConfigError, check_choice, check_keys

EMISSION_MODELS = ("color_extinction", "emission_density")


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
        """Build from the ``[transfer]`` table of a scene file (Contract 1)."""
        if not isinstance(cfg, dict):
            raise ConfigError(f"{where}: expected a table")
        check_keys(where, cfg, ["emission", "points", "table"])
        emission = cfg.get("emission", "color_extinction")
        if ("points" in cfg) == ("table" in cfg):
            raise ConfigError(f"{where}: give exactly one of 'points' or 'table'")
        if "points" in cfg:
            return cls(cfg["points"], emission, where=where)
        tab = cfg["table"]
        if not isinstance(tab, dict):
            raise ConfigError(f"{where}.table: expected {{ file = ..., range = [smin, smax] }}")
        check_keys(f"{where}.table", tab, ["file", "range"])
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
        return out

    def normalise(self, s: Any) -> np.ndarray:
        """Scalar mapped to [0, 1] over the TF range (table coordinate convention), clamped."""
        lo, hi = self.srange
        return np.clip((np.asarray(s, dtype=np.float64) - lo) / (hi - lo), 0.0, 1.0)

    def to_warp(self, device: str):
        """Device arrays ``(s: float32[K], values: vec4[K])`` for :func:`warpvol.kernels.tf.tf_eval`."""
        import warp as wp

        s = wp.array(self.points[:, 0].astype(np.float32), dtype=wp.float32, device=device)
        v = wp.array(self.points[:, 1:5].astype(np.float32), dtype=wp.vec4, device=device)
        return s, v

    def __repr__(self) -> str:
        return f"TransferFunction({len(self.points)} points, {self.emission!r}, range={self.srange})"
