"""Scenes: mesh + transfer function + camera, read from a TOML scene file (Contract 1).

Top-level keys: ``[mesh]`` (required, see :func:`warpvol.loaders.load_mesh`), ``[transfer]``
(:meth:`TransferFunction.from_config`), ``[camera]`` (:meth:`Camera.from_config`) and ``name``.
``[transfer]`` takes ``points``, ``table`` or a ParaView preset, ``paraview = "preset.json"`` or
``paraview = { file = "preset.json", name = "...", range = [smin, smax], unit_distance = 1.0 }``
(see :meth:`TransferFunction.from_paraview`; an addition to Contract 1, older files read as before).
With ``[mesh] builtin = "NAME"``, ``[transfer]`` and ``[camera]`` may be omitted and the built-in
scene's defaults are used; a ``[camera]`` that is given replaces the default camera entirely (keys
it leaves out take :class:`Camera`'s defaults, not the built-in's).

Errors name the scene file and the key, e.g. ``scene.toml: camera.fov_y_deg: 200.0 is outside the
allowed range (0, 180)``.
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .camera import Camera
from .errors import ConfigError, check_keys
from .loaders import load_mesh
from .mesh import TetMesh
from .transfer import TransferFunction

SCENE_KEYS = ("mesh", "transfer", "camera", "name")


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
    >>> from warpvol.builtin import builtin_scene
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


def scene_from_config(cfg: dict, base_dir: Path | str = ".", where: str = "scene", *, strict: bool = False,
                      name: str | None = None, source: Path | None = None) -> Scene:
    """Build a :class:`Scene` from a parsed scene table. ``where`` prefixes error messages; relative
    file names are relative to ``base_dir``; ``name`` is the fallback when ``cfg`` has no ``name``."""
    if not isinstance(cfg, dict):
        raise ConfigError(f"{where}: expected a table, got {cfg!r}")
    check_keys(where, cfg, SCENE_KEYS)
    if "mesh" not in cfg:
        raise ConfigError(f"{where}: missing [mesh] table")
    mesh_cfg = cfg["mesh"]
    mesh = load_mesh(mesh_cfg, base_dir, where=f"{where}: mesh", strict=strict)

    builtin = mesh_cfg.get("builtin") if isinstance(mesh_cfg, dict) else None
    if "transfer" in cfg:
        tf = TransferFunction.from_config(cfg["transfer"], base_dir, where=f"{where}: transfer")
    elif builtin is not None:
        from .builtin import builtin_transfer

        tf = builtin_transfer(builtin)
    else:
        raise ConfigError(f"{where}: missing [transfer] table (only built-in meshes have a default)")
    if "camera" in cfg:
        cam = Camera.from_config(cfg["camera"], where=f"{where}: camera")
    elif builtin is not None:
        from .builtin import builtin_camera

        cam = builtin_camera(builtin)
    else:
        raise ConfigError(f"{where}: missing [camera] table (only built-in meshes have a default)")

    scene_name = cfg.get("name", name if name is not None else (builtin or "scene"))
    if not isinstance(scene_name, str) or not scene_name:
        raise ConfigError(f"{where}: name: expected a non-empty string, got {scene_name!r}")
    return Scene(mesh=mesh, transfer=tf, camera=cam, name=scene_name, source=source)


def load_scene(path: Path | str, *, strict: bool = False) -> Scene:
    r"""Read a TOML scene file (Contract 1), or a built-in scene given as ``"builtin:NAME"``.

    Parameters
    ----------
    path : str or pathlib.Path
        The scene file; relative file names inside it are relative to its folder.
    strict : bool
        Zero-volume tets are an error instead of being dropped with a warning.

    Returns
    -------
    Scene

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "box.toml"
    >>> _ = f.write_text('[mesh]\nbuiltin = "box"\n[camera]\nwidth_px = 32\nheight_px = 16\n')
    >>> s = load_scene(f)
    >>> s.name, s.mesh.n_tets, (s.camera.width_px, s.camera.height_px)
    ('box', 384, (32, 16))
    >>> load_scene("builtin:sphere").mesh.n_tets
    2560
    """
    if isinstance(path, str) and path.startswith("builtin:"):
        from .builtin import builtin_scene

        return builtin_scene(path.split(":", 1)[1])
    if not isinstance(path, (str, Path)):
        raise ConfigError(f"path: expected a scene file name, got {type(path).__name__}")
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"scene file not found: {p}")
    try:
        with open(p, "rb") as fh:
            cfg = tomllib.load(fh)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{p}: TOML syntax error: {e}") from None
    except UnicodeDecodeError as e:
        raise ConfigError(f"{p}: not a UTF-8 text file: {e}") from None
    return scene_from_config(cfg, p.parent, where=str(p), strict=strict, name=p.stem, source=p)
