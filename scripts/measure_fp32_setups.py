"""Measure two small arithmetic choices of the faithful presets against the plain set-up a card would
have run: HARC's depth-peeling tolerance (``espinha2005_*``: :data:`warpvol.raycasting.harc.PEEL_TOL`
against a plain "beyond the last exit" comparison) and VSBUFFER's float64 origin shift
(``westermann1997``: :data:`warpvol.vsbuffer.vsbuffer.ORIGIN_SHIFT` against the mesh's own frame in
float32 with rays from the eye). Prints, per scene, the pixels that differ, their largest difference,
both renders' max abs error against the float64 reference, and lost rays / missed cells.

    ./run.sh python scripts/measure_fp32_setups.py --size 64 --scenes sphere concave spx
"""

from __future__ import annotations

import argparse

import numpy as np

from warpvol.pipeline import Pipeline
from warpvol.raycasting import harc
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.scene_file import load_scene
from warpvol.vsbuffer import vsbuffer

#: (presets, module, attribute, the faithful value, the plain value, counts to print)
CHOICES = {
    "peel_tol": (("espinha2005_full", "espinha2005_partial"), harc, "PEEL_TOL", harc.PEEL_TOL, 0.0,
                 (("harc", "lost_rays"), ("harc_peel", "lost_rays"), ("harc_peel", "reentries"))),
    "origin_shift": (("westermann1997",), vsbuffer, "ORIGIN_SHIFT", True, False,
                     (("vsbuffer", "missed_cells"), ("vsbuffer", "lost_segments"))),
}


def scene(name: str, size: int):
    """A built-in scene by name, else ``scenes/NAME.toml``, at ``size`` x ``size`` pixels."""
    from warpvol.scene.builtin import BUILTIN_SCENES

    sc = load_scene(f"builtin:{name}" if name in BUILTIN_SCENES else f"scenes/{name}.toml")
    return sc.with_camera(width_px=size, height_px=size)


def measure(choice: str, sc, ref=None) -> list[dict]:
    """Per preset of ``choice``: both renders' comparison (the faithful value against the plain one)."""
    presets, mod, attr, faithful, plain, keys = CHOICES[choice]
    if ref is None:
        ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    rows = []
    for preset in presets:
        out = {}
        for label, value in (("faithful", faithful), ("plain", plain)):
            setattr(mod, attr, value)
            try:
                res = Pipeline.load(preset).render(sc, reference=ref, quiet=True)
            finally:
                setattr(mod, attr, faithful)
            st = res.report["stats"]
            out[label] = (np.asarray(res.image, np.float64), res.report["error"]["max_abs"],
                          {f"{s}.{k}": st.get(s, {}).get(k, 0) for s, k in keys})
        d = np.abs(out["faithful"][0] - out["plain"][0]).max(axis=-1)
        rows.append({"preset": preset, "pixels_differ": int((d > 0).sum()), "max_diff": float(d.max()),
                     "max_abs_faithful": out["faithful"][1], "max_abs_plain": out["plain"][1],
                     "counts_faithful": out["faithful"][2], "counts_plain": out["plain"][2]})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--scenes", nargs="+", default=["sphere", "box", "concave", "stiff", "spx"])
    ap.add_argument("--choices", nargs="+", default=list(CHOICES), choices=list(CHOICES))
    a = ap.parse_args()
    for name in a.scenes:
        sc = scene(name, a.size)
        ref = render_reference(sc.mesh, sc.transfer, sc.camera)
        for choice in a.choices:
            for r in measure(choice, sc, ref):
                print(f"{name:10s} {choice:12s} {r['preset']:20s} differ {r['pixels_differ']:5d} of {a.size ** 2} "
                      f"max diff {r['max_diff']:.3g}  max abs {r['max_abs_faithful']:.4g} / plain "
                      f"{r['max_abs_plain']:.4g}  {r['counts_faithful']} / plain {r['counts_plain']}", flush=True)


if __name__ == "__main__":
    main()
