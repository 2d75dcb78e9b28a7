"""Every generated file under docs/data/ says where its numbers came from (warpvol/tools/provenance.py), one
script knows how to regenerate each (scripts/regenerate_docs_data.py), and the pages show it beside each
table (docs/hooks.py)."""

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

from warpvol.tools import provenance

ROOT = Path(__file__).parents[1]
DATA = ROOT / "docs" / "data"
FILES = sorted(DATA.glob("*.json"))


def _module(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def _hooks():
    return _module(ROOT / "docs" / "hooks.py", "docs_hooks_for_provenance")


def _parts(doc: dict) -> list[str]:
    """The parts a file is written in (by several runs): a paper's tables (the reproduction scripts), or
    paper_figures.json's papers."""
    if str(doc.get("source", "")).startswith("python scripts/reproduce_"):
        return list(doc["tables"])
    if "espinha2005" in doc and "rows" in doc["espinha2005"]:
        return [k for k in doc if k != provenance.KEY]
    return []


def test_a_run_block_has_every_field_and_its_loads():
    b = provenance.finish(provenance.start("python scripts/x.py --json y", timing=True))
    assert set(provenance.FIELDS) <= set(b)
    assert b["command"] == "python scripts/x.py --json y" and b["timing"] is True
    if b["load"]["start"] is not None:  # a system with load averages
        assert len(b["load"]["start"]) == 3 and len(b["load"]["end"]) == 3
        assert "load (1 min)" in provenance.describe(b)
    commit, dirty = provenance.git_state()
    assert b["commit"] == (commit or "unknown") and b["dirty"] == dirty


def test_a_file_written_in_parts_keeps_each_parts_block():
    old = {"tables": {"a": {}, "b": {}}}
    provenance.stamp(old, dict(provenance.start("first"), date="d1"))  # an older file: one block for all
    doc = provenance.stamp(dict(old, tables={"a": {}, "b": {}, "c": {}}), dict(provenance.start("second"), date="d2"),
                           parts=["b", "c"], all_parts=["a", "b"])
    assert provenance.of(doc, "a")["command"] == "first"
    assert provenance.of(doc, "b")["command"] == provenance.of(doc, "c")["command"] == "second"
    assert provenance.of(doc)["command"] == "second" and "parts" not in provenance.of(doc)
    assert provenance.of({"rows": []}) is None


def test_reproduction_scripts_stamp_the_tables_they_write(tmp_path):
    from warpvol.reproduce.common import write_tables_json

    path = tmp_path / "p.json"
    table = {"columns": ["x"], "rows": [[1]]}
    write_tables_json(path, "python scripts/one.py", {"t1": table, "t2": table})
    write_tables_json(path, "python scripts/two.py", {"t2": table})
    doc = json.loads(path.read_text())
    assert provenance.of(doc, "t1")["command"] == "python scripts/one.py"
    assert provenance.of(doc, "t2")["command"] == "python scripts/two.py"
    assert provenance.of(doc, "t2")["timing"] is True and provenance.of(doc, "t2")["load"]["start"] is not None


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_every_generated_file_names_its_commit_and_command(path):
    doc = json.loads(path.read_text())
    blocks = [provenance.of(doc)] + [provenance.of(doc, p) for p in _parts(doc)]
    assert blocks[0] is not None, f"{path.name} has no {provenance.KEY} block"
    for b in blocks:
        assert set(provenance.FIELDS) <= set(b), (path.name, sorted(b))
        assert b["command"] and b["date"]
        assert b["commit"] == "unknown" or len(b["commit"]) == 40, b["commit"]
        if b["timing"]:  # a timing names its machine, unless stamped afterwards from history (not known)
            assert b["machine"] is not None or "afterwards" in b.get("note", ""), path.name
    top = doc[provenance.KEY]
    for p in _parts(doc):
        assert p in top.get("parts", {}), f"{path.name}: table {p} has no block of its own"


def test_every_stamped_commit_is_in_the_history():
    """Each stamped commit is an ancestor of HEAD, not only an object in this clone: a commit that reached
    main rebased leaves its old hash behind in the worktree that ran it, and a fresh clone lacks it."""
    commits = sorted({provenance.of(json.loads(p.read_text()))["commit"] for p in FILES} - {"unknown"})
    try:
        shallow = subprocess.run(["git", "rev-parse", "--is-shallow-repository"], cwd=ROOT, capture_output=True,
                                 text=True, timeout=30)
    except OSError:
        pytest.skip("git not available")
    if shallow.returncode != 0:
        pytest.skip("not a git checkout")
    if shallow.stdout.strip() == "true":
        pytest.skip("a shallow clone holds only part of the history")
    outside = [c for c in commits
               if subprocess.run(["git", "merge-base", "--is-ancestor", c, "HEAD"], cwd=ROOT,
                                 capture_output=True, timeout=30).returncode != 0]
    assert not outside, f"stamped commits that are not in HEAD's history: {outside}"


def test_one_script_knows_every_generated_file():
    regen = _module(ROOT / "scripts" / "regenerate_docs_data.py", "regenerate_docs_data_for_test")
    assert {p.name for p in regen.PRODUCERS} == {p.stem for p in FILES}
    for p in regen.PRODUCERS:
        assert p.cost and p.commands
    listing = regen.listing()
    assert all(f"docs/data/{p.stem}.json" in listing for p in FILES)
    assert regen.main(["--only", "no_such_file"]) == 2


@pytest.mark.parametrize("marker, name", [("table: guthe2002/table5", "guthe2002"), ("table: skip/summary", "skip"),
                                           ("bench: bench_concave", "bench_concave")])
def test_pages_show_the_provenance_beside_each_table(marker, name):
    doc = json.loads((DATA / f"{name}.json").read_text())
    part = marker.split("/")[1] if "/" in marker else None
    block = provenance.of(doc, part)
    text = _hooks().expand(f"<!-- {marker} -->")
    assert f"From `docs/data/{name}.json`" in text and block["commit"][:10] in text
    assert block["date"][:10] in text and block["command"] in text
    if block["timing"]:
        assert "load (1 min)" in text or "machine load not recorded" in text


def test_the_regenerate_script_runs_a_producer_and_checks_its_stamp(tmp_path, monkeypatch, capsys):
    regen = _module(ROOT / "scripts" / "regenerate_docs_data.py", "regenerate_docs_data_for_run")
    monkeypatch.setattr(regen, "DATA", tmp_path)
    writes = ("from warpvol.tools import provenance as p; import sys; "
              "p.write_json(sys.argv[1], {'rows': []}, p.start('fake', timing=True))")
    stamped = regen.Producer("fake", (f'python -c "{writes}" {tmp_path / "fake.json"}',), "a second")
    assert regen.run(stamped, 1, 2) is True
    out = capsys.readouterr().out
    assert "[1/2] fake: expected a second" in out and "done in" in out and "load (1 min)" in out
    unstamped = regen.Producer("bare", (f'python -c "open(\'{tmp_path / "bare.json"}\', \'w\').write(\'{{}}\')"',), "?")
    assert regen.run(unstamped, 2, 2) is False
    assert "carries no provenance of this run" in capsys.readouterr().out
