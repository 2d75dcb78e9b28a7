"""MkDocs hooks: the parts of the site that are generated, not written by hand.

Markers in a page's Markdown (HTML comments, so a page reads fine without the hook) are replaced
when the site is built:

``<!-- table: PAPER/TABLE -->``
    A reproduced table from ``docs/data/PAPER.json``, the JSON a reproduction script writes.
    Expected layout::

        {"source": "python scripts/reproduce_PAPER.py ...",      # how the file was made (optional)
         "tables": {"TABLE": {"title": "...",                    # optional
                              "columns": ["row", "paper", "warpvol", ...],
                              "rows": [[...], ...] or [{column: value}, ...],
                              "notes": "..."}}}                  # optional

    Until that file (or that table in it) exists the marker becomes a note saying the table is not
    generated yet. Every generated file carries a ``_provenance`` block (commit, command, date and, for
    timings, the machine's load: :mod:`warpvol.tools.provenance`); the table's (or the file's) block is
    shown under each table, figure and caption made from the file.
``<!-- bench: NAME -->``
    The table of a ``warpvol bench ... -o DIR`` run, ``DIR/table.json`` copied to
    ``docs/data/NAME.json``: one row per preset with its time, error and Pareto mark.
``<!-- preset: NAME -->``
    The stages of a shipped preset, read from its TOML file, with the parameters the preset sets.
``<!-- presets -->``
    Every shipped preset with its one-line description.
``<!-- cli: SUBCOMMAND -->``
    The ``--help`` text of ``warpvol SUBCOMMAND`` (``<!-- cli: -->`` for ``warpvol --help``),
    taken from the installed command when the site is built.

The Papers section of the navigation is built from the families' declarations (each paper's ``page``
and ``nav`` title in ``FAMILY["papers"]``, :func:`papers_nav`). The contributors' architecture page
(``docs/architecture.md``) is added to the navigation when the file exists, and ``<!-- architecture-link -->`` becomes a link to it (or a sentence saying it is not
written yet), so the site builds with ``--strict`` either way.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

DOCS = Path(__file__).resolve().parent
DATA = DOCS / "data"
ROOT = DOCS.parent

MARKER = re.compile(r"(?<!`)<!--\s*(table|bench|presets|preset|stage-params|cli|architecture-link|error-time|paper-figure|value)\b\s*:?\s*([^>]*?)\s*-->")


# -- formatting -----------------------------------------------------------------------------------
CODE_SPAN = re.compile(r"(`[^`\n]*`)")
#: characters of plain text that Markdown would read as markup: backslash-escaped
MD_SPECIAL = re.compile(r"([\\*_\[\]#|])")


def md_text(text: str) -> str:
    """Text from a JSON file as Markdown that shows it as written: ``*``, ``_``, ``[``, ``]``, ``#``, ``|``
    and ``\\`` escaped, ``<`` and ``>`` as entities, newlines as spaces; `code spans` (the notes' way of
    naming a constant) are kept as code.

    >>> print(md_text("5.6 s x pixels / (450*450*2*450), `a_b*c` <ok>"))
    5.6 s x pixels / (450\\*450\\*2\\*450), `a_b*c` &lt;ok&gt;
    """
    parts = CODE_SPAN.split(str(text).replace("\n", " "))
    return "".join(p if k % 2 else MD_SPECIAL.sub(r"\\\1", p).replace("<", "&lt;").replace(">", "&gt;")
                   for k, p in enumerate(parts))


def _cell(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        if v == 0:
            return "0"
        a = abs(v)
        # an exponent's minus sign must not break the number over two lines in a narrow column
        return f"{v:.3g}" if 1e-3 <= a < 1e5 else f'<span class="nb">{v:.2e}</span>'
    if isinstance(v, (list, tuple)):
        return ", ".join(_cell(x) for x in v)
    if isinstance(v, dict):
        return ", ".join(f"{k} {_cell(x)}" for k, x in v.items())
    return md_text(v)


#: a generated table with more columns than this is split into several, each repeating the key columns
MAX_COLUMNS = 10


def markdown_table(columns: list[str], rows: list) -> str:
    """A Markdown table; ``rows`` are lists in column order or dicts keyed by column. A table of more than
    :data:`MAX_COLUMNS` columns becomes several tables (one under the other), each repeating the leading
    key columns (up to two whose values are all text), so that each fits a page's width."""
    rows = [[r.get(c) for c in columns] if isinstance(r, dict) else (list(r) + [None] * len(columns))[:len(columns)]
            for r in rows]
    if len(columns) <= MAX_COLUMNS:
        return _one_table(columns, rows)
    keys = 0
    while keys < 2 and rows and all(isinstance(r[keys], str) for r in rows):
        keys += 1
    keys = max(keys, 1)
    rest = list(range(keys, len(columns)))
    n_parts = -(-len(rest) // (MAX_COLUMNS - keys))
    per = -(-len(rest) // n_parts)
    parts = []
    for k in range(n_parts):
        idx = list(range(keys)) + rest[k * per:(k + 1) * per]
        parts.append(_one_table([columns[i] for i in idx], [[r[i] for i in idx] for r in rows]))
    return "\n\n".join(parts)


def _one_table(columns: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(_cell(c) for c in columns) + " |", "|" + " --- |" * len(columns)]
    for vals in rows:
        lines.append("| " + " | ".join(_cell(v) for v in vals) + " |")
    return "\n".join(lines)


def _commits_since(commit: str) -> int | None:
    """How many commits the checkout the site is built from is ahead of ``commit`` (None: unknown)."""
    if not re.fullmatch(r"[0-9a-f]{7,40}", str(commit)):
        return None
    try:
        r = subprocess.run(["git", "rev-list", "--count", f"{commit}..HEAD"], cwd=ROOT, capture_output=True,
                           text=True, timeout=20)
    except (OSError, subprocess.SubprocessError):
        return None
    return int(r.stdout) if r.returncode == 0 and r.stdout.strip().isdigit() else None


def provenance_line(doc: dict, name: str, part: str | None = None) -> str:
    """Markdown (one italic paragraph): where ``docs/data/NAME.json`` (its ``part``) came from: date,
    commit (and how many commits the site's code is past it), command, and for a timing the load."""
    from warpvol.tools.provenance import describe, of

    block = of(doc, part)
    if block is None:
        return f"*From `docs/data/{name}.json`, which records no provenance (commit, command, date).*"
    since = _commits_since(block.get("commit", ""))
    after = f" ({since} commit{'s' if since > 1 else ''} before this site's code)" if since else ""
    head, _, rest = describe(block).partition(" by `")
    command, _, tail = rest.partition("`")
    return f"*From `docs/data/{name}.json`: {md_text(head)}{after} by `{command}`{md_text(tail)}*"


def _note(kind: str, title: str, text: str) -> str:
    body = "\n".join("    " + line for line in text.splitlines())
    return f'!!! {kind} "{title}"\n{body}\n'


# -- markers --------------------------------------------------------------------------------------
def paper_table(arg: str) -> str:
    paper, _, table = arg.partition("/")
    path = DATA / f"{paper}.json"
    missing = f"Not generated yet: table `{table}` of `docs/data/{paper}.json`, which the reproduction script " \
              f"in `scripts/` writes."
    if not path.is_file():
        return _note("note", f"{paper} {table}: not generated yet", missing)
    data = json.loads(path.read_text())
    t = (data.get("tables") or {}).get(table)
    if not t:
        return _note("note", f"{paper} {table}: not generated yet", missing)
    rows = t.get("rows") or []
    cols = t.get("columns") or (list(rows[0]) if rows and isinstance(rows[0], dict) else [])
    out = []
    if t.get("title"):
        out.append(f"**{_cell(t['title'])}**\n")
    out.append(markdown_table(cols, rows))
    if t.get("notes"):
        out.append(f"\n{md_text(t['notes'])}")
    out.append("\n" + provenance_line(data, paper, table))
    return "\n".join(out) + "\n"


BENCH_COLUMNS = [("pipeline", "preset"), ("status", "status"), ("total_s", "time [s]"), ("first_s", "first [s]"),
                 ("setup_s", "set-up [s]"), ("compile_s", "compile [s]"), ("rmse", "RMSE"), ("max_abs", "max abs"),
                 ("psnr", "PSNR [dB]"), ("pareto", "Pareto")]


def bench_table(arg: str) -> str:
    path = DATA / f"{arg}.json"
    if not path.is_file():
        return _note("note", f"{arg}: not generated yet",
                     f"Run `warpvol bench ... -o DIR` and copy `DIR/table.json` to `docs/data/{arg}.json`.")
    data = json.loads(path.read_text())
    rows = data.get("rows") or []
    present = [(k, h) for k, h in BENCH_COLUMNS if any(k in r for r in rows)]
    # spread over the timed renders, where the bench records it
    at = 3  # after the median time, in the order min, max
    for k, h in (("min_s", "min [s]"), ("max_s", "max [s]"), ("total_min_s", "min [s]"), ("total_max_s", "max [s]")):
        if any(k in r for r in rows) and h not in [x[1] for x in present]:
            present.insert(at, (k, h))
            at += 1
    table_rows = []
    for r in rows:
        row = [r.get(k) for k, _ in present]
        if r.get("status") not in (None, "ok"):
            row[present.index(("status", "status"))] = f"{r.get('status')}: {r.get('message') or ''}".strip(": ")
        table_rows.append(row)
    sc = data.get("scene") or {}
    head = []
    if sc:
        img = sc.get("image") or ["?", "?"]
        head.append(f"Scene `{sc.get('name')}`: {sc.get('tets')} tets, {sc.get('projection')} camera, "
                    f"{img[0]}x{img[1]} pixels; median over {rows[0].get('repeats', '?') if rows else '?'} "
                    f"timed renders after a warm-up render (`first [s]`).\n")
    meta = data.get("meta") or data.get("metadata")
    if isinstance(meta, dict) and meta:
        head.append(markdown_table(["", ""], [[k, v] for k, v in meta.items()]) + "\n")
    return "\n".join(h.rstrip("\n") + "\n\n" for h in head) + markdown_table([h for _, h in present], table_rows) + \
        "\n\n" + provenance_line(data, arg) + "\n"


def _preset_dir():
    from importlib import resources

    return resources.files("warpvol.presets")


def preset_stages(name: str) -> str:
    p = _preset_dir() / f"{name}.toml"
    if not p.is_file():
        raise ValueError(f"docs: preset marker names {name!r}, which is not a shipped preset")
    cfg = tomllib.loads(p.read_text())
    rows = []
    for k, st in enumerate(cfg.get("stages", []), 1):
        params = {key: v for key, v in st.items() if key != "stage"}
        rows.append([k, f"`{st['stage']}`", ", ".join(f"`{key} = {json.dumps(v)}`" for key, v in params.items())
                     or "(defaults)"])
    losses = cfg.get("known_losses", "").strip()  # a faithful preset's losses, as every report states them
    return (f"`{name}`: {cfg.get('description', '').strip()}\n\n"
            + (f"*Known losses:* {losses.removeprefix('known losses ')}\n\n" if losses else "")
            + markdown_table(["#", "stage", "set by the preset"], rows) + "\n")


def presets_list(_: str) -> str:
    rows = []
    for p in sorted(_preset_dir().iterdir(), key=lambda p: p.name):
        if p.name.endswith(".toml"):
            cfg = tomllib.loads(p.read_text())
            rows.append([f"`{p.name[:-5]}`", cfg.get("description", "").strip()])
    return markdown_table(["preset", "description"], rows) + "\n"


_HELP: dict[str, str] = {}


def _warpvol_command() -> list[str]:
    exe = Path(sys.executable).with_name("warpvol")
    if exe.is_file():
        return [str(exe)]
    found = shutil.which("warpvol")
    if found:
        return [found]
    raise RuntimeError("docs: the `warpvol` command is not installed in this environment (pip install -e .)")


def cli_help(sub: str) -> str:
    if sub not in _HELP:
        env = dict(os.environ, COLUMNS="100", NO_COLOR="1", TERM="dumb")
        args = _warpvol_command() + ([sub] if sub else []) + ["--help"]
        r = subprocess.run(args, capture_output=True, text=True, env=env, timeout=120, cwd=ROOT)
        if r.returncode != 0:
            raise RuntimeError(f"docs: `{' '.join(args)}` failed ({r.returncode}): {r.stderr.strip()}")
        _HELP[sub] = r.stdout.rstrip()
    return "```text\n$ warpvol " + (sub + " " if sub else "") + "--help\n" + _HELP[sub] + "\n```\n"


def stage_params(_: str = "") -> str:
    """Every registered stage with its parameters, from the stages' ``Param`` declarations."""
    from warpvol.pipeline import _load_builtin_stages
    from warpvol.stage import STAGES

    _load_builtin_stages()
    out = []
    for name in sorted(STAGES):
        cls = STAGES[name]
        out.append(f"### `{name}`\n\n{cls.summary}\n")
        if not cls.params:
            out.append("No parameters.\n")
            continue
        out.append("| parameter | type | default | allowed | meaning |\n| --- | --- | --- | --- | --- |")
        for p in cls.params:
            allowed = p.allowed()
            doc = p.doc + (f" (old name: `{'`, `'.join(p.aliases)}`)" if p.aliases else "")
            allowed = allowed.replace("|", "\\|")
            out.append(f"| `{p.name}` | {p.kind.__name__} | `{p.default!r}` | {allowed} | {doc.replace('|', chr(92) + '|')} |")
        out.append("")
    return "\n".join(out) + "\n"


def _architecture_exists() -> bool:
    return (DOCS / "architecture.md").is_file()


def architecture_link(_: str, page_url: str = "") -> str:
    if _architecture_exists():
        return "[Architecture](architecture.md): how the package is laid out and how a render flows through it."
    return "The architecture page (`docs/architecture.md`) is not written yet."


#: design width in pixels of a generated figure (drawn at twice that for sharp screens)
FIGURE_WIDTH_PX = 900


def error_time_plot(arg: str) -> str:
    """``<!-- error-time: NAME -->``: the bench run ``docs/data/NAME.json`` as a log-log figure of RMSE
    against run time, every preset labelled (:func:`warpvol.tools.report_html.error_time_figure`), as a
    PNG inside the page at its design width."""
    import base64
    import io

    path = DATA / f"{arg}.json"
    if not path.is_file():
        return _note("note", f"{arg}: not generated yet",
                     f"Run `warpvol bench ... -o DIR` and copy `DIR/table.json` to `docs/data/{arg}.json`.")
    from warpvol.tools.report_html import ERROR_TIME_SIZE, error_time_figure

    rows = json.loads(path.read_text()).get("rows") or []
    fig = error_time_figure(rows)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=2 * FIGURE_WIDTH_PX / ERROR_TIME_SIZE[0])
    data = base64.b64encode(buf.getvalue()).decode()
    return (f'<figure class="wv-figure"><img src="data:image/png;base64,{data}" width="{FIGURE_WIDTH_PX}" '
            f'alt="RMSE against run time of every preset, log-log ({arg})"><figcaption>Generated from '
            f'<code>docs/data/{arg}.json</code>: every preset that rendered, its median time and its RMSE; '
            'red: the Pareto front; where the bench recorded it, a bar from the fastest to the slowest timed '
            'render.</figcaption></figure>\n\n' + provenance_line(json.loads(path.read_text()), arg) + "\n")


def paper_figure(arg: str) -> str:
    """``<!-- paper-figure: PAPER -->``: ``docs/img/papers/PAPER.png`` (each preset of the paper beside the
    exact one: image over error map) with a caption of the numbers from ``docs/data/paper_figures.json``,
    both written by ``scripts/docs_paper_figures.py``."""
    path = DATA / "paper_figures.json"
    f = json.loads(path.read_text()).get(arg) if path.is_file() else None
    if not f or not (DOCS / "img" / "papers" / f"{arg}.png").is_file():
        return _note("note", f"{arg}: figure not generated yet",
                     f"Run `python scripts/docs_paper_figures.py --only {arg}`.")
    rows = "; ".join(f"`{r['pipeline']}` " + (f"RMSE {_cell(r['rmse'])}, max {_cell(r['max_abs'])}, "
                                                f"{_cell(r['cold_s'])} s" if r["status"] == "ok"
                                                else f"{r['status']}: {md_text(r['reason'] or '')}")
                     for r in f["rows"])
    return (f"![{md_text(arg)}: each preset's image over its error map against the exact reference]"
            f"(../img/papers/{arg}.png)\n\n"
            f"*To set beside the paper's {md_text(f['beside'])}: the same comparison rendered here, "
            f"`{f['scene']}` at {f['size']}x{f['size']} pixels, one render each (its time includes kernel "
            f"compilation and set-up): {rows}.*\n\n{provenance_line(json.loads(path.read_text()), 'paper_figures', arg)}\n")


def _rows_of(doc: dict, table: str) -> tuple[list[str], list[dict]]:
    t = (doc.get("tables") or {}).get(table)
    if t is None:
        raise ValueError(f"docs: no table {table!r}")
    rows = t.get("rows") or []
    cols = t.get("columns") or (list(rows[0]) if rows and isinstance(rows[0], dict) else [])
    return cols, [r if isinstance(r, dict) else dict(zip(cols, r)) for r in rows]


def select_rows(doc: dict, table: str, conditions: dict[str, str]) -> list[dict]:
    """The rows of ``table`` whose column values (as text) are those of ``conditions`` (a comma list: any
    of them)."""
    cols, rows = _rows_of(doc, table)
    bad = [c for c in conditions if c not in cols]
    if bad:
        raise ValueError(f"docs: table {table!r} has no column {bad[0]!r} (columns: {cols})")
    return [r for r in rows if all(_plain(r[c]) in v.split(",") for c, v in conditions.items())]


def _plain(v) -> str:
    return str(v) if not isinstance(v, float) or not v.is_integer() else str(int(v))


def quoted_value(arg: str) -> str:
    """``<!-- value: FILE/TABLE COLUMN=VALUE ... | COLUMN | FORMAT -->``: a number of a generated table
    quoted in prose, so the sentence says what the data say. The conditions (shell words; ``A,B``: any of
    them) must pick one row, or with ``FORMAT`` starting ``range `` any number of rows, shown as
    ``lowest-highest``. ``FORMAT`` is a Python format spec (default ``.3g``); ``,`` in it groups digits."""
    import shlex

    head, column, *fmt = [x.strip() for x in arg.split("|")]
    fmt = fmt[0] if fmt else ".3g"
    spread = fmt.startswith("range ")
    fmt = fmt.removeprefix("range ").strip()
    words = shlex.split(head)
    name, _, table = words[0].partition("/")
    doc = json.loads((DATA / f"{name}.json").read_text())
    conds = dict(w.split("=", 1) for w in words[1:])
    rows = select_rows(doc, table, conds)
    if not rows or (len(rows) > 1 and not spread):
        raise ValueError(f"docs: value marker {arg!r} picks {len(rows)} rows of {name}/{table}, not one")
    vals = [r[column] for r in rows]
    if any(not isinstance(v, (int, float)) for v in vals):
        raise ValueError(f"docs: value marker {arg!r}: {column!r} is not a number in every row: {vals}")
    lo, hi = format(min(vals), fmt), format(max(vals), fmt)
    return lo if lo == hi else f"{lo}-{hi}"


HANDLERS = {"value": quoted_value, "paper-figure": paper_figure, "table": paper_table, "bench": bench_table, "preset": preset_stages, "presets": presets_list,
            "cli": cli_help, "stage-params": stage_params, "architecture-link": architecture_link, "error-time": error_time_plot}


def expand(markdown: str) -> str:
    """Replace every marker in ``markdown`` (outside code blocks and `inline code`) by what it stands for."""
    out, in_code = [], False
    for line in markdown.splitlines(keepends=True):
        if line.lstrip().startswith("```"):
            in_code = not in_code
        if not in_code:
            line = MARKER.sub(lambda m: HANDLERS[m.group(1)](m.group(2)), line)
        out.append(line)
    return "".join(out)


# -- MkDocs events --------------------------------------------------------------------------------
def papers_nav() -> list[dict]:
    """The site's Papers section, from the families' declarations: ``[{title: page}]`` of every paper entry
    that gives a ``page`` and its ``nav`` title (:func:`warpvol.family.family_papers`), in the papers' order,
    each page once."""
    from warpvol.family import family_papers

    out, seen = [], set()
    for paper in family_papers():
        if paper.get("nav") and paper.get("page") and paper["page"] not in seen:
            seen.add(paper["page"])
            out.append({paper["nav"]: paper["page"]})
    return out


def on_config(config, **kwargs):
    """The Papers section from the families' declarations (:func:`papers_nav`, after the user guide), and the
    architecture page in the contributors' section when the file exists."""
    nav = config.get("nav") or []
    papers = {"Papers": papers_nav()}
    at = next((k for k, item in enumerate(nav) if isinstance(item, dict) and "Papers" in item), None)
    if at is not None:
        nav[at] = papers
    elif papers["Papers"]:
        guide = next((k for k, item in enumerate(nav) if isinstance(item, dict) and "User guide" in item), 0)
        nav.insert(guide + 1, papers)
    if not _architecture_exists():
        return config
    for item in nav:
        if isinstance(item, dict) and "Contributing" in item:
            section = item["Contributing"]
            if isinstance(section, list) and not any("architecture.md" in str(e) for e in section):
                section.append({"Architecture": "architecture.md"})
    return config


def on_page_markdown(markdown, page=None, config=None, files=None, **kwargs):
    # a page with generated tables gives its width to them: no table of contents beside the text column
    if page is not None and re.search(r"(?<!`)<!--\s*(table|bench)\b", markdown):
        hide = page.meta.setdefault("hide", [])
        if isinstance(hide, list) and "toc" not in hide:
            hide.append("toc")
    return expand(markdown)


# the package's docstrings are numpy style with Sphinx cross-reference roles (:class:`Camera`);
# mkdocstrings shows them as text, so the role is dropped and the name kept as code
ROLE = re.compile(r":(?:py:)?(?:class|meth|func|data|attr|mod|exc|obj|const):<code>~?([^<]*)</code>")


def _role(m: re.Match) -> str:
    name = m.group(1)
    return f"<code>{name.rsplit('.', 1)[-1] if m.group(0).count('~') else name}</code>"


def on_page_content(html, page=None, config=None, files=None, **kwargs):
    return zoomable_images(api_defaults(ROLE.sub(_role, html)))


IMG_ALONE = re.compile(r'(<a\b[^>]*>\s*)?(<img\b[^>]*\bsrc="(?!data:)([^"]+)"[^>]*>)')


def zoomable_images(html: str) -> str:
    """Every image file on a page (not already a link) becomes a link to itself, opened at full size on
    a click: a figure drawn wider than the text column stays legible."""
    return IMG_ALONE.sub(lambda m: m.group(0) if m.group(1) else f'<a class="zoom" href="{m.group(3)}">{m.group(2)}</a>',
                         html)


# -- API reference: the Default column from the live signature -------------------------------------
DOC_HEADING = re.compile(r'<h\d id="(warpvol(?:\.\w+)+)" class="doc doc-heading">')
PARAM_ROW = re.compile(r'(<tr class="doc-section-item">\s*<td>\s*<code>(\w+)</code>\s*</td>.*?)(<td>(?:(?!<td>).)*?</td>)'
                       r'(\s*</tr>)', re.S)


def _api_object(dotted: str):
    import importlib

    parts = dotted.split(".")
    obj = importlib.import_module(parts[0])
    for name in parts[1:]:
        obj = getattr(obj, name, None)
        if obj is None:
            return None
    return obj


def _param_table_section(section: str, dotted: str) -> str:
    """``section`` (one documented object's HTML, up to the next object) with its parameter table's
    Default column taken from the object's signature; a documented parameter the signature lacks is an
    error."""
    import html as _html
    import inspect

    start = section.find("<th>Default</th>")
    if start < 0:
        return section
    end = section.find("</table>", start)
    obj = _api_object(dotted)
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return section
    params = sig.parameters
    var_kw = any(p.kind is p.VAR_KEYWORD for p in params.values())

    def row(m: re.Match) -> str:
        name = m.group(2)
        p = params.get(name)
        if p is None:
            if var_kw:
                return m.group(0)
            raise ValueError(f"docs: {dotted} documents a parameter {name!r} that its signature "
                             f"{dotted}{sig} does not have")
        cell = "<em>required</em>" if p.default is p.empty else f"<code>{_html.escape(repr(p.default))}</code>"
        return f"{m.group(1)}<td>\n                {cell}\n            </td>{m.group(4)}"

    return section[:start] + PARAM_ROW.sub(row, section[start:end]) + section[end:]


def api_defaults(html: str) -> str:
    """Every mkdocstrings parameter table on a page with its Default column generated from the live
    signature (``inspect.signature``), so a default shows as the value it is (``'raycast'``, not the name
    of the constant written in the source) and no parameter borrows another's default."""
    heads = list(DOC_HEADING.finditer(html))
    if not heads:
        return html
    out, pos = [], 0
    for k, m in enumerate(heads):
        end = heads[k + 1].start() if k + 1 < len(heads) else len(html)
        out.append(html[pos:m.end()])
        out.append(_param_table_section(html[m.end():end], m.group(1)))
        pos = end
    out.append(html[pos:])
    return "".join(out)
