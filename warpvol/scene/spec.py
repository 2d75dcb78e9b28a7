"""A scene named by a string or path: ``builtin:NAME``, a scene ``.toml`` file or a mesh file, the last
with the defaults of :mod:`warpvol.scene.defaults` (kept apart from that module, which the scene-file
reader uses for a file without ``[transfer]`` or ``[camera]``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from warpvol.errors import ConfigError
from warpvol.scene.defaults import default_scene, default_transfer, pixel_size
from warpvol.scene.loaders import read_mesh_file
from warpvol.scene.scene import Scene
from warpvol.scene.scene_file import load_scene


def scene_from_spec(spec: Any, *, scalars: str | None = None, split: int | None = None, colormap: str | None = None,
                    size: Any = None, strict: bool = False, where: str = "scene", step: Any = None, time: Any = None,
                    option_prefix: str = "") -> Scene:
    """A scene named by a string or path: ``"builtin:NAME"``, a scene ``.toml`` file (Contract 1), or
    any other file a mesh pyvista reads (``.vtu``, ``.vtk``, ...), which gets :func:`default_scene`.
    ``colormap`` replaces the transfer function by :func:`default_transfer` in that colour map;
    ``size`` (pixels or ``(width_px, height_px)``) replaces the image size; ``scalars``,
    ``split``, and ``step`` or ``time`` (the step of a time series such as a ``.pvd``) apply to a mesh
    file; messages name them with ``option_prefix`` (the command line's ``--``: ``--scalars``).

    Examples
    --------
    >>> s = scene_from_spec("builtin:linear_box", size=8, colormap="Cool to Warm")
    >>> s.name, (s.camera.width_px, s.camera.height_px), s.transfer.srange == s.mesh.scalar_range
    ('linear_box', (8, 8), True)
    """
    if not isinstance(spec, (str, Path)) or str(spec) == "":
        raise ConfigError(f"{where}: expected 'builtin:NAME', a scene .toml file or a mesh file, got {spec!r}")
    p = Path(spec)
    is_mesh_file = not (isinstance(spec, str) and spec.startswith("builtin:")) and p.suffix.lower() != ".toml"
    if not is_mesh_file:
        given = [k for k, v in (("scalars", scalars), ("split", split), ("step", step), ("time", time)) if v is not None]
        if given:
            names = "/".join(option_prefix + k for k in given)
            raise ConfigError(f"{names}: only used with a mesh file; {str(spec)!r} is a scene (its [mesh] table "
                              f"takes {', '.join(given)})")
        scene = load_scene(spec, strict=strict)
        if colormap is not None:
            scene = Scene(mesh=scene.mesh, transfer=default_transfer(scene.mesh, colormap, where="colormap"),
                          camera=scene.camera, name=scene.name, source=scene.source)
        if size is not None:
            w, h = pixel_size(size)
            scene = scene.with_camera(width_px=w, height_px=h)
        return scene
    if not p.is_file():
        raise ConfigError(f"{where}: file not found: {p} (expected 'builtin:NAME', a scene .toml file or a mesh "
                          "file pyvista reads)")
    mesh = read_mesh_file(p, scalars, strict=strict, where="mesh file", split=split, active_scalars=True,
                          step=step, time=time, option_prefix=option_prefix)
    return default_scene(mesh, colormap, size, name=p.stem, source=p)
