"""Image bands on Dask: the reference in row bands on a local cluster equals the single-process image bit
for bit, also when a worker is killed mid-run."""

import os
import signal

import numpy as np
import pytest

import warpvol
from warpvol.bands import band_rows, reference_in_bands
from warpvol.errors import ConfigError
from warpvol.reference.numpy_render import render_reference


def test_band_rows_cover_the_image_once():
    for h in (1, 2, 7, 64, 513):
        for n in (1, 3, 8, 1000):
            rows = band_rows(h, n)
            covered = np.concatenate([np.arange(a, b + 1) for a, b in rows])
            assert np.array_equal(covered, np.arange(h)) and len(rows) == min(n, h)


def test_rows_of_the_reference_equal_the_whole_image():
    s = warpvol.builtin_scene("sphere").with_camera(width_px=21, height_px=17)
    full = render_reference(s.mesh, s.transfer, s.camera)
    parts = [render_reference(s.mesh, s.transfer, s.camera, rows=r) for r in band_rows(17, 4)]
    assert np.array_equal(np.concatenate(parts), full)
    with pytest.raises(ConfigError, match="rows"):
        render_reference(s.mesh, s.transfer, s.camera, rows=(3, 17))


def test_local_cluster_bit_identical_with_a_worker_killed():
    s = warpvol.builtin_scene("concave").with_camera(width_px=40, height_px=36)
    full = render_reference(s.mesh, s.transfer, s.camera)
    stats = {}
    assert np.array_equal(reference_in_bands(s, "local", bands=5, workers=2, stats=stats), full)
    assert stats["bands"] == 5 and stats["workers"] == 2

    killed = []

    def kill_one(k, client):
        if killed:
            return
        pids = client.run(os.getpid)  # worker address -> process id
        pid = sorted(pids.values())[0]
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    img = reference_in_bands(s, "local", bands=12, workers=2, on_band=kill_one)
    assert killed and np.array_equal(img, full)


def test_scheduler_argument_is_checked():
    s = warpvol.builtin_scene("box").with_camera(width_px=4, height_px=4)
    with pytest.raises(ConfigError, match="--workers"):
        reference_in_bands(s, "local", workers=0)
    with pytest.raises(ConfigError, match="--scheduler"):
        reference_in_bands(s, "")
