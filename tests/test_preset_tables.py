"""README.md's and docs/guide/presets.md's preset tables are what scripts/preset_tables.py generates from
warpvol.families.PRESET_TABLE, and that list names every shipped preset once."""

import importlib.util
from pathlib import Path

from warpvol.families import PRESET_TABLE
from warpvol.pipeline import list_presets

ROOT = Path(__file__).resolve().parents[1]


def _script():
    spec = importlib.util.spec_from_file_location("preset_tables", ROOT / "scripts" / "preset_tables.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_preset_tables_are_what_the_script_generates(capsys):
    assert _script().main(["--check"]) == 0, capsys.readouterr().out + " (run python scripts/preset_tables.py)"


def test_the_preset_table_names_every_shipped_preset_once():
    named = [p for _, _, presets, _ in PRESET_TABLE for p in presets]
    assert sorted(named) == sorted(n for n, _ in list_presets())
