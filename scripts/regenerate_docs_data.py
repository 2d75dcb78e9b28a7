"""Regenerate the files under ``docs/data/`` that the documentation's tables and figures are made from.

Each file is written by one producer (a script of ``scripts/`` or ``warpvol bench``), which stamps it with
its ``_provenance`` block (commit, command, date, machine load: ``warpvol/tools/provenance.py``). This script
knows every producer, what it costs and what it writes, and runs the ones asked for one after the other,
printing progress::

    python scripts/regenerate_docs_data.py --list              # every file: command, cost, current stamp
    python scripts/regenerate_docs_data.py --only skip,paper_figures
    python scripts/regenerate_docs_data.py --all               # everything (hours on a 2-core machine)

Timings are taken on the machine that runs this: run it on a machine with nothing else running, and read
the load each file records. Costs are those seen on a shared 2-core machine where recorded; a producer
whose cost was never recorded says so, and this script prints each one's wall time as it ends.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "docs" / "data"
sys.path.insert(0, str(ROOT))

from warpvol.tools import provenance  # noqa: E402


@dataclass(frozen=True)
class Producer:
    name: str
    #: commands run in the checkout's root, in order ("python" is this interpreter, "warpvol" its command)
    commands: tuple[str, ...]
    #: what it costs, as seen (or "not recorded")
    cost: str
    #: expected seconds where recorded (for the total), else None
    seconds: float | None = None
    #: files it writes besides docs/data/NAME.json
    also: tuple[str, ...] = ()
    #: a file to copy to docs/data/NAME.json after the commands (a bench's table.json)
    copy_from: str | None = None


PRODUCERS = (
    Producer("roettger2002", ("python scripts/reproduce_roettger2002.py --json docs/data/roettger2002.json",),
             "not recorded"),
    Producer("guthe2002", ("python scripts/reproduce_guthe2002.py --json docs/data/guthe2002.json",),
             "Table 4 alone (--skip figs,table5) 56 s at load 11; the figures and Table 5 not recorded"),
    Producer("kraus2004", ("python scripts/reproduce_kraus2004.py --json docs/data/kraus2004.json",),
             "not recorded"),
    Producer("espinha2005", ("python scripts/reproduce_espinha2005.py --json docs/data/espinha2005.json",),
             "not recorded"),
    Producer("westermann1997", ("python scripts/reproduce_westermann1997.py --json docs/data/westermann1997.json",),
             "about 30 min (450x450, Blunt Fin, SPX and the fe stand-in)", 1800),
    Producer("validate_model", ("python scripts/validate_model.py --json docs/data/validate_model.json",),
             "minutes with the counter cache filled; about 75 min refilling it (29 configurations, 2 cores at "
             "load 8-15)", 4500),
    Producer("paper_figures", ("python scripts/docs_paper_figures.py",),
             "the renders alone 77 s at load ~15 (the cold times the file records), plus start-up and plotting", 120,
             also=("docs/img/papers/*.png",)),
    Producer("bench_concave", ("warpvol bench builtin:concave --pipelines all --repeats 3 --no-audit -o out/bench",),
             "19 s at load 0.9-1.1 on 2 cores (57 s at load 5.5-5.7, 1 min 44 s at load 9.5-10)", 60, copy_from="out/bench/table.json"),
    Producer("skip", ("python scripts/bench_skip.py --repeat 3 --docs",),
             "106 s at load 1.1-1.6 on 2 cores (2 views x 3 transfer functions, 4 rounds of 7 renderers)", 110),
    Producer("skip_small", ("python scripts/bench_skip.py --small --repeat 5 --docs",),
             "7 s at load 0.5 on 2 cores (4 views, 6 rounds of 3 renderers, the references cached; 10 s at load 2.5)", 10),
    Producer("march_lanes", ("python scripts/bench_march.py scenes/bluntfin_close.toml --tf dense --size 512 --repeat 3 "
                             "--lanes 0 --json docs/data/march_lanes.json",
                             "python scripts/bench_march.py scenes/bluntfin_close.toml --tf opaque --size 512 --repeat 3 "
                             "--lanes 0 --json docs/data/march_lanes.json",
                             "python scripts/bench_march.py scenes/bluntfin_close.toml --tf sparse --size 512 --repeat 3 "
                             "--lanes 0 --json docs/data/march_lanes.json"),
             "about 30 s at load 0.8 on 2 cores (3 views, 4 rounds of LANES=1 and the CPU's lanes; 2.5 min at load 7-9)",
             30),
    Producer("reference_pace", ("python scripts/bench_reference.py --rounds 3 --docs",),
             "12 s at load 0.6-0.8 on 2 cores (2 views, 512^2, 4 rounds of raycast and the reference; 40 s at load 5-5.6)", 15),
    Producer("pt_spans", ("python scripts/bench_pt.py --spans --repeat 3 --json docs/data/pt_spans.json",),
             "32 s at load 1.6 on 2 cores (2 views x 3 transfer functions, 512^2, 4 rounds of 3 renderers; "
             "about 12 min at load 5-7)", 40),
    Producer("scaling_shell", ("python scripts/bench_scaling.py --tf shell --kinds structured "
                               "--renderers raycast,harc_best,pt_best,vtk_pt",),
             "not recorded"),
    Producer("scaling", ("python scripts/bench_scaling.py",
                         "python scripts/bench_scaling.py --kinds '' --sizes 2048 --merge",
                         "python scripts/bench_scaling.py --tets 1e7 --kinds structured --sizes 256 --merge --timeout 900",
                         "python scripts/bench_scaling.py --renderers vsbuffer_best --merge --timeout 900",
                         "python scripts/bench_scaling.py --renderers vsbuffer_best --tets 1e7 --kinds structured "
                         "--sizes 256 --repeat 1 --merge --timeout 1200"),
             "224 s + 71 s + 357 s + about 2,400 s + more (the 10^7-tet vsbuffer_best point: 208 s first render, "
             "132 s a frame), 24 GB of memory", 3300, also=("docs/img/scaling.png",)),
)
BY_NAME = {p.name: p for p in PRODUCERS}


def stamp_of(name: str) -> dict | None:
    path = DATA / f"{name}.json"
    if not path.is_file():
        return None
    return provenance.of(json.loads(path.read_text()))


def listing() -> str:
    lines = []
    for p in PRODUCERS:
        b = stamp_of(p.name)
        now = "missing" if b is None and not (DATA / f"{p.name}.json").is_file() else (
            "no provenance" if b is None else f"{b.get('date', '?')[:10]} at {str(b.get('commit'))[:10]}")
        lines.append(f"{p.name}: docs/data/{p.name}.json" + (f" (+ {', '.join(p.also)})" if p.also else ""))
        lines.append(f"    cost: {p.cost}")
        lines.append(f"    now:  {now}")
        for c in p.commands:
            lines.append(f"    $ {c}")
        if p.copy_from:
            lines.append(f"    then {p.copy_from} -> docs/data/{p.name}.json")
    return "\n".join(lines)


def argv_of(command: str) -> list[str]:
    import shlex

    args = shlex.split(command)
    if args[0] == "python":
        args[0] = sys.executable
    elif args[0] == "warpvol":
        exe = Path(sys.executable).with_name("warpvol")
        args[0] = str(exe) if exe.is_file() else (shutil.which("warpvol") or "warpvol")
    return args


def run(p: Producer, k: int, n: int) -> bool:
    print(f"[{k}/{n}] {p.name}: expected {p.cost}", flush=True)
    t0 = time.time()
    for c in p.commands:
        print(f"[{k}/{n}] {p.name}: $ {c}", flush=True)
        r = subprocess.run(argv_of(c), cwd=ROOT)
        if r.returncode != 0:
            print(f"[{k}/{n}] {p.name}: FAILED (exit {r.returncode}) after {time.time() - t0:.0f} s", flush=True)
            return False
    if p.copy_from:
        shutil.copyfile(ROOT / p.copy_from, DATA / f"{p.name}.json")
    b = stamp_of(p.name)
    fresh = b is not None and b.get("date", "") >= time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(t0 - 1))
    print(f"[{k}/{n}] {p.name}: done in {time.time() - t0:.0f} s; "
          + (provenance.describe(b) if fresh else "WARNING: the file carries no provenance of this run"), flush=True)
    return fresh


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--list", action="store_true", help="list every file, its command, its cost and its stamp")
    ap.add_argument("--only", help="comma list of names (see --list)")
    ap.add_argument("--all", action="store_true", help="regenerate every file (hours)")
    a = ap.parse_args(argv)
    if a.list or not (a.only or a.all):
        print(listing())
        if not a.list:
            print("\nnothing run: name files with --only NAME[,NAME] or give --all")
        return 0
    names = [x for x in (a.only or "").split(",") if x] or list(BY_NAME)
    bad = [x for x in names if x not in BY_NAME]
    if bad:
        print(f"regenerate_docs_data: unknown name(s) {', '.join(bad)}; known: {', '.join(BY_NAME)}", file=sys.stderr)
        return 2
    todo = [BY_NAME[x] for x in names]
    known = sum(p.seconds or 0 for p in todo)
    unknown = [p.name for p in todo if p.seconds is None]
    print(f"{len(todo)} file(s); recorded costs add up to about {known / 60:.0f} min"
          + (f", plus {', '.join(unknown)} (cost not recorded)" if unknown else ""), flush=True)
    failed = [p.name for k, p in enumerate(todo, 1) if not run(p, k, len(todo))]
    if failed:
        print(f"not regenerated: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
