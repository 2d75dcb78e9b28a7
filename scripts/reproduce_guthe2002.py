"""Reproduce Guthe et al. 2002: Fig. 6 (ping-pong hardware vs software pre-integration, m = 128),
Figs. 4/7 as numbers (linear vs degree-2 vs degree-4 colour reconstruction error over the whole
(sf, sb, l) domain) with error images, Table 4 (texture setup times for n = 1, 2, 4 at 512^2,
software vs hardware-emulated ping-pong, with ratios) and Table 5 (frame rates with numeric, MPVO and
XMPVO sorting, degree 2, 1280x960: Blunt Fin with the 5-tet split, 187,318 tets; the Bucky Ball
from ``bucky.raw`` with the 6-tet split, 178,746 tets, where the paper has 177k -- its exact
tetrahedralisation is not known; emulated fps on this CPU, modelled fps per card profile).

The computations are in ``warpvol.reproduce.guthe2002`` (``fig6``, ``fig7``, ``table4``, ``table5``).

    ./run.sh python scripts/reproduce_guthe2002.py [--out out/] [--res 512] [--device cpu] [--skip table5]
        [--json docs/data/guthe2002.json]
"""

from __future__ import annotations

import argparse
import os
import sys

from warpvol.reproduce import guthe2002 as g
from warpvol.reproduce.common import add_json_option, format_table, write_tables_json
from warpvol.tools import provenance


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="out/")
    ap.add_argument("--res", type=int, default=512, help="2D texture resolution (paper: 512)")
    ap.add_argument("--eval", type=int, default=64, help="evaluation grid per axis for Figs. 4/7 numbers")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--skip", default="", help="comma-separated: figs, table4, table5")
    ap.add_argument("--width", type=int, default=1280, help="Table 5 view port")
    ap.add_argument("--height", type=int, default=960)
    add_json_option(ap)
    a = ap.parse_args(argv)
    prov = provenance.start(provenance.command_line("scripts/reproduce_guthe2002.py", argv), timing=True)
    skip = set(filter(None, a.skip.split(",")))
    os.makedirs(a.out, exist_ok=True)
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    tf = g.guthe_tf()
    tables = {}
    if "figs" not in skip:
        tables["fig6"] = g.fig6(tf, a.res, device=a.device, out=a.out)
        print(format_table(tables["fig6"]), flush=True)
        tables["fig7"] = g.fig7(tf, a.res, a.eval, device=a.device, out=a.out)
        print(format_table(tables["fig7"]), flush=True)
    if "table4" not in skip:
        tables["table4"] = g.table4(tf, a.res, device=a.device)
        print(format_table(tables["table4"]), flush=True)
    if "table5" not in skip:
        tables["table5"] = g.table5(g.table5_scenes(a.width, a.height), res=a.res, device=a.device,
                                    log=lambda m: print(m, file=sys.stderr, flush=True))
        print(format_table(tables["table5"]), flush=True)
    if a.json:
        cmd = " ".join(["python scripts/reproduce_guthe2002.py", *(argv if argv is not None else sys.argv[1:])])
        write_tables_json(a.json, cmd, tables, prov)


if __name__ == "__main__":
    main()
