"""Reproduce Espinha & Celes 2005, Tables 2 and 3 and Fig. 8, on the emulated GPU.

Tables 2/3: VICP (``weiler2003_vicp``), HARC with full pre-integration (``espinha2005_full``) and HARC
with partial pre-integration (``espinha2005_partial``) with the scene's TF resampled to 10 and to 255
linear segments, on the Blunt Fin and the LOX Post at 512x512, over several viewpoints (the scene's
camera turned about its target); min and max emulated tets/s (tets / wall time of the emulation on
this machine's CPU) and speeds relative to HARC-Full, beside the paper's GeForce 6800 GT numbers.
The counters of each render (cells visited, fragment-program steps, fragments, peel passes) are
written to the JSON so the throughput model (issue 8) can turn them into modelled tets/s.

Fig. 8: full vs partial pre-integration on a mesh whose cells differ in size by a factor ~6e4 (the
built-in ``stiff`` scene): images and RMSE against the exact reference.

The computations are in ``warpvol.reproduce.espinha2005`` (``method_runs``, ``vicp_runs``, ``table2``,
``table3``, ``fig8``).

Usage::

    ./run.sh python scripts/reproduce_espinha2005.py [--size 512] [--views 3] [--scenes bluntfin loxpost]
        [--json docs/data/espinha2005.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from warpvol.reproduce import espinha2005 as e
from warpvol.reproduce.common import add_json_option, format_table, write_tables_json
from warpvol.tools import provenance

ROOT = Path(__file__).resolve().parents[1]


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--views", type=int, default=3)
    ap.add_argument("--scenes", nargs="+", default=["bluntfin", "loxpost"])
    ap.add_argument("--fig8-size", type=int, default=256)
    ap.add_argument("--skip-tables", action="store_true", help="Fig. 8 only")
    ap.add_argument("--vicp-only", action="store_true", help="only the modelled VICP rows of Table 2")
    ap.add_argument("--out", default=str(ROOT / "out" / "espinha2005"))
    ap.add_argument("--device", default="cpu")
    add_json_option(ap)
    args = ap.parse_args(argv)
    prov = provenance.start(provenance.command_line("scripts/reproduce_espinha2005.py", argv), timing=True)
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    result, tables = {"size": args.size, "views": args.views}, {}
    scenes = {}
    if not args.skip_tables:
        scenes = {name: e.paper_scene(name, args.size) for name in args.scenes}
        for name, sc in scenes.items():
            log(f"{name}: {sc.mesh.n_tets} tets, {args.size}x{args.size}, {args.views} viewpoints")
    if args.vicp_only:
        result["vicp"] = e.vicp_runs(scenes, args.views, device=args.device, log=log)
        tables["table2"] = e.table2({}, result["vicp"], args.size)
        (out / "vicp.json").write_text(json.dumps(result, indent=2, default=float))
    else:
        tables["fig8"] = e.fig8(args.fig8_size, out=out, device=args.device)
        if not args.skip_tables:
            result["tables"] = e.method_runs(scenes, args.views, device=args.device, log=log)
            result["vicp"] = e.vicp_runs(scenes, args.views, device=args.device, log=log)
            tables["table2"] = e.table2(result["tables"], result["vicp"], args.size)
            tables["table3"] = e.table3(result["tables"], args.size)
        (out / "result.json").write_text(json.dumps(result, indent=2, default=float))
    for t in tables.values():
        print(format_table(t), flush=True)
    if args.json:
        cmd = " ".join(["python scripts/reproduce_espinha2005.py", *(argv if argv is not None else sys.argv[1:])])
        write_tables_json(args.json, cmd, tables, prov)
    return 0


if __name__ == "__main__":
    sys.exit(main())
