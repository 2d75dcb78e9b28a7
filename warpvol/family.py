"""Family discovery: which packages bring stages and presets, found without a list kept by hand.

A *family* is a package with a ``stages`` subpackage (one module per stage, each registering itself with
:func:`warpvol.stage.register_stage`), optionally a ``presets`` folder of pipeline TOML files and a
``FAMILY`` dict in its ``__init__`` that declares it: ``title`` (the group heading of ``warpvol pipelines``),
``renderer`` (a renderer family imports no other one; ``tests/test_architecture.py`` holds it to that) and
``presets`` (preset name -> the short line ``warpvol pipelines`` shows).

Two mechanisms find them:

* the built-in families by a **package scan**: every folder of ``warpvol/`` with a ``stages`` package;
* any other package by an **entry point** in the group ``warpvol.families`` (``name = "package"``), which a
  distribution declares in its ``pyproject.toml`` (``[project.entry-points."warpvol.families"]``).

Examples
--------
>>> "warpvol.raycasting" in family_packages() and "warpvol.tables" in family_packages()
True
>>> family_declaration("warpvol.raycasting")["renderer"]
True
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
