"""What a reader sees, measured in headless Chromium at a 1280-px window: the demo page's error map at
its own size or larger (its labels legible), the documentation's tables readable (every column inside
the viewport or inside a scroll container), its figures at their design width or zoomable."""

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
VIEWPORT = {"width": 1280, "height": 900}


def _check_site():
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import check_site
    finally:
        sys.path.pop(0)
    return check_site


@pytest.fixture(scope="module")
def browser():
    exe, why = _check_site().find_browser()
    if exe is None:
        pytest.skip(f"no headless browser: {why}")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=_check_site().BROWSER_ARGS)
        yield b
        b.close()


def test_demo_error_map_is_shown_at_its_own_size(tmp_path, browser, capsys):
    from warpvol.cli import main
    from warpvol.metrics import ERROR_PNG_TEXT_PX

    assert main(["demo", "--size", "32", "-o", str(tmp_path), "--quiet"]) == 0
    capsys.readouterr()
    page = browser.new_page(viewport=VIEWPORT)
    page.goto((tmp_path / "index.html").as_uri(), wait_until="load")
    sizes = page.evaluate("""() => Array.from(document.images).map(i => [i.getAttribute('src'),
        i.getBoundingClientRect().width, i.naturalWidth])""")
    page.close()
    shown = {src: (w, natural) for src, w, natural in sizes}
    w, natural = shown["error.png"]
    assert natural > 0 and w >= natural, shown  # not shrunk: its text stays ERROR_PNG_TEXT_PX high
    assert ERROR_PNG_TEXT_PX >= 12


def _hooks():
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import hooks
    finally:
        sys.path.pop(0)
    return hooks


def _json_texts():
    import json

    for path in sorted((ROOT / "docs" / "data").glob("*.json")):
        tables = json.loads(path.read_text()).get("tables") or {}
        for name, t in tables.items():
            for key in ("title", "notes"):
                if isinstance(t.get(key), str):
                    yield f"{path.stem}/{name}/{key}", t[key]


def test_text_from_json_shows_as_written_in_markdown():
    """Notes and titles of the generated tables (and a formula with ``*``) come out of Markdown as their own
    text: no emphasis, no link, no HTML from plain characters; `code` stays code."""
    import html
    import re

    import markdown

    hooks = _hooks()
    texts = dict(_json_texts())
    texts["formula"] = "5.6 s x pixels read / (450*450*2*450) + 4.47 us; a_b_c, [x], <tag>, #1 & `k_1*2`"
    assert "westermann1997/table1/notes" in texts
    for key, text in texts.items():
        out = markdown.markdown(hooks.md_text(text), extensions=["tables"])
        assert not re.search(r"<(em|strong|a|h\d)\b", out), (key, out)
        shown = html.unescape(re.sub(r"<[^>]+>", "", out)).strip()
        assert shown == " ".join(text.replace("`", "").split()), key
