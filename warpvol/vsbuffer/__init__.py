"""VSBUFFER sweep planes (Westermann & Ertl 1997): host code (:mod:`.vsbuffer`), convex cells
(:mod:`.cells`), the octree of cells (:mod:`.octree`) and the stages (:mod:`.stages`).
"""

#: the tolerance rows of the family's presets (tests/tolerances.py gathers them)
_TOLERANCES = {
    "vsbuffer/westermann1997": {"rmse": 0.06, "max_abs": 0.4,
             "why": ("the paper's VSBUFFER at 32x32, buffer rows = image height, trapezoid rule (1 step per cell) and "
                     "cells the buffer misses lost (counted as lost_segments). Seen: rmse <= 0.050, max_abs <= 0.375 "
                     "(sphere)")},
    "vsbuffer/vsbuffer_best": {"rmse": 2e-06, "max_abs": 0.0001,
             "why": ("exact segments, gaps behind interior faces recovered and rays the audit flags integrated again from "
                     "their sorted cut cells; float32 as raycast/fp32. Seen: rmse <= 1.9e-7, max_abs <= 3.2e-6 (built-ins, "
                     "32x32)")},
    "vsbuffer/table_exact": {"rmse": 0.01, "max_abs": 0.1,
             "why": ("vsb_sweep integration = table: 64^2 x 32 fp32 exact table, log2 thickness axis, trilinear with 8-bit "
                     "weights, otherwise as vsbuffer_best. Seen: rmse <= 7.6e-3, max_abs <= 6.6e-2 (sphere; table "
                     "resolution)")},
}

#: the family's declaration (:mod:`warpvol.family`): its papers and their presets, pages, files; the
#: tolerance rows of its presets. A renderer family imports no other family.
FAMILY = {
    "title": "sweep planes",
    "renderer": True,
    "papers": (
        {"title": "exact and fast", "purpose": "exact", "order": (0, 4), "exact": True,
         "name": "The VSBUFFER sweep made exact",
         "presets": {"vsbuffer_best": "VSBUFFER sweep made exact, hexahedra drawn whole; slow (plane by plane)"},
         "table": "the VSBUFFER sweep with hexahedra, wedges and pyramids drawn whole, every missed cell recovered and "
                  "the rays through cells too thin for float32 traced in float64; slow, since the sweep is emulated "
                  "plane by plane",
         "code": {"host": ["vsbuffer/vsbuffer.py", "vsbuffer/cells.py", "vsbuffer/octree.py"],
                  "stages": ["vsbuffer/stages/vsb_setup.py", "vsbuffer/stages/vsb_sweep.py",
                             "conditioning/stages/condition.py", "conditioning/stages/visibility.py"],
                  "kernels": ["kernels/vsbuffer.py", "kernels/vsbuffer_audit.py"]}},
        {"title": "Westermann & Ertl 1997", "order": (2, 1997), "page": "papers/westermann1997.md",
         "nav": "Westermann & Ertl 1997",
         "presets": {"westermann1997": "VSBUFFER as published: ID buffers per scanline, trapezoidal rule"},
         "table": "VSBUFFER as published: ID buffers per scanline, trapezoidal rule, missed cells counted",
         "code": {"host": ["vsbuffer/vsbuffer.py", "vsbuffer/cells.py", "vsbuffer/octree.py"],
                  "stages": ["vsbuffer/stages/vsb_setup.py", "vsbuffer/stages/vsb_sweep.py"],
                  "kernels": ["kernels/vsbuffer.py", "kernels/vsbuffer_audit.py"],
                  "reproduce": ["reproduce/westermann1997.py", "scripts/reproduce_westermann1997.py"]}},
    ),
    "tolerance_rows": {"westermann1997": "vsbuffer/westermann1997", "vsbuffer_best": "vsbuffer/vsbuffer_best"},
    # tests/tolerances.py: a whole render against the exact reference, premultiplied RGBA in [0, 1]
    "tolerances": _TOLERANCES,
}
