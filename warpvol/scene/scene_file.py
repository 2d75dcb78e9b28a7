"""Scenes: mesh + transfer function + camera, read from a TOML scene file (Contract 1).

Top-level keys: ``[mesh]`` (required, see :func:`warpvol.scene.loaders.load_mesh`), ``[transfer]``
(:meth:`TransferFunction.from_config`), ``[camera]`` (:meth:`Camera.from_config`) and ``name``.
``[transfer]`` takes ``points``, ``table`` or a ParaView preset, ``paraview = "preset.json"`` or
``paraview = { file = "preset.json", name = "...", range = [smin, smax], unit_distance = 1.0 }``
(see :meth:`TransferFunction.from_paraview`; an addition to Contract 1, older files read as before).
``[transfer]`` and ``[camera]`` may be omitted: with ``[mesh] builtin = "NAME"`` the built-in scene's
are used, with any other mesh the defaults of a mesh given on the command line
(:func:`warpvol.scene.defaults.default_transfer`: viridis over the point scalars with ParaView's opacity
ramp; :meth:`Camera.fit` at 512 x 512; an extension of Contract 1, which shows both tables). A
``[camera]`` that is given replaces the default camera entirely (keys it leaves out take
:class:`Camera`'s defaults, not the built-in's or the fitted one's).

Unknown keys are found in every table before anything is read, and named all in one message, each
with the key it most likely meant (``did you mean 'fov_y_deg'?``).

Errors name the scene file and the key, e.g. ``scene.toml: camera.fov_y_deg: 200.0 is outside the
allowed range (0, 180)``.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from warpvol import io as wio  # (wio.available_memory: the one place a test or a caller replaces it)
from warpvol.errors import ConfigError, unknown_keys
from warpvol.io import toml_nesting
from warpvol.scene import datasets
from warpvol.scene.builtin import builtin_camera, builtin_scene, builtin_transfer
from warpvol.scene.camera import CAMERA_KEYS, Camera
from warpvol.scene.defaults import DEFAULT_SIZE, default_transfer
from warpvol.scene.loaders import MESH_KEYS, PLOT3D_KEYS, RAW_KEYS, _file, check_raw_size, load_mesh, raw_dtype
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TRANSFER_KEYS, TRANSFER_PARAVIEW_KEYS, TRANSFER_TABLE_KEYS, TransferFunction

SCENE_KEYS = ("mesh", "transfer", "camera", "name")
#: the tables of a scene file and the keys each allows (``""``: the top level)
SCENE_TABLES = {"": SCENE_KEYS, "mesh": MESH_KEYS, "mesh.plot3d": PLOT3D_KEYS, "mesh.raw": RAW_KEYS,
                "transfer": TRANSFER_KEYS, "transfer.table": TRANSFER_TABLE_KEYS,
                "transfer.paraview": TRANSFER_PARAVIEW_KEYS, "camera": CAMERA_KEYS}


def check_scene_keys(cfg: dict, where: str = "scene") -> None:
    """Every unknown key of every table of a scene file (:data:`SCENE_TABLES`) in one error, each with
    the key it most likely meant; tables that are not tables are left to the readers, which say so.

    Examples
    --------
    >>> check_scene_keys({"mesh": {"builtin": "box", "scalar": "s"}, "trasnfer": {}, "camera": {"fov": 30}}, "s.toml")
    Traceback (most recent call last):
    ...
    warpvol.errors.ConfigError: s.toml: unknown key(s) 'trasnfer' (did you mean 'transfer'?); allowed: 'mesh', 'transfer', 'camera', 'name'. mesh: unknown key(s) 'scalar' (did you mean 'scalars'?); allowed: 'path', 'plot3d', 'raw', 'builtin', 'scalars', 'strict', 'split', 'step', 'time'. camera: unknown key(s) 'fov' (did you mean 'fov_y_deg'?); allowed: 'projection', 'eye', 'target', 'up', 'fov_y_deg', 'height', 'ortho_height', 'width_px', 'height_px'
    """
    parts = []
    for table, allowed in SCENE_TABLES.items():
        t = cfg
        for k in table.split(".") if table else []:
            t = t.get(k) if isinstance(t, dict) else None
        msg = unknown_keys(t, allowed) if isinstance(t, dict) else None
        if msg:
            parts.append(f"{table}: {msg}" if table else msg)
    if parts:
        raise ConfigError(f"{where}: " + ". ".join(parts))


def scene_from_config(cfg: dict, base_dir: Path | str = ".", where: str = "scene", *, strict: bool = False,
                      name: str | None = None, source: Path | None = None) -> Scene:
    """Build a :class:`Scene` from a parsed scene table. ``where`` prefixes error messages; relative
    file names are relative to ``base_dir``; ``name`` is the fallback when ``cfg`` has no ``name``."""
    if not isinstance(cfg, dict):
        raise ConfigError(f"{where}: expected a table, got {cfg!r}")
    check_scene_keys(cfg, where)
    if "mesh" not in cfg:
        raise ConfigError(f"{where}: missing [mesh] table")
    mesh_cfg = cfg["mesh"]
    mesh = load_mesh(mesh_cfg, base_dir, where=f"{where}: mesh", strict=strict)

    builtin = mesh_cfg.get("builtin") if isinstance(mesh_cfg, dict) else None
    if "transfer" in cfg:
        tf = TransferFunction.from_config(cfg["transfer"], base_dir, where=f"{where}: transfer")
    elif builtin is not None:
        tf = builtin_transfer(builtin)
    else:  # as for a mesh file given on its own: viridis over its scalars, ParaView's opacity ramp
        tf = default_transfer(mesh, where=f"{where}: transfer (default)")
    if "camera" in cfg:
        cam = Camera.from_config(cfg["camera"], where=f"{where}: camera")
    elif builtin is not None:
        cam = builtin_camera(builtin)
    else:  # as for a mesh file given on its own: fitted to the mesh
        cam = Camera.fit(mesh, width_px=DEFAULT_SIZE[0], height_px=DEFAULT_SIZE[1])

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
        return builtin_scene(path.split(":", 1)[1])
    if not isinstance(path, (str, Path)):
        raise ConfigError(f"path: expected a scene file name, got {type(path).__name__}")
    p = Path(path)
    cfg = _read_toml(p)
    _check_mesh_memory(cfg.get("mesh"), p)
    try:
        return scene_from_config(cfg, p.parent, where=str(p), strict=strict, name=p.stem, source=p)
    except MemoryError:
        raise ConfigError(f"{p}: mesh: the mesh it names does not fit in the memory available to warpvol "
                          f"({_mesh_desc(cfg.get('mesh'), p.parent)}); use a smaller or subsampled mesh") from None


def _read_toml(p: Path) -> dict:
    if not p.is_file():
        raise ConfigError(f"scene file not found: {p}")
    try:
        text = p.read_text(encoding="utf-8")
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{p}: TOML syntax error: {e}") from None
    except UnicodeDecodeError as e:
        raise ConfigError(f"{p}: not a UTF-8 text file: {e}") from None
    except RecursionError:
        raise ConfigError(f"{p}: TOML nested too deeply {toml_nesting(text)}, beyond what Python's parser "
                          "handles; a scene file needs at most a few levels") from None


#: bytes per sample of a raw volume once it is a tet mesh: float64 point and scalar, six int64 tets
RAW_BYTES_PER_SAMPLE = 8 * 3 + 8 + 6 * 4 * 8


def _raw_samples(mesh_cfg: Any) -> int | None:
    raw = mesh_cfg.get("raw") if isinstance(mesh_cfg, dict) else None
    if not isinstance(raw, dict) or not isinstance(raw.get("dims"), list) or len(raw["dims"]) != 3:
        return None
    if not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in raw["dims"]):
        return None  # the loader names what is wrong
    return int(raw["dims"][0]) * int(raw["dims"][1]) * int(raw["dims"][2])


def _check_mesh_memory(mesh_cfg: Any, p: Path) -> None:
    """A raw volume whose tet mesh cannot fit in the memory there is is refused before it is read."""

    n = _raw_samples(mesh_cfg)
    if n is not None:  # a file that does not match its dims is that, whatever memory there is
        raw = mesh_cfg["raw"]
        try:
            f, dt = _file(p.parent, raw.get("path"), "path"), raw_dtype(raw.get("dtype"))
        except ConfigError:
            f = None  # the loader names what is wrong
        if f is not None:
            check_raw_size(f, raw["dims"], dt, where=f"{p}: mesh.raw")
    have = wio.available_memory() if n is not None else None
    if n is not None and have is not None and n * RAW_BYTES_PER_SAMPLE > have:
        raise ConfigError(f"{p}: mesh.raw: the volume is too large for the memory available to warpvol "
                          f"({_mesh_desc(mesh_cfg, p.parent).removeprefix('mesh.raw: ')}; {_gib(have)} available); use a smaller or "
                          "subsampled volume")


def _mesh_desc(mesh_cfg: Any, base_dir: Path) -> str:
    """What a ``[mesh]`` table names, for an out-of-memory message: the source and its size."""
    if not isinstance(mesh_cfg, dict):
        return "its [mesh]"
    n = _raw_samples(mesh_cfg)
    if n is not None:
        dims = mesh_cfg["raw"]["dims"]
        return (f"mesh.raw: {' x '.join(map(str, dims))} = {n:,} samples, about {6 * n:,} tets: "
                f"{_gib(n * RAW_BYTES_PER_SAMPLE)} for points, scalars and tets alone")
    files = [f for f, _ in _input_files({"mesh": mesh_cfg}, base_dir)]
    sizes = ", ".join(f"{f} ({_gib(f.stat().st_size)})" for f in files if f.is_file())
    return f"mesh file {sizes}" if sizes else "its [mesh]"


def _gib(nbytes: float) -> str:
    return f"{nbytes / 2**30:.1f} GiB" if nbytes >= 2**30 else f"{nbytes / 2**20:.0f} MiB"


def _input_files(cfg: dict, base_dir: Path) -> list[tuple[Path, str]]:
    """``(file, key)`` for every string value of a parsed scene table that names an existing file
    (relative names against ``base_dir``): the mesh, PLOT3D, raw, transfer table and preset files."""
    out: list[tuple[Path, str]] = []
    stack: list[tuple[str, Any]] = [("", cfg)]
    while stack:  # iterative: a deeply nested value is no recursion
        key, v = stack.pop()
        if isinstance(v, dict):
            stack += [(f"{key}.{k}" if key else str(k), x) for k, x in v.items()]
        elif isinstance(v, list):
            stack += [(f"{key}[{i}]", x) for i, x in enumerate(v)]
        elif isinstance(v, str) and v and "\0" not in v:
            f = Path(v).expanduser()
            f = f if f.is_absolute() else base_dir / f
            try:
                r = datasets.resolve(f)  # a data-set file missing from shared/data: the data cache's copy
                if r is not None:
                    out.append((r, key))
            except (OSError, ConfigError):  # a name too long for the file system is no file; the loader names a
                pass                        # damaged cached copy
    return sorted(out)


def scene_files(path: Path | str) -> list[tuple[Path, str]]:
    """``(file, what)`` for a scene file and every file it names (mesh, transfer function), e.g.
    ``(Path("scene.toml"), "scene file")``, ``(Path("fin.vtu"), "mesh.path in scene.toml")``;
    ``[]`` for ``builtin:NAME``; ``[(path, "mesh file")]`` for a file that is no ``.toml`` (a mesh
    file given as the scene). Read before the scene is loaded, so that outputs can be checked
    against the inputs first."""
    if isinstance(path, str) and path.startswith("builtin:"):
        return []
    p = Path(path)
    if p.suffix.lower() != ".toml":
        return [(p, "mesh file")]
    cfg = _read_toml(p)
    return [(p, "scene file")] + [(f, f"{k} in {p.name}") for f, k in _input_files(cfg, p.parent)]


def scene_digest(spec: str | Path) -> str:
    """SHA-256 (hex) of a scene's inputs as they are on disk: the scene file's bytes and those of
    every file it names (a ``builtin:NAME`` is its name); a changed mesh or transfer function file
    changes it, a scene file moved elsewhere does not."""
    import hashlib

    h = hashlib.sha256()
    if isinstance(spec, str) and spec.startswith("builtin:"):
        h.update(spec.encode())
        return h.hexdigest()
    files = scene_files(spec)
    for k, (f, what) in enumerate(files):
        h.update(f"{k}:{what.split(' in ')[0]}:".encode())
        h.update(file_digest(f).encode())
    return h.hexdigest()


def file_digest(path: Path | str) -> str:
    """SHA-256 (hex) of a file's bytes."""
    import hashlib

    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()
