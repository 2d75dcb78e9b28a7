"""Projected tetrahedra: host code (:mod:`.pt`, :mod:`.sort`, :mod:`.pt_thin`, :mod:`.programs`) and the
stages (:mod:`.stages`) of Shirley & Tuchman, Röttger & Ertl, Guthe et al., Weiler et al., Kraus et al. and
``pt_best``.

Several papers share this folder because they share the projected-tetrahedra pipeline (vertex transform,
visibility sort, projection, rasteriser and blending): :data:`FAMILY`'s ``papers`` say which files each one
uses (the architecture page's table is generated from them).
"""

#: the tolerance rows of the family's presets (tests/tolerances.py gathers them)
_TOLERANCES = {
    "pt/constant_tf/ortho/fp32": {"rmse": 0.0001, "max_abs": 0.001,
             "why": ("projected tetrahedra, constant TF (averaged colour exact): thick vertex rounded to 1/256 px while "
                     "its (sf, sb, l) are the exact crossing's; seen 3.4e-5 / 3.6e-4 (box, 48^2, random orthographic view)")},
    "pt/constant_tf/ortho/fp16": {"rmse": 0.0005, "max_abs": 0.0025,
             "why": "as pt/constant_tf/ortho/fp32 with an fp16 buffer; seen 1.8e-4 / 1.2e-3"},
    "pt/constant_tf/ortho/unorm12": {"rmse": 0.0004, "max_abs": 0.002,
             "why": ("as pt/constant_tf/ortho/fp32, + frame-buffer rounding after every blend; seen unorm12 1.6e-4 / "
                     "8.8e-4, unorm8 2.2e-3 / 1.2e-2")},
    "pt/constant_tf/ortho/unorm8": {"rmse": 0.004, "max_abs": 0.02,
             "why": ("as pt/constant_tf/ortho/fp32, + frame-buffer rounding after every blend; seen unorm12 1.6e-4 / "
                     "8.8e-4, unorm8 2.2e-3 / 1.2e-2")},
    "pt/constant_tf/perspective/fp32": {"rmse": 0.004, "max_abs": 0.04,
             "why": ("l interpolated linearly in screen space is not perspective-correct (Kraus et al. 2004); seen 2.1e-3 "
                     "/ 2.4e-2")},
    "pt_vertex_color/fp32": {"rmse": 0.012, "max_abs": 0.1,
             "why": ("Shirley-Tuchman/Stein averaged colour on smooth TFs (linear_box, concave, stiff 64^2); seen <= "
                     "7.3e-3 / 7.7e-2. Not for narrow TF peaks (sphere: 0.10 / 0.63)")},
    "roettger2000_3d": {"rmse": 0.015, "max_abs": 0.12,
             "why": ("preset as shipped (software 64^3 table, RGBA8 table, 8-bit buffer); box, linear_box, sphere, concave "
                     "64^2; seen <= 8.4e-3 / 8.7e-2")},
    "roettger2000_3d/stiff": {"rmse": 0.05, "max_abs": 0.3,
             "why": "cells 2e-5 thin read the first l texel centre (lmax / 128) of the uniform l axis; seen 2.9e-2 / 0.22"},
    "pt_table3d/exact/fp32": {"rmse": 0.004, "max_abs": 0.04,
             "why": ("exact 128x128x64 table, fp32 texture and buffer, sphere 64^2 (screen-linear sf, sb, l); seen 2.3e-3 "
                     "/ 2.3e-2")},
    "roettger2002_hw/32x32x32": {"rmse": 0.04, "max_abs": 0.3,
             "why": ("emulated 12-bit per-slice table 32x32x32, 128 steps, rgba12 texture, 12-bit buffer; every blend "
                     "rounds (error grows with steps, Roettger & Ertl Table 1); box, sphere 48^2; seen <= 2.9e-2 / 0.24")},
    "roettger2002_hw": {"rmse": 0.02, "max_abs": 0.15,
             "why": ("preset as shipped (64^3, 128 steps, 12 bit), concave 64^2; seen at 128^2: box 1.0e-2 / 0.064, "
                     "linear_box 4.9e-3 / 0.031, sphere 1.2e-2 / 0.099, concave 9.1e-3 / 0.071, stiff 6.3e-3 / 0.082")},
    "roettger2002_cylindrical": {"rmse": 0.025, "max_abs": 0.2,
             "why": ("preset as shipped (64 planes of 64^2 = 1x, RGBA8 atlas, 8-bit buffer); linear_box, sphere, concave "
                     "64^2; seen <= 1.6e-2 / 0.165 (sphere; 4x planes: 1.2e-2 / 0.12). stiff uses the "
                     "roettger2000_3d/stiff row (seen 2.95e-2 / 0.224)")},
    "guthe2002_linear": {"rmse": 0.005, "max_abs": 0.05,
             "why": ("presets with n_s = 64 (shipped: 512), box, linear_box, concave, stiff 48^2 (colour x extinction "
                     "only); seen linear <= 3.2e-3 / 2.9e-2, degree 2 <= 3.0e-3 / 2.9e-2 (software slices, m = 128; 8-bit "
                     "buffer and texels dominate)")},
    "guthe2002_quadratic_gf4": {"rmse": 0.005, "max_abs": 0.05,
             "why": ("presets with n_s = 64 (shipped: 512), box, linear_box, concave, stiff 48^2 (colour x extinction "
                     "only); seen linear <= 3.2e-3 / 2.9e-2, degree 2 <= 3.0e-3 / 2.9e-2 (software slices, m = 128; 8-bit "
                     "buffer and texels dominate)")},
    "guthe2002_quartic_radeon": {"rmse": 0.045, "max_abs": 0.25,
             "why": ("the Radeon 8500 preset: 12-bit ping-pong slices (m = 128, truncated every pass); seen box 1.33e-2 / "
                     "3.5e-2, linear_box 1.38e-2 / 4.0e-2, concave 3.38e-2 / 0.177, stiff 1.06e-2 / 5.9e-2 (exact slices: "
                     "<= 3.1e-3 / 2.9e-2)")},
    "kraus2004_basic": {"rmse": 0.018, "max_abs": 0.14,
             "why": ("n_s = 64, 8-bit table and buffer, uniform l axis, all built-ins 48^2; seen <= 1.16e-2 / 9.0e-2 "
                     "(sphere's narrow peak); stiff row 6e-3 / 5e-2 (seen 3.4e-3 / 2.9e-2)")},
    "kraus2004_basic/stiff": {"rmse": 0.006, "max_abs": 0.05,
             "why": "kraus2004_basic on the stiff scene; seen 3.4e-3 / 2.9e-2"},
    "kraus2004_full": {"rmse": 0.016, "max_abs": 0.15,
             "why": ("n_s = 64, HILO16, log2 axis on every mesh (the paper's), perspective-correct on every camera, fp16 "
                     "buffer; seen box 1.8e-3 / 5.4e-3, concave 4.5e-3 / 1.7e-2 (the log axis' coarse thick slices), "
                     "sphere 1.22e-2 / 9.8e-2 (table resolution on the narrow peak); stiff row 6e-3 / 3e-2 (seen 3.5e-3 / "
                     "1.6e-2)")},
    "kraus2004_full/stiff": {"rmse": 0.006, "max_abs": 0.03,
             "why": "kraus2004_full on the stiff scene; seen 3.5e-3 / 1.6e-2"},
    "pt_best": {"rmse": 0.00025, "max_abs": 0.004,
             "why": ("exact per-fragment integral, perspective-correct, fp32 buffer, MPVO / XMPVO; attribute planes from "
                     "the unsnapped positions (coverage snapped); seen 64^2 box 3.4e-8 / 2.9e-7, sphere 1.1e-5 / 4.7e-4, "
                     "concave 2.6e-6 / 1.6e-4, stiff 8.9e-6 / 2.2e-4; sphere with 4,096 rough TF points 3.4e-5 / 1.7e-3 "
                     "(20,000: 8.0e-5 / 7.0e-3, warned with its rounding bound); Blunt Fin 128^2 1.4e-5 / 1.7e-3 (snapped "
                     "planes: 3.3e-5 / 7.9e-4); with snapped planes SPX 512^2 6.8e-6 / 7.8e-4, Blunt Fin close 1.8e-5 / "
                     "1.7e-3 (pixels inside faces the snapping can flip redone in float64)")},
    "weiler2003_vicp": {"rmse": 0.025, "max_abs": 0.15,
             "why": ("VICP: per-fragment ray exit, MPVO/MPVONC, 128^3 RGBA8 table, 8-bit blending; seen 48^2 <= 1.7e-2 / "
                     "0.11 (stiff), others <= 3.0e-3 / 3.1e-2")},
}

#: the family's declaration (:mod:`warpvol.family`): its papers and their presets, pages, files; the
#: tolerance rows of its presets. A renderer family imports no other family.
FAMILY = {
    "title": "cell projection",
    "renderer": True,
    "papers": (
        {"title": "exact and fast", "order": (0, 3), "name": "Exact cell projection", "exact": True,
         "presets": {"pt_best": "cell projection with exact visibility and an exact per-fragment integral"},
         "table": "cell projection with exact visibility at the pixel centres, perspective-correct attributes and "
                  "an exact per-fragment integral (no table)",
         "code": {"host": ["projection/pt.py", "projection/programs.py", "projection/pt_thin.py",
                           "shared/pixel_marks.py"],
                  "stages": ["projection/stages/pt_integrate.py", "projection/stages/pt_perspective.py",
                             "conditioning/stages/condition.py", "conditioning/stages/visibility.py"],
                  "kernels": ["kernels/pt_classify.py", "kernels/pt.py", "kernels/pt_draw.py", "kernels/pt_span.py",
                              "kernels/pt_span_lanes.py", "kernels/integrate.py"]}},
        {"title": "cell projection as VTK does it", "order": (1, 1), "name": "Shirley & Tuchman 1990",
         "presets": {"pt_vertex_color": "projected tetrahedra, averaged per-vertex colour, 8-bit blending"},
         "table": "projected tetrahedra (Shirley & Tuchman 1990), averaged per-vertex colour, 8-bit blending",
         "code": {"host": ["projection/pt.py", "projection/programs.py"],
                  "stages": ["projection/stages/vertex.py", "projection/stages/sort_cells.py",
                             "projection/stages/pt_project.py", "projection/stages/pt_vertex_color.py"],
                  "kernels": ["kernels/pt_classify.py", "kernels/pt.py", "kernels/pt_draw.py", "kernels/vertex.py",
                              "kernels/raster*.py", "kernels/blend.py"]}},
        {"title": "visibility sort", "order": (1, 2), "name": "Visibility sort (MPVO, MPVONC, XMPVO, centroid)",
         "code": {"host": ["projection/sort.py"], "stages": ["projection/stages/sort_cells.py"],
                  "kernels": ["kernels/sort.py"]}},
        {"title": "Roettger, Kraus & Ertl 2000; Roettger & Ertl 2002", "order": (2, 2000),
         "purpose": "Röttger, Kraus & Ertl 2000; Röttger & Ertl 2002",
         "page": "papers/roettger2002.md", "nav": "Röttger & Ertl 2002",
         "presets": {"roettger2000_3d": "pre-integrated PT, software 64^3 table in an RGBA8 3D texture",
                     "roettger2002_hw": "pre-integrated PT, table built by emulated 12-bit Octane MXI hardware",
                     "roettger2002_cylindrical": "pre-integrated PT, the 3D table as cylindrical 2D alpha-planes"},
         "table": "pre-integrated projected tetrahedra: software 3D table, emulated 12-bit hardware table, "
                  "cylindrical 2D planes",
         "code": {"host": ["projection/pt.py", "projection/programs.py", "tables/roettger_sw.py",
                           "tables/roettger_hw.py", "tables/cylindrical.py"],
                  "stages": ["projection/stages/pt_table3d.py", "projection/stages/pt_cylindrical.py",
                             "tables/stages/table_roettger_*.py", "tables/stages/table_cylindrical.py"],
                  "kernels": ["kernels/pt.py", "kernels/preint.py"],
                  "reproduce": ["reproduce/roettger2002.py", "scripts/reproduce_roettger2002.py"]}},
        {"title": "Guthe et al. 2002", "order": (2, 2002), "page": "papers/guthe2002.md", "nav": "Guthe et al. 2002",
         "presets": {"guthe2002_linear": "2D multi-texturing, separated opacity, colour linear in thickness",
                     "guthe2002_quadratic_gf4": "as guthe2002_linear, colour of degree 2 (GeForce4, 4 texture units)",
                     "guthe2002_quartic_radeon": "as guthe2002_linear, colour of degree 4 (Radeon 8500, 6 units)"},
         "table": "2D multi-texturing with a separated opacity and a colour polynomial of degree 1, 2 or 4",
         "code": {"host": ["projection/pt.py", "projection/programs.py", "tables/guthe2d.py", "tables/pingpong.py"],
                  "stages": ["projection/stages/pt_guthe.py", "tables/stages/table_guthe.py",
                             "tables/stages/table_pingpong.py"],
                  "kernels": ["kernels/pt.py", "kernels/preint.py", "kernels/combiners.py"],
                  "reproduce": ["reproduce/guthe2002.py", "scripts/reproduce_guthe2002.py"]}},
        {"title": "Weiler et al. 2003", "order": (2, 2003), "page": "papers/espinha2005.md",
         "presets": {"weiler2003_vicp": "view-independent cell projection, 128^3 8-bit pre-integration table"},
         "table": "view-independent cell projection with a 128³ 8-bit table (Espinha & Celes' baseline)",
         "code": {"host": ["projection/pt.py", "tables/exact.py"],
                  "stages": ["projection/stages/vicp.py", "tables/stages/table_exact.py"],
                  "kernels": ["kernels/vicp.py"]}},
        {"title": "Kraus, Qiao & Ebert 2004", "order": (2, 2004), "page": "papers/kraus2004.md",
         "nav": "Kraus, Qiao & Ebert 2004",
         "presets": {"kraus2004_basic": "pre-integrated PT, 8-bit 256x256x16 table, screen-space attributes",
                     "kraus2004_full": "perspective-correct attributes, HILO16 log-thickness table, fp16 buffer"},
         "table": "pre-integrated projected tetrahedra without and with perspective-correct attributes, HILO16 "
                  "table on a logarithmic thickness axis and an fp16 buffer",
         "code": {"host": ["projection/pt.py", "projection/programs.py", "tables/incremental.py", "tables/exact.py"],
                  "stages": ["projection/stages/pt_table3d.py", "projection/stages/pt_perspective.py",
                             "tables/stages/table_incremental.py"],
                  "kernels": ["kernels/pt.py", "kernels/preint.py"],
                  "reproduce": ["reproduce/kraus2004.py", "scripts/reproduce_kraus2004.py"]}},
    ),
    "tolerance_rows": {"pt_vertex_color": "pt_vertex_color/fp32",
                       "roettger2002_cylindrical/stiff": "roettger2000_3d/stiff"},
    # tests/tolerances.py: a whole render against the exact reference, premultiplied RGBA in [0, 1]
    "tolerances": _TOLERANCES,
}
