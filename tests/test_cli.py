"""Command line (Contract 3): render / reference / pipelines / demo, and no output on bad input."""

import json

import numpy as np
import pytest

from warpvol.cli import main
from warpvol.io import read_exr

SCENE = """
name = "tiny"
[mesh]
builtin = "sphere"
[camera]
projection = "perspective"
eye = [0.5, 0.8, 4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y_deg = 40.0
width_px = 24
height_px = 20
"""


@pytest.fixture
def scene_file(tmp_path):
    p = tmp_path / "scene.toml"
    p.write_text(SCENE)
    return p


def test_render_reference_and_report(scene_file, tmp_path, capsys):
    ref, out, rep, png, err = (tmp_path / n for n in ("ref.exr", "out.exr", "r.json", "p.png", "e.png"))
    assert main(["reference", str(scene_file), "-o", str(ref), "--quiet"]) == 0
    assert main(["render", str(scene_file), "--pipeline", "raycast", "-o", str(out), "--reference", str(ref),
                 "--report", str(rep), "--png", str(png), "--error-image", str(err), "--quiet"]) == 0
    img, r = read_exr(out), read_exr(ref)
    assert img.shape == r.shape == (20, 24, 4)
    assert img[..., 3].max() > 0.05  # the sphere is visible
    report = json.loads(rep.read_text())
    assert report["pipeline"] == "raycast"
    assert set(report["stages"]) >= {"cell_setup", "entry_bins", "raycast"}
    # the sphere's TF is two shells: the walk is confined to their cells and re-enters them (peel runs)
    assert "peel" in report["stages"] and report["left_out"]["raycast"]["cells_not_walked"] > 0
    assert report["error"]["rmse"] < 1e-4 and report["error"]["psnr"] > 80
    assert report["error"]["max_abs"] == pytest.approx(float(np.abs(img - r).max()), rel=1e-6)
    assert png.stat().st_size > 0 and err.stat().st_size > 0
    assert report["error"]["error_image_scale"] == pytest.approx(report["error"]["max_abs"], rel=1e-6)


def test_pipelines_lists_presets(capsys):
    assert main(["pipelines", "--stages"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("exact and fast\n  raycast ")
    assert "max_steps" in out and "entry_bins" in out
    assert "needs: cells, entry_bins; provides: march, image" in out


@pytest.mark.parametrize("args, message", [
    (["render", "missing.toml", "--pipeline", "raycast"], "missing.toml"),
    (["render", "{scene}", "--pipeline", "nope"], "'nope' is neither a preset nor a file"),
    (["render", "{scene}", "--pipeline", "raycast", "--reference", "nothere.exr"], "nothere.exr"),
    (["render", "builtin:nosuch", "--pipeline", "raycast"], "nosuch"),
])
def test_bad_input_names_it_and_writes_nothing(args, message, scene_file, tmp_path, capsys):
    out = tmp_path / "o.exr"
    argv = [a.replace("{scene}", str(scene_file)) for a in args] + ["-o", str(out), "--quiet"]
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".o.exr")]


def test_bad_scene_key_is_reported(tmp_path, capsys):
    p = tmp_path / "s.toml"
    p.write_text(SCENE.replace("fov_y_deg = 40.0", "fov_y_deg = 190.0"))
    assert main(["reference", str(p), "-o", str(tmp_path / "r.exr"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "fov_y_deg" in err and "190" in err
    assert not (tmp_path / "r.exr").exists()


def test_demo_writes_image_reference_and_report(tmp_path, capsys):
    d = tmp_path / "demo"
    assert main(["demo", "--scene", "box", "--size", "24", "-o", str(d), "--quiet"]) == 0
    for n in ("image.exr", "reference.exr", "image.png", "error.png", "report.json"):
        assert (d / n).is_file(), n
    rep = json.loads((d / "report.json").read_text())
    assert rep["error"]["rmse"] < 1e-4


def test_render_with_computed_reference(scene_file, tmp_path):
    rep = tmp_path / "r.json"
    assert main(["render", str(scene_file), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"),
                 "--compute-reference", "--report", str(rep), "--quiet"]) == 0
    report = json.loads(rep.read_text())
    assert report["error"]["rmse"] < 1e-5 and report["reference_s"] > 0


def _strict_json(text):
    def no_constant(name):
        raise AssertionError(f"report holds {name}: not strict JSON")

    return json.loads(text, parse_constant=no_constant)


def test_report_is_strict_json_for_an_exact_match(scene_file, tmp_path, capsys):
    first, second, rep = tmp_path / "a.exr", tmp_path / "b.exr", tmp_path / "r.json"
    assert main(["render", str(scene_file), "--pipeline", "raycast", "-o", str(first), "--quiet"]) == 0
    assert main(["render", str(scene_file), "--pipeline", "raycast", "-o", str(second), "--reference", str(first),
                 "--report", str(rep), "--quiet"]) == 0
    e = _strict_json(rep.read_text())["error"]
    assert e["rmse"] == 0 and e["psnr"] is None and "unbounded" in e["psnr_note"]
    assert "psnr=exact" in capsys.readouterr().out


def test_report_json_turns_any_non_finite_number_into_a_listed_null():
    from warpvol.pipeline import report_json

    r = _strict_json(report_json({"stats": {"x": float("nan"), "y": [1.0, float("-inf")]}, "n": np.int64(3)}))
    assert r == {"stats": {"x": None, "y": [1.0, None]}, "n": 3, "non_finite": ["stats.x", "stats.y[1]"]}
