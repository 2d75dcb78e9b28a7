"""Image and text output: OpenEXR via OpenImageIO, PNG previews, atomic writes.

Every writer goes through a temporary file in the target folder followed by :func:`os.replace`, so a
failed or interrupted run never leaves a partial output file behind.
"""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .errors import ConfigError


def _umask() -> int:
    """The process's umask; read from /proc where possible (``os.umask`` can only be read by setting
    it, which races with other threads creating files)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


@contextmanager
def _atomic_target(path: str | Path):
    path = Path(path)
    if path.parent and not path.parent.exists():
        raise ConfigError(f"output folder does not exist: {path.parent}")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent or ".")
    os.close(fd)
    # mkstemp creates 0600; an output file gets what open() would give it: 0666 less the umask
    os.chmod(tmp, 0o666 & ~_umask())
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    with _atomic_target(path) as tmp:
        Path(tmp).write_text(text)


def _write_oiio(path: str, pixels: np.ndarray, fmt) -> None:
    import OpenImageIO as oiio

    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(path)
    if out is None:
        raise OSError(f"OpenImageIO cannot create {path}: {oiio.geterror()}")
    spec = oiio.ImageSpec(w, h, c, fmt)
    if c == 4:
        spec.channelnames = ("R", "G", "B", "A")
        spec.alpha_channel = 3
    if not out.open(path, spec):
        raise OSError(f"OpenImageIO cannot open {path}: {out.geterror()}")
    ok = out.write_image(pixels)
    out.close()
    if not ok:
        raise OSError(f"OpenImageIO failed writing {path}: {out.geterror()}")


def write_exr(path: str | Path, image: np.ndarray) -> None:
    """Write a float RGBA (H, W, 4) image (row 0 = top) as a float32 OpenEXR file."""
    import OpenImageIO as oiio

    img = np.ascontiguousarray(image, dtype=np.float32)
    if img.ndim != 3 or img.shape[2] not in (1, 3, 4):
        raise ValueError(f"write_exr: expected (H, W, 1|3|4) image, got shape {img.shape}")
    with _atomic_target(path) as tmp:
        _write_oiio(tmp, img, oiio.FLOAT)


def read_exr(path: str | Path) -> np.ndarray:
    """Read an image written by :func:`write_exr` (or any OIIO-readable file) as float32 (H, W, C)."""
    import OpenImageIO as oiio

    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"image file not found: {path}")
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise ConfigError(f"cannot read image {path}: {oiio.geterror()}")
    try:
        data = inp.read_image(oiio.FLOAT)
    finally:
        inp.close()
    return np.asarray(data, dtype=np.float32)


def composite_over(image: np.ndarray, background=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Premultiplied RGBA over an opaque background colour -> RGB."""
    bg = np.asarray(background, dtype=np.float64)
    return image[..., :3] + (1.0 - image[..., 3:4]) * bg


def write_png(path: str | Path, image: np.ndarray, background=(0.0, 0.0, 0.0), exposure: float = 1.0) -> None:
    """8-bit PNG preview: premultiplied RGBA composited over ``background`` (or a grey/RGB image)."""
    import OpenImageIO as oiio

    img = np.asarray(image, dtype=np.float64)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    rgb = composite_over(img, background) if img.shape[2] == 4 else img[..., :3]
    codes = np.clip(np.rint(np.clip(rgb * exposure, 0, 1) * 255.0), 0, 255).astype(np.uint8)
    with _atomic_target(path) as tmp:
        _write_oiio(tmp, np.ascontiguousarray(codes), oiio.UINT8)
