"""Reproduce Kraus, Qiao & Ebert 2004 ("Projected tetrahedra without rendering artifacts"):

* Table 1: total time per frame (sorting included) of the basic pre-integrated PT algorithm (i) and
  the overhead of each enhancement -- perspective interpolation (ii), HILO lookup textures (iii),
  logarithmic lookup (iv) -- then alpha dithering and the floating-point colour buffer; NASA Blunt
  Fin with the paper's 5-tet split (187,318 tets), 800x600, tables 256x256x16;
* Table 2: tets/s of the Table 2 configuration (perspective + logarithmic HILO, 8-bit frame
  buffer) on the Blunt Fin and on stand-ins for the paper's other meshes (not available here):
  LOX Post for the heat sink, SPX for the tapered cylinder, the combustor for the X38;
* the artifact study as images and RMSE against the exact reference: perspective vs linear
  interpolation (iso-surface-like TF peak, Fig. 8), 8-bit vs HILO table (Fig. 7a/c), 8-bit vs float
  buffer vs dithering (Figs. 7b, 9), uniform vs logarithmic thickness axis on the extreme edge-ratio
  mesh (builtin ``stiff``, longest/shortest edge 6e4) with its smooth TF and with an iso-surface-like
  TF peak (Fig. 10 is an iso-surface).

Emulated times are this machine's CPU's (the fastest of ``--repeat`` renders after a first one that
compiles kernels and builds the table, as the paper's times exclude table builds); modelled times
are the counted work of the timed render on the ``quadro_fx3000`` profile (``warpvol.model``; the
fp16 colour buffer as that card ran it: read back as a texture and composited in the fragment
program). The tables' computations are in ``warpvol.reproduce.kraus2004``.

    ./run.sh python scripts/reproduce_kraus2004.py [--out out/kraus2004] [--width 800 --height 600]
        [--skip table1,table2,artifacts] [--device cpu] [--json docs/data/kraus2004.json]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from warpvol.reproduce import kraus2004 as k
from warpvol.reproduce.common import add_json_option, format_table, write_tables_json
from warpvol.tools import provenance

ROOT = Path(__file__).resolve().parents[1]


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "kraus2004"))
    ap.add_argument("--width", type=int, default=800)
    ap.add_argument("--height", type=int, default=600)
    ap.add_argument("--art-width", type=int, default=400, help="Blunt Fin artifact images")
    ap.add_argument("--art-height", type=int, default=300)
    ap.add_argument("--small", type=int, default=192, help="built-in artifact images (square)")
    ap.add_argument("--n-s", type=int, default=256)
    ap.add_argument("--n-l", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=2, help="timed renders per configuration (fastest kept)")
    ap.add_argument("--skip", default="", help="comma-separated: table1, table2, artifacts")
    ap.add_argument("--device", default="cpu")
    add_json_option(ap)
    a = ap.parse_args(argv)
    prov = provenance.start(provenance.command_line("scripts/reproduce_kraus2004.py", argv), timing=True)
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    skip = set(filter(None, a.skip.split(",")))
    kw = dict(n_s=a.n_s, n_l=a.n_l, device=a.device)
    tables = {}
    if "table1" not in skip:
        tables["table1"] = k.table1(k.bluntfin187(a.width, a.height), repeat=a.repeat, log=log, **kw)
        print(format_table(tables["table1"]), flush=True)
    if "table2" not in skip:
        tables["table2"] = k.table2(k.table2_scenes(a.width, a.height), repeat=a.repeat, log=log, **kw)
        print(format_table(tables["table2"]), flush=True)
    if "artifacts" not in skip:
        studies = k.artifact_studies(small=a.small, art_width=a.art_width, art_height=a.art_height, n_s=a.n_s,
                                     n_l=a.n_l)
        tables["artifacts"] = k.artifacts(studies, device=a.device, out=a.out, log=log)
        print(format_table(tables["artifacts"]), flush=True)
    if a.json:
        cmd = " ".join(["python scripts/reproduce_kraus2004.py", *(argv if argv is not None else sys.argv[1:])])
        write_tables_json(a.json, cmd, tables, prov)
    return 0


if __name__ == "__main__":
    sys.exit(main())
