"""Ray casting: the consistent float32 walk (``raycast``, ``peel``) and hardware ray casting (HARC,
Espinha & Celes 2005; host code in :mod:`.harc`); the stages in :mod:`.stages`.
"""

#: the tolerance rows of the family's presets (tests/tolerances.py gathers them)
_TOLERANCES = {
    "raycast/fp32": {"rmse": 2e-06, "max_abs": 0.0001,
             "why": ("float32 points relative to the mesh centre, ray origins moved to the mesh in float64; consistent "
                     "Plücker edge tests, depth and scalar from face barycentrics (no gradients: slivers need no looser "
                     "entry); segment integrals to ~1e-7. Seen: rmse <= 9.1e-8, max_abs <= 2.1e-6 on the issue-7 cases "
                     "(Delaunay slivers, caps/kites to 1e-12, eyes at 1e6 sizes); Blunt Fin 6.8e-8 / 6.4e-6; Blunt Fin "
                     "close view 512^2, narrow shell TF (crossing scalars' float32 error bounded, rays over it redone in "
                     "float64): 9.9e-7 / 2.7e-5")},
    "harc_best": {"rmse": 2e-06, "max_abs": 0.0001,
             "why": ("the raycast/fp32 walk (shared funcs) entered from the rasterised boundary, exact segments, fp32 "
                     "buffer; seen on the built-ins 48^2 <= 1.9e-7 / 3.3e-6")},
    "espinha2005_partial": {"rmse": 0.01, "max_abs": 0.25,
             "why": ("paper's Fig. 6 plane walk, 256^2 centre-anchored iso table (nearest: control points between sf and "
                     "its texel centre are missed, counted in iso_missed), 512^2 fp16 psi, RGBA8 buffer; seen 48^2 sphere "
                     "6.0e-3 / 0.18 (narrow TF peaks), others <= 9.3e-4 / 5.4e-3")},
    "espinha2005_full": {"rmse": 0.025, "max_abs": 0.15,
             "why": ("128^3 RGBA8 exact table, trilinear with 8-bit weights, RGBA8 buffer; seen 48^2 <= 1.6e-2 / 0.10 "
                     "(stiff: thin cells read the first l texel), others <= 2.0e-3 / 2.3e-2")},
    "harc/partial_segment": {"max_abs": 5e-06,
             "why": ("one cell segment: iso splits (edge-anchored 256^2 table, 'behind' rule) + psi (512^2 endpoint fp32, "
                     "fp32 weights) vs the exact integral, 255-segment TF; seen 1.4e-6")},
}

#: the family's declaration (:mod:`warpvol.family`): its papers and their presets, pages, files; the
#: tolerance rows of its presets. A renderer family imports no other family.
FAMILY = {
    "title": "ray casting",
    "renderer": True,
    "papers": (
        {"title": "exact and fast", "order": (0, 1), "name": "Consistent float32 ray casting", "exact": True,
         "presets": {"raycast": "default; float32 ray casting through the cells, exact segment integrals"},
         "table": "float32 ray casting through the cell adjacency, exact segment integrals for the piecewise-linear "
                  "transfer function, re-entry for non-convex meshes; handles the eye inside the mesh; walks only the "
                  "cells the transfer function makes visible and stops a ray once its transmittance is below 1e-6 "
                  "(`--no-skip`: every cell, every ray to its end)",
         "code": {"host": ["shared/thin_cells.py", "shared/visible.py", "shared/entry_bins.py"],
                  "stages": ["raycasting/stages/cell_setup.py", "raycasting/stages/entry_bins.py",
                             "raycasting/stages/raycast.py", "raycasting/stages/peel.py",
                             "conditioning/stages/condition.py", "conditioning/stages/visibility.py"],
                  "kernels": ["kernels/raycast.py", "kernels/cellwalk.py", "kernels/walk.py", "kernels/integrate.py",
                              "kernels/lanes*.py"]}},
        {"title": "exact and fast", "order": (0, 2), "name": "HARC made exact", "exact": True,
         "presets": {"harc_best": "hardware ray casting (rasterised start, peeling), raycast's exact walk"},
         "table": "hardware ray casting (rasterised ray start, depth peeling) made exact: `raycast`'s walk and "
                  "integrals in the HARC pipeline, leaving out the same",
         "code": {"host": ["raycasting/harc.py", "shared/integration.py", "shared/thin_cells.py",
                           "shared/visible.py"],
                  "stages": ["raycasting/stages/cell_setup.py", "raycasting/stages/harc*.py"],
                  "kernels": ["kernels/harc.py", "kernels/cellwalk.py", "kernels/harc_walk.py", "kernels/walk.py",
                              "kernels/harc_lanes.py", "kernels/lanes*.py"]}},
        {"title": "Espinha & Celes 2005", "order": (2, 2005), "page": "papers/espinha2005.md",
         "nav": "Espinha & Celes 2005",
         "presets": {"espinha2005_full": "hardware ray casting with a full 128^3 RGBA8 pre-integration table",
                     "espinha2005_partial": "hardware ray casting with partial pre-integration (iso-crossing, psi)"},
         "table": "hardware ray casting with a full 3D table or with partial pre-integration",
         "code": {"host": ["raycasting/harc.py", "shared/integration.py", "tables/psi.py", "tables/isocross.py"],
                  "stages": ["raycasting/stages/cell_setup.py", "raycasting/stages/harc*.py",
                             "tables/stages/table_psi.py", "tables/stages/table_iso.py",
                             "tables/stages/table_exact.py"],
                  "kernels": ["kernels/harc.py", "kernels/cellwalk.py", "kernels/harc_walk.py",
                              "kernels/harc_integ.py", "kernels/walk.py"],
                  "reproduce": ["reproduce/espinha2005.py", "scripts/reproduce_espinha2005.py"]}},
    ),
    "tolerance_rows": {"raycast": "raycast/fp32"},
    # tests/tolerances.py: a whole render against the exact reference, premultiplied RGBA in [0, 1]
    "tolerances": _TOLERANCES,
}
