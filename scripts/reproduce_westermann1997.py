"""Reproduce Westermann & Ertl 1997, Table 1: VSBUFFER at 450x450 with 450 scanlines.

Per data set: tets, drawn tets (cells drawn over all sweep planes), time in ID-buffer generation
("GrOps": octree query, two ID passes, read-back, comparison) and in integration ("Int": column walk,
intersections, integration), emulated on this machine's CPU, with a modelled time for the paper's
SGI Indigo2 IMPACT / R4400, and the RMSE against the exact float64 reference; the paper's rows beside.

Data sets: Blunt Fin (``scenes/bluntfin.toml``, 224,874 tets of which 115 have zero volume and are
dropped), SPX (``../shared/data/spx.vtk``, 12,936 tets; not in the paper), and a finite-element-like
mesh standing in for the paper's ``fedata`` (not available): a concave annular sector of 6-tet hexes,
99,000 tets, with a smooth "stress" field. The paper's artificial ``ell64`` is not reproduced.

View: orthographic, the long main diagonal of the bounding box mapped to the image height (the
paper: "the long main diagonal of the data sets is mapped to 450 pixel"), VSBUFFER depth rows = 450.

The table's computation is ``warpvol.reproduce.westermann1997.table1``.

    ./run.sh python scripts/reproduce_westermann1997.py [--size 450] [--datasets bluntfin spx fe]
        [--presets westermann1997 vsbuffer_best] [--out out/westermann1997] [--json docs/data/westermann1997.json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys

from warpvol.reproduce.common import add_json_option, format_table, write_tables_json
from warpvol.reproduce.westermann1997 import dataset, table1
from warpvol.tools import provenance


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=450, help="image size = scanlines = VSBUFFER depth rows (paper: 450)")
    ap.add_argument("--datasets", nargs="+", default=["bluntfin", "spx", "fe"], choices=["bluntfin", "spx", "fe"])
    ap.add_argument("--presets", nargs="+", default=["westermann1997", "vsbuffer_best"])
    ap.add_argument("--out", default="out/westermann1997")
    ap.add_argument("--device", default="cpu")
    add_json_option(ap)
    a = ap.parse_args(argv)
    prov = provenance.start(provenance.command_line("scripts/reproduce_westermann1997.py", argv), timing=True)
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    t = table1([(name, dataset(name, a.size)) for name in a.datasets], a.presets, device=a.device, out=a.out,
               log=lambda m: print(m, file=sys.stderr, flush=True))
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "table1.json"), "w") as f:
        json.dump([dict(zip(t["columns"], r)) for r in t["rows"]], f, indent=1)
    print(format_table(t))
    if a.json:
        cmd = " ".join(["python scripts/reproduce_westermann1997.py", *(argv if argv is not None else sys.argv[1:])])
        write_tables_json(a.json, cmd, {"table1": t}, prov)


if __name__ == "__main__":
    main()
