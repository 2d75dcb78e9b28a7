"""The paper pages' figures: each paper's presets beside the exact one on one scene, image over error map.

    ./run.sh python scripts/docs_paper_figures.py [--scene builtin:concave] [--size 128] [--only espinha2005,...]

For each paper, every preset of :data:`PAPERS` renders the scene once (``warpvol.compare``, one reference
for all) and the figure puts the images in the top row and their error maps against the exact float64
reference below, on one logarithmic colour scale per figure; each title gives the preset, the time of
that render on this CPU (kernel compilation and set-up included: ``repeats=0``) and its RMSE. A preset that
declines the scene keeps its column with the reason. Writes ``docs/img/papers/PAPER.png`` (drawn for
:data:`WIDTH_IN` x 100 px, the width the paper pages show it at) and ``docs/data/paper_figures.json``
(what each figure shows, with the numbers, for the captions).
"""

from __future__ import annotations

import argparse
import json
import sys
import textwrap
from pathlib import Path

from warpvol.tools import provenance

ROOT = Path(__file__).resolve().parent.parent
#: paper -> (the paper's figure this sets beside, presets left to right; the exact one last)
PAPERS = {
    "westermann1997": ("the VSBUFFER renderings of the paper's data sets", ["westermann1997", "vsbuffer_best"]),
    "roettger2002": ("Fig. 8's 3D-texture and 2D-texture (cylindrical) pre-integration",
                     ["roettger2000_3d", "roettger2002_hw", "roettger2002_cylindrical", "pt_best"]),
    "guthe2002": ("Fig. 7, the approximations of the three-dimensional ray integral",
                  ["guthe2002_linear", "guthe2002_quadratic_gf4", "guthe2002_quartic_radeon", "pt_best"]),
    "kraus2004": ("the artifact figures: perspective cracks and the 8-bit table",
                  ["weiler2003_vicp", "kraus2004_basic", "kraus2004_full", "pt_best"]),
    "espinha2005": ("Fig. 8, full against partial pre-integration", ["espinha2005_full", "espinha2005_partial",
                                                                     "harc_best"]),
}
#: inches per column at 100 dpi
COLUMN_IN = 2.4
WIDTH_IN = 4 * COLUMN_IN + 0.9


def paper_figure(cmp, names: list[str], title: str):
    """Images (top) over error maps (bottom), one column per preset, one colour scale."""
    from matplotlib.figure import Figure

    from warpvol.figures import draw_declined, draw_pair
    from warpvol.metrics import ERROR_LABEL, draw_error, error_norm

    n = len(names)
    fig = Figure(figsize=(COLUMN_IN * n + 0.9, 2 * COLUMN_IN + 0.6), dpi=100, layout="constrained")
    axes = fig.subplots(2, n, squeeze=False)
    norm = error_norm(*(r.error_image for r in cmp.results.values())) if cmp.results else None
    im = None
    for k, row in enumerate(cmp.table):
        if row["pipeline"] in cmp.results:
            res = cmp.results[row["pipeline"]]
            draw_pair(axes[0, k], None, res, row["pipeline"], norm)
            im = draw_error(axes[1, k], res.error_image, norm, colorbar=False)
            axes[1, k].set_title(f"max |error| {res.error['max_abs']:.2e}", fontsize=9)
        else:
            axes[1, k].set_axis_off()
            draw_declined(axes[0, k], row["pipeline"], row["status"], textwrap.fill(row["reason"], 30))
    if im is not None:  # one colour bar: every error map shares the scale
        cb = fig.colorbar(im, ax=list(axes[1, :]), fraction=0.04, pad=0.02)
        cb.set_label(ERROR_LABEL, fontsize=8)
        cb.ax.tick_params(labelsize=8)
    fig.suptitle(title, fontsize=10)
    return fig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="builtin:concave")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--only", help="comma list of papers (default: all)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "img" / "papers"))
    ap.add_argument("--json", default=str(ROOT / "docs" / "data" / "paper_figures.json"))
    args = ap.parse_args(argv)
    prov = provenance.start(provenance.command_line("scripts/docs_paper_figures.py", argv), timing=True)
    import warpvol

    papers = args.only.split(",") if args.only else list(PAPERS)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = Path(args.json)
    data = json.loads(path.read_text()) if path.is_file() else {}
    scene = warpvol.load_scene(args.scene).with_camera(width_px=args.size, height_px=args.size)
    for paper in papers:
        what, names = PAPERS[paper]
        cmp = warpvol.compare(scene, names, repeats=0)
        title = f"{scene.name}, {args.size}x{args.size}: image (top), |error| against the exact reference (bottom)"
        paper_figure(cmp, names, title).savefig(out / f"{paper}.png", dpi=100)
        data[paper] = {"source": f"python scripts/docs_paper_figures.py --scene {args.scene} --size {args.size}",
                       "scene": args.scene, "size": args.size, "beside": what,
                       "rows": [{k: r[k] for k in ("pipeline", "status", "cold_s", "rmse", "max_abs", "reason")}
                                for r in cmp.table]}
        print(f"{paper}: " + ", ".join(f"{r['pipeline']} {r['status']} rmse={r['rmse']}" for r in cmp.table))
    provenance.write_json(path, data, prov, parts=papers, all_parts=[k for k in data if k != provenance.KEY])
    return 0


if __name__ == "__main__":
    sys.exit(main())
