"""The families' declarations (``FAMILY`` in each family's ``__init__``) are the one place a paper is described:
every shipped preset belongs to one paper entry and has a tolerance row, every file a paper names exists and
every module of a renderer family is named by some paper (so any paper's code is one look-up away), and the
site's Papers section is built from the declared pages."""

import sys
from pathlib import Path

from tolerances import EXACT_PRESETS, PRESET_ROWS, TOLERANCES, VARIANT_ROWS, preset_tolerance
from warpvol.family import family_declaration, family_packages, family_papers, family_tolerances
from warpvol.pipeline import list_presets

ROOT = Path(__file__).resolve().parents[1]
BUILTIN = [p for p in family_packages() if p.startswith("warpvol.")]


def _hooks():
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import hooks
    finally:
        sys.path.pop(0)
    return hooks


def _declared_path(path: str) -> Path:
    return ROOT / path if path.split("/")[0] in ("kernels", "scripts") else ROOT / "warpvol" / path


def test_every_shipped_preset_belongs_to_one_paper_and_has_a_tolerance_row():
    named = [n for p in family_papers() for n in p.get("presets", {})]
    assert sorted(named) == sorted(n for n, _ in list_presets())
    for name in named:
        assert set(preset_tolerance(name)) & {"rmse", "max_abs"}, name
    rows, preset_rows = family_tolerances()
    assert set(preset_rows.values()) <= set(TOLERANCES) and set(rows) <= set(TOLERANCES)
    assert set(PRESET_ROWS.values()) | set(VARIANT_ROWS.values()) <= set(rows)
    assert all(row.get("why") for row in rows.values())  # each row says why it is what it is
    # the exact presets, from the entries declared exact, in the papers' order
    assert EXACT_PRESETS == ("raycast", "harc_best", "pt_best", "vsbuffer_best")


def test_every_file_a_paper_names_exists():
    missing = []
    for p in family_papers():
        if p["family"] not in BUILTIN:
            continue
        for kind, paths in (p.get("code") or {}).items():
            assert kind in ("host", "stages", "kernels", "reproduce"), (p["title"], kind)
            missing += [f"{p['title']}: {kind} {path}" for path in paths
                        if not list(_declared_path(path).parent.glob(_declared_path(path).name))]
        if p.get("page"):
            assert (ROOT / "docs" / p["page"]).is_file(), p["page"]
    assert missing == []


def test_every_module_of_a_renderer_family_is_named_by_a_paper():
    """A newcomer finds any paper's code in one step (the architecture page's table): no module of a renderer
    family's folder or its stages is left out of every paper's ``code``."""
    named = set()
    for p in family_papers():
        for paths in (p.get("code") or {}).values():
            for path in paths:
                named.update(q.resolve() for q in _declared_path(path).parent.glob(_declared_path(path).name))
    unnamed = []
    for pkg in BUILTIN:
        if not family_declaration(pkg).get("renderer"):
            continue
        folder = ROOT / Path(*pkg.split("."))
        unnamed += [str(f.relative_to(ROOT)) for f in sorted([*folder.glob("*.py"), *folder.glob("stages/*.py")])
                    if f.name != "__init__.py" and f.resolve() not in named]
    assert unnamed == [], "name these files in their paper's FAMILY['papers'][...]['code']"


def test_the_sites_papers_section_is_built_from_the_declared_pages():
    nav = _hooks().papers_nav()
    pages = [page for item in nav for page in item.values()]
    assert sorted(pages) == sorted(f"papers/{f.name}" for f in (ROOT / "docs" / "papers").glob("*.md"))
    assert nav[0] == {"Westermann & Ertl 1997": "papers/westermann1997.md"}
    assert "papers/" not in (ROOT / "mkdocs.yml").read_text()  # no hand-written copy of the list
    config = {"nav": [{"Home": "index.md"}, {"User guide": []}, {"Contributing": [{"Contributing": "c.md"}]}]}
    assert _hooks().on_config(config)["nav"][2] == {"Papers": nav}
