"""What a reader sees, measured in headless Chromium at a 1280-px window: the demo page's error map at
its own size or larger (its labels legible), the documentation's tables readable (every column inside
the viewport or inside a scroll container), its figures at their design width or zoomable."""

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
VIEWPORT = {"width": 1280, "height": 900}


def _docs_module(name: str):
    """A module of ``docs/`` (``check_site``, ``hooks``), imported from there."""
    import importlib

    sys.path.insert(0, str(ROOT / "docs"))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.pop(0)


def _check_site():
    return _docs_module("check_site")


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

    hooks = _docs_module("hooks")
    texts = dict(_json_texts())
    texts["formula"] = "5.6 s x pixels read / (450*450*2*450) + 4.47 us; a_b_c, [x], <tag>, #1 & `k_1*2`"
    assert "westermann1997/table1/notes" in texts
    for key, text in texts.items():
        out = markdown.markdown(hooks.md_text(text), extensions=["tables"])
        assert not re.search(r"<(em|strong|a|h\d)\b", out), (key, out)
        shown = html.unescape(re.sub(r"<[^>]+>", "", out)).strip()
        assert shown == " ".join(text.replace("`", "").split()), key


#: the pages with wide generated tables and figures
WIDE_PAGES = ["performance/", "papers/westermann1997/", "papers/roettger2002/", "papers/guthe2002/",
              "papers/kraus2004/", "papers/espinha2005/"]

_TABLES_JS = """() => {
  const vw = document.documentElement.clientWidth;
  return Array.from(document.querySelectorAll('article table')).map((t, i) => {
    const r = t.getBoundingClientRect();
    let p = t.parentElement, scroller = null;
    while (p && p !== document.body) {
      const cs = getComputedStyle(p);
      if ((cs.overflowX === 'auto' || cs.overflowX === 'scroll') && p.scrollWidth > p.clientWidth + 1) {
        scroller = {visible: !/(transparent|rgba\\(0, 0, 0, 0\\))\\s*$/.test(cs.scrollbarColor || ''),
                    right: p.getBoundingClientRect().right, width: p.clientWidth};
        break;
      }
      p = p.parentElement;
    }
    const head = Array.from(t.rows[0] ? t.rows[0].cells : []).map(c => c.textContent.trim());
    return {i, right: r.right, width: r.width, vw, scroller, head};
  });
}"""


def _served(site):
    return _check_site()._serve(Path(site))


def test_every_table_is_readable_at_1280_px(site, browser):
    """Every table of the paper and performance pages lies inside the viewport, or inside a scroll container
    with a visible scroll bar that itself lies inside the viewport and shows most of the table: no column
    (the ratio, error and Pareto columns included) is cut off unseen."""
    server, base = _served(site)
    page = browser.new_page(viewport=VIEWPORT)
    try:
        cut, n = [], 0
        for pg in WIDE_PAGES:
            page.goto(f"{base}/{pg}", wait_until="load")
            for t in page.evaluate(_TABLES_JS):
                n += 1
                fits = t["right"] <= t["vw"] + 0.5
                # scrolled: with a visible bar, inside the viewport, and at most a fifth more than it shows
                sc = t["scroller"]
                scrolls = sc is not None and sc["visible"] and sc["right"] <= t["vw"] + 0.5 and \
                    t["width"] <= 1.2 * sc["width"]
                if not (fits or scrolls):
                    cut.append(f"{pg} table {t['i']} ({', '.join(t['head'][:3])}, ...): right edge {t['right']:.0f} px")
    finally:
        page.close()
        server.shutdown()
    assert n >= 27 and cut == [], cut


def _api_tables(page_html: str):
    """``(object, [(parameter, default shown)])`` for every parameter table of the API reference page."""
    import html
    import re

    heads = list(re.finditer(r'<h\d id="(warpvol(?:\.\w+)+)" class="doc doc-heading">', page_html))
    for k, m in enumerate(heads):
        seg = page_html[m.end():heads[k + 1].start() if k + 1 < len(heads) else len(page_html)]
        start = seg.find("<th>Default</th>")
        if start < 0:
            continue
        table = seg[start:seg.find("</table>", start)]
        rows = []
        for r in re.findall(r'<tr class="doc-section-item">.*?</tr>', table, re.S):
            cells = [html.unescape(re.sub(r"<[^>]+>", "", c)).strip() for c in re.findall(r"<td>.*?</td>", r, re.S)]
            rows.append((cells[0], cells[-1]))
        yield m.group(1), rows


def test_api_reference_parameters_exist_with_their_real_defaults(site):
    """The Python API page's parameter tables: every documented parameter is in the object's signature, and the
    Default column shows the signature's own default (``'raycast'``, ``None``, ``True``; ``required``)."""
    import importlib
    import inspect

    checked, wrong = 0, []
    for dotted, rows in _api_tables((site / "guide" / "python" / "index.html").read_text()):
        obj = importlib.import_module("warpvol")
        for part in dotted.split(".")[1:]:
            obj = getattr(obj, part)
        params = inspect.signature(obj).parameters
        for name, shown in rows:
            p = params.get(name)
            real = None if p is None else "required" if p.default is p.empty else repr(p.default)
            checked += 1
            if shown != real:
                wrong.append(f"{dotted}({name}): shown {shown!r}, signature {real!r}")
    assert checked >= 40 and wrong == [], wrong


def test_numpydoc_parameters_are_one_per_entry_and_in_the_signature():
    """Each public function's numpydoc Parameters name one parameter per entry (a grouped ``a, b`` entry
    gives all of them the first one's type and default in the rendered table) and only parameters its
    signature has."""
    import inspect
    import re

    bad = []
    for name in ("render", "compare", "builtin_scene", "load_scene", "presets", "set_cache_budget"):
        fn = getattr(__import__("warpvol"), name)
        params = inspect.signature(fn).parameters
        doc = inspect.getdoc(fn) or ""
        block = re.search(r"^Parameters\n-+\n(.*?)(?:^\w[^\n]*\n-+\n|\Z)", doc, re.S | re.M)
        for line in (block.group(1).splitlines() if block else []):
            if line and not line[0].isspace():  # an entry: "name : type" (its description is indented)
                names = [n.strip() for n in line.split(" : ")[0].split(",")]
                if len(names) > 1 or names[0] not in params:
                    bad.append(f"{name}: {line.strip()!r}")
    assert bad == [], bad


_IMAGES_JS = """() => Array.from(document.querySelectorAll('article img')).map(i => {
  const a = i.closest('a');
  const design = i.getAttribute('width') ? Number(i.getAttribute('width')) : i.naturalWidth;
  return {src: (i.getAttribute('src') || '').slice(0, 60), alt: i.alt, shown: i.getBoundingClientRect().width,
          design, zoom: !!a && a.href === i.currentSrc};
})"""


def test_figures_are_legible_at_the_page_width(site, browser):
    """Every figure on the performance and paper pages is shown at its design width (the width it was drawn
    for), or opens at full size on a click; the performance page has the error-against-time figure and each
    paper page our renders and error maps of its presets."""
    server, base = _served(site)
    page = browser.new_page(viewport=VIEWPORT)
    try:
        small, alts, paper_images = [], [], set()
        for pg in WIDE_PAGES:
            page.goto(f"{base}/{pg}", wait_until="load")
            for im in page.evaluate(_IMAGES_JS):
                alts.append(im["alt"])
                if "img/papers/" in im["src"]:
                    paper_images.add(pg)
                if im["shown"] + 0.5 < im["design"] and not im["zoom"]:
                    small.append(f"{pg} {im['src']}: shown {im['shown']:.0f} px of {im['design']} px, no zoom")
    finally:
        page.close()
        server.shutdown()
    assert any(a.startswith("RMSE against run time of every preset") for a in alts), alts
    assert paper_images == {pg for pg in WIDE_PAGES if pg.startswith("papers/")}  # ours beside each paper's figure
    assert small == [], small
