"""The documentation: every Python block of the README and of the user guide runs as written, and the
site builds with warnings as errors with no broken internal link or image (checked in headless
Chromium)."""

import re
import sys
from pathlib import Path

import matplotlib.pyplot
import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", ROOT / "docs" / "index.md", *sorted((ROOT / "docs" / "guide").glob("*.md"))]


def python_blocks():
    for path in DOCS:
        for k, code in enumerate(re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S)):
            yield pytest.param(path, code, id=f"{path.relative_to(ROOT)}[{k}]")


@pytest.mark.parametrize("path,code", list(python_blocks()))
def test_python_block_runs_as_written(path, code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a block writes its files into the current folder
    ns = {"__name__": "__main__"}
    exec(compile(code, f"{path.relative_to(ROOT)} (Python block)", "exec"), ns)
    matplotlib.pyplot.close("all")


def test_readme_has_python_blocks_and_stays_short():
    text = (ROOT / "README.md").read_text()
    assert "```python" in text and len(text.splitlines()) <= 220
    for word in ("this session", "next session", "issue ", "Issue "):
        assert word not in text, word


# the site fixture (mkdocs build --strict, once per session) is in tests/conftest.py


def test_site_builds_strict(site):
    assert (site / "index.html").is_file() and (site / "guide" / "scene-files" / "index.html").is_file()


def test_site_has_no_broken_links(site):
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import check_site
    finally:
        sys.path.pop(0)
    exe, why = check_site.find_browser()
    if exe is None:
        pytest.skip(f"no headless browser: {why}")
    report = check_site.crawl_site(site)
    assert len(report.pages) >= 10 and report.links_checked > 100
    assert report.broken == []
