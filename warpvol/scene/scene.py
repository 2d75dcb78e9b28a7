"""A renderable scene: mesh + transfer function + camera (read from files by :mod:`.scene_file`)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from warpvol.errors import ConfigError
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import TransferFunction


@dataclass
class Scene:
    """A renderable scene.

    Attributes
    ----------
    mesh : TetMesh
    transfer : TransferFunction
    camera : Camera
    name : str
        Short name (scene file stem, built-in name or the ``name`` key).
    source : pathlib.Path or None
        The scene file it was read from (``None`` for built-ins and dict input).

    Examples
    --------
    >>> from warpvol.scene.builtin import builtin_scene
    >>> s = builtin_scene("box").with_camera(width_px=16, height_px=8)
    >>> s.camera.width_px, s.camera.height_px, s.mesh.n_tets
    (16, 8, 384)
    """

    mesh: TetMesh
    transfer: TransferFunction
    camera: Camera
    name: str
    source: Path | None = None

    def __post_init__(self):
        for field_name, kind in (("mesh", TetMesh), ("transfer", TransferFunction), ("camera", Camera)):
            value = getattr(self, field_name)
            if not isinstance(value, kind):
                raise ConfigError(f"Scene: {field_name}: expected a {kind.__name__}, got {type(value).__name__} "
                                  "(warpvol.render converts pyvista meshes, presets and plotters)")
        if not isinstance(self.name, str) or not self.name:
            raise ConfigError(f"Scene: name: expected a non-empty string, got {self.name!r}")

    def with_camera(self, **overrides: Any) -> "Scene":
        """A copy whose camera has the given fields replaced (e.g. ``width_px=64``)."""
        return dataclasses.replace(self, camera=self.camera.replace(**overrides))

    def __repr__(self) -> str:
        return (f"Scene({self.name!r}, {self.mesh!r}, {self.transfer!r}, {self.camera.projection} camera "
                f"{self.camera.width_px}x{self.camera.height_px})")
