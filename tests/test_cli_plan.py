"""``warpvol plan``: one preset by default, ``all`` by name with its expected time announced, and presets
that decline the scene listed with their reason while the others go on."""

import itertools

import pytest

import warpvol
from warpvol.cli import main
from warpvol.errors import ConfigError
from warpvol.pipeline import DEFAULT_PIPELINE, Pipeline, list_presets
from warpvol.tools.plan import run_plan

SMALL = ["--width", "8", "--height", "8", "--repeats", "1"]


def planned(out: str) -> list[str]:
    return [line[:-1] for line in out.splitlines() if line.endswith(":") and " on " in line]


def test_plan_without_pipeline_plans_and_measures_the_default_preset_only(capsys):
    assert main(["plan", "builtin:box"] + SMALL) == 0
    out = capsys.readouterr().out
    assert planned(out) == [f"{DEFAULT_PIPELINE} on box"]
    assert "render: " in out  # measured


def test_plan_all_is_asked_for_by_name(capsys):
    assert main(["plan", "builtin:box", "--pipeline", "all", "--no-measure", "--quiet"] + SMALL) == 0
    assert planned(capsys.readouterr().out) == [f"{n} on box" for n, _ in list_presets()]


def test_plan_lists_the_presets_that_decline_and_goes_on(capsys):
    # the sphere's transfer function is emission_density: Guthe's 2D tables need color_extinction
    assert warpvol.builtin_scene("sphere").transfer.emission == "emission_density"
    assert main(["plan", "builtin:sphere", "--pipeline", "guthe2002_linear,raycast"] + SMALL) == 0
    cap = capsys.readouterr()
    assert planned(cap.out) == ["guthe2002_linear on sphere", "raycast on sphere"]
    assert "declined: tf.emission: Guthe's 2D tables need the 'color_extinction' model" in cap.out
    assert cap.out.count("render: ") == 1  # raycast measured after the decline
    assert "plan: 1 declined: guthe2002_linear on sphere (tf.emission: Guthe's" in cap.err
    assert "expected to take about" in cap.err


def test_plan_of_one_preset_that_declines_is_an_error(capsys):
    assert main(["plan", "builtin:sphere", "--pipeline", "guthe2002_linear"] + SMALL) == 2
    assert "warpvol: error: tf.emission: Guthe's 2D tables" in capsys.readouterr().err


def test_plan_announces_the_expected_time_from_the_first_preset(capsys):
    # a clock that advances 10 s per reading (the run's start, the pair's start and end, the time spent):
    # the first pair is announced as 30 s, the other two at 2 x 30 s, and the totals follow the mean
    ticks = itertools.count(0.0, 10.0)
    notes = []
    scene = warpvol.builtin_scene("box").with_camera(width_px=8, height_px=8)
    pipes = [Pipeline.load("raycast")] * 3
    rows = run_plan(pipes, [scene], measure=False, note=notes.append, clock=lambda: next(ticks))
    assert [r["status"] for r in rows] == ["planned"] * 3
    assert not notes  # a dry run renders nothing: no time to announce
    ticks = itertools.count(0.0, 10.0)
    with pytest.raises(ConfigError):  # a single pair that declines: its refusal is the answer
        run_plan([Pipeline.load("guthe2002_linear")], [warpvol.builtin_scene("sphere").with_camera(width_px=8,
                 height_px=8)], repeats=1, note=notes.append, clock=lambda: next(ticks))
    rows = run_plan(pipes, [scene], repeats=1, note=notes.append, clock=lambda: next(ticks))
    assert [r["status"] for r in rows] == ["ok"] * 3
    assert notes[0].startswith("plan: 3 preset x scene pairs")
    assert "the first took 30 s; the other 2 expected to take about 60 s if each costs as much" in notes[1]
    assert notes[-1].endswith("in all")


def test_a_dry_run_lists_the_presets_whose_scene_checks_decline(capsys):
    # scalars beyond float32: the presets without the condition stage decline before rendering
    from warpvol.tools.stress import build_case

    scene = build_case("scalars_1e39", quick=True).scene
    notes = []
    rows = run_plan([Pipeline.load("raycast"), Pipeline.load("pt_vertex_color")], [scene], measure=False,
                    note=notes.append)
    assert [(r["pipeline"], r["status"]) for r in rows] == [("raycast", "planned"), ("pt_vertex_color", "declined")]
    assert "beyond float32's range" in rows[1]["message"]
    assert "declined: scalars_1e39: scalars:" in capsys.readouterr().out
    assert notes == [f"plan: 1 declined: pt_vertex_color on scalars_1e39 ({rows[1]['message']})"]
