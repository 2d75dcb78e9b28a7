"""Tolerances of whole renders against the exact reference, one row per pipeline / number format.

Every test that compares a render with ``warpvol.reference`` takes its bounds from here, so the
accuracy each pipeline promises is stated in one place. Values are on premultiplied RGBA in [0, 1].

=====================  ===========  ===========  ==================================================
key                    rmse         max_abs      why
=====================  ===========  ===========  ==================================================
raycast/fp32           2e-5         5e-4         float32 geometry (plane distances, s = g.x + g0),
                                                 exact segment integrals; silhouette pixels whose
                                                 rays graze faces dominate max_abs
segment/fp32           (rel) 2e-5   --           one segment integral in float32 vs float64 closed form
=====================  ===========  ===========  ==================================================
"""

TOLERANCES = {
    "raycast/fp32": {"rmse": 2e-5, "max_abs": 5e-4},
    "segment/fp32": {"rtol": 2e-5, "atol": 1e-6},
}
