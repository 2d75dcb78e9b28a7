"""The shipped presets grouped by purpose, as ``warpvol pipelines`` lists them: exact and fast, cell
projection as VTK does it, then each paper's faithful reproduction, every preset with a short line.

Nothing here is kept by hand: every family declares its papers in its own folder (``FAMILY["papers"]``,
:mod:`warpvol.family`), and the groups, the preset tables of README.md and docs/guide/presets.md
(``scripts/preset_tables.py``) and the architecture page's table of where each paper lives are built from
those declarations.

Examples
--------
>>> groups = preset_groups()
>>> groups[0][0], [name for name, _, _ in groups[0][1]][:2]
('exact and fast', ['raycast', 'harc_best'])
>>> preset_table()[0][:3]
('exact and fast', None, ('raycast',))
"""

from __future__ import annotations

from warpvol.family import family_papers
from warpvol.pipeline import list_presets

#: columns of ``warpvol pipelines`` lines
PIPELINES_WIDTH = 100


def preset_families() -> tuple[tuple[str, dict[str, str]], ...]:
    """``((group, {preset: short line}), ...)``: the families' papers with presets, those of one title
    together, in the papers' order."""
    groups: dict[str, dict[str, str]] = {}
    for paper in family_papers():
        if paper.get("presets"):
            groups.setdefault(paper["title"], {}).update(paper["presets"])
    return tuple(groups.items())


def preset_table() -> tuple[tuple[str, str | None, tuple[str, ...], str], ...]:
    """The rows of the preset tables of README.md and docs/guide/presets.md (``scripts/preset_tables.py``
    writes both): ``(purpose, paper page under docs/papers/ or None, presets, what they are)``, one per paper
    entry with presets."""
    return tuple((p.get("purpose", p["title"]), p["page"].removeprefix("papers/") if p.get("page") else None,
                  tuple(p["presets"]), p.get("table", ""))
                 for p in family_papers() if p.get("presets"))


def __getattr__(name: str):
    # the names these tables had when they were kept here by hand
    if name == "PRESET_FAMILIES":
        return preset_families()
    if name == "PRESET_TABLE":
        return preset_table()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def preset_groups() -> list[tuple[str, list[tuple[str, str, str]]]]:
    """``(group, [(preset, short line, full description)])`` of every shipped preset: the groups of the
    families' declarations (:func:`preset_families`), then "other" for presets they do not name (short line:
    the description cut)."""
    full = dict(list_presets())
    groups, named = [], set()
    for family, items in preset_families():
        rows = [(n, short, full[n]) for n, short in items.items() if n in full and n not in named]
        named.update(items)
        if rows:
            groups.append((family, rows))
    other = [(n, d, d) for n, d in full.items() if n not in named]
    if other:
        groups.append(("other", other))
    return groups


def fit_line(text: str, width: int = PIPELINES_WIDTH) -> str:
    """``text`` cut to ``width`` columns (ending in ``...`` when cut)."""
    return text if len(text) <= width else text[:width - 3].rstrip() + "..."
