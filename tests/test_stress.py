"""warpvol stress --quick: every case x every preset, no crash, no NaN/Inf, failures reported."""

import json

import numpy as np

from warpvol.cli import main
from warpvol.pipeline import list_presets
from warpvol.tools.stress import CASES, Case, build_case, run_case


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
    from warpvol.reference.numpy_render import render_reference

    c = build_case("image_4096x4096", quick=True).scene.with_camera(width_px=24, height_px=24)
    ref = render_reference(c.mesh, c.transfer, c.camera)
    from warpvol.tools.stress import _box_closed_form

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
    import warpvol.tools.stress as st

    monkeypatch.setattr(st, "run_case", lambda c, pipes, device="cpu", on_step=None: [{"case": c.name, "pipeline": "x",
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
    from warpvol.tools.stress import build_case, run_case

    rows = run_case(build_case("image_1x1", quick=True), [Pipeline.load("westermann1997")])
    row = rows[-1]
    assert row["status"] == "ok" and row["rmse"] > 0.1
    assert "vsbuffer:" in row["message"] and "missed" in row["message"]


def test_stress_saves_each_case_and_resumes(tmp_path):
    """-o saves every case's rows as it finishes (cases/NAME.json); --resume reuses them (the same
    rows, not run again) and runs the missing ones; a resume with other pipelines is an error naming
    both; an interrupted suite (Ctrl-C after its first case) keeps the finished case and says how to go on."""
    import json
    import signal
    import subprocess
    import sys

    from helpers import restore_sigint
    from warpvol.cli import main

    args = ["stress", "--quick", "--quiet", "--pipelines", "raycast", "pt_best", "--cases", "one_tet", "image_1x1",
            "-o", str(tmp_path)]
    assert main(args) == 0
    cases = tmp_path / "cases"
    assert sorted(f.name for f in cases.iterdir()) == ["image_1x1.json", "one_tet.json"]
    first = json.loads((cases / "one_tet.json").read_text())["rows"]
    (cases / "image_1x1.json").unlink()
    assert main(args + ["--resume"]) == 0
    rows = json.loads((tmp_path / "stress.json").read_text())["rows"]
    assert [r for r in rows if r["case"] == "one_tet"] == first  # reused, times included
    assert {r["case"] for r in rows} == {"one_tet", "image_1x1"} and (cases / "image_1x1.json").exists()
    assert main(["stress", "--quick", "--quiet", "--pipelines", "raycast", "--cases", "one_tet", "-o", str(tmp_path),
                 "--resume"]) == 2
    # Ctrl-C after the first case (the second, full-size 622,938-tet grid, takes seconds to build and to
    # compute its reference before any render)
    d2 = tmp_path / "ctrl_c"
    p = subprocess.Popen([sys.executable, "-m", "warpvol.cli", "stress", "--pipelines", "raycast", "--progress",
                          "--cases", "one_tet", "many_tets", "-o", str(d2)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, preexec_fn=restore_sigint)
    seen = []
    for line in p.stderr:
        seen.append(line)
        if "one_tet: done" in line:  # --progress: a line per step also into a pipe
            break
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130, seen + [err]
    assert "--resume" in err and (d2 / "cases" / "one_tet.json").exists()
    assert not (d2 / "cases" / "many_tets.json").exists() and not (d2 / "stress.json").exists()
