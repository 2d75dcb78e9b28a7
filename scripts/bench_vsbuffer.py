"""Benchmark: time per frame of the VSBUFFER presets against the best projected-tetrahedra (PT) and
HARC presets on the same view, as ratios taken in one run, with each render's RMSE against the exact
reference.

Presets come from ``warpvol pipelines``: PT = ``pt_*`` and the Roettger presets, HARC = names with
``harc`` / ``espinha`` and the ``raycast`` preset (the HARC cell walk); of each family the ``*_best``
preset if one exists, else every one found; a family without presets is named as not yet available.
Times are the median of ``--repeat`` rounds, interleaved (one render of each preset per round, after a
warm-up round with kernel compilation, table builds and mesh derived data), as in
``scripts/bench_raycast.py``.

    ./run.sh python scripts/bench_vsbuffer.py [--scene scenes/bluntfin.toml] [--size 256] [--repeat 2]
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_raycast import interleaved_times, scene_and_reference, warpvol_renderer  # noqa: E402

VSB = ("westermann1997", "vsbuffer_best")
PT_KEYS = ("pt_", "roettger", "shirley", "kraus", "guthe")
HARC_KEYS = ("harc", "espinha")


def families(names: list[str]) -> dict[str, list[str]]:
    """Presets per family (VSBUFFER, PT, HARC): the ``*_best`` one where it exists, else all.

    Examples
    --------
    >>> families(["raycast", "pt_vertex_color", "roettger2000_3d", "westermann1997", "vsbuffer_best"])
    {'VSBUFFER': ['westermann1997', 'vsbuffer_best'], 'PT': ['pt_vertex_color', 'roettger2000_3d'], 'HARC': ['raycast']}
    """
    def pick(found: list[str]) -> list[str]:
        return [n for n in found if n.endswith("_best")] or found

    pt = [n for n in names if any(n.startswith(k) or k in n for k in PT_KEYS) and n not in VSB]
    harc = [n for n in names if any(k in n for k in HARC_KEYS) or n == "raycast"]
    return {"VSBUFFER": [n for n in VSB if n in names], "PT": pick(pt), "HARC": pick(harc)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "bluntfin.toml"))
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--skip", default="", help="comma-separated presets to leave out (named as skipped)")
    ap.add_argument("--out", default=str(ROOT / "out" / "bench_vsbuffer"))
    a = ap.parse_args(argv)
    from warpvol.pipeline import list_presets, quiet_warp

    quiet_warp()
    scene, ref = scene_and_reference(a.scene, a.size, Path(a.out))
    fam = families([n for n, _ in list_presets()])
    skip = set(filter(None, a.skip.split(",")))
    renderers, results, family_of = [], {}, {}
    for family, names in fam.items():
        if not names:
            print(f"{family}: no preset yet (not yet available)")
        for name in names:
            if name in skip:
                print(f"{family}: {name} skipped (--skip)")
                continue
            render, image, result = warpvol_renderer(scene, a.device, preset=name)
            renderers.append((name, render, image))
            results[name], family_of[name] = result, family
    times = interleaved_times(renderers, a.repeat)
    med = {n: statistics.median(t[1:]) for n, t in times.items()}
    base = med.get("vsbuffer_best") or next(iter(med.values()))
    print(f"\n{scene.name}, {a.size}x{a.size} {scene.camera.projection}, {scene.mesh.n_tets:,} tets, device "
          f"{a.device}, median of {a.repeat} interleaved rounds after a warm-up")
    print("| family | preset | time per frame [s] | first render [s] | / vsbuffer_best | RMSE | max abs |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, _, image in renderers:
        img = image()
        rmse, mx = float(np.sqrt(((img - ref) ** 2).mean())), float(np.abs(img - ref).max())
        print(f"| {family_of[name]} | {name} | {med[name]:.3f} | {times[name][0]:.3f} | {med[name] / base:.2f}x | "
              f"{rmse:.2e} | {mx:.2e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
