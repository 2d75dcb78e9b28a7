"""Segments as an OpenEXR deep image (premultiplied RGBA, ``Z``, ``ZBack``) through OpenImageIO.

Each segment of :class:`warpvol.segments.Segments` becomes one volumetric deep sample: ``R, G, B`` its
premultiplied radiance, ``A = 1 - exp(-tau)`` its opacity, ``Z`` and ``ZBack`` its front and back depth.
**Depth convention**: ``Z`` is view-space depth, the distance from the eye along the camera's forward axis
(the distance from the eye plane, not along the pixel's ray), as compositors (Nuke's deep nodes,
OpenEXR's "Interpreting Deep Pixels") read it; an orthographic camera's ray parameter already is that
depth, a perspective ray's is scaled by the cosine of its angle to the forward axis. Samples are stored
front to back, as float32, so flattening the file (OpenImageIO's ``ImageBufAlgo.flatten``, a
compositor, or :func:`read_deep`) gives the image to float32 rounding.

OpenImageIO's Python API fills deep data one value at a time (``DeepData.set_deep_value``): about a
microsecond per value, six values per sample; the writer is therefore called after the image is written
(``warpvol render --deep``), off the render's critical path.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from warpvol.errors import ConfigError
from warpvol.io import Outputs
from warpvol.segments import Segments

CHANNELS = ("R", "G", "B", "A", "Z", "ZBack")


def view_depth_scale(camera) -> np.ndarray:
    """``(H*W,)`` factor from the ray parameter of each pixel's ray to view-space depth (1 for an
    orthographic camera; ``1 / |f + x r + y u|`` for a perspective one, Contract 2's ray)."""
    w, h = int(camera.width_px), int(camera.height_px)
    if camera.projection != "perspective":
        return np.ones(h * w)
    th = np.tan(np.radians(camera.fov_y_deg) / 2.0)
    x = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * th * camera.aspect
    y = (1.0 - 2.0 * (np.arange(h) + 0.5) / h) * th
    return (1.0 / np.sqrt(1.0 + y[:, None] ** 2 + x[None, :] ** 2)).ravel()


def write_deep(path: str | Path, segs: Segments, camera, stats: dict | None = None) -> None:
    """Write ``segs`` (of ``camera``'s image) as a deep OpenEXR file at ``path`` (written to a temporary
    file beside it and renamed: nothing is left at ``path`` if it fails). ``stats`` gets ``samples`` and
    ``seconds`` (the fill, sample by sample, and the write)."""
    import OpenImageIO as oiio


    t0 = time.perf_counter()
    h, w = segs.shape
    if (h, w) != (int(camera.height_px), int(camera.width_px)):
        raise ConfigError(f"--deep: segments of a {h}x{w} image, camera of {camera.height_px}x{camera.width_px}")
    scale = view_depth_scale(camera)
    pix = segs.pixels()
    vals = np.empty((len(segs), 6), dtype=np.float32)
    vals[:, :3] = segs.rgb
    vals[:, 3] = -np.expm1(-segs.tau)
    vals[:, 4] = segs.front * scale[pix]
    vals[:, 5] = segs.back * scale[pix]
    if not np.isfinite(vals).all():
        raise ConfigError(f"--deep: a segment's value is not finite in float32 (depth or colour beyond 3.4e38); "
                          f"{path} not written")
    counts = segs.counts()
    spec = oiio.ImageSpec(w, h, 6, oiio.FLOAT)
    spec.channelnames = CHANNELS
    spec.alpha_channel = 3
    spec.z_channel = 4
    spec.deep = True
    spec.attribute("compression", "zips")

    def write(tmp: str, shown: Path) -> None:
        dd = oiio.DeepData()
        dd.init(spec)
        for p in np.flatnonzero(counts):  # the Python API fills one value at a time
            n = int(counts[p])
            p = int(p)
            dd.set_samples(p, n)
            base = int(segs.offsets[p])
            for s in range(n):
                row = vals[base + s]
                for c in range(6):
                    dd.set_deep_value(p, c, s, float(row[c]))
        out = oiio.ImageOutput.create(tmp)
        if out is None or not out.open(tmp, spec):
            raise OSError(f"OpenImageIO cannot write {shown}: {oiio.geterror() if out is None else out.geterror()}")
        ok = out.write_deep_image(dd)
        out.close()
        if not ok:
            raise OSError(f"OpenImageIO failed writing {shown}: {out.geterror()}")

    with Outputs() as outs:
        outs._stage(path, write)
    if stats is not None:
        stats.update(samples=int(len(segs)), seconds=time.perf_counter() - t0)


def read_deep(path: str | Path, camera=None) -> Segments:
    """The segments of a deep OpenEXR file written by :func:`write_deep` (depths back to the ray parameter
    when ``camera`` is given, else left as stored: view-space depth)."""
    import OpenImageIO as oiio

    path = Path(path)
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise ConfigError(f"cannot read deep image {path}: {oiio.geterror()}")
    try:
        spec = inp.spec()
        if not spec.deep:
            raise ConfigError(f"{path} is not a deep image")
        dd = inp.read_native_deep_image()
    finally:
        inp.close()
    names = list(spec.channelnames)
    missing = [c for c in CHANNELS if c not in names]
    if missing:
        raise ConfigError(f"deep image {path} lacks channel(s) {', '.join(missing)}")
    idx = [names.index(c) for c in CHANNELS]
    h, w = spec.height, spec.width
    counts = np.array([dd.samples(p) for p in range(h * w)], dtype=np.int64)
    vals = np.empty((int(counts.sum()), 6), dtype=np.float64)
    k = 0
    for p in np.flatnonzero(counts):
        for s in range(int(counts[p])):
            vals[k] = [dd.deep_value(int(p), c, s) for c in idx]
            k += 1
    pix = np.repeat(np.arange(h * w), counts)
    scale = view_depth_scale(camera)[pix] if camera is not None else np.ones(len(pix))
    with np.errstate(divide="ignore"):
        tau = -np.log1p(-vals[:, 3])
    return Segments.from_unsorted(pix, vals[:, 4] / scale, vals[:, 5] / scale, vals[:, :3], tau, (h, w))
