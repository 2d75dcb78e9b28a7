#!/usr/bin/env python
"""Conformance of the emulated GPU against a real OpenGL: Mesa llvmpipe through VTK offscreen (EGL).

For every canvas size and seed, the conformance soup (:func:`warpvol.gpu.glref.conformance_soup`:
random triangles, vertices on pixel centres and edges, an exact tiling, slivers, sub-pixel and
off-grid triangles, snapping ties, horizontal edges through pixel centres; ~260 triangles) is drawn
by llvmpipe and by the emulated rasteriser + blending unit, and the script prints

* per-triangle coverage differences, (triangle, pixel) pairs, in the display orientation (warpvol's
  picture = GL's picture) and in GL memory order (mirrored), for four rule sets;
* the snapping-tie group separately (exact ties only on power-of-two canvases: elsewhere the fp32
  vertex path, VTK's orthographic matrix and llvmpipe's viewport scale, is not exact, so tie
  vertices no longer reach llvmpipe's snapping as ties);
* hit counts in the tiling (max per pixel, GL and emulated; pixels whose counts differ);
* blended RGBA8 buffers, premultiplied (ONE, ONE_MINUS_SRC_ALPHA) and straight alpha
  (SRC_ALPHA, ONE_MINUS_SRC_ALPHA; alpha ONE, ONE_MINUS_SRC_ALPHA), flat colours over a random
  background, with the blending unit's ``exact`` and ``llvmpipe`` arithmetic;
* fragment codes: Gouraud colours with blending off, under the rasteriser's ``barycentric`` and
  ``llvmpipe`` (plane equation) interpolation rules, and how many differing codes sit within 1e-3
  code of an exact k + 1/2 tie in the barycentric fp32 value.

    ./run.sh python scripts/gl_conformance.py [--seeds 0 1 2] [--sizes 64x64 128x64 64x48 100x75]
"""

from __future__ import annotations

import argparse
import sys
import time

from warpvol.pipeline import quiet_warp


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--sizes", nargs="+", default=["64x64", "128x64", "32x32", "64x48", "100x75"])
    args = ap.parse_args(argv)
    quiet_warp()
    from warpvol.gpu.glref import GLCanvas, conformance_figures, gl_unavailable_reason

    reason = gl_unavailable_reason()
    if reason:
        print(f"skipped: {reason}")
        return 1
    sizes = [tuple(int(v) for v in s.lower().split("x")) for s in args.sizes]
    t0 = time.perf_counter()
    rows = []
    for w, h in sizes:
        canvas = GLCanvas(w, h)
        for seed in args.seeds:
            rows.append(((w, h), seed, conformance_figures(canvas, seed)))
    print(f"GL: {canvas.renderer}")
    f0 = rows[0][2]
    print(f"soup: {f0['triangles']} triangles per seed ({f0['snap_tie_triangles']} with snapping ties); "
          f"rule sets: fill_rule + snap_ties; 'llvmpipe' = bottom_left + even (the defaults)\n")

    rules = list(f0["coverage_display"])
    print("Coverage: differing (triangle, pixel) pairs / triangles, snapping-tie group apart")
    print("| canvas | seed | orientation | " + " | ".join(rules) + " | ties: " + " | ties: ".join(rules) + " |")
    print("|" + " --- |" * (3 + 2 * len(rules)))
    for (w, h), seed, f in rows:
        for orient in ("display", "memory"):
            cov = [f"{f[f'coverage_{orient}'][r]} / {f[f'coverage_{orient}_tris'][r]}" for r in rules]
            tie = [f"{p} / {t}" for p, t in (f[f"snap_tie_{orient}"][r] for r in rules)]
            print(f"| {w}x{h} | {seed} | {orient} | " + " | ".join(cov) + " | " + " | ".join(tie) + " |")

    print("\nTiling (llvmpipe rules): max hits per pixel GL / emulated, covered pixels, pixels with differing counts")
    for (w, h), seed, f in rows:
        g, e, n = f["tiling_hits"]
        print(f"  {w}x{h} seed {seed}: {g} / {e}, {n} px, {f['tiling_diff']} differ")

    keys = list(f0["blend"])
    print("\nBlended RGBA8 buffers (llvmpipe rules): pixels differing / max code difference")
    print("| canvas | seed | ties drawn | " + " | ".join(keys) + " |")
    print("|" + " --- |" * (3 + len(keys)))
    for (w, h), seed, f in rows:
        vals = [f"{n} / {m}" for n, m in (f["blend"][k] for k in keys)]
        print(f"| {w}x{h} | {seed} | {'yes' if f['ties_in_buffers'] else 'no'} | " + " | ".join(vals) + " |")

    print("\nFragment codes (Gouraud, blending off), interp_rule/arithmetic: codes differing / of all, "
          "max difference, differing at k+1/2 ties")
    for (w, h), seed, f in rows:
        s = "; ".join(f"{a}: {n}/{tot}, max {m}, {ties} at ties" for a, (n, m, tot, ties) in f["gouraud"].items())
        print(f"  {w}x{h} seed {seed}: {s}")
    print(f"\n{len(rows)} canvas/seed runs in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
