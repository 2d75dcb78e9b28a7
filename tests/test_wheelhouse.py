"""scripts/build_wheelhouse.py without the network: files over the part size split into parts and joined
again by the wheelhouse's reassemble.py (standard library only, run as the target machine runs it), a
damaged or missing part named, the requirements pinned to the versions installed here, the Blunt Fin
files copied with their checksums."""

from __future__ import annotations

import hashlib
import importlib.metadata
import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"


@pytest.fixture(scope="module")
def bw():
    spec = importlib.util.spec_from_file_location("build_wheelhouse", ROOT / "scripts" / "build_wheelhouse.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def fake_wheelhouse(folder: Path) -> dict[str, bytes]:
    files = {"big-1.0-py3-none-any.whl": os.urandom(5000), "small-1.0-py3-none-any.whl": b"small",
             "data/grid.bin": os.urandom(2100)}
    for name, b in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(b)
    return files


def reassemble(folder: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(folder / "reassemble.py"), str(folder)], capture_output=True, text=True,
                          timeout=60)


def test_split_large_cuts_files_over_the_limit_into_ordered_parts(bw, tmp_path):
    data = os.urandom(2500)
    (tmp_path / "a.whl").write_bytes(data)
    (tmp_path / "b.whl").write_bytes(b"x" * 1000)
    entries = bw.split_large(tmp_path, 1000)
    assert entries == {"a.whl": {"size": 2500, "sha256": hashlib.sha256(data).hexdigest(),
                                 "parts": ["a.whl.part000", "a.whl.part001", "a.whl.part002"]}}
    assert not (tmp_path / "a.whl").exists() and (tmp_path / "b.whl").stat().st_size == 1000  # at the limit: whole
    assert [(tmp_path / p).stat().st_size for p in entries["a.whl"]["parts"]] == [1000, 1000, 500]
    assert b"".join((tmp_path / p).read_bytes() for p in entries["a.whl"]["parts"]) == data


def test_the_wheelhouse_is_joined_and_checked_by_its_own_script(bw, tmp_path):
    files = fake_wheelhouse(tmp_path)
    bw.finish(tmp_path, 1000 / 2**20)  # parts of 1000 bytes
    parts = json.loads((tmp_path / "parts.json").read_text())
    assert sorted(parts) == ["big-1.0-py3-none-any.whl", "data/grid.bin"]
    assert len(parts["big-1.0-py3-none-any.whl"]["parts"]) == 5 and len(parts["data/grid.bin"]["parts"]) == 3
    assert "data/grid.bin.part002" in parts["data/grid.bin"]["parts"]
    assert (tmp_path / "install.sh").read_text().startswith("#!/bin/sh") and (tmp_path / "reassemble.py").is_file()
    sums = (tmp_path / "SHA256SUMS").read_text().splitlines()
    assert sorted(ln.split()[1] for ln in sums) == sorted(files)
    r = reassemble(tmp_path)
    assert r.returncode == 0, r.stderr
    assert "big-1.0-py3-none-any.whl: joined from 5 parts, SHA-256 checked" in r.stdout
    assert {n: (tmp_path / n).read_bytes() for n in files} == files
    assert not list(tmp_path.rglob("*.part*"))
    r = reassemble(tmp_path)  # joined before: nothing to do, every checksum checked again
    assert r.returncode == 0 and "joined from" not in r.stdout and "every file whole" in r.stdout


def test_a_damaged_part_is_named_and_nothing_is_joined(bw, tmp_path):
    fake_wheelhouse(tmp_path)
    bw.finish(tmp_path, 1000 / 2**20)
    part = tmp_path / "big-1.0-py3-none-any.whl.part003"
    part.write_bytes(b"\0" + part.read_bytes()[1:])
    r = reassemble(tmp_path)
    assert r.returncode == 1
    assert "reassemble: big-1.0-py3-none-any.whl: the joined parts have 5000 bytes and SHA-256" in r.stderr
    assert "(a part is damaged or from another build)" in r.stderr
    assert not (tmp_path / "big-1.0-py3-none-any.whl").exists() and part.exists()
    assert (tmp_path / "data" / "grid.bin").is_file()  # the other file is joined


def test_a_missing_part_is_named(bw, tmp_path):
    fake_wheelhouse(tmp_path)
    bw.finish(tmp_path, 1000 / 2**20)
    (tmp_path / "data" / "grid.bin.part001").unlink()
    r = reassemble(tmp_path)
    assert r.returncode == 1 and r.stderr == "reassemble: data/grid.bin: part(s) missing: data/grid.bin.part001\n"


def test_requirements_are_pinned_to_what_is_installed_here(bw):
    v = importlib.metadata.version
    assert bw.requirements(False, True) == [f"warp-lang=={v('warp-lang')}", f"numpy=={v('numpy')}"]
    assert bw.requirements(False, False) == ["warp-lang", "numpy"]
    full = bw.requirements(True, True)
    assert f"dask[distributed]=={v('dask')}" in full and f"pooch=={v('pooch')}" in full and len(full) >= 9


@pytest.mark.skipif(not (SHARED / "bluntfinq.bin").is_file(), reason=f"{SHARED} (../shared/data) is absent")
def test_the_blunt_fin_files_are_copied_with_their_checksums(bw, tmp_path):
    from warpvol.scene.datasets import DATA_SETS

    got = bw.copy_data(tmp_path / "data", ["bluntfin"])
    assert [p.name for p in got] == ["bluntfinxyz.bin", "bluntfinq.bin"]
    assert [bw.sha256(p) for p in got] == [f.sha256 for f in DATA_SETS["bluntfin"].files]
