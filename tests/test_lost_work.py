"""No lost or stale work: inputs are never overwritten, a folder command replaces or deletes only the
files it wrote (recorded in OUTDIR/.warpvol-files.json), arguments are checked before any file is
touched, a resume ignores stray temporary files and corrupt records and keys on content hashes, and
errors for deep TOML, huge meshes and a bad ``reference`` argument name what is wrong."""

import json
import os

import numpy as np
import pytest

from warpvol.cli import main
from warpvol.errors import ConfigError

BOX = '[mesh]\nbuiltin = "box"\n[camera]\nwidth_px = {w}\nheight_px = {h}\neye = [{ex}, 1.5, 4.0]\n'


def _box_scene(path, w=10, h=9, ex=2.0):
    path.write_text(BOX.format(w=w, h=h, ex=ex))
    return path


# -- 8: inputs are never outputs ------------------------------------------------------------------
def test_render_never_writes_over_an_input_however_it_is_spelled(tmp_path, capsys):
    from warpvol.pipeline import _read_pipeline_text

    scene = _box_scene(tmp_path / "s.toml")
    ref = tmp_path / "ref.exr"
    assert main(["reference", str(scene), "-o", str(ref), "--quiet"]) == 0
    capsys.readouterr()
    before = ref.read_bytes()
    (tmp_path / "sub").mkdir()
    (tmp_path / "alias.exr").symlink_to(ref)
    os.link(ref, tmp_path / "hard.exr")
    for out in (ref, tmp_path / "sub" / ".." / "ref.exr", tmp_path / "alias.exr", tmp_path / "hard.exr"):
        assert main(["render", str(scene), "--pipeline", "raycast", "--reference", str(ref), "-o", str(out),
                     "--quiet"]) == 2
        err = capsys.readouterr().err
        assert f"-o: {out} is an input of this run (--reference image: {ref})" in err, err
    # the reference given through the link, the output under its real name: refused too
    assert main(["render", str(scene), "--pipeline", "raycast", "--reference", str(tmp_path / "alias.exr"),
                 "-o", str(ref), "--report", str(tmp_path / "r.json"), "--quiet"]) == 2
    assert "is an input of this run" in capsys.readouterr().err
    assert ref.read_bytes() == before and not (tmp_path / "r.json").exists()
    # a file the scene names (here its mesh, checked before the mesh is read) and the scene itself
    data = tmp_path / "cells.exr"
    data.write_bytes(b"not a mesh")
    (tmp_path / "m.toml").write_text(f'[mesh]\npath = "{data.name}"\nscalars = "s"\n')
    assert main(["reference", str(tmp_path / "m.toml"), "-o", str(data), "--quiet"]) == 2
    assert f"-o: {data} is an input of this run (mesh.path in m.toml: {data})" in capsys.readouterr().err
    assert data.read_bytes() == b"not a mesh"
    # a pipeline file (any name that exists is read as one)
    pipe = tmp_path / "cast.json"
    pipe.write_text(_read_pipeline_text("raycast")[0])
    assert main(["render", str(scene), "--pipeline", str(pipe), "-o", str(tmp_path / "o.exr"),
                 "--report", str(tmp_path / "sub" / ".." / "cast.json"), "--quiet"]) == 2
    assert f"is an input of this run (pipeline file: {pipe})" in capsys.readouterr().err
    assert pipe.read_text() == _read_pipeline_text("raycast")[0] and not (tmp_path / "o.exr").exists()


def test_bench_refuses_a_folder_whose_output_name_is_its_scene(tmp_path, capsys):
    scene = _box_scene(tmp_path / "index.html")  # an odd name, but the user's file
    text = scene.read_text()
    assert main(["bench", str(scene), "--pipelines", "raycast", "--repeats", "1", "--no-audit", "-o", str(tmp_path),
                 "--quiet"]) == 2
    # a scene given by a file name without .toml is read as a mesh file: either way it is an input
    assert f"-o (index.html): {scene} is an input of this run (" in capsys.readouterr().err
    assert scene.read_text() == text


# -- 9: only the tool's own files are replaced or deleted -----------------------------------------
def test_stress_keeps_files_it_did_not_write(tmp_path, capsys):
    cases = tmp_path / "cases"
    cases.mkdir()
    mine = {"notes.json": '{"my": "notes"}', "draft.json": "[1, 2"}
    for n, t in mine.items():
        (cases / n).write_text(t)
    args = ["stress", "--quick", "--quiet", "--pipelines", "raycast", "-o", str(tmp_path)]
    # a bad case name fails before anything is touched
    assert main(args + ["--cases", "one_tet", "no_such_case"]) == 2
    assert "--cases: unknown stress case 'no_such_case'" in capsys.readouterr().err
    assert {p.name: p.read_text() for p in cases.iterdir()} == mine
    assert not (tmp_path / ".warpvol-files.json").exists()
    # a run writes its own case file beside the user's, a fresh run replaces only its own
    assert main(args + ["--cases", "one_tet"]) == 0
    capsys.readouterr()
    assert sorted(p.name for p in cases.iterdir()) == ["draft.json", "notes.json", "one_tet.json"]
    manifest = json.loads((tmp_path / ".warpvol-files.json").read_text())["files"]
    assert manifest["cases/one_tet.json"]["tool"] == "stress" and "cases/notes.json" not in manifest
    assert main(args + ["--cases", "constant_scalars"]) == 0  # not --resume: its earlier case file goes
    capsys.readouterr()
    assert sorted(p.name for p in cases.iterdir()) == ["constant_scalars.json", "draft.json", "notes.json"]
    assert all((cases / n).read_text() == t for n, t in mine.items())
    # a user's file under a name the run would write: refused before any work, left as it was
    (cases / "one_tet.json").write_text("my one_tet notes")
    (tmp_path / "stress.md").unlink()
    m = json.loads((tmp_path / ".warpvol-files.json").read_text())
    m["files"].pop("stress.md")
    (tmp_path / ".warpvol-files.json").write_text(json.dumps(m))
    (tmp_path / "stress.md").write_text("my summary")
    assert main(args + ["--cases", "one_tet"]) == 2
    err = capsys.readouterr().err
    assert f"-o: {cases / 'one_tet.json'} exists and was not written by warpvol stress" in err
    assert (cases / "one_tet.json").read_text() == "my one_tet notes"
    (cases / "one_tet.json").unlink()
    assert main(args + ["--cases", "one_tet"]) == 2
    assert "stress.md exists and was not written by warpvol stress" in capsys.readouterr().err
    assert (tmp_path / "stress.md").read_text() == "my summary"


def test_bench_keeps_files_it_did_not_write(tmp_path, capsys):
    rows = tmp_path / "pipelines"
    rows.mkdir()
    np.save(rows / "mine.npy", np.arange(3.0))
    (rows / "mine.json").write_text('{"a": 1}')
    args = ["bench", "builtin:box", "--width", "7", "--height", "6", "--repeats", "1", "--no-audit", "--quiet",
            "--pipelines", "raycast", "-o", str(tmp_path)]
    assert main(args) == 0
    assert main(args) == 0  # again, not --resume: its own row replaced
    capsys.readouterr()
    assert sorted(p.name for p in rows.iterdir()) == ["mine.json", "mine.npy", "raycast.json", "raycast.npy"]
    assert np.array_equal(np.load(rows / "mine.npy"), np.arange(3.0))
    assert (rows / "mine.json").read_text() == '{"a": 1}'
    # a user's page where bench writes index.html: refused up front
    owned = json.loads((tmp_path / ".warpvol-files.json").read_text())
    owned["files"].pop("index.html")
    (tmp_path / ".warpvol-files.json").write_text(json.dumps(owned))
    (tmp_path / "index.html").write_text("<p>mine</p>")
    assert main(args) == 2
    assert "index.html exists and was not written by warpvol bench" in capsys.readouterr().err
    assert (tmp_path / "index.html").read_text() == "<p>mine</p>"


# -- 10: resume: stray temp files, corrupt records, content hashes --------------------------------
def test_stress_resume_ignores_temp_files_and_reruns_a_corrupt_record(tmp_path, capsys):
    args = ["stress", "--quick", "--pipelines", "raycast", "--cases", "one_tet", "constant_scalars",
            "-o", str(tmp_path)]
    assert main(args + ["--quiet"]) == 0
    cases = tmp_path / "cases"
    kept = json.loads((cases / "one_tet.json").read_text())["rows"]
    # a kill during a save leaves the writer's temporary file, cut short
    (cases / ".one_tet.json.k3x9q1.json").write_text('{"quick": true, "rows": [{"case"')
    cut = '{"quick": true, "pipelines": ["ray'
    (cases / "constant_scalars.json").write_text(cut)  # an old writer's cut: not as recorded, so not warpvol's
    capsys.readouterr()
    assert main(args + ["--resume"]) == 2
    assert "constant_scalars.json exists and was not written by warpvol stress; it changed" in capsys.readouterr().err
    assert (cases / "constant_scalars.json").read_text() == cut
    (cases / "constant_scalars.json").unlink()
    assert main(args + ["--resume"]) == 0
    rows = json.loads((tmp_path / "stress.json").read_text())["rows"]
    assert [r for r in rows if r["case"] == "one_tet"] == kept  # reused
    assert json.loads((cases / "constant_scalars.json").read_text())["case"] == "constant_scalars"  # run again


def test_bench_resume_keys_on_the_pipeline_toml(tmp_path, capsys):
    from warpvol.pipeline import _read_pipeline_text

    pipe = tmp_path / "cast.toml"
    text = _read_pipeline_text("raycast")[0]
    pipe.write_text(text)
    out = tmp_path / "out"
    args = ["bench", "builtin:box", "--width", "9", "--height", "8", "--repeats", "1", "--no-audit",
            "--pipelines", str(pipe), "-o", str(out)]
    assert main(args + ["--quiet"]) == 0
    rec = out / "pipelines" / "raycast.json"  # the preset's text names the pipeline
    first = json.loads(rec.read_text())
    (out / "pipelines" / ".raycast.json.z81kq0.json").write_text('{"scene": "')  # a killed writer's temp file
    capsys.readouterr()
    assert main(args + ["--resume"]) == 0  # unchanged: reused, the temp file ignored
    assert json.loads(rec.read_text())["row"]["first_s"] == first["row"]["first_s"]
    assert "changed" not in capsys.readouterr().err
    pipe.write_text(text + "\n# edited: same stages, other text\n")
    assert main(args + ["--resume"]) == 0
    assert "pipeline raycast changed since its row was saved: it is benched again" in capsys.readouterr().err
    again = json.loads(rec.read_text())
    assert again["pipeline_sha"] != first["pipeline_sha"] and again["row"]["first_s"] != first["row"]["first_s"]


def test_sweep_task_keys_follow_the_scene_files_content(tmp_path):
    from warpvol.scene.scene_file import scene_digest
    from warpvol.tools.sweep import load_config, plan_tasks, run_sweep

    scene = _box_scene(tmp_path / "s.toml", w=8, h=8, ex=2.0)
    cfg_file = tmp_path / "sweep.toml"
    cfg_file.write_text('name = "t"\nscenes = ["s.toml"]\npresets = ["raycast"]\n')

    def keys():
        return [t.key for t in plan_tasks(load_config(cfg_file))[0]]

    k0 = keys()
    out = tmp_path / "out"
    r0 = run_sweep(load_config(cfg_file), out, serial=True)
    assert r0.skipped_done == 0 and r0.rows[0]["status"] == "ok"
    assert keys() == k0 and run_sweep(load_config(cfg_file), out, serial=True).skipped_done == 1
    _box_scene(scene, w=8, h=8, ex=-2.5)  # same path, another view
    assert keys() != k0
    r1 = run_sweep(load_config(cfg_file), out, serial=True)
    assert r1.skipped_done == 0 and r1.rows[0]["task"] != r0.rows[0]["task"]
    a = np.load(out / "tasks" / f"{r0.rows[0]['task']}.npy")
    b = np.load(out / "tasks" / f"{r1.rows[0]['task']}.npy")
    assert np.abs(a - b).max() > 1e-3  # the new row is the new view's render, not the old one's
    # a file the scene names counts too (checked without reading it as a mesh)
    mesh = tmp_path / "m.vtu"
    mesh.write_bytes(b"\x00" * 64)
    (tmp_path / "m.toml").write_text('[mesh]\npath = "m.vtu"\nscalars = "s"\n')
    d0 = scene_digest(tmp_path / "m.toml")
    mesh.write_bytes(b"\x00" * 63 + b"\x01")
    assert scene_digest(tmp_path / "m.toml") != d0
    (tmp_path / "sub").mkdir()
    assert scene_digest(tmp_path / "m.toml") == scene_digest(str(tmp_path / "sub" / ".." / "m.toml"))


# -- errors -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["scene", "pipeline", "sweep"])
def test_deeply_nested_toml_is_a_clean_error_naming_the_file(tmp_path, capsys, kind):
    deep = "x = " + "{ y = " * 1200 + "1" + " }" * 1200 + "\n"  # 1,200 inline tables: about 9 KB
    f = tmp_path / f"{kind}.toml"
    scene = _box_scene(tmp_path / "ok.toml")
    if kind == "scene":
        f.write_text('[mesh]\nbuiltin = "box"\n' + deep)
        argv = ["render", str(f), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"), "--quiet"]
    elif kind == "pipeline":
        f.write_text(deep)
        argv = ["render", str(scene), "--pipeline", str(f), "-o", str(tmp_path / "o.exr"), "--quiet"]
    else:
        f.write_text('scenes = ["ok.toml"]\n' + deep)
        argv = ["sweep", str(f), "--serial", "-o", str(tmp_path / "out"), "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"warpvol: error: {f}: ") and "Traceback" not in err and len(err.splitlines()) == 1, err
    assert "nested too deeply" in err or "recursion" in err


def test_a_volume_too_large_for_memory_names_the_volume_not_the_image(tmp_path, capsys, monkeypatch):
    from warpvol import cli, io
    from warpvol.scene import loaders

    raw = tmp_path / "v.raw"
    raw.write_bytes(np.arange(30 * 20 * 25, dtype=np.uint8).tobytes())
    f = tmp_path / "v.toml"
    f.write_text('[mesh]\nraw = { path = "v.raw", dims = [30, 20, 25], dtype = "uint8", spacing = [1, 1, 1] }\n'
                 '[transfer]\npoints = [[0, 1, 1, 1, 0.1], [255, 1, 0, 0, 1.0]]\n'
                 "[camera]\neye = [60, 50, 70]\ntarget = [15, 10, 12]\nwidth_px = 12\nheight_px = 12\n")
    argv = ["render", str(f), "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"), "--quiet"]
    # the estimate refuses it before it is read: 15,000 samples need ~3.4 MB as tets
    monkeypatch.setattr(io, "available_memory", lambda: 3 * 2**20)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"{f}: mesh.raw: the volume is too large for the memory available" in err and "30 x 20 x 25" in err
    assert "smaller image" not in err and "subsampled volume" in err
    monkeypatch.setattr(io, "available_memory", lambda: 2**34)

    def oom(*a, **k):
        raise MemoryError

    # running out while reading it
    monkeypatch.setattr(loaders, "read_raw", oom)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "mesh: the mesh it names does not fit in the memory" in err and "smaller image" not in err
    monkeypatch.undo()
    # running out while rendering a 12x12 image: the mesh is named, the image cleared
    from warpvol.pipeline import Pipeline

    monkeypatch.setattr(cli, "_available_memory", lambda: 2**31)
    monkeypatch.setattr(Pipeline, "render", oom)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "the mesh of v (" in err and "a 12x12 image" in err and "is not the problem" in err
    assert "render a smaller image" not in err and not (tmp_path / "o.exr").exists()


@pytest.mark.parametrize("value, words", [("maybe", "'maybe' is no image file (file not found)"),
                                          ("yes.exr", "'yes.exr' is no image file (file not found)"),
                                          (2.5, "got 2.5"), ({"a": 1}, "got a dict")])
def test_render_reference_errors_name_the_argument(tmp_path, value, words):
    import warpvol

    s = warpvol.builtin_scene("box").with_camera(width_px=6, height_px=5)
    with pytest.raises(ConfigError) as e:
        warpvol.render(s.mesh, s.transfer, s.camera, reference=value)
    msg = str(e.value)
    assert msg.startswith("render(reference): ") and words in msg, msg
    assert "True (compute the exact reference)" in msg and "EXR image file" in msg and "(H, W, 4)" in msg
