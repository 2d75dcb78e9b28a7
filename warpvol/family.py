"""Family discovery: which packages bring stages and presets, found without a list kept by hand.

A *family* is a package with a ``stages`` subpackage (one module per stage, each registering itself with
:func:`warpvol.stage.register_stage`), optionally a ``presets`` folder of pipeline TOML files and a
``FAMILY`` dict in its ``__init__`` that declares it, once:

``title``
    the family's name;
``renderer``
    a renderer family imports no other one (``tests/test_architecture.py`` holds it to that);
``papers``
    its papers (or other groups of presets), each a dict: ``title`` (the group heading of ``warpvol
    pipelines``; entries of one title form one group), ``order`` (where it sorts among every family's
    entries: ``(0, k)`` the exact presets, ``(1, k)`` cell projection as VTK does it, ``(2, year)`` the
    papers), ``presets`` (preset name -> the short line ``warpvol pipelines`` shows), ``table`` (what the
    presets are, in the README's and the presets page's table), ``purpose`` (that table's first column, default
    ``title``), ``page`` (its docs page under ``docs/``; with ``nav``, the page's title in the site's Papers
    section), ``name`` (its row in the architecture page's table, default ``purpose``), ``exact`` (its presets
    promise the exact reference to float32: the tests that sweep every exact preset take them) and ``code`` (its
    files: ``host``, ``stages``, ``kernels``, ``reproduce``; paths under ``warpvol/`` unless they start with
    ``kernels/`` or ``scripts/``, ``*`` patterns allowed);
``tolerances``
    the tolerance rows of its presets (``tests/tolerances.py`` gathers them): row -> bounds (``rmse``,
    ``max_abs``, ...) and ``why``; ``tolerance_rows`` maps a preset (or ``preset/variant``) to its row where
    the row is not its name.

A family that declares ``presets`` instead of ``papers`` is one group titled by its ``title``.

Two mechanisms find the families:

* the built-in families by a **package scan**: every folder of ``warpvol/`` with a ``stages`` package;
* any other package by an **entry point** in the group ``warpvol.families`` (``name = "package"``), which a
  distribution declares in its ``pyproject.toml`` (``[project.entry-points."warpvol.families"]``).

Examples
--------
>>> "warpvol.raycasting" in family_packages() and "warpvol.tables" in family_packages()
True
>>> family_declaration("warpvol.raycasting")["renderer"]
True
>>> [p["title"] for p in family_papers()][:2]
['exact and fast', 'exact and fast']
>>> family_tolerances()[1]["raycast"]
'raycast/fp32'
"""

from __future__ import annotations

import functools
import importlib
import sys
from importlib import metadata, resources
from pathlib import Path

#: the entry-point group a package outside warpvol declares itself in
ENTRY_POINT_GROUP = "warpvol.families"
_ROOT = Path(__file__).resolve().parent


@functools.lru_cache(maxsize=8)
def _family_packages(path: tuple[str, ...]) -> tuple[str, ...]:
    builtin = sorted(f"warpvol.{p.parent.parent.name}" for p in _ROOT.glob("*/stages/__init__.py"))
    extra = sorted({ep.value for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)} - set(builtin))
    return tuple(builtin + extra)


def family_packages() -> list[str]:
    """Every family's package: the built-in ones (a scan of ``warpvol/``), then those of the entry points."""
    return list(_family_packages(tuple(sys.path)))


def family_declaration(package: str) -> dict:
    """The ``FAMILY`` dict a family's ``__init__`` declares (empty when it declares none)."""
    return dict(getattr(importlib.import_module(package), "FAMILY", {}) or {})


def load_family_stages() -> None:
    """Import every family's ``stages`` package (each registers its stage modules)."""
    for package in family_packages():
        importlib.import_module(f"{package}.stages")


def family_preset_files() -> dict[str, object]:
    """``name -> file`` of the preset TOML files in the families' own ``presets`` folders."""
    out = {}
    for package in family_packages():
        if package == "warpvol.presets":
            continue
        try:
            folder = resources.files(package) / "presets"
        except ModuleNotFoundError:
            continue
        if folder.is_dir():
            out.update({p.name[:-5]: p for p in folder.iterdir() if p.name.endswith(".toml")})
    return out


#: ``order`` of a paper entry that gives none (after every built-in entry)
LAST = (9, 0)


def family_papers() -> list[dict]:
    """Every family's paper entries (``FAMILY["papers"]``; a family that declares only ``presets`` is one
    entry titled by its ``title``), each with ``family`` (its package) added, sorted by ``order`` (then by
    family, stably)."""
    out = []
    for package in family_packages():
        decl = family_declaration(package)
        papers = decl.get("papers")
        if papers is None and decl.get("presets"):
            papers = ({"title": decl.get("title", package), "presets": decl["presets"]},)
        out += [{**paper, "family": package} for paper in papers or ()]
    return sorted(out, key=lambda p: tuple(p.get("order", LAST)))


def family_tolerances() -> tuple[dict[str, dict], dict[str, str]]:
    """``(rows, preset_rows)``: every family's tolerance rows (row -> its bounds and ``why``) and which row a
    preset (or ``preset/variant``) takes where it is not the preset's name. A row two families declare is an
    error naming both."""
    rows, owner, preset_rows = {}, {}, {}
    for package in family_packages():
        decl = family_declaration(package)
        for key, row in (decl.get("tolerances") or {}).items():
            if key in rows:
                raise ValueError(f"tolerance row {key!r} is declared by {owner[key]} and by {package}")
            rows[key], owner[key] = dict(row), package
        preset_rows.update(decl.get("tolerance_rows") or {})
    return rows, preset_rows
