"""The code is clean under the linter: ``ruff check`` with the rule set in ``pyproject.toml`` (pyflakes'
undefined names, unused imports and variables, and import order) passes on the whole repository."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def ruff() -> str | None:
    """The ruff of the environment that runs the tests (installed with the ``test`` extras)."""
    here = Path(sys.executable).parent / "ruff"
    return str(here) if here.exists() else shutil.which("ruff")


def test_ruff_check_passes():
    exe = ruff()
    if exe is None:
        pytest.skip("ruff is not installed (pip install -e '.[test]' installs it)")
    run = subprocess.run([exe, "check", "--no-cache", str(ROOT)], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, f"ruff check found problems (ruff check --fix repairs most):\n{run.stdout}{run.stderr}"


def test_contributing_layout_names_only_paths_that_exist():
    """docs/contributing.md's layout table describes the tree as it is: every path it names exists."""
    text = (ROOT / "docs" / "contributing.md").read_text()
    table = text[text.index("| path | what |"):text.index("## House rules")]
    paths = [line.split("`")[1] for line in table.splitlines() if line.startswith("| `")]
    assert len(paths) > 10
    missing = [p for p in paths if not (ROOT / p).exists()]
    assert not missing, f"docs/contributing.md names paths that do not exist: {missing}"
