"""Tolerances of whole renders against the exact reference, one row per pipeline / number format.

Every test that compares a render with ``warpvol.reference`` takes its bounds from here, so the
accuracy each pipeline promises is stated in one place. Values are on premultiplied RGBA in [0, 1].

=====================  ===========  ===========  ==================================================
key                    rmse         max_abs      why
=====================  ===========  ===========  ==================================================
raycast/fp32           2e-6         1e-4         float32 geometry relative to the mesh centre
                                                 (plane distances, s = g.x + g0), segment integrals
                                                 to ~1e-7; rays grazing boundary faces (entry t
                                                 error ~ rounding / |d.n|) dominate max_abs. Seen:
                                                 rmse <= 4.3e-7, max_abs <= 3.2e-5 (built-ins,
                                                 Blunt Fin, LOX post, combustor)
segment/fp32           (rel) 2e-5   --           one segment integral in float32 vs float64 closed form
vsbuffer/              6e-2         4e-1         the paper's VSBUFFER at 32x32, buffer rows = image
  westermann1997                                 height, trapezoid rule (1 step per cell) and cells
                                                 the buffer misses lost (counted as lost_segments).
                                                 Seen: rmse <= 0.050, max_abs <= 0.377 (sphere)
vsbuffer/              2e-6         1e-4         exact segments, gaps behind interior faces recovered
  vsbuffer_best                                  and rays the audit flags integrated again from their
                                                 sorted cut cells; float32 as raycast/fp32. Seen:
                                                 rmse <= 4.3e-7, max_abs <= 4.7e-6 (built-ins, 32x32)
=====================  ===========  ===========  ==================================================
"""

TOLERANCES = {
    "raycast/fp32": {"rmse": 2e-6, "max_abs": 1e-4},
    "segment/fp32": {"rtol": 2e-5, "atol": 1e-6},
    "vsbuffer/westermann1997": {"rmse": 6e-2, "max_abs": 4e-1},
    "vsbuffer/vsbuffer_best": {"rmse": 2e-6, "max_abs": 1e-4},
}
