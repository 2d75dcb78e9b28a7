"""Command-line hygiene of outputs: permissions, path checks before any work, all outputs or none."""

import os
import stat

import numpy as np
import pytest

from warpvol.io import atomic_write_text, write_exr, write_png


@pytest.fixture
def umask():
    old = os.umask(0o022)
    yield lambda m: os.umask(m)
    os.umask(old)


@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_outputs_get_the_users_umask(tmp_path, umask, mask, mode):
    umask(mask)
    img = np.zeros((2, 3, 4), np.float32)
    write_exr(tmp_path / "a.exr", img)
    write_png(tmp_path / "a.png", img)
    atomic_write_text(tmp_path / "a.json", "{}\n")
    for n in ("a.exr", "a.png", "a.json"):
        assert stat.S_IMODE((tmp_path / n).stat().st_mode) == mode, n
