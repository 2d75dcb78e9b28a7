"""The command line's checks of what a user gives it, made before any costly work (:mod:`warpvol.cli`).

* flags: pixel counts (:func:`check_sizes`), the Dask options (:func:`check_bands`);
* outputs: extensions, folders that exist and are writable, no two outputs on one file
  (:func:`check_outputs`, :func:`output_folder`);
* inputs: the files a scene and the pipeline files read (:func:`scene_inputs`, :func:`pipeline_inputs`,
  checked by :func:`warpvol.io.check_inputs` against the outputs);
* memory: an image too large to index or to hold is refused up front (:func:`check_image_memory`), and a
  ``MemoryError`` is reported naming the image or the mesh (:func:`out_of_memory`). Both are given the
  bytes of memory available (the command line's probe), so that they stay plain functions of their
  arguments.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from warpvol.errors import ConfigError, check_number


def check_sizes(args) -> None:
    """``--width`` / ``--height`` / ``--size`` are pixel counts >= 1 (0 is an error, not "unset")."""
    for flag in ("width", "height", "size"):
        v = getattr(args, flag, None)
        if v is not None:
            check_number(f"--{flag}", v, lo=1, integer=True)


def check_bands(args) -> None:
    """``--scheduler`` / ``--bands`` / ``--workers``, checked before any work."""
    if args.scheduler is None:
        for flag, v in (("--bands", args.bands), ("--workers", args.workers)):
            if v is not None:
                raise ConfigError(f"{flag}: only used with --scheduler")
        return
    if args.scheduler != "local" and "://" not in args.scheduler:
        raise ConfigError(f"--scheduler: expected 'local' or a Dask scheduler address such as tcp://HOST:8786, "
                          f"got {args.scheduler!r}")
    if args.bands is not None and args.bands < 1:
        raise ConfigError(f"--bands: expected an integer >= 1, got {args.bands}")
    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers: expected an integer >= 1, got {args.workers}")


#: output flag -> allowed file extensions
OUTPUT_EXTENSIONS = {"-o": (".exr",), "--report": (".json",), "--png": (".png",), "--error-image": (".png",),
                     "--deep": (".exr",)}

#: ``-o`` of render and reference: an OpenEXR image, or the 8-bit PNG preview as the image
IMAGE_OUTPUT = {"-o": (".exr", ".png")}


def check_outputs(outputs: dict[str, str | None], extensions: dict[str, tuple] | None = None) -> dict[str, Path]:
    """Check every output path before any work is done: extension supported (:data:`OUTPUT_EXTENSIONS`,
    or ``extensions`` for a flag), not a folder, folder exists and is writable, no two outputs on the
    same file. Returns flag -> path for those given."""
    given = {flag: g for flag, g in outputs.items() if g is not None}  # messages show them as typed
    seen: dict[str, str] = {}
    for flag, g in given.items():
        key = os.path.realpath(g)
        if key in seen:
            raise ConfigError(f"{flag}: {g} is also the {seen[key]} output; give each output its own file")
        seen[key] = flag
    for flag, g in given.items():
        p, exts = Path(g), (extensions or {}).get(flag, OUTPUT_EXTENSIONS[flag])
        if p.suffix.lower() not in exts:
            raise ConfigError(f"{flag}: {g}: unsupported file extension {p.suffix or '(none)'!r}; "
                              f"expected {' or '.join(exts)}")
        if p.is_dir():
            raise ConfigError(f"{flag}: {g} is a folder; expected a file name")
        if not p.parent.is_dir():
            raise ConfigError(f"{flag}: output folder does not exist: {p.parent}")
        check_writable(flag, p.parent)
    return {flag: Path(g) for flag, g in given.items()}


def check_writable(flag: str, folder: Path) -> None:
    """Refuse a folder this process cannot create a file in."""
    # creating a file is the only reliable test (permissions, ACLs, read-only mounts, root)
    try:
        fd, probe = tempfile.mkstemp(prefix=".warpvol-probe.", dir=folder)
    except OSError as e:
        raise ConfigError(f"{flag}: cannot write into folder {folder}: {e.strerror or e}") from None
    os.close(fd)
    os.unlink(probe)


def folder_outputs(outdir: Path, rels: list[str]) -> dict[str, Path]:
    """The files ``rels`` of an output folder as outputs for :func:`warpvol.io.check_inputs`."""
    return {f"-o ({r})": outdir / r for r in rels}


def output_folder(path: str, flag: str = "-o") -> Path:
    """An output folder: created if missing, refused if a file (or under one), checked writable."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ConfigError(f"{flag}: {p} exists and is not a folder; give a folder (created if missing)")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as e:  # a file on the way (FileExistsError, NotADirectoryError), permissions
        raise ConfigError(f"{flag}: cannot create the folder {p}: {e.strerror or e}"
                          + (" (a file of that name is on its path)" if isinstance(e, (FileExistsError,
                                                                                     NotADirectoryError)) else "")
                          ) from None
    check_writable(flag, p)
    return p


def scene_inputs(spec: str) -> list[tuple[Path, str]]:
    """The files a scene reads (:func:`warpvol.scene.scene_file.scene_files`); ``[]`` for a built-in, and for a
    scene file that cannot be read (loading it then says why)."""
    from warpvol.scene.scene_file import scene_files

    if spec.startswith("builtin:"):
        return []
    try:
        return scene_files(spec)
    except ConfigError:
        return []


def pipeline_inputs(names) -> list[tuple[Path, str]]:
    """The pipeline files among preset names and files."""
    from warpvol.pipeline import _preset_files

    presets = _preset_files()
    names = [names] if isinstance(names, (str, Path)) else list(names or [])
    return [(Path(n), "pipeline file") for n in map(str, names) if n not in presets and Path(n).is_file()]


#: conservative bytes per pixel of one render's buffers (measured on `raycast`, 4096^2: ray state and
#: image 44 B/px, + PNG preview 77 B/px; error metrics hold ~4 float64 RGBA images at their peak)
BYTES_PER_PIXEL = {"render": 64, "png": 128, "reference": 192, "error_image": 160}
#: Warp launches index pixels with int32
MAX_PIXELS = 2**31 - 1


def check_image_memory(camera, parts: list[str], have: int | None, flag: str = "--width/--height") -> None:
    """Refuse an image too large to index or to hold in the ``have`` bytes of memory available (``None``:
    not known), before any work on it; ``parts`` are the keys of :data:`BYTES_PER_PIXEL` the run needs."""
    w, h = camera.width_px, camera.height_px
    n = w * h
    if n > MAX_PIXELS:
        raise ConfigError(f"{flag}: {w}x{h} = {n} pixels; at most {MAX_PIXELS} (int32 pixel indices)")
    need = n * sum(BYTES_PER_PIXEL[p] for p in parts)
    if have is not None and need > have:
        raise ConfigError(f"{flag}: a {w}x{h} image needs about {_size(need)} for this run "
                          f"({need // n} bytes per pixel), more than the {_size(have)} of memory "
                          "available; render a smaller image")


def out_of_memory(scene, parts: list[str], what: str, have: int | None) -> ConfigError:
    """The error for a ``MemoryError`` raised by ``what`` (e.g. "rendering with raycast") on ``scene``:
    names the image when its buffers are a large share of the ``have`` bytes of memory there are, else the mesh."""
    cam, m = scene.camera, scene.mesh
    w, h = cam.width_px, cam.height_px
    need = w * h * sum(BYTES_PER_PIXEL[p] for p in parts)
    image = f"a {w}x{h} image (about {_size(need)})"
    mesh = f"the mesh of {scene.name} ({m.n_tets:,} tets, {m.n_points:,} points)"
    if have is not None and need > have // 4:
        return ConfigError(f"out of memory {what}: {image} with {mesh} does not fit in the {_size(have)} available; "
                           "render a smaller image (--width/--height)")
    return ConfigError(f"out of memory {what}: {mesh} and the buffers built from it do not fit in the memory "
                       f"available{'' if have is None else f' ({_size(have)})'}; {image} is not the problem: "
                       "use a smaller or subsampled mesh")


def _size(nbytes: int) -> str:
    return f"{nbytes / 2**30:.1f} GiB" if nbytes >= 2**30 else f"{nbytes / 2**20:.0f} MiB"


def load_scene(spec: str, args) -> "object":
    """The scene of ``SCENE`` (a scene file, ``builtin:NAME`` or a mesh file), with the options of ``args``
    (``--scalars``, ``--colormap``, ``--strict``, ``--step``, ``--time``) and ``--width`` / ``--height`` applied."""
    from warpvol.scene.spec import scene_from_spec

    try:
        scene = scene_from_spec(spec, scalars=getattr(args, "scalars", None), colormap=getattr(args, "colormap", None),
                                strict=getattr(args, "strict", False), where="scene",
                                step=getattr(args, "step", None), time=getattr(args, "time", None), option_prefix="--")
    except MemoryError:
        if not spec.startswith("builtin:"):
            raise
        raise ConfigError(f"{spec}: the built-in mesh does not fit in the memory available") from None
    over = {}
    if getattr(args, "width", None) is not None:
        over["width_px"] = args.width
    if getattr(args, "height", None) is not None:
        over["height_px"] = args.height
    if over:
        scene.camera = scene.camera.replace(**over)
    return scene
