"""warpvol bench / plan: report fields, Pareto front, reference cache, planner skip rules, HTML in a browser."""

import csv
import io
import json
import shutil

import numpy as np
import pytest

import warpvol
from tolerances import TOLERANCES, preset_tolerance
from warpvol.cli import main
from warpvol.errors import ConfigError
from warpvol.pipeline import Pipeline, list_presets
from warpvol.scene.builtin import BUILTIN_SCENES
from warpvol.tools.bench import pareto_front, quick_pipeline, scene_hash


def _dominated(p, q):
    return q[0] <= p[0] and q[1] <= p[1] and (q[0] < p[0] or q[1] < p[1])


@pytest.fixture(scope="module")
def bench_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    assert main(["bench", "builtin:concave", "--width", "24", "--height", "20", "--repeats", "2", "-o", str(out),
                 "--quiet", "--quick"]) == 0
    return out


def test_bench_report_has_every_preset_and_field(bench_dir):
    doc = json.loads((bench_dir / "table.json").read_text())
    assert [r["pipeline"] for r in doc["rows"]] == [n for n, _ in list_presets()]
    assert doc["scene"]["image"] == [24, 20] and doc["scene"]["convex"] is False
    for r in doc["rows"]:
        assert r["status"] == "ok", r.get("message")
        for k in ("total_s", "first_s", "stages_s", "rmse", "max_abs", "psnr", "table_bytes", "counters", "pareto"):
            assert k in r, k
        assert r["repeats"] == 2 and r["total_s"] > 0 and r["rmse"] >= 0 and r["max_abs"] >= r["rmse"]
        assert 0 < r["min_s"] <= r["total_s"] <= r["max_s"]  # the median of the repeats and their spread
        assert r["planner"] == []  # no planner audit without --audit
        assert set(r["stages_s"]) | {s["stage"] for s in r["skipped"]} == set(Pipeline.load(r["pipeline"]).stage_keys())
        assert all(isinstance(v, int) for c in r["counters"].values() for v in c.values())
    ray = next(r for r in doc["rows"] if r["pipeline"] == "raycast")
    assert ray["rmse"] < preset_tolerance("raycast")["rmse"] and ray["counters"]["raycast"]["cell_steps"] > 0
    # the CSV and Markdown tables hold the same rows
    rows = list(csv.DictReader(io.StringIO((bench_dir / "table.csv").read_text())))
    assert [r["pipeline"] for r in rows] == [r["pipeline"] for r in doc["rows"]]
    assert float(rows[0]["rmse"]) == pytest.approx(doc["rows"][0]["rmse"])
    md = (bench_dir / "table.md").read_text()
    assert all(f"| {r['pipeline']} |" in md for r in doc["rows"])
    assert (bench_dir / "pareto.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    meta = doc["meta"]
    for k in ("date", "commit", "warpvol", "Warp", "VTK", "CPU", "cores", "load average at the start",
              "load average at the end", "timer resolution [s]"):
        assert meta.get(k), k
    assert meta["warpvol"] == __import__("importlib.metadata").metadata.version("warpvol")


def test_bench_pareto_front_is_right_for_its_numbers(bench_dir):
    rows = [r for r in json.loads((bench_dir / "table.json").read_text())["rows"] if r["status"] == "ok"]
    pts = [(r["total_s"], r["rmse"]) for r in rows]
    for r, p in zip(rows, pts):
        assert r["pareto"] == (not any(_dominated(p, q) for q in pts if q is not p))
    svg = (bench_dir / "pareto.svg").read_text()
    assert svg.count("<title>") == len(rows) and svg.count("(Pareto front)") == sum(r["pareto"] for r in rows)
    assert "RMSE against emulated run time" in svg and "modelled" not in svg
    assert not (bench_dir / "pareto_modelled.svg").exists()  # no --gpu: one clock


def test_pareto_front():
    pts = [(1.0, 1e-3), (2.0, 1e-5), (3.0, 1e-4), (1.0, 1e-3), (0.5, 1.0), (2.0, 1e-5 + 1e-9), (4.0, 0.0)]
    assert pareto_front(pts) == [True, True, False, True, True, False, True]
    rng = np.random.default_rng(3)
    pts = [tuple(x) for x in rng.random((40, 2))]
    front = pareto_front(pts)
    for p, f in zip(pts, front):
        assert f == (not any(_dominated(p, q) for q in pts))
    assert pareto_front([]) == []


def test_reference_is_cached_by_scene_content(tmp_path):
    from warpvol.tools.bench import cached_reference

    scene = warpvol.builtin_scene("linear_box").with_camera(width_px=6, height_px=5)
    a, _, hit_a = cached_reference(scene, tmp_path)
    b, _, hit_b = cached_reference(warpvol.builtin_scene("linear_box").with_camera(width_px=6, height_px=5), tmp_path)
    assert (hit_a, hit_b) == (False, True) and np.array_equal(a, b)
    assert len(list(tmp_path.glob("reference-*.npy"))) == 1
    edited = warpvol.builtin_scene("linear_box").with_camera(width_px=6, height_px=5)
    edited.transfer = warpvol.TransferFunction(edited.transfer.points * [1, 1, 1, 1, 2])
    assert scene_hash(edited) != scene_hash(scene)


def test_bench_rejects_bad_input_before_work(tmp_path, capsys):
    assert main(["bench", "builtin:box", "--pipelines", "nope", "-o", str(tmp_path / "o")]) == 2
    assert "nope" in capsys.readouterr().err and not (tmp_path / "o").exists()
    assert main(["bench", "builtin:box", "--repeats", "0", "-o", str(tmp_path / "o")]) == 2
    assert "--repeats" in capsys.readouterr().err


def test_gpu_profiles_give_modelled_times_or_say_why_not(tmp_path, capsys):
    from warpvol.tools.bench import gpu_support

    if gpu_support("geforce6800gt") is not None:
        pytest.skip(f"no GPU profiles in this build: {gpu_support('geforce6800gt')}")
    assert main(["bench", "builtin:box", "--gpu", "nope", "-o", str(tmp_path / "x")]) == 2
    assert "unknown GPU profile 'nope'" in capsys.readouterr().err and not (tmp_path / "x").exists()
    assert main(["bench", "builtin:box", "--width", "12", "--height", "12", "--gpu", "geforce6800gt", "--quick",
                 "--repeats", "1", "--no-audit", "--quiet", "-o", str(tmp_path)]) == 0
    rows = {r["pipeline"]: r for r in json.loads((tmp_path / "table.json").read_text())["rows"]}
    assert rows["raycast"]["modelled_s"] > 0 and rows["raycast"]["gpu_note"] is None
    assert set(rows["raycast"]["modelled_stages_s"]) == set(rows["raycast"]["stages_s"])
    for r in rows.values():  # every row is modelled, or says in words why not
        assert r["status"] == "ok" and (r["modelled_s"] is not None or r["gpu_note"].startswith("not modelled"))
    front = [r for r in rows.values() if r.get("pareto_modelled")]
    assert front and all(r["modelled_s"] is not None for r in front)
    svg = (tmp_path / "pareto_modelled.svg").read_text()
    assert svg.count("(Pareto front)") == len(front) and "RMSE against modelled GPU time (geforce6800gt)" in svg
    page = (tmp_path / "index.html").read_text()
    for r in rows.values():  # a preset without a model is listed under the modelled plot with the reason
        if r["modelled_s"] is None:
            assert f"<li><b>{r['pipeline']}</b>: not modelled" in page, r["pipeline"]


@pytest.mark.parametrize("scene_name", list(BUILTIN_SCENES))
def test_planner_skip_rules_leave_the_image_unchanged(scene_name):
    """Each stage a preset skips for a built-in scene: rendering with it forced on gives the same image."""
    scene = warpvol.builtin_scene(scene_name).with_camera(width_px=20, height_px=16)
    tol = TOLERANCES["planner/skip"]
    for name, _ in list_presets():
        pipe = quick_pipeline(Pipeline.load(name))  # small tables: the skip rules are the same
        plan = pipe.plan(scene)
        try:
            base = pipe.render(scene, quiet=True)
        except ConfigError as e:  # a preset that refuses the scene has nothing to audit (Guthe: emission density)
            assert "color_extinction" in str(e), (name, e)
            continue
        assert [s["stage"] for s in base.report["skipped"]] == [p["stage"] for p in plan if p["run"] is False]
        for p in plan:
            if p["run"] is False:
                forced = pipe.render(scene, quiet=True, force={p["stage"]})
                assert forced.report["forced"] == [{"stage": p["stage"], "reason": p["reason"]}]
                assert p["stage"] in forced.report["stages"]
                d = np.abs(forced.image.astype(np.float64) - base.image)
                assert np.sqrt(np.mean(d * d)) <= tol["rmse"] and d.max() <= tol["max_abs"], (name, p)


def test_plan_command_prints_reasons_and_savings(capsys):
    assert main(["plan", "builtin:box", "--pipeline", "raycast", "--width", "8", "--height", "8", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert "peel" in out and "skipped: mesh boundary is convex" in out and "leaving it out saves" in out


def _browser():
    try:
        from playwright.sync_api import sync_playwright  # noqa: F401
    except ImportError:
        return None, "playwright is not installed (pip install playwright)"
    exe = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome") if shutil.which(n)), None)
    if exe is None:
        return None, "no Chromium binary on PATH (Debian: apt-get install chromium)"
    return exe, None


def test_bench_page_opens_in_a_headless_browser(bench_dir, tmp_path):
    exe, why = _browser()
    if exe is None:
        pytest.skip(f"no headless browser: {why}")
    from playwright.sync_api import sync_playwright

    errors = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on("requestfailed", lambda r: errors.append(f"request failed: {r.url}"))
        page.goto((bench_dir / "index.html").as_uri())
        widths = page.evaluate("Array.from(document.images).map(i => i.complete ? i.naturalWidth : -1)")
        titles = page.evaluate("document.querySelectorAll('svg g[id^=\"pareto-emulated-\"] > title').length")
        svgs = page.evaluate("document.querySelectorAll('div.plot svg').length")
        text = page.evaluate("document.body.innerText")
        shot = page.screenshot(full_page=True)
        browser.close()
    assert errors == []
    n = len(list_presets())
    assert len(widths) == 1 + 2 * n and all(w > 0 for w in widths)  # reference, image + error per preset
    assert titles == n and svgs == 1  # one plot (no --gpu: one clock), a hover title per preset
    assert all(k in text for k in ("commit", "Warp", "VTK", "CPU", "load average", "min [s]", "max [s]"))
    (tmp_path / "shot.png").write_bytes(shot)
    from warpvol.io import read_exr

    img = read_exr(tmp_path / "shot.png")
    assert img.shape[0] > 900 and img[..., :3].std() > 0.05  # a page with content, not a blank screen


class _ModelledPipeline(Pipeline):
    """A pipeline whose render takes a GPU profile, as in builds with the throughput model."""

    def __init__(self, base, seconds):
        super().__init__(base.stages, name=base.name)
        self.seconds = seconds

    def render(self, scene, *, gpu=None, **kw):
        res = super().render(scene, **kw)
        if gpu is not None:
            res.report["modelled_s"] = {"stages": {k: self.seconds / 2 for k in res.report["stages"]},
                                        "total": self.seconds, "unmodelled": {}}
        return res


def test_modelled_times_have_their_own_pareto_front(tmp_path):
    from warpvol.tools.bench import BenchResult, bench_pipeline, describe_scene, mark_pareto, write_bench

    scene = warpvol.builtin_scene("box").with_camera(width_px=6, height_px=6)
    base = Pipeline.load("raycast")
    ref = np.zeros((6, 6, 4))
    rows = []
    for k, secs in enumerate((2e-3, 1e-3)):
        r = bench_pipeline(_ModelledPipeline(base, secs), scene, ref, repeats=1, gpu="somegpu", audit=False)
        r.pop("_image")
        r["pipeline"] = f"p{k}"
        rows.append(r)
    assert [r["modelled_s"] for r in rows] == [2e-3, 1e-3] and rows[0]["gpu_note"] is None
    rows[1]["rmse"] = rows[0]["rmse"] * 2  # p1: faster when modelled, less accurate
    rows[0]["total_s"], rows[1]["total_s"] = 1.0, 2.0  # p0: faster when emulated
    mark_pareto(rows)
    assert [r["pareto"] for r in rows] == [True, False] and [r["pareto_modelled"] for r in rows] == [True, True]
    write_bench(BenchResult(describe_scene(scene), rows, ref, 0.0, False, {}, "somegpu"), tmp_path)
    svg = (tmp_path / "pareto_modelled.svg").read_text()
    assert svg.count("(Pareto front)") == 2 and "RMSE against modelled GPU time (somegpu)" in svg
    assert "RMSE against emulated run time" not in svg and svg.count("<title>") == 2
    assert "modelled_s.raycast" in (tmp_path / "table.csv").read_text()


def test_bench_saves_each_pipeline_and_resumes(tmp_path):
    """-o saves each pipeline's row and image as it finishes (pipelines/KEY.json + .npy); --resume
    reuses them (the same row: not run again) and runs the missing ones, the page and table whole; a
    resume with other settings (--repeats) is an error naming the difference."""
    import json

    from warpvol.cli import main

    args = ["bench", "builtin:box", "--width", "12", "--height", "10", "--repeats", "1", "--quiet", "--no-audit",
            "--pipelines", "raycast", "pt_best", "-o", str(tmp_path)]
    assert main(args) == 0
    d = tmp_path / "pipelines"
    assert sorted(f.name for f in d.iterdir()) == ["pt_best.json", "pt_best.npy", "raycast.json", "raycast.npy"]
    first = json.loads((d / "raycast.json").read_text())["row"]
    (d / "pt_best.json").unlink()
    assert main(args + ["--resume"]) == 0
    rows = {r["pipeline"]: r for r in json.loads((tmp_path / "table.json").read_text())["rows"]}
    assert rows["raycast"]["total_s"] == first["total_s"] and rows["raycast"]["first_s"] == first["first_s"]
    assert rows["pt_best"]["status"] == "ok" and (d / "pt_best.json").exists()
    assert "raycast" in (tmp_path / "index.html").read_text()  # the reused image is on the page
    bad = [a if a != "1" else "2" for a in args] + ["--resume"]
    assert main(bad) == 2


def test_plot_axes_span_whole_decades():
    """Two exact presets whose RMSE differ in rounding only (5.750e-8, 5.762e-8; on the GeForce 6800 GT the
    only presets with a model): the axis spans whole decades, not their 0.2 % difference."""
    from warpvol.tools.report_html import pareto_figure

    rows = [{"pipeline": "a", "status": "ok", "rmse": 5.750e-8, "total_s": 0.2, "modelled_s": 8.7e-4, "pareto": True,
             "pareto_modelled": True},
            {"pipeline": "b", "status": "ok", "rmse": 5.762e-8, "total_s": 0.3, "modelled_s": 1.09e-3, "pareto": False,
             "pareto_modelled": False},
            {"pipeline": "c", "status": "ok", "rmse": 1e-3, "total_s": 0.1, "modelled_s": None, "pareto": True,
             "gpu_note": "not modelled: sort: cells_sorted"}]
    fig, tips = pareto_figure(rows, "modelled_s", gpu="geforce6800gt")
    ax = fig.axes[0]
    assert ax.get_ylim() == pytest.approx((1e-8, 1e-7)) and ax.get_xlim() == pytest.approx((1e-4, 1e-2))
    assert ax.get_title() == "RMSE against modelled GPU time (geforce6800gt)" and len(tips) == 2
    fig, tips = pareto_figure(rows, "total_s")
    assert fig.axes[0].get_title() == "RMSE against emulated run time" and len(tips) == 3


def test_audit_runs_only_with_audit_and_noise_is_shown_as_such(tmp_path, capsys):
    """--audit renders each stage a preset leaves out forced on (raycast on the convex box: peel); without it
    (the default, or --no-audit) nothing is forced. A render difference within the spread of the repeats is
    shown in words, never as a signed number."""
    import re

    from warpvol.tools.machine import timer_resolution

    base = ["bench", "builtin:box", "--width", "12", "--height", "10", "--repeats", "3", "--pipelines", "raycast"]
    for extra, audited in (([], False), (["--no-audit"], False), (["--audit"], True)):
        out = tmp_path / ("x" + "".join(extra))
        assert main(base + extra + ["-o", str(out)]) == 0
        row = json.loads((out / "table.json").read_text())["rows"][0]
        assert [s["stage"] for s in row["skipped"]] == ["peel"]
        assert bool(row["planner"]) == audited, extra
    a = row["planner"][0]
    assert a["stage"] == "peel" and a["forced_min_s"] <= a["forced_total_s"] <= a["forced_max_s"]
    page = (out / "index.html").read_text()
    cell = re.search(r"<td>peel</td><td>[^<]*</td><td>[^<]*</td><td>[^<]*</td><td>[^<]*</td><td>([^<]*)</td>", page)
    noise = max(row["max_s"] - row["min_s"], a["forced_max_s"] - a["forced_min_s"])
    if abs(a["total_diff_s"]) < timer_resolution():
        assert cell.group(1) == "&lt; timer resolution"
    elif abs(a["total_diff_s"]) <= noise:
        assert cell.group(1).startswith("within the repeats"), cell.group(1)
    else:
        assert float(cell.group(1)) == pytest.approx(a["total_diff_s"], rel=1e-3)
    assert "not measured (run with --audit)" in (tmp_path / "x" / "index.html").read_text()


def test_progress_stays_off_stdout(tmp_path, capsys):
    """Not on a terminal (pytest's captured streams): no progress at all, stdout holds the table only; with
    --progress, plain lines on stderr (none longer than the terminal's default 80 columns is padded), still
    nothing on stdout."""
    args = ["bench", "builtin:box", "--width", "8", "--height", "8", "--repeats", "1", "--pipelines", "raycast"]
    assert main(args + ["-o", str(tmp_path / "a")]) == 0
    out, err = capsys.readouterr()
    assert err == "" and out.splitlines()[0].startswith("| pipeline |") and "[warpvol]" not in out
    assert main(args + ["--progress", "-o", str(tmp_path / "b")]) == 0
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert lines and all(ln.startswith("[warpvol] bench box") and ln == ln.rstrip() for ln in lines), lines
    assert "left" in lines[-1] and "(100 %)" in lines[-1]
    assert "[warpvol]" not in out and out.splitlines()[0].startswith("| pipeline |")


def test_progress_bar_on_a_terminal_fits_its_width(monkeypatch):
    """On a terminal the rich bar is as wide as the terminal (here 60 columns), never padded past it, with
    the time left; work inside a step (detail) shows as its own line and disappears with the step."""
    import io
    import re

    from warpvol import progress

    class Tty(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.setenv("COLUMNS", "60")
    tty = Tty()
    with progress.ProgressBar("bench concave", 4, stream=tty) as bar:
        bar.advance(1, "raycast: run 1/3 of a long name that does not fit in sixty columns at all")
        assert progress.detail("vsb_sweep", 0.5, "plane 8 of 16")
        with progress.ProgressBar("reference", stream=tty) as inner:  # nested: a detail line of the bar
            assert inner.mode == "child"
            inner.fraction(0.25)
        bar._rich.refresh()
        bar.advance(3, "done")
    assert not progress.detail("x", 0.5)  # no bar open: nothing happens
    text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", tty.getvalue())
    lines = [ln for ln in re.split(r"[\r\n]+", text) if ln.strip()]
    assert lines and max(len(ln) for ln in lines) <= 60, max(lines, key=len)
    assert any("left" in ln for ln in lines) and any("vsb_sweep" in ln or "reference" in ln for ln in lines)
