"""Tolerances of whole renders against the exact reference, one row per pipeline / number format.

Every test that compares a render with ``warpvol.reference`` takes its bounds from here, so the
accuracy each pipeline promises is stated in one place. Values are on premultiplied RGBA in [0, 1].

=====================  ===========  ===========  ==================================================
key                    rmse         max_abs      why
=====================  ===========  ===========  ==================================================
raycast/fp32           2e-6         1e-4         float32 points relative to the mesh centre, ray
                                                 origins moved to the mesh in float64; consistent
                                                 Plücker edge tests, depth and scalar from face
                                                 barycentrics (no gradients: slivers need no looser
                                                 entry); segment integrals to ~1e-7. Seen: rmse <=
                                                 9.1e-8, max_abs <= 2.1e-6 on the issue-7 cases
                                                 (Delaunay slivers, caps/kites to 1e-12, eyes at
                                                 1e6 sizes); Blunt Fin 6.8e-8 / 6.4e-6
segment/fp32           (rel) 2e-5   --           one segment integral in float32 vs float64 closed form
planner/skip           1e-6         1e-5         a render with a stage the planner left out forced back
                                                 on vs the render without it (same pipeline, same
                                                 scene): the skip rule claims the stage changes
                                                 nothing. Seen: 0 / 0 (raycast, peel on convex meshes)
=====================  ===========  ===========  ==================================================
"""

TOLERANCES = {
    "raycast/fp32": {"rmse": 2e-6, "max_abs": 1e-4},
    "segment/fp32": {"rtol": 2e-5, "atol": 1e-6},
    "planner/skip": {"rmse": 1e-6, "max_abs": 1e-5},
}
