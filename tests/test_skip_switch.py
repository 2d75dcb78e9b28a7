"""The skip switch reaches the stages wherever presets are compared: ``warpvol.compare(skip=)``,
``bench_pipeline`` / ``run_bench`` (``warpvol bench --no-skip``) and the measured part of ``warpvol plan``."""

import json

import pytest

from test_visibility import _scene
from warpvol.cli import main
from warpvol.errors import ConfigError
from warpvol.pipeline import Pipeline


def test_compare_passes_skip_to_every_render():
    import warpvol

    sc = _scene(px=12)  # 10 layers, the TF's shell meets 2 of them
    n = sc.mesh.n_tets
    on = warpvol.compare(sc, ["pt_best"], repeats=1)
    off = warpvol.compare(sc, ["pt_best"], repeats=1, skip=False)
    assert on.results["pt_best"].report["left_out"]["sort"]["cells_culled"] == n - n // 5
    rep = off.results["pt_best"].report
    assert rep["skip"] is False and "left_out" not in rep
    assert rep["counters"]["pt_project"]["tets_projected"] == n


def test_bench_pipeline_row_says_what_was_left_out():
    from warpvol.tools.bench import bench_pipeline

    sc, pipe = _scene(px=12), Pipeline.load("pt_best")
    n = sc.mesh.n_tets
    on = bench_pipeline(pipe, sc, None, repeats=1, audit=False)
    off = bench_pipeline(pipe, sc, None, repeats=1, audit=False, skip=False)
    assert on["skip"] is True and on["left_out"]["sort"]["cells_culled"] == n - n // 5
    assert off["skip"] is False and off["left_out"] == {}
    assert off["counters"]["pt_project"]["tets_projected"] == n


def test_cli_bench_no_skip(tmp_path):
    size = ["--width", "8", "--height", "8", "--repeats", "1", "--quiet"]
    for flag, out in (([], tmp_path / "on"), (["--no-skip"], tmp_path / "off")):
        assert main(["bench", "builtin:box", "--pipelines", "pt_best", "-o", str(out)] + flag + size) == 0
    row_on = json.loads((tmp_path / "on" / "table.json").read_text())["rows"][0]
    row_off = json.loads((tmp_path / "off" / "table.json").read_text())["rows"][0]
    assert row_on["skip"] is True and row_on["left_out"]
    assert row_off["skip"] is False and row_off["left_out"] == {}
    # a bench with the other setting is not resumed from these rows
    rec = json.loads(next((tmp_path / "off" / "pipelines").glob("*.json")).read_text())
    assert rec["skip"] is False


def test_cli_plan_measures_with_the_switch(capsys):
    size = ["--width", "8", "--height", "8", "--repeats", "1", "--quiet"]
    assert main(["plan", "builtin:box", "--pipeline", "pt_best"] + size) == 0
    out = capsys.readouterr().out
    assert "leaves out:" in out and "left out: cells_culled" in out and "skipping off" not in out
    assert main(["plan", "builtin:box", "--pipeline", "pt_best", "--no-skip"] + size) == 0
    out = capsys.readouterr().out
    assert "leaves out:" not in out and "left out:" not in out and "skipping off" in out


def test_sweep_option_skip_false(tmp_path):
    from warpvol.tools.sweep import load_config, run_sweep

    cfg = tmp_path / "s.toml"
    cfg.write_text('scenes = ["builtin:box"]\npresets = ["pt_best"]\n[[views]]\nname = "tiny"\nwidth_px = 8\n'
                   'height_px = 8\n[[options]]\nname = "default"\n[[options]]\nname = "no-skip"\nskip = false\n')
    res = run_sweep(load_config(cfg), tmp_path / "o", serial=True, quiet=True)
    rows = {r["options"]: r for r in res.rows}
    assert rows["default"]["status"] == rows["no-skip"]["status"] == "ok"
    assert rows["default"]["skip"] is True and rows["default"]["left_out"]
    assert rows["no-skip"]["skip"] is False and rows["no-skip"]["left_out"] == {}
    bad = tmp_path / "b.toml"
    bad.write_text(cfg.read_text().replace("skip = false", 'skip = "no"'))
    with pytest.raises(ConfigError, match=r"skip: expected true or false"):
        load_config(bad)


def test_stress_no_skip(tmp_path):
    from warpvol.tools.stress import Case, run_case

    sc = _scene(px=12)
    n = sc.mesh.n_tets
    case, pipes = Case("layers", sc, ""), [Pipeline.load("pt_best")]
    on, off = run_case(case, pipes)[1], run_case(case, pipes, skip=False)[1]
    assert on["status"] == off["status"] == "ok"
    assert f"sort: cells_culled {n - n // 5}" in on["left_out"] and off["left_out"] == ""
    out = tmp_path / "st"
    assert main(["stress", "--quick", "--cases", "one_tet", "--pipelines", "pt_best", "--no-skip", "-o", str(out),
                 "--quiet"]) == 0
    assert json.loads(next((out / "cases").glob("*.json")).read_text())["skip"] is False


def test_the_ray_casters_confinement_travels_as_a_value():
    """``cell_setup`` says whether the walk is confined to the visible cells as ``cells["confined"]``; the
    later stages read that value (:func:`warpvol.shared.visible.confined`), not whether a key is present."""
    from types import SimpleNamespace

    import numpy as np

    from warpvol.shared.visible import confined

    cells = {"confined": False, "entry_faces": np.zeros((0, 2), np.int64)}
    ctx = SimpleNamespace(skip=True, buffers={"cells": cells}, planned=set())
    assert confined(ctx) is False
    cells["confined"] = True
    assert confined(ctx) is True
    ctx.skip = False
    assert confined(ctx) is False
    sc = _scene(px=12)
    on, off = (Pipeline.load("raycast").render(sc, quiet=True, skip=s).report for s in (True, False))
    assert on["stats"]["cell_setup"]["cells_not_walked"] > 0 and "peel" not in [s["stage"] for s in on["skipped"]]
    assert "cells_not_walked" not in off["stats"]["cell_setup"] and "left_out" not in off
