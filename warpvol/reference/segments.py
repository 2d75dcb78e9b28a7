"""The exact reference as segments: one per entry of each pixel's ray into the mesh (:mod:`warpvol.segments`).

The NumPy reference (:mod:`warpvol.reference.numpy_render`) traces each ray's segments through the cells
watertight (the exit depth of one cell is bit-identical to the entry depth of the next) and integrates them
exactly; here the cells' segments that follow each other without a gap join into the segment of one entry,
composited front to back. Flattened they give :func:`~warpvol.reference.numpy_render.render_reference` to
rounding (~1e-15), and merged with the segments of the other pieces of a mesh, the reference of the whole.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from warpvol.reference.integrate import integrate_segments
from warpvol.reference.numpy_render import _DEFAULT_BAND_PAIRS, _DEFAULT_CHUNK_PAIRS, _iter_chunks, check_rows
from warpvol.reference.scalars import normal_scalars
from warpvol.segments import Segments, stack_rows


def reference_segments(mesh, tf, camera, *, rows: tuple[int, int] | None = None, chunk_tets: int = 65536,
                       band_pairs: int = _DEFAULT_BAND_PAIRS, progress: Callable[[float], None] | None = None,
                       stats: dict | None = None) -> Segments:
    """The exact reference of ``mesh`` as :class:`~warpvol.segments.Segments` (image rows ``rows``, default
    all), one segment per entry of a pixel's ray into the mesh; ``stats`` gets ``n_cell_segments`` and
    ``n_segments``."""
    W, H = int(camera.width_px), int(camera.height_px)
    first, last = check_rows(rows, H)
    if hasattr(mesh, "check_overlap"):
        mesh.check_overlap()
    mesh, tf = normal_scalars(mesh, tf)
    bands, band, n_cells = [], [], 0
    for (r0, r1), ch in _iter_chunks(mesh, camera, chunk_tets=int(chunk_tets), chunk_pairs=_DEFAULT_CHUNK_PAIRS,
                                     band_pairs=int(band_pairs), progress=progress, rows=(first, last)):
        if ch is not None:
            rgb, tau = integrate_segments(ch["s_in"], ch["s_out"], ch["t_out"] - ch["t_in"], tf)
            band.append((ch["pixel"] - r0 * W, ch["t_in"], ch["t_out"], rgb, tau))
            n_cells += len(ch["pixel"])
            continue
        cat = [np.concatenate([b[k] for b in band]) if band else np.zeros((0, 3) if k == 3 else 0) for k in range(5)]
        band = []
        bands.append(Segments.entries(*cat, (r1 - r0 + 1, W)))
    out = stack_rows(bands) if bands else Segments.empty((last - first + 1, W))
    if stats is not None:
        stats.update(n_cell_segments=int(n_cells), n_segments=len(out))
    return out
