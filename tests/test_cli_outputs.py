"""Command-line hygiene of outputs: permissions, path checks before any work, all outputs or none."""

import os
import stat

import numpy as np
import pytest

from test_cli import scene_file  # noqa: F401  (fixture: a small scene file)
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


def _leftovers(folder):
    return sorted(p.name for p in folder.rglob("*") if p.name not in ("scene.toml", "sub", "ro"))


def _unwritable_folder(tmp_path):
    if os.geteuid() == 0:  # root writes anywhere chmod allows; sysfs refuses new files even to root
        return "/sys"
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    return str(ro)


@pytest.mark.parametrize("outputs, message", [
    (["-o", "{d}/x.exr", "--report", "{d}/x.exr"], "--report: {d}/x.exr is also the -o output"),
    (["-o", "{d}/x.exr", "--png", "{d}/p.png", "--error-image", "{d}/./p.png", "--reference", "{d}/r.exr"],
     "--error-image: {d}/./p.png is also the --png output"),
    (["-o", "{d}/x.exr", "--report", "{d}/sub"], "--report: {d}/sub: unsupported file extension"),
    (["-o", "{d}/x.exr", "--report", "{d}/sub.json"], "--report: {d}/sub.json is a folder"),
    (["-o", "{d}/x.jpg"], "-o: {d}/x.jpg: unsupported file extension '.jpg'; expected .exr or .png"),
    (["-o", "{d}/x.exr", "--png", "{d}/p.jpg"], "--png: {d}/p.jpg: unsupported file extension '.jpg'"),
    (["-o", "{d}/nope/x.exr"], "-o: output folder does not exist: {d}/nope"),
    (["-o", "{ro}/x.exr"], "-o: cannot write into folder {ro}"),
])
def test_every_output_is_checked_before_any_work(tmp_path, capsys, outputs, message):
    from warpvol.cli import main

    (tmp_path / "sub").mkdir()
    (tmp_path / "sub.json").mkdir()
    ro = _unwritable_folder(tmp_path) if "{ro}" in message else ""
    fill = lambda a: a.replace("{d}", str(tmp_path)).replace("{ro}", ro)  # noqa: E731
    # the scene does not exist: an output error first proves the outputs are checked before the scene
    assert main(["render", str(tmp_path / "missing.toml"), "--pipeline", "raycast", "--quiet"]
                + [fill(a) for a in outputs]) == 2
    err = capsys.readouterr().err
    assert err.startswith("warpvol: error: ") and fill(message) in err, err
    assert "missing.toml" not in err and _leftovers(tmp_path) == ["sub.json"]


def test_unknown_pipeline_is_reported_before_the_reference_is_computed(scene_file, tmp_path, capsys):
    from warpvol.cli import main

    assert main(["render", str(scene_file), "--pipeline", "raycats", "-o", str(tmp_path / "o.exr"),
                 "--compute-reference"]) == 2
    err = capsys.readouterr().err
    assert "'raycats' is neither a preset nor a file" in err and "reference" not in err
    assert _leftovers(tmp_path) == []


def test_a_run_writes_all_its_outputs_or_none(scene_file, tmp_path, capsys, monkeypatch):
    from warpvol import io
    from warpvol.cli import main

    argv = ["render", str(scene_file), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"), "--quiet",
            "--compute-reference", "--png", str(tmp_path / "p.png"), "--error-image", str(tmp_path / "e.png"),
            "--report", str(tmp_path / "r.json")]
    real = io._write_oiio
    calls = []

    def full_disk(tmp, pixels, fmt, shown):
        calls.append(shown)
        if len(calls) == 2:  # o.exr is already written (to its temporary file); e.png is encoded by matplotlib
            raise OSError(28, "No space left on device", tmp)
        real(tmp, pixels, fmt, shown)

    monkeypatch.setattr(io, "_write_oiio", full_disk)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"cannot write {tmp_path / 'p.png'}: No space left on device" in err
    assert "/." not in err  # never the temporary file's name
    assert _leftovers(tmp_path) == []
    monkeypatch.setattr(io, "_write_oiio", real)
    assert main(argv) == 0
    assert _leftovers(tmp_path) == ["e.png", "o.exr", "p.png", "r.json"]


def test_interrupted_outputs_leave_nothing(tmp_path):
    from warpvol.io import Outputs

    with pytest.raises(KeyboardInterrupt):
        with Outputs() as out:
            out.text(tmp_path / "a.json", "{}")
            out.exr(tmp_path / "a.exr", np.zeros((2, 2, 4)))
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("flag", ["--width", "--height"])
def test_zero_width_or_height_is_an_error(scene_file, tmp_path, capsys, flag):
    from warpvol.cli import main

    assert main(["render", str(scene_file), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"),
                 flag, "0", "--quiet"]) == 2
    assert f"warpvol: error: {flag}: 0 is outside the allowed range [1, inf]" in capsys.readouterr().err
    assert main(["reference", str(scene_file), "-o", str(tmp_path / "o.exr"), flag, "-3", "--quiet"]) == 2
    assert f"{flag}: -3 is outside" in capsys.readouterr().err
    assert _leftovers(tmp_path) == []


def test_an_image_too_large_for_memory_is_refused_up_front(scene_file, tmp_path, capsys, monkeypatch):
    from warpvol import cli

    # beyond int32 pixel indices
    assert cli.main(["render", str(scene_file), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"),
                     "--width", "70000", "--height", "70000", "--quiet"]) == 2
    assert "4900000000 pixels; at most 2147483647" in capsys.readouterr().err
    # more memory than there is (1 MiB available here)
    monkeypatch.setattr(cli, "_available_memory", lambda: 2**20)
    assert cli.main(["render", str(scene_file), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"),
                     "--width", "200", "--height", "100", "--compute-reference", "--png", str(tmp_path / "p.png"),
                     "--quiet"]) == 2
    err = capsys.readouterr().err
    want = 200 * 100 * sum(cli.BYTES_PER_PIXEL[k] for k in ("render", "png", "reference"))
    assert f"a 200x100 image needs about {want / 2**20:.0f} MiB" in err and "than the 1 MiB of memory" in err
    assert "reference" not in err.split("needs")[0] and _leftovers(tmp_path) == []
    # the same image fits when it fits
    monkeypatch.setattr(cli, "_available_memory", lambda: want)
    assert cli.main(["render", str(scene_file), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"),
                     "--width", "20", "--height", "10", "--quiet"]) == 0


def test_demo_size_zero_or_too_large_is_refused_before_its_folder_is_made(tmp_path, capsys):
    from warpvol.cli import main

    for size, message in (("0", "--size: 0 is outside the allowed range [1, inf]"),
                          ("50000", "--size: 50000x50000 = 2500000000 pixels; at most 2147483647")):
        assert main(["demo", "--size", size, "-o", str(tmp_path / "demo"), "--quiet"]) == 2
        assert message in capsys.readouterr().err
        assert list(tmp_path.iterdir()) == []
