"""Where a generated number came from: the ``_provenance`` block of every file under ``docs/data/``.

Every script that writes a file the documentation quotes stamps it through this module, so the pages can
say beside each table when, at which commit, by which command and (for timings) at what machine load its
numbers were made. The block, at the top level of the JSON document under :data:`KEY`::

    {"commit": "<40 hex digits>",   # the checkout's HEAD when the run started
     "dirty": false,                # files outside docs/ differed from that commit (null: not known)
     "command": "python scripts/...",
     "date": "2026-12-07 15:00:00 UTC",
     "timing": true,                # the file holds times measured on this machine
     "load": {"start": [1.2, 0.9, 0.8], "end": [1.4, 1.0, 0.8],    # 1 / 5 / 15 min; null: not known
              "during": [0.9, 1.6]},        # optional: lowest and highest 1-min load the run recorded
     "machine": {"cpu": "...", "cores": "2", "os": "Linux ..."},   # null: not known
     "note": "..."}                 # optional

A file written in parts (one paper's tables by several runs, ``write_tables_json``) keeps a block per part
under ``"parts"`` (same keys); :func:`of` gives the block of a part, or the file's own.

Examples
--------
>>> b = start("python scripts/x.py", timing=True)
>>> doc = stamp({"tables": {"t": {}}}, b, parts=["t"])
>>> sorted(of(doc, "t")) == sorted(FIELDS)
True
>>> of(doc, "t")["command"]
'python scripts/x.py'
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import shlex
import sys
from pathlib import Path

from warpvol.tools.machine import _git, cpu_cores, cpu_model, git_state

#: the key of the block in a generated JSON document
KEY = "_provenance"
#: the keys of a block (``note`` optional, ``parts`` only at the top level)
FIELDS = ("commit", "dirty", "command", "date", "timing", "load", "machine")
def load_now() -> list[float] | None:
    """The 1, 5 and 15 minute load averages, rounded to 0.01 (None where the system has none)."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        return None


def machine() -> dict[str, str]:
    return {"cpu": cpu_model(), "cores": cpu_cores(), "os": f"{platform.system()} {platform.release()}"}


def command_line(script: str | None = None, argv: list[str] | None = None) -> str:
    """The command as a user would type it: ``python scripts/NAME.py ARGS`` (``script``: the path to
    show; default the running script's path relative to the checkout)."""
    if script is None:
        p = Path(sys.argv[0]).resolve()
        top = _git("rev-parse", "--show-toplevel")
        try:
            script = str(p.relative_to(top)) if top else p.name
        except ValueError:
            script = p.name
    args = sys.argv[1:] if argv is None else list(argv)
    return " ".join(["python", script, *(shlex.quote(a) for a in args)])


def start(command: str, *, timing: bool = False, note: str | None = None) -> dict:
    """A block for a run starting now (commit, dirty, date, load at the start, machine); :func:`stamp`
    adds the load at the end. ``timing``: the run's file holds times measured on this machine."""
    commit, dirty = git_state()
    block = {"commit": commit or "unknown", "dirty": dirty, "command": command,
             "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC"),
             "timing": bool(timing), "load": {"start": load_now(), "end": None}, "machine": machine()}
    if note:
        block["note"] = note
    return block


def with_loads(block: dict, loads) -> dict:
    """``block`` with the lowest and highest of ``loads`` (1-min load averages the run recorded, e.g. one
    per measured point) as ``load.during``."""
    vals = [float(x) for x in loads if x is not None]
    if not vals:
        return block
    return dict(block, load=dict(block.get("load") or {}, during=[min(vals), max(vals)]))


def finish(block: dict) -> dict:
    """``block`` with the load at the end recorded (once)."""
    load = block.get("load")
    if isinstance(load, dict) and load.get("end") is None and "start" in load and block.get("machine") is not None:
        block = dict(block, load=dict(load, end=load_now()))
    return block


def stamp(doc: dict, block: dict, parts: list[str] | None = None, all_parts: list[str] | None = None) -> dict:
    """Put ``block`` (finished: :func:`finish`) into ``doc`` under :data:`KEY` and return ``doc``.
    ``parts``: the parts (tables) this run wrote, where the file is written in parts; the other parts keep
    their blocks, and a part of ``all_parts`` that had none takes the file's earlier block."""
    block = {k: v for k, v in finish(block).items() if k != "parts"}
    if parts is None:
        doc[KEY] = block
        return doc
    old = doc.get(KEY) if isinstance(doc.get(KEY), dict) else None
    known = dict((old or {}).get("parts") or {})
    if old:
        base = {k: v for k, v in old.items() if k != "parts"}
        for name in all_parts or []:
            known.setdefault(name, base)
    for name in parts:
        known[name] = block
    doc[KEY] = dict(block, parts=known)
    return doc


def write_json(path, doc: dict, block: dict, parts: list[str] | None = None,
               all_parts: list[str] | None = None, indent: int = 1) -> None:
    """Stamp ``doc`` (:func:`stamp`) and write it to ``path`` (NaN refused: JSON has none)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    stamp(doc, block, parts, all_parts)
    path.write_text(json.dumps(doc, indent=indent, allow_nan=False, default=float) + "\n")


def of(doc: dict, part: str | None = None) -> dict | None:
    """The block of ``part`` of ``doc`` where it has one, else the file's block (None: unstamped)."""
    top = doc.get(KEY) if isinstance(doc, dict) else None
    if not isinstance(top, dict):
        return None
    if part is not None and part in (top.get("parts") or {}):
        return top["parts"][part]
    return {k: v for k, v in top.items() if k != "parts"}


def _loads(load) -> str | None:
    if not isinstance(load, dict):
        return None
    vals = [v[0] for v in (load.get("start"), load.get("end")) if isinstance(v, (list, tuple)) and v]
    vals += [v for v in load.get("during") or [] if isinstance(v, (int, float))]
    if not vals:
        return None
    lo, hi = min(vals), max(vals)
    return f"{lo:.1f}" if round(lo, 1) == round(hi, 1) else f"{lo:.1f}-{hi:.1f}"


def describe(block: dict | None) -> str:
    """One sentence for a page: date, commit, command and, for a timing, the 1-minute load at the start
    and end on the machine's cores and CPU."""
    if not block:
        return "Provenance not recorded."
    commit = str(block.get("commit") or "unknown")
    short = commit[:10] if len(commit) >= 10 and all(c in "0123456789abcdef" for c in commit[:10]) else commit
    dirty = {True: " with local changes", None: ""}.get(block.get("dirty"), "")
    out = f"Generated {str(block.get('date', 'unknown'))[:10]} at commit {short}{dirty} by `{block.get('command') or 'unknown'}`"
    if block.get("timing"):
        mach = block.get("machine") or {}
        load = _loads(block.get("load"))
        cpu = mach.get("cpu") if mach.get("cpu") not in (None, "", "unknown") else None
        where = (f" on {mach.get('cores', '?')} cores" + (f" ({cpu})" if cpu else "")) if mach else ""
        out += f"; load (1 min) {load}{where}" if load else f"; machine load not recorded{where}"
    note = block.get("note")
    return out + "." + (f" {note}" if note else "")
