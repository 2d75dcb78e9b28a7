"""Output folders keep every byte a user put there: ``demo``, ``bench``, ``stress`` and ``sweep`` replace or
delete only files they wrote that are still as written (name, size and content hash in the folder's
record, made after writing), and a record copied in from another folder counts for nothing."""

import json
import shutil

import pytest

from warpvol.cli import main
from warpvol.io import MANIFEST, OwnedFiles

STRESS = ["stress", "--quick", "--quiet", "--pipelines", "raycast"]
BENCH = ["bench", "builtin:box", "--width", "6", "--height", "5", "--repeats", "1", "--no-audit", "--quiet",
         "--pipelines", "raycast"]
DEMO = ["demo", "--scene", "box", "--size", "6", "--quiet"]


def _run(argv, out, capsys, code=0) -> str:
    capsys.readouterr()
    assert main(argv + ["-o", str(out)]) == code
    return capsys.readouterr().err


def _tree(folder) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("argv,name", [
    (DEMO, "report.json"), (DEMO, "index.html"), (STRESS + ["--cases", "one_tet"], "stress.md"),
    (STRESS + ["--cases", "one_tet"], "cases/one_tet.json"), (BENCH, "index.html"), (BENCH, "pipelines/raycast.json")])
@pytest.mark.parametrize("same_size", [False, True])
def test_rerun_after_the_user_replaced_a_file_keeps_it(tmp_path, capsys, argv, name, same_size):
    _run(argv, tmp_path, capsys)
    f = tmp_path / name
    mine = (b"x" * f.stat().st_size) if same_size else b"my own notes\n"  # same size: only the hash tells
    f.write_bytes(mine)
    err = _run(argv, tmp_path, capsys, 2)
    assert f"{f} exists and was not written by warpvol" in err and "changed since warpvol wrote it" in err
    assert f.read_bytes() == mine


def test_a_replaced_case_outside_the_run_is_not_deleted(tmp_path, capsys):
    _run(STRESS + ["--cases", "one_tet", "constant_scalars"], tmp_path, capsys)
    f = tmp_path / "cases" / "constant_scalars.json"
    f.write_text("my notes on this case")
    _run(STRESS + ["--cases", "one_tet"], tmp_path, capsys)  # not --resume: its own old cases go, not this
    assert f.read_text() == "my notes on this case"
    assert not OwnedFiles(tmp_path, "stress").owns("cases/constant_scalars.json")


@pytest.mark.parametrize("tool", ["bench", "stress", "demo"])
def test_failed_run_then_a_user_file_under_its_name_is_kept(tmp_path, capsys, monkeypatch, tool):
    from warpvol import cli
    from warpvol.tools import bench, stress

    def fail(*a, **k):
        raise MemoryError

    argv, name = {"bench": (BENCH, "index.html"), "stress": (STRESS + ["--cases", "one_tet"], "stress.json"),
                  "demo": (DEMO, "report.json")}[tool]
    with monkeypatch.context() as m:  # the run fails after its checks, before it writes anything
        m.setattr({"bench": bench, "stress": stress, "demo": cli}[tool],
                  {"bench": "run_bench", "stress": "run_stress", "demo": "compute_reference"}[tool], fail)
        _run(argv, tmp_path, capsys, 2)
    assert not (tmp_path / MANIFEST).exists() or name not in json.loads((tmp_path / MANIFEST).read_text())["files"]
    (tmp_path / name).write_text("mine")
    assert "was not written by warpvol" in _run(argv, tmp_path, capsys, 2)
    assert (tmp_path / name).read_text() == "mine"


@pytest.mark.parametrize("argv,name", [(DEMO, "report.json"), (STRESS + ["--cases", "one_tet"], "stress.md"),
                                       (BENCH, "table.json")])
def test_a_copied_record_is_refused(tmp_path, capsys, argv, name):
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    _run(argv, a, capsys)
    b.mkdir()
    shutil.copy(a / MANIFEST, b / MANIFEST)  # the record alone, beside a user's file of a recorded name
    (b / name).write_text("mine")
    assert "describes" in _run(argv, b, capsys, 2)
    assert _tree(b) == {MANIFEST: (a / MANIFEST).read_bytes(), name: b"mine"}
    shutil.copytree(a, c)  # the whole folder, bytes as recorded: still another folder's record
    before = _tree(c)
    err = _run(argv, c, capsys, 2)
    assert f"the record {MANIFEST} there describes {a}, not this folder" in err
    assert _tree(c) == before


def test_a_file_put_there_during_the_run_is_kept_and_nothing_is_half_written(tmp_path, capsys, monkeypatch):
    from warpvol.tools import stress

    real = stress.run_stress

    def run_then_user_writes(*a, **k):
        rows = real(*a, **k)
        (tmp_path / "stress.md").write_text("written while it ran")
        return rows

    monkeypatch.setattr(stress, "run_stress", run_then_user_writes)
    err = _run(STRESS + ["--cases", "one_tet"], tmp_path, capsys, 2)
    assert "stress.md exists and was not written by warpvol stress" in err
    assert (tmp_path / "stress.md").read_text() == "written while it ran"
    assert not any((tmp_path / n).exists() for n in ("stress.json", "stress.csv", "stress.html"))  # all or none


def test_record_says_name_size_hash_and_folder(tmp_path, capsys):
    import hashlib

    _run(DEMO, tmp_path, capsys)
    rec = json.loads((tmp_path / MANIFEST).read_text())
    assert rec["folder"] == str(tmp_path.resolve())
    for rel, e in rec["files"].items():
        data = (tmp_path / rel).read_bytes()
        assert e == {"tool": "demo", "size": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    _run(DEMO, tmp_path, capsys)  # its own files, as written: replaced


def test_sweep_records_its_task_files_and_keeps_a_replaced_one(tmp_path, capsys):
    cfg = tmp_path / "sweep.toml"
    cfg.write_text('scenes = ["builtin:box"]\npresets = ["raycast"]\n[[views]]\nname = "v"\nwidth_px = 6\nheight_px = 6\n')
    argv, out = ["sweep", str(cfg), "--serial", "--quiet"], tmp_path / "o"
    _run(argv, out, capsys)
    files = json.loads((out / MANIFEST).read_text())["files"]
    tasks = sorted(r for r in files if r.startswith("tasks/"))
    assert len(tasks) == 2 and all(files[r]["tool"] == "sweep" for r in tasks) and "index.html" in files
    task = out / tasks[0]
    task.write_bytes(b"mine")
    assert "changed since warpvol wrote it" in _run(argv, out, capsys, 2)
    assert task.read_bytes() == b"mine"
