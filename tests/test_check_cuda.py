"""scripts/check_cuda.py without a GPU: rows written as they finish, the budget (rows that would not fit
skipped with the reason), the direct image comparison (pixels more than 1e-5 apart counted), the whole
run with the CPU standing in for ``cuda:0``, and the exit status where a driver is present but Warp
sees no CUDA device."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def cc():
    spec = importlib.util.spec_from_file_location("check_cuda", ROOT / "scripts" / "check_cuda.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_each_row_is_in_the_file_and_on_stdout_as_it_finishes(cc, tmp_path, capsys):
    clock = Clock()
    rows = cc.Rows(tmp_path / "rows.jsonl", 0.0, clock)
    clock.t = 1.5
    rows.add({"phase": "scenes", "preset": "raycast", "scene": "sphere", "size": 48, "status": "ok"})
    lines = (tmp_path / "rows.jsonl").read_text().splitlines()  # read while the file is still open
    assert [json.loads(ln) for ln in lines] == [{"phase": "scenes", "preset": "raycast", "scene": "sphere", "size": 48,
                                                 "status": "ok", "t_s": 1.5}]
    assert capsys.readouterr().out == "[   1.5 s] scenes sphere 48 raycast: ok\n"
    rows.add({"phase": "scenes", "preset": "pt_best", "status": "SKIPPED", "reason": "why"})
    assert len((tmp_path / "rows.jsonl").read_text().splitlines()) == 2
    rows.close()


def test_compare_images_counts_pixels_more_than_1e_5_apart(cc):
    a = np.zeros((4, 5, 4), np.float32)
    b = a.copy()
    b[0, 0, 3] = 2e-5   # one channel past 1e-5
    b[1, 1, :] = 1e-5   # not more than 1e-5
    b[2, 2, 0] = 3e-3   # past 1e-5 and past raycast's max_abs row
    r = cc.compare_images(a, b, {"max_abs": 1e-4, "rmse": 2e-6})
    assert (r["px_diff"], r["px_total"], r["identical"]) == (2, 20, False)
    assert r["max_abs"] == pytest.approx(3e-3) and r["status"] == "DIFFERS"
    r = cc.compare_images(a, b, {"max_abs": 4e-3, "rmse": 1e-3})
    assert r["status"] == "ok" and r["px_diff"] == 2
    assert cc.compare_images(a, a, {"max_abs": 0.0, "rmse": 0.0})["identical"]


def fake_scene(name, size, tets):
    return SimpleNamespace(name=name, camera=SimpleNamespace(width_px=size, height_px=size),
                           mesh=SimpleNamespace(n_tets=tets))


def test_rows_that_would_not_fit_are_skipped_with_the_reason(cc, tmp_path, capsys):
    """A fake clock and a fake comparison costing 1 s per 1e5 units of work: the budget runs the small rows,
    skips the large one whose estimate does not fit, and still runs a later small one that does."""
    clock = Clock()
    budget = cc.Budget(60.0, 0.0, clock)
    rows = cc.Rows(tmp_path / "rows.jsonl", 0.0, clock)
    est = cc.Estimator(prior=1e-5)

    def fake_compare(label, cfg, scene, tol, devices, n):
        clock.t += cc.Estimator.work(scene.camera.width_px ** 2, 6, scene.mesh.n_tets) / 1e5
        return {"status": "ok", "identical": True}

    small, big = fake_scene("small", 16, 1000), fake_scene("big", 512, 200_000)
    jobs = [("raycast", "raycast", small), ("raycast", "raycast", big), ("pt_best", "pt_best", small)]
    budget.start_phase("scenes")
    cc.run_jobs(jobs, rows, budget, est, ("cpu", "cpu"), (3, 1), "scenes", compare_fn=fake_compare)
    got = [(r["scene"], r["preset"], r["status"]) for r in rows.rows]
    assert got == [("small", "raycast", "ok"), ("big", "raycast", "SKIPPED"), ("small", "pt_best", "ok")]
    skipped = rows.rows[1]
    want = cc.Estimator.work(512 ** 2, 6, 200_000) / 1e5  # the rate the small row ran at, times the big row's work
    assert skipped["estimate_s"] == pytest.approx(want, rel=1e-3)
    assert skipped["reason"] == f"needs ~{want:.1f} s, {60.0 - clock.t + rows.rows[2]['seconds']:.1f} s of --budget 60 s left"
    rows.close()


def test_a_phase_share_is_named_when_it_is_what_runs_out(cc):
    clock = Clock()
    budget = cc.Budget(100.0, 0.0, clock)
    budget.start_phase("self-check", cc.SHARES["self-check"])
    assert budget.why_not(5.0) is None
    clock.t = 12.0
    assert budget.why_not(5.0) == "needs ~5.0 s, the self-check phase has 3.0 s left of its 15 s"
    budget.start_phase("scenes")
    assert budget.why_not(5.0) is None and budget.why_not(60.0) == "needs ~60.0 s, 88.0 s of --budget 100 s left"


def test_the_cpu_stands_in_for_cuda(cc, tmp_path, capsys):
    """The whole run with ``--device cpu``: self-check, then the scene rows compared CPU against CPU."""
    out = tmp_path / "out"
    rc = cc.main(["-o", str(out), "--device", "cpu", "--presets", "raycast", "--scene", "builtin:box",
                  "--sizes", "16", "--small-size", "12", "--self-size", "8", "--budget", "600"])
    assert rc == 0
    rows = [json.loads(ln) for ln in (out / "rows.jsonl").read_text().splitlines()]
    assert [(r["phase"], r["scene"], r["size"]) for r in rows] == [
        ("self-check", "concave", 8), ("self-check", "sphere", 8), ("scenes", "concave", 12), ("scenes", "sphere", 12),
        ("scenes", "box", 16)]
    for r in rows:
        assert r["status"] == "ok" and r["identical"] and r["px_diff"] == 0 and r["px_total"] == r["size"] ** 2, r
    assert all(len(r["time_s"]) == 2 and None not in r["time_s"] for r in rows if r["phase"] == "scenes")
    assert json.loads((out / "check_cuda.json").read_text())["rows"] == rows
    md = (out / "check_cuda.md").read_text()
    assert "| scenes | raycast | box | 16 | ok |" in md and "| 0 / 256 |" in md
    printed = capsys.readouterr().out
    assert "scenes box 16 raycast: ok" in printed and "rows: 5 ok" in printed


def test_a_driver_without_a_cuda_device_exits_non_zero(cc, tmp_path, monkeypatch, capsys):
    import warp as wp

    if wp.is_cuda_available():
        pytest.skip("Warp sees a CUDA device here")
    monkeypatch.setattr(cc, "probe_driver", lambda: "nvidia-smi -L: GPU 0: a test")
    out = tmp_path / "out"
    assert cc.main(["-o", str(out), "--presets", "raycast"]) == cc.EXIT_NO_DEVICE == 3
    (row,) = [json.loads(ln) for ln in (out / "rows.jsonl").read_text().splitlines()]
    assert row["status"] == "NO DEVICE" and "a CUDA driver is here (nvidia-smi -L: GPU 0: a test) but Warp" in row["reason"]
    assert "driver: NO DEVICE" in capsys.readouterr().out


def test_without_driver_or_device_the_self_check_runs_and_the_run_says_so(cc, tmp_path, monkeypatch, capsys):
    import warp as wp

    if wp.is_cuda_available():
        pytest.skip("Warp sees a CUDA device here")
    monkeypatch.setattr(cc, "probe_driver", lambda: None)
    out = tmp_path / "out"
    assert cc.main(["-o", str(out), "--presets", "raycast", "--self-size", "8"]) == 0
    rows = [json.loads(ln) for ln in (out / "rows.jsonl").read_text().splitlines()]
    assert [r["phase"] for r in rows] == ["self-check", "self-check"]
    assert "no CUDA device" in capsys.readouterr().out


def test_the_compile_phase_loads_every_module_or_says_how_many_it_left(cc):
    clock = Clock()
    budget = cc.Budget(100.0, 0.0, clock)
    budget.start_phase("compile", cc.SHARES["compile"])
    row = cc.compile_all(["cpu"], budget)
    assert row["status"] == "ok" and row["loaded"] == row["modules"] > 10
    clock.t = 36.0  # past the compile phase's 35 s: no module load starts
    row = cc.compile_all(["cpu"], budget)
    assert row["status"] == "PARTIAL" and row["loaded"] == 0
    assert row["reason"] == f"{row['modules']} of {row['modules']} module loads not started within the compile phase's " \
                            "35 s; they compile on first use"
