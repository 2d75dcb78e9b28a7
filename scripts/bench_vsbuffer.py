"""Time per frame of the VSBUFFER presets against the best projected-tetrahedra (PT) and HARC presets on
the same view, as ratios taken in one run (median of ``--repeat`` renders after a warm-up render),
with each render's RMSE against the exact reference.

Presets are taken from ``warpvol pipelines``: PT = names starting ``pt`` or naming a PT paper
(``shirley``, ``roettger``, ``kraus``, ``guthe``), HARC = names with ``harc`` or ``espinha`` or the
``raycast`` preset (the HARC cell walk); of each family the ``*_best`` preset if there is one, else
every one found. Families with no preset yet are named as not available.

    ./run.sh python scripts/bench_vsbuffer.py [--scene scenes/bluntfin.toml] [--size 256] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

PT_KEYS = ("pt", "shirley", "roettger", "kraus", "guthe")
HARC_KEYS = ("harc", "espinha")


def families(names: list[str]) -> dict[str, list[str]]:
    """Presets per family (VSBUFFER, PT, HARC), the ``*_best`` one where it exists."""
    def pick(found: list[str]) -> list[str]:
        best = [n for n in found if n.endswith("_best")]
        return best or found

    vsb = [n for n in names if n in ("westermann1997", "vsbuffer_best")]
    pt = [n for n in names if n.startswith("pt") or any(k in n for k in PT_KEYS[1:])]
    harc = [n for n in names if any(k in n for k in HARC_KEYS) or n == "raycast"]
    return {"VSBUFFER": vsb, "PT": pick(pt), "HARC": pick(harc)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="scenes/bluntfin.toml")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--device", default="cpu")
    a = ap.parse_args(argv)
    from warpvol.pipeline import Pipeline, list_presets, quiet_warp
    from warpvol.reference import render_reference
    from warpvol.scene import load_scene

    quiet_warp()
    sc = load_scene(a.scene).with_camera(width_px=a.size, height_px=a.size)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    fam = families([n for n, _ in list_presets()])
    rows = []
    for family, names in fam.items():
        if not names:
            print(f"{family}: no preset yet (not yet available)")
        for name in names:
            pipe = Pipeline.load(name, device=a.device)
            pipe.render(sc, quiet=True)  # warm-up: kernels compiled, derived mesh data cached
            ts, img = [], None
            for _ in range(a.repeat):
                t0 = time.perf_counter()
                img = pipe.render(sc, quiet=True).image
                ts.append(time.perf_counter() - t0)
            rmse = float(np.sqrt(((img - ref) ** 2).mean()))
            rows.append((family, name, float(np.median(ts)), rmse))
    base = next((t for f, n, t, _ in rows if n == "vsbuffer_best"), rows[0][2])
    print(f"\n{sc.name}, {a.size}x{a.size}, {sc.camera.projection}, {sc.mesh.n_tets:,} tets, device {a.device}, "
          f"median of {a.repeat}")
    print("| family | preset | time per frame [s] | / vsbuffer_best | RMSE |")
    print("| --- | --- | --- | --- | --- |")
    for f, n, t, e in rows:
        print(f"| {f} | {n} | {t:.3f} | {t / base:.2f}x | {e:.2e} |")


if __name__ == "__main__":
    main()
