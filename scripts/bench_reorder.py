"""Morton renumbering of cells and points (the ``condition`` stage's ``reorder``): time with and without it.

Renders one mesh with each preset twice -- ``reorder = "none"`` and ``"morton"`` (or ``"auto"``) -- interleaved
in one process, ``--repeat`` rounds after a warm-up round (kernels compiled, per-mesh data built, the
renumbering done), and prints per preset the median warm frame of each, their ratio (> 1: renumbering is
faster), the first render of each (the renumbering is part of it), the largest image difference between
the two, and the mesh's far-neighbour fraction before and after (:mod:`warpvol.conditioning.reorder`).

Meshes: ``--mesh delaunay`` / ``structured`` (``scripts/bench_scaling.py``'s cube meshes of ``--tets`` tets, cached
in ``out/bench_scaling``) or a scene file (``--scene scenes/loxpost.toml``).

Usage::

    ./run.sh python scripts/bench_reorder.py [--mesh delaunay] [--tets 1e6] [--size 512] [--repeat 3]
    ./run.sh python scripts/bench_reorder.py --scene scenes/loxpost.toml --mode morton
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))


def scene_of(args):
    from warpvol.scene.camera import Camera
    from warpvol.scene.mesh import TetMesh
    from warpvol.scene.scene import Scene
    from warpvol.scene.transfer import TransferFunction

    if args.scene:
        from warpvol.scene.scene_file import load_scene

        return load_scene(args.scene).with_camera(width_px=args.size, height_px=args.size)
    from bench_scaling import TF_POINTS, mesh_file

    data = np.load(mesh_file(ROOT / "out" / "bench_scaling", args.mesh, args.tets))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Delaunay slivers dropped as zero-volume tets
        mesh = TetMesh(data["points"], data["tets"], data["scalars"], name=f"{args.mesh}_{int(args.tets)}")
    return Scene(mesh=mesh, transfer=TransferFunction(np.array(TF_POINTS)),
                 camera=Camera.fit(mesh, width_px=args.size, height_px=args.size), name=mesh.name)


def pipelines(preset: str, modes: tuple[str, str]):
    """The preset twice, its ``condition`` stage's ``reorder`` set to each mode."""
    from warpvol.pipeline import Pipeline
    from warpvol.tools.sweep import pipeline_config

    out = {}
    for mode in modes:
        cfg = pipeline_config(preset, (("condition.reorder", mode),))
        if isinstance(cfg, str):  # the preset has no condition stage: nothing to renumber
            raise SystemExit(f"--presets: {preset}: {cfg}")
        out[mode] = Pipeline.from_config(cfg)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mesh", default="delaunay", choices=("delaunay", "structured"))
    ap.add_argument("--tets", type=float, default=1e6)
    ap.add_argument("--scene", help="a scene file instead of --mesh / --tets")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--presets", default="raycast,harc_best,pt_best")
    ap.add_argument("--mode", default="morton", choices=("morton", "auto"),
                    help="the renumbered run's reorder (auto: only if the mesh's order is incoherent)")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    if args.repeat < 1:
        raise SystemExit(f"--repeat: at least 1, got {args.repeat}")

    from warpvol.conditioning.reorder import far_neighbour_fraction, reordered_mesh
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    sc = scene_of(args)
    far0 = far_neighbour_fraction(sc.mesh.adjacency)
    far1 = far_neighbour_fraction(reordered_mesh(sc.mesh).adjacency)
    print(f"{sc.name}: {sc.mesh.n_tets:,} tets, {args.size}^2; neighbour pairs > 4,096 records apart: "
          f"{far0:.1%} as given, {far1:.1%} renumbered; load {os.getloadavg()[0]:.2f}")
    print(f"{'preset':<12}{'none [s]':>10}{args.mode + ' [s]':>12}{'ratio':>8}{'first none':>12}"
          f"{'first ' + args.mode:>14}{'max |diff|':>12}  renumbered")
    modes = ("none", args.mode)
    for preset in [p for p in args.presets.split(",") if p]:
        pipes = pipelines(preset, modes)
        first, img, done = {}, {}, {}
        for m, p in pipes.items():
            t0 = time.perf_counter()
            r = p.render(sc, quiet=True)
            first[m], img[m] = time.perf_counter() - t0, r.image
            done[m] = r.report["stats"]["condition"]["reordered"]
        times = {m: [] for m in modes}
        for _ in range(args.repeat):
            for m, p in pipes.items():
                t0 = time.perf_counter()
                p.render(sc, quiet=True)
                times[m].append(time.perf_counter() - t0)
        med = {m: statistics.median(v) for m, v in times.items()}
        print(f"{preset:<12}{med['none']:>10.3f}{med[args.mode]:>12.3f}{med['none'] / med[args.mode]:>8.2f}"
              f"{first['none']:>12.2f}{first[args.mode]:>14.2f}{float(np.abs(img['none'] - img[args.mode]).max()):>12.2e}"
              f"  {done[args.mode]}", flush=True)
    print(f"load {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
