"""Command-line hygiene of inputs: a corrupt or truncated mesh file is reported as unreadable in one
line, without VTK's log on the terminal."""

import numpy as np
import pytest

from warpvol.cli import main


def _vtu(tmp_path):
    import pyvista as pv

    g = pv.ImageData(dimensions=(4, 4, 4)).cast_to_unstructured_grid().triangulate()
    g.point_data["s"] = np.arange(g.n_points, dtype=float)
    good = tmp_path / "good.vtu"
    g.save(good)
    return good.read_bytes()


def _damage(data, how):
    if how == "truncated":
        return data[: len(data) // 2]
    if how == "tail cut":
        return data[:-40]
    if how == "payload":  # XML intact, a compressed data array garbled
        i = data.index(b'format="binary"')
        i = data.index(b">", i) + 30
        return data[:i] + b"A" * 16 + data[i + 16:]
    if how == "garbage":
        return bytes(np.random.default_rng(1).integers(0, 256, 2000, dtype=np.uint8))
    return b""


@pytest.mark.parametrize("how", ["truncated", "tail cut", "payload", "garbage", "empty"])
def test_corrupt_or_truncated_vtu_is_reported_unreadable(tmp_path, capfd, how):
    (tmp_path / "m.vtu").write_bytes(_damage(_vtu(tmp_path), how))
    scene = tmp_path / "s.toml"
    scene.write_text('[mesh]\npath = "m.vtu"\nscalars = "s"\n[camera]\nwidth_px = 8\nheight_px = 8\n')
    capfd.readouterr()
    assert main(["render", str(scene), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"), "--quiet"]) == 2
    out, err = capfd.readouterr()
    assert err.startswith(f"warpvol: error: {scene}: mesh.path: cannot read {tmp_path / 'm.vtu'}: the file is corrupt "
                          "or truncated (VTK: "), err
    assert err.count("\n") == 1 and out == ""  # one line: no VTK log, no pyvista warning
    assert not (tmp_path / "o.exr").exists()


def test_intact_vtu_still_renders(tmp_path):
    _vtu(tmp_path)
    scene = tmp_path / "s.toml"
    scene.write_text('[mesh]\npath = "good.vtu"\nscalars = "s"\n[transfer]\npoints = [[0, 1, 1, 1, 1.0], [64, 1, 1, 1, 1.0]]\n'
                     '[camera]\nwidth_px = 8\nheight_px = 8\neye = [1.5, 1.5, 9]\ntarget = [1.5, 1.5, 1.5]\n')
    assert main(["render", str(scene), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"), "--quiet"]) == 0
