"""warpvol sweep: Dask (2 worker processes, one killed mid-sweep) equals the serial sweep; resume; failures."""

import json
import os
import signal
import time

import numpy as np
import pytest

from warpvol.cli import main
from warpvol.errors import ConfigError
from warpvol.tools.sweep import load_config, plan_tasks, run_sweep

CONFIG = """
name = "test"
scenes = ["builtin:box", "builtin:concave"]
presets = ["raycast", "pt_vertex_color"]   # two kinds of pipeline; the table presets would cost seconds per task
repeats = 2
[[views]]
name = "a"
width_px = 48
height_px = 40
[[views]]
name = "b"
width_px = 40
height_px = 48
eye = [5.0, 1.0, 2.0]
[[options]]
name = "default"
[[options]]
name = "t_min0"
overrides = { "raycast.early_termination" = 0.0 }
[[options]]
name = "bad"
overrides = { "raycast.early_termination" = -1.0 }
[[options]]
name = "elsewhere"
overrides = { "no_such_stage.bits" = 8 }
"""

COMPARED = ("status", "message", "rmse", "max_abs", "psnr", "counters", "skipped", "table_bytes")


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    d = tmp_path_factory.mktemp("sweep")
    (d / "sweep.toml").write_text(CONFIG)
    return load_config(d / "sweep.toml")


@pytest.fixture(scope="module")
def serial(config, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    return out, run_sweep(config, out, serial=True)


def _by_task(res):
    return {r["task"]: r for r in res.rows}


def test_serial_sweep_rows(config, serial):
    out, res = serial
    tasks, na = plan_tasks(config)
    assert len(res.rows) == 2 * 2 * 2 * 4 == len(tasks) + len(na)
    status = [r["status"] for r in res.rows]
    # 'elsewhere' applies to no preset, 't_min0' and 'bad' only to raycast
    assert status.count("n/a") == len(na) == 2 * 2 * (2 + 2)
    assert all("has no stage" in r["message"] for r in res.rows if r["status"] == "n/a")
    bad = [r for r in res.rows if r["options"] == "bad"]
    assert all(r["status"] == "failed" and "early_termination" in r["message"] for r in bad if r["pipeline"] == "raycast")
    ok = [r for r in res.rows if r["status"] == "ok"]
    assert ok and all(r["rmse"] < 2e-6 for r in ok if r["pipeline"] == "raycast")
    assert all((out / "tasks" / f"{r['task']}.npy").is_file() for r in ok)
    assert len(list((out / "references").glob("*.npy"))) == 4  # one per scene and view, shared


def test_dask_sweep_with_a_killed_worker_equals_the_serial_sweep(config, serial, tmp_path):
    pytest.importorskip("dask.distributed")
    out_s, res_s = serial
    killed = {}

    def kill_one(row, client):
        if killed or client is None:
            return
        for _ in range(100):  # a worker between two tasks gets its next one within milliseconds
            busy = [w for w, keys in client.processing().items() if keys]
            if busy:
                break
            time.sleep(0.01)
        pids = client.run(os.getpid)
        victim = (busy or list(pids))[0]
        killed.update(worker=victim, busy=bool(busy))
        os.kill(pids[victim], signal.SIGKILL)

    res_d = run_sweep(config, tmp_path, workers=2, on_result=kill_one)
    assert killed, "no worker was killed"
    assert killed["busy"], "the killed worker had no task in flight"
    s, d = _by_task(res_s), _by_task(res_d)
    assert set(s) == set(d)
    for k in s:
        for f in COMPARED:
            assert s[k].get(f) == d[k].get(f), (k, f)
        if s[k]["status"] == "ok":
            assert np.array_equal(np.load(out_s / "tasks" / f"{k}.npy"), np.load(tmp_path / "tasks" / f"{k}.npy"))
    # every task's row is on disk: nothing was lost with the killed worker
    ok = [k for k, r in s.items() if r["status"] == "ok"]
    assert all((tmp_path / "tasks" / f"{k}.json").is_file() for k in ok)


def test_restarted_sweep_skips_what_is_done(config, serial, tmp_path):
    out, res = serial
    again = run_sweep(config, out, serial=True)
    n_ok = sum(r["status"] == "ok" for r in res.rows)
    assert again.skipped_done == n_ok
    assert {k: r.get("rmse") for k, r in _by_task(again).items()} == {k: r.get("rmse") for k, r in _by_task(res).items()}
    # an interrupted sweep: remove some rows, start again, only those are rendered
    gone = [r["task"] for r in res.rows if r["status"] == "ok"][:3]
    for k in gone:
        (out / "tasks" / f"{k}.json").unlink()
    rendered = []
    again = run_sweep(config, out, serial=True, on_result=lambda r, c: rendered.append(r["task"]))
    assert sorted(k for k in rendered if k in gone) == sorted(gone) and again.skipped_done == n_ok - 3


def test_sweep_command_writes_the_bench_outputs(tmp_path, capsys):
    cfg = tmp_path / "s.toml"
    cfg.write_text('scenes = ["builtin:box"]\npresets = ["raycast"]\n[[views]]\nname = "v"\nwidth_px = 8\nheight_px = 8\n')
    assert main(["sweep", str(cfg), "--serial", "--quiet", "-o", str(tmp_path / "o")]) == 0
    doc = json.loads((tmp_path / "o" / "table.json").read_text())
    assert [r["status"] for r in doc["rows"]] == ["ok"] and doc["rows"][0]["pareto"] is True
    for f in ("table.csv", "table.md", "pareto.png", "pareto.svg", "index.html"):
        assert (tmp_path / "o" / f).stat().st_size > 0
    assert "1 rows (0 done before, 0 failed)" in capsys.readouterr().out


@pytest.mark.parametrize("text, message", [
    ('scenes = []', "scenes: expected a non-empty list"),
    ('scenes = ["builtin:box"]\nrepeats = 0', "repeats: expected an integer >= 1"),
    ('scenes = ["builtin:box"]\npresets = ["nope"]', "'nope' is neither a preset nor a file"),
    ('scenes = ["builtin:box"]\n[[views]]\nname = "v"\nzoom = 2', "zoom"),
    ('scenes = ["builtin:box"]\n[[options]]\nname = "o"\noverrides = { bits = 8 }', "stage.param"),
    ('scenes = ["missing.toml"]', "file not found"),
])
def test_bad_configs_name_the_key(tmp_path, text, message):
    f = tmp_path / "s.toml"
    f.write_text(text)
    with pytest.raises(ConfigError, match=message):
        load_config(f)


def test_sweep_on_an_existing_scheduler(tmp_path, capsys):
    distributed = pytest.importorskip("dask.distributed")
    cfg = tmp_path / "s.toml"
    cfg.write_text('scenes = ["builtin:linear_box"]\npresets = ["raycast", "pt_vertex_color"]\n'
                   '[[views]]\nname = "v"\nwidth_px = 8\nheight_px = 6\n')
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None, silence_logs=40) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        assert main(["sweep", str(cfg), "--scheduler", cluster.scheduler_address, "--quiet", "-o", str(tmp_path / "o")]) == 0
    rows = json.loads((tmp_path / "o" / "table.json").read_text())["rows"]
    assert [r["status"] for r in rows] == ["ok", "ok"] and rows[0]["host"]
    assert main(["sweep", str(cfg), "--scheduler", "127.0.0.1:1", "-o", str(tmp_path / "o")]) == 2
    assert "--scheduler: expected tcp://HOST:PORT" in capsys.readouterr().err


def test_an_interrupted_sweep_resumes_where_it_stopped(config, serial, tmp_path):
    seen = []

    def stop_after_three(row, client):
        seen.append(row["task"])
        if len(seen) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(config, tmp_path, serial=True, on_result=stop_after_three)
    done = {k for k in seen if (tmp_path / "tasks" / f"{k}.json").is_file()}
    assert done  # the tasks finished before the interrupt are stored
    rest = []
    res = run_sweep(config, tmp_path, serial=True, on_result=lambda r, c: rest.append(r["task"]))
    assert res.skipped_done == len(done) and not set(rest) & done  # ... and not rendered again
    assert {k: r.get("rmse") for k, r in _by_task(res).items()} == {k: r.get("rmse") for k, r in _by_task(serial[1]).items()}
