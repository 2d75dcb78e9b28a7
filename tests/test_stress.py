"""warpvol stress --quick: every case x every preset, no crash, no NaN/Inf, failures reported."""

import json

import numpy as np
import pytest

from warpvol.cli import main
from warpvol.pipeline import list_presets
from warpvol.stress import CASES, Case, build_case, run_case


def test_stress_quick_runs_every_case_with_every_preset(tmp_path, capsys):
    rc = main(["stress", "--quick", "--quiet", "-o", str(tmp_path)])
    out = capsys.readouterr()
    rows = json.loads((tmp_path / "stress.json").read_text())["rows"]
    failed = [(r["case"], r["pipeline"], r["message"]) for r in rows if r["status"] == "failed"]
    assert rc == 0 and failed == [], failed
    presets = {n for n, _ in list_presets()}
    for case in CASES:
        got = {r["pipeline"] for r in rows if r["case"] == case}
        assert presets <= got and any(p.startswith("reference") for p in got), case
    for r in rows:
        assert r["status"] in ("ok", "declined")
        if r["status"] == "ok":
            assert r["finite"] is True and (r["rmse"] is None or np.isfinite(r["rmse"]))
        else:
            assert r["message"]  # a pipeline that cannot handle a case says why
    assert f"{len(CASES)} cases:" in out.out and "0 failed" in out.out
    page = (tmp_path / "stress.html").read_text()
    assert page.count("<tr>") == (len(CASES) + 1) + (len(rows) + 1) + (len(CASES) + 1) and "0 failed" in page
    assert out.out.count("| camera_far |") == 1 + 1 + len(presets)  # matrix row + reference + one per preset


def test_closed_form_cases_match_the_exact_reference():
    from warpvol.reference import render_reference

    c = build_case("image_4096x4096", quick=True).scene.with_camera(width_px=24, height_px=24)
    ref = render_reference(c.mesh, c.transfer, c.camera)
    from warpvol.stress import _box_closed_form

    assert np.abs(_box_closed_form(c.camera)() - ref).max() < 1e-9


class _Exploding:
    name = "exploding"

    def render(self, scene, **kw):
        raise ZeroDivisionError("boom")


class _NaN:
    name = "nan"

    def render(self, scene, **kw):
        raise RuntimeError("pipeline 'nan' produced NaN/Inf pixels")


def test_a_crash_or_nan_is_a_failed_row_and_the_exit_status_says_so(monkeypatch, capsys):
    case = build_case("one_tet", quick=True)
    rows = run_case(case, [_Exploding(), _NaN()])
    assert [r["status"] for r in rows] == ["ok", "failed", "failed"]
    assert rows[1]["message"] == "ZeroDivisionError: boom" and rows[2]["finite"] is False
    bad = Case("one_tet", case.scene, "", analytic=lambda: np.full((24, 24, 4), np.nan))
    assert run_case(bad, [])[0]["status"] == "failed"
    import warpvol.stress as st

    monkeypatch.setattr(st, "run_case", lambda c, pipes, device="cpu": [{"case": c.name, "pipeline": "x",
                        "status": "failed", "finite": None, "time_s": 0.0, "message": "boom"}])
    assert main(["stress", "--quick", "--quiet", "--cases", "one_tet"]) == 1
    assert "one_tet / x failed: boom" in capsys.readouterr().err


def test_unknown_case_is_an_error(capsys):
    assert main(["stress", "--cases", "nope"]) == 2
    assert "unknown stress case 'nope'" in capsys.readouterr().err


def test_stage_warnings_reach_the_stress_table():
    """A pipeline that flags its own losses in a stage's stats (the faithful VSBUFFER on a 1x1 image:
    one depth row misses the cells) has the warning in its stress row, not an empty note."""
    from warpvol.pipeline import Pipeline
    from warpvol.stress import build_case, run_case

    rows = run_case(build_case("image_1x1", quick=True), [Pipeline.load("westermann1997")])
    row = rows[-1]
    assert row["status"] == "ok" and row["rmse"] > 0.1
    assert "vsbuffer:" in row["message"] and "missed" in row["message"]
