"""README.md's and docs/guide/presets.md's preset tables and docs/architecture.md's table of where each paper
lives are what scripts/preset_tables.py generates from the families' declarations, and the preset table names
every shipped preset once."""

import importlib.util
from pathlib import Path

from warpvol.families import PRESET_TABLE, preset_table
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
    named = [p for _, _, presets, _ in preset_table() for p in presets]
    assert sorted(named) == sorted(n for n, _ in list_presets())
    assert PRESET_TABLE == preset_table()  # the name it had when the table was kept by hand


def test_the_stage_page_is_generated_from_every_stages_params():
    """docs/guide/stages.md's tables come from the stages' Param declarations: every stage and parameter."""
    import sys

    from warpvol.pipeline import _load_builtin_stages
    from warpvol.stage import STAGES

    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import hooks
    finally:
        sys.path.pop(0)
    assert "<!-- stage-params -->" in (ROOT / "docs" / "guide" / "stages.md").read_text()
    text = hooks.stage_params("")
    _load_builtin_stages()
    for name, cls in STAGES.items():
        assert f"### `{name}`" in text
        assert all(f"| `{p.name}` |" in text for p in cls.params), name
    assert "(old name: `t_min`)" in text
