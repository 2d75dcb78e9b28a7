"""Image bands on Dask: the exact reference of a scene split into row bands, computed by Dask workers
and stitched.

A pixel's reference value depends only on its own ray, so the rows ``first..last`` of
:func:`warpvol.reference.numpy_render.render_reference` (``rows=``) are bit-identical to the same rows of the whole
image, and the bands can be computed anywhere. ``scheduler="local"`` starts a local cluster of worker
processes (one thread each, on 127.0.0.1); any other string is the address of a running Dask scheduler
(``tcp://host:8786``), so the reference of a mesh too slow for one machine spreads over a cluster. The
scene is sent to the workers once. A worker lost mid-run (killed, out of memory, its machine gone) loses
only its band: Dask's scheduler computes it again on another worker (up to ``allowed-failures``, 3 by
default, per band).

Examples
--------
>>> band_rows(10, 3)
[(0, 2), (3, 6), (7, 9)]
"""

from __future__ import annotations

import os
import time
from typing import Any, Callable

import numpy as np

from warpvol.errors import ConfigError
from warpvol.pipeline import quiet_warp
from warpvol.progress import ProgressBar
from warpvol.reference.numpy_render import render_reference
from warpvol.timing import CompileClock, announce_compile


def band_rows(height: int, n_bands: int) -> list[tuple[int, int]]:
    """``n_bands`` bands of consecutive rows (first, last inclusive) covering ``height`` rows, sizes
    differing by at most one row (fewer bands when there are fewer rows)."""
    n = max(1, min(int(n_bands), int(height)))
    edges = [round(k * height / n) for k in range(n + 1)]
    return [(edges[k], edges[k + 1] - 1) for k in range(n)]


def _worker_setup() -> None:
    quiet_warp()


def reference_band(scene: Any, first: int, last: int) -> np.ndarray:
    """Rows ``first..last`` of the scene's exact reference (runs on a worker; top-level so it pickles)."""
    _worker_setup()
    return render_reference(scene.mesh, scene.transfer, scene.camera, rows=(first, last))


def _client(scheduler: str, workers: int, memory_limit: str | int | None = None):
    """``(client, cluster or None)`` for ``"local"`` or a scheduler address; ``memory_limit``: each local
    worker's (Dask's ``memory_limit``: bytes or a string such as ``"2GB"``; default Dask's share of the
    machine)."""
    from dask.distributed import Client, LocalCluster

    if not isinstance(scheduler, str) or not scheduler:
        raise ConfigError(f"--scheduler: expected 'local' or a Dask scheduler address such as "
                          f"tcp://host:8786, got {scheduler!r}")
    if scheduler == "local":
        if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
            raise ConfigError(f"--workers: expected an integer >= 1, got {workers!r}")
        extra = {} if memory_limit is None else {"memory_limit": memory_limit}
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=None, silence_logs=40, **extra)
        return Client(cluster), cluster
    try:
        return Client(scheduler, timeout="20s"), None
    except (OSError, TimeoutError) as e:
        raise ConfigError(f"--scheduler: cannot reach the Dask scheduler at {scheduler}: {e}") from None


def reference_in_bands(scene: Any, scheduler: str = "local", *, bands: int | None = None, workers: int = 2,
                       quiet: bool = True, on_band: Callable[[int, Any], None] | None = None,
                       stats: dict | None = None) -> np.ndarray:
    """The exact reference of ``scene`` computed in row bands by Dask workers and stitched.

    Parameters
    ----------
    scene : Scene
    scheduler : str
        ``"local"`` (a local cluster of ``workers`` processes, closed afterwards) or the address of a
        running Dask scheduler.
    bands : int, optional
        Number of row bands (default: 4 per worker of the cluster, at most one per row).
    workers : int
        Worker processes of a local cluster.
    quiet : bool
        No progress bar (shown on a terminal otherwise: bands done, ETA).
    on_band : callable, optional
        ``on_band(k, client)`` after band ``k`` arrives (tests use it to kill a worker mid-run).
    stats : dict, optional
        Filled with ``bands``, ``workers`` and ``seconds``.

    Returns
    -------
    (H, W, 4) float64
        Equal bit for bit to :func:`warpvol.reference.numpy_render.render_reference` of the whole image.
    """
    from dask.distributed import as_completed

    t0 = time.perf_counter()
    H, W = int(scene.camera.height_px), int(scene.camera.width_px)
    client, cluster = _client(scheduler, workers)
    try:
        n_workers = max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
        if bands is not None and (not isinstance(bands, int) or isinstance(bands, bool) or bands < 1):
            raise ConfigError(f"--bands: expected an integer >= 1, got {bands!r}")
        rows = band_rows(H, bands or 4 * n_workers)
        [scene_f] = client.scatter([scene], broadcast=True)
        futs = {client.submit(reference_band, scene_f, a, b, key=f"reference-band-{k}-{os.getpid()}-{id(scene)}",
                              pure=False): k for k, (a, b) in enumerate(rows)}
        img = np.zeros((H, W, 4), dtype=np.float64)
        with ProgressBar(f"reference in {len(rows)} bands", len(rows), enabled=not quiet) as prog:
            for f in as_completed(futs):
                k = futs[f]
                a, b = rows[k]
                img[a:b + 1] = f.result()
                prog.advance()
                if on_band is not None:
                    on_band(k, client)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    if stats is not None:
        stats.update(bands=len(rows), workers=n_workers, seconds=time.perf_counter() - t0)
    return img


def compute_reference(scene, quiet: bool = False, scheduler: str | None = None, bands: int | None = None,
                      workers: int = 2) -> tuple[np.ndarray, float]:
    """The exact reference with a progress bar (ETA) on a terminal; with ``scheduler`` in row bands on a
    Dask cluster (:mod:`warpvol.bands`)."""
    t0 = time.perf_counter()
    if scheduler is not None:
        img = reference_in_bands(scene, scheduler, bands=bands, workers=workers, quiet=quiet)
    else:
        # the reference's kernels compile on first use: said before the wait, as for a pipeline's
        with ProgressBar("reference", enabled=not quiet) as bar, CompileClock(None if quiet else announce_compile):
            img = render_reference(scene.mesh, scene.transfer, scene.camera, progress=bar.fraction)
    return img, time.perf_counter() - t0
