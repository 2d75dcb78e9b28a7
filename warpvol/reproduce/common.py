"""What the reproduction modules share."""

from __future__ import annotations

from warpvol import model
from warpvol.gpu.counters import Counters
from warpvol.model import load_profile
from warpvol.tools import provenance


def counted(fn, *a, **kw) -> dict:
    with Counters() as c:
        fn(*a, **kw)
    return c.as_dict()


# -- tables as data: what the scripts print and write with ``--json`` (read by docs/hooks.py) ---------
def table(title: str, columns: list[str], rows: list[list], notes: str = "") -> dict:
    """A reproduced table: ``rows`` are lists in ``columns`` order (numbers, strings or None)."""
    for r in rows:
        if len(r) != len(columns):
            raise ValueError(f"table {title!r}: a row has {len(r)} values for {len(columns)} columns: {r!r}")
    return {"title": title, "columns": list(columns), "rows": [list(r) for r in rows], "notes": notes}


def _plain(v):
    """JSON-safe value: numpy scalars as Python numbers, non-finite floats as strings."""
    import math

    if hasattr(v, "item") and not isinstance(v, (list, tuple, dict)):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    return v


def format_table(t: dict) -> str:
    """A table as the Markdown the scripts print (numbers to 4 significant digits)."""
    def cell(v):
        if v is None:
            return "-"
        if isinstance(v, float):
            return f"{v:.4g}"
        if isinstance(v, int) and not isinstance(v, bool):
            return f"{v:,}"
        return str(v)

    lines = [f"\n{t['title']}", "| " + " | ".join(t["columns"]) + " |", "|" + " --- |" * len(t["columns"])]
    lines += ["| " + " | ".join(cell(v) for v in r) + " |" for r in t["rows"]]
    if t.get("notes"):
        lines.append(t["notes"])
    return "\n".join(lines)


def write_tables_json(path, source: str, tables: dict, prov: dict | None = None) -> None:
    """``{"source": ..., "tables": {name: table}, "_provenance": ...}``, the layout docs/hooks.py reads
    (``<!-- table: PAPER/NAME -->``). A file that exists is updated: tables of the same name are replaced,
    others kept (a run of part of a script keeps the rest), each with its own provenance block
    (:mod:`warpvol.tools.provenance`). ``prov``: the block the run started with
    (:func:`~warpvol.tools.provenance.start`; default: one started now, a timing)."""
    import json
    from pathlib import Path


    if prov is None:
        prov = provenance.start(source, timing=True)
    path = Path(path)
    data = json.loads(path.read_text()) if path.is_file() else {}
    old = data.get("tables") or {}
    earlier = list(old)
    for name, t in tables.items():
        t = dict(t, rows=[_plain(list(r)) for r in t["rows"]], source=source)
        old[name] = t
    data["source"] = source
    data["tables"] = old
    provenance.write_json(path, data, prov, parts=list(tables), all_parts=earlier)


def calibrations(*profiles: str) -> str:
    """The calibrated constants of GPU profiles, each with the paper row it was fitted on, as the
    profile's TOML states them: the rows of a table that were used to fit are calibrations, not checks."""

    out = []
    for name in profiles:
        p = load_profile(name)
        for group in (p.rates, p.host):
            for key, e in group.items():
                if str(e["source"]).lower().startswith("calibrated"):
                    out.append(f"`{name}.{key}` = {e['value']:.4g} ({e['source']})")
    return ("Calibrated constants: " + "; ".join(out) + ".") if out else \
        f"No constant of {', '.join(profiles)} is calibrated on a paper's row."


def modelled_seconds(report: dict, profile: str):
    """Modelled seconds of a render's counters on a GPU profile (:mod:`warpvol.model`), or None (said
    on stderr) when the profile lacks a capability the counted work needs."""
    import sys


    p = model.load_profile(profile)
    try:
        for key, c in report["counters"].items():
            model.check_caps(p, key, model.counter_needs(c))
    except Exception as e:  # noqa: BLE001 - ConfigError naming the missing capability
        print(f"    (not modelled on {profile}: {e})", file=sys.stderr)
        return None
    return model.model_report(report["counters"], p)["total"]


def add_json_option(ap) -> None:
    ap.add_argument("--json", metavar="PATH", default=None,
                    help="also write the printed tables as data (docs/data/PAPER.json is what the docs read)")
