"""warpvol bench / plan: report fields, Pareto front, reference cache, planner skip rules, HTML in a browser."""

import csv
import io
import json
import shutil

import numpy as np
import pytest

import warpvol
from tolerances import TOLERANCES
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
        assert set(r["stages_s"]) | {s["stage"] for s in r["skipped"]} == set(Pipeline.load(r["pipeline"]).stage_keys())
        assert all(isinstance(v, int) for c in r["counters"].values() for v in c.values())
    ray = next(r for r in doc["rows"] if r["pipeline"] == "raycast")
    assert ray["rmse"] < TOLERANCES["raycast/fp32"]["rmse"] and ray["counters"]["raycast"]["cell_steps"] > 0
    # the CSV and Markdown tables hold the same rows
    rows = list(csv.DictReader(io.StringIO((bench_dir / "table.csv").read_text())))
    assert [r["pipeline"] for r in rows] == [r["pipeline"] for r in doc["rows"]]
    assert float(rows[0]["rmse"]) == pytest.approx(doc["rows"][0]["rmse"])
    md = (bench_dir / "table.md").read_text()
    assert all(f"| {r['pipeline']} |" in md for r in doc["rows"])
    assert (bench_dir / "pareto.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bench_pareto_front_is_right_for_its_numbers(bench_dir):
    rows = [r for r in json.loads((bench_dir / "table.json").read_text())["rows"] if r["status"] == "ok"]
    pts = [(r["total_s"], r["rmse"]) for r in rows]
    for r, p in zip(rows, pts):
        assert r["pareto"] == (not any(_dominated(p, q) for q in pts if q is not p))
    svg = (bench_dir / "pareto.svg").read_text()
    assert svg.count("<title>") == len(rows) and svg.count("(Pareto front)") == sum(r["pareto"] for r in rows)


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
    assert (tmp_path / "pareto_modelled.svg").read_text().count("(Pareto front)") == len(front)


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
        titles = page.evaluate("document.querySelectorAll('svg circle title').length")
        shot = page.screenshot(full_page=True)
        browser.close()
    assert errors == []
    n = len(list_presets())
    assert len(widths) == 2 + 2 * n and all(w > 0 for w in widths)  # plot, reference, image + error per preset
    assert titles == n
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
    assert (tmp_path / "pareto_modelled.svg").read_text().count("(Pareto front)") == 2
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


def test_plot_labels_do_not_overlap():
    """label_offsets on a crowded cluster (17 labels within a few points of each other, as the table
    presets sit on the Blunt Fin plot): no two label boxes overlap, none leaves the plot area, none
    covers a marker."""
    import itertools

    from warpvol.tools.report_html import label_offsets

    rng = np.random.default_rng(3)
    pts = [(300 + rng.uniform(-15, 15), 200 + rng.uniform(-10, 10), 60 + 5 * k % 40, 12.0) for k in range(17)]
    area = (0.0, 0.0, 640.0, 420.0)
    offs = label_offsets(pts, area, step=12.0, gap=7.0, marker=6.0)
    boxes = [(x + dx, y + dy, x + dx + w, y + dy + h) for (x, y, w, h), (dx, dy) in zip(pts, offs)]
    for a, b in itertools.combinations(boxes, 2):
        assert not (a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]), (a, b)
    for b in boxes:
        assert area[0] <= b[0] and b[2] <= area[2] and area[1] <= b[1] and b[3] <= area[3]
        for x, y, _, _ in pts:
            assert not (b[0] < x + 6 and x - 6 < b[2] and b[1] < y + 6 and y - 6 < b[3])
