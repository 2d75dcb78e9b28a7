"""Tolerances of whole renders against the exact reference, one row per pipeline / number format.

Every test that compares a render with ``warpvol.reference.numpy_render`` takes its bounds from here, so the
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
                                                 1e6 sizes); Blunt Fin 6.8e-8 / 6.4e-6; Blunt Fin
                                                 close view 512^2, narrow shell TF (crossing scalars'
                                                 float32 error bounded, rays over it redone in
                                                 float64): 9.9e-7 / 2.7e-5
segment/fp32           (rel) 2e-5   --           one segment integral in float32 vs float64 closed form
planner/skip           1e-6         1e-5         a render with a stage the planner left out forced back
                                                 on vs the render without it (same pipeline, same
                                                 scene): the skip rule claims the stage changes
                                                 nothing. Seen: 0 / 0 (raycast, peel on convex meshes)
skip/on_off            1e-6         1e-5         a render with skipping on (invisible cells culled, early
                                                 termination at a 1e-6 bound, front-to-back blending) vs
                                                 the same pipeline with skip=False: the cells left out
                                                 composite as the identity. Seen (pt_best): <= 1.0e-6
                                                 max_abs (blending order's rounding)
pt/constant_tf/ortho/   1e-4 / 5e-4  1e-3 / 2.5e-3  projected tetrahedra, constant TF (averaged colour exact):
  fp32 / fp16                            thick vertex rounded to 1/256 px while its (sf, sb, l)
                                         are the exact crossing's; fp32 seen 3.4e-5 / 3.6e-4,
                                         fp16 1.8e-4 / 1.2e-3 (box, 48^2, random orthographic view)
pt/constant_tf/ortho/   4e-4 / 4e-3  2e-3 / 2e-2    + frame-buffer rounding after every blend; seen unorm12
  unorm12 / unorm8                                  1.6e-4 / 8.8e-4, unorm8 2.2e-3 / 1.2e-2
pt/constant_tf/         4e-3         4e-2           l interpolated linearly in screen space is not
  perspective/fp32                                  perspective-correct (Kraus et al. 2004); seen 2.1e-3
                                                    / 2.4e-2
pt_vertex_color/fp32    1.2e-2       0.1            Shirley-Tuchman/Stein averaged colour on smooth TFs
                                                    (linear_box, concave, stiff 64^2); seen <= 7.3e-3 /
                                                    7.7e-2. Not for narrow TF peaks (sphere: 0.10 / 0.63)
roettger2000_3d         1.5e-2       0.12           preset as shipped (software 64^3 table, RGBA8 table,
                                                    8-bit buffer); box, linear_box, sphere, concave 64^2;
                                                    seen <= 8.4e-3 / 8.7e-2
roettger2000_3d/stiff   5e-2         0.3            cells 2e-5 thin read the first l texel centre
                                                    (lmax / 128) of the uniform l axis; seen 2.9e-2 / 0.22
pt_table3d/exact/fp32   4e-3         4e-2           exact 128x128x64 table, fp32 texture and buffer, sphere
                                                    64^2 (screen-linear sf, sb, l); seen 2.3e-3 / 2.3e-2
roettger2002_hw/        4e-2         0.3            emulated 12-bit per-slice table 32x32x32, 128 steps,
  32x32x32                                          rgba12 texture, 12-bit buffer; every blend rounds
                                                    (error grows with steps, Roettger & Ertl Table 1);
                                                    box, sphere 48^2; seen <= 2.9e-2 / 0.24
roettger2002_cylindrical  2.5e-2     0.2            preset as shipped (64 planes of 64^2 = 1x, RGBA8 atlas,
                                                    8-bit buffer); linear_box, sphere, concave 64^2; seen
                                                    <= 1.6e-2 / 0.165 (sphere; 4x planes: 1.2e-2 / 0.12).
                                                    stiff uses the roettger2000_3d/stiff row (seen 2.95e-2
                                                    / 0.224)
roettger2002_hw         2e-2         0.15           preset as shipped (64^3, 128 steps, 12 bit), concave
                                                    64^2; seen at 128^2: box 1.0e-2 / 0.064, linear_box
                                                    4.9e-3 / 0.031, sphere 1.2e-2 / 0.099, concave 9.1e-3
                                                    / 0.071, stiff 6.3e-3 / 0.082
guthe2002_*            5e-3         5e-2         presets with n_s = 64 (shipped: 512), box, linear_box,
                                                 concave, stiff 48^2 (colour x extinction only); seen
                                                 linear <= 3.2e-3 / 2.9e-2, degree 2 <= 3.0e-3 / 2.9e-2
                                                 (software slices, m = 128; 8-bit buffer and texels
                                                 dominate)
guthe2002_quartic_     4.5e-2       0.25         the Radeon 8500 preset: 12-bit ping-pong slices (m =
radeon                                           128, truncated every pass); seen box 1.33e-2 / 3.5e-2,
                                                 linear_box 1.38e-2 / 4.0e-2, concave 3.38e-2 / 0.177,
                                                 stiff 1.06e-2 / 5.9e-2 (exact slices: <= 3.1e-3 / 2.9e-2)
kraus2004_basic        1.8e-2       0.14         n_s = 64, 8-bit table and buffer, uniform l axis, all
                                                 built-ins 48^2; seen <= 1.16e-2 / 9.0e-2 (sphere's narrow
                                                 peak); stiff row 6e-3 / 5e-2 (seen 3.4e-3 / 2.9e-2)
kraus2004_full         1.6e-2       0.15         n_s = 64, HILO16, log2 axis on every mesh (the paper's),
                                                 perspective-correct on every camera, fp16 buffer; seen
                                                 box 1.8e-3 / 5.4e-3, concave 4.5e-3 / 1.7e-2 (the log
                                                 axis' coarse thick slices), sphere 1.22e-2 / 9.8e-2
                                                 (table resolution on the narrow peak); stiff row 6e-3 /
                                                 3e-2 (seen 3.5e-3 / 1.6e-2)
pt_best                2.5e-4       4e-3         exact per-fragment integral, perspective-correct, fp32
                                                 buffer, MPVO / XMPVO; attribute planes from the
                                                 unsnapped positions (coverage snapped); seen 64^2 box
                                                 3.4e-8 / 2.9e-7, sphere 1.1e-5 / 4.7e-4, concave 2.6e-6 /
                                                 1.6e-4, stiff 8.9e-6 / 2.2e-4; sphere with 4,096 rough
                                                 TF points 3.4e-5 / 1.7e-3 (20,000: 8.0e-5 / 7.0e-3,
                                                 warned with its rounding bound); Blunt Fin 128^2
                                                 1.4e-5 / 1.7e-3 (snapped planes: 3.3e-5 / 7.9e-4); with
                                                 snapped planes SPX 512^2 6.8e-6 / 7.8e-4, Blunt Fin close
                                                 1.8e-5 / 1.7e-3 (pixels inside faces the snapping can
                                                 flip redone in float64)
harc_best               2e-6         1e-4         the raycast/fp32 walk (shared funcs) entered from the
                                                    rasterised boundary, exact segments, fp32 buffer; seen on
                                                    the built-ins 48^2 <= 1.9e-7 / 3.3e-6
espinha2005_partial     1e-2         0.25         paper's Fig. 6 plane walk, 256^2 centre-anchored iso table
                                                    (nearest: control points between sf and its texel centre
                                                    are missed, counted in iso_missed), 512^2 fp16 psi, RGBA8
                                                    buffer; seen 48^2 sphere 6.0e-3 / 0.18 (narrow TF
                                                    peaks), others <= 9.3e-4 / 5.4e-3
espinha2005_full        2.5e-2       0.15         128^3 RGBA8 exact table, trilinear with 8-bit weights, RGBA8
                                                    buffer; seen 48^2 <= 1.6e-2 / 0.10 (stiff: thin cells read
                                                    the first l texel), others <= 2.0e-3 / 2.3e-2
weiler2003_vicp         2.5e-2       0.15         VICP: per-fragment ray exit, MPVO/MPVONC, 128^3 RGBA8 table,
                                                    8-bit blending; seen 48^2 <= 1.7e-2 / 0.11 (stiff), others
                                                    <= 3.0e-3 / 3.1e-2
harc/partial_segment    --           5e-6         one cell segment: iso splits (edge-anchored 256^2 table,
                                                    'behind' rule) + psi (512^2 endpoint fp32, fp32 weights)
                                                    vs the exact integral, 255-segment TF; seen 1.4e-6
vsbuffer/              6e-2         4e-1         the paper's VSBUFFER at 32x32, buffer rows = image
  westermann1997                                 height, trapezoid rule (1 step per cell) and cells
                                                 the buffer misses lost (counted as lost_segments).
                                                 Seen: rmse <= 0.050, max_abs <= 0.375 (sphere)
vsbuffer/              2e-6         1e-4         exact segments, gaps behind interior faces recovered
  vsbuffer_best                                  and rays the audit flags integrated again from their
                                                 sorted cut cells; float32 as raycast/fp32. Seen:
                                                 rmse <= 1.9e-7, max_abs <= 3.2e-6 (built-ins, 32x32)
vsbuffer/table_exact   1e-2         0.1          vsb_sweep integration = table: 64^2 x 32 fp32 exact
                                                 table, log2 thickness axis, trilinear with 8-bit
                                                 weights, otherwise as vsbuffer_best. Seen: rmse <=
                                                 7.6e-3, max_abs <= 6.6e-2 (sphere; table resolution)
pieces/raycast         1e-5         1e-4         a mesh cut into pieces, each rendered by raycast into
                                                 segments and merged by depth, against the single-process
                                                 raycast image (early termination off in the pieces;
                                                 float32 points of a piece in the whole mesh's frame).
                                                 Seen: rmse <= 4.2e-8, max_abs <= 5.9e-7 (built-ins, 48x40,
                                                 3 slab pieces); Lox post in 4 pieces 1.3e-7 / 2.5e-6
pieces/harc_best       1e-5         1e-4         as pieces/raycast, each piece rendered by harc_best into
                                                 segments (its first pass and depth-peel passes), against
                                                 the single-process harc_best image. Seen: rmse <= 3.3e-8,
                                                 max_abs <= 7.3e-7 (concave, sphere, box; 48x40, 3 slab
                                                 pieces; concave 24x20, 2)
pieces/reference       --           1e-12        the exact reference of pieces merged by depth against the
                                                 whole mesh's. Seen: <= 3.3e-16
=====================  ===========  ===========  ==================================================
"""

TOLERANCES = {
    "raycast/fp32": {"rmse": 2e-6, "max_abs": 1e-4},
    "segment/fp32": {"rtol": 2e-5, "atol": 1e-6},
    "planner/skip": {"rmse": 1e-6, "max_abs": 1e-5},
    "skip/on_off": {"rmse": 1e-6, "max_abs": 1e-5},
    "pt/constant_tf/ortho/fp32": {"rmse": 1e-4, "max_abs": 1e-3},
    "pt/constant_tf/ortho/fp16": {"rmse": 5e-4, "max_abs": 2.5e-3},
    "pt/constant_tf/ortho/unorm12": {"rmse": 4e-4, "max_abs": 2e-3},
    "pt/constant_tf/ortho/unorm8": {"rmse": 4e-3, "max_abs": 2e-2},
    "pt/constant_tf/perspective/fp32": {"rmse": 4e-3, "max_abs": 4e-2},
    "pt_vertex_color/fp32": {"rmse": 1.2e-2, "max_abs": 0.1},
    "roettger2000_3d": {"rmse": 1.5e-2, "max_abs": 0.12},
    "roettger2000_3d/stiff": {"rmse": 5e-2, "max_abs": 0.3},
    "pt_table3d/exact/fp32": {"rmse": 4e-3, "max_abs": 4e-2},
    "roettger2002_hw/32x32x32": {"rmse": 4e-2, "max_abs": 0.3},
    "roettger2002_hw": {"rmse": 2e-2, "max_abs": 0.15},
    "roettger2002_cylindrical": {"rmse": 2.5e-2, "max_abs": 0.2},
    "guthe2002_linear": {"rmse": 0.005, "max_abs": 0.05},
    "guthe2002_quadratic_gf4": {"rmse": 0.005, "max_abs": 0.05},
    "guthe2002_quartic_radeon": {"rmse": 0.045, "max_abs": 0.25},
    "kraus2004_basic": {"rmse": 0.018, "max_abs": 0.14},
    "kraus2004_basic/stiff": {"rmse": 0.006, "max_abs": 0.05},
    "kraus2004_full": {"rmse": 0.016, "max_abs": 0.15},
    "kraus2004_full/stiff": {"rmse": 0.006, "max_abs": 0.03},
    "pt_best": {"rmse": 0.00025, "max_abs": 0.004},
    "harc_best": {"rmse": 2e-6, "max_abs": 1e-4},
    "espinha2005_partial": {"rmse": 1e-2, "max_abs": 0.25},
    "espinha2005_full": {"rmse": 2.5e-2, "max_abs": 0.15},
    "weiler2003_vicp": {"rmse": 2.5e-2, "max_abs": 0.15},
    "harc/partial_segment": {"max_abs": 5e-6},
    "vsbuffer/westermann1997": {"rmse": 6e-2, "max_abs": 4e-1},
    "vsbuffer/vsbuffer_best": {"rmse": 2e-6, "max_abs": 1e-4},
    "vsbuffer/table_exact": {"rmse": 1e-2, "max_abs": 0.1},
    "pieces/raycast": {"rmse": 1e-5, "max_abs": 1e-4},
    "pieces/harc_best": {"rmse": 1e-5, "max_abs": 1e-4},
    "pieces/reference": {"max_abs": 1e-12},
}

#: bounds of the pre-integration table builders against their references (the table tests; the keys are
#: described in ``tests/test_tables_common.py``)
TABLE_TOLERANCES = {
    "exact3d/fp32": {"rtol": 2e-5, "atol": 2e-6},
    "exact3d/fp16": {"rtol": 2 ** -11, "atol": 2e-6},
    "exact3d/hilo16": {"atol": 0.5 / 65535 + 2e-6},
    "exact3d/rgba8": {"atol": 0.5 / 255 + 2e-6},
    "roettger_sw/fp32/color_extinction": {"rms": 0.01, "max": 0.05},
    # eq. 6's Stein step (l/n) kappa with n = 1..2 near the diagonal at l rho = 2: first-order error
    "roettger_sw/fp32/emission_density": {"rms": 0.05, "max": 0.6},
    "roettger_hw/12": {"lsb": 1 / 4095},
    "roettger_hw/8": {"lsb": 1 / 255},
    "geforce3/8": {"lsb": 1 / 255},
    "pingpong/radeon8500": {"lsb": 1 / 4080},
    "incremental/log2": {"max": 0.02},
    "incremental/uniform": {"max": 0.02},
    "cylindrical/4x": {"max": 0.05},  # and <= the 3D table's own trilinear error (asserted too)
    "guthe/nodes": {"max": 2e-3},
    "psi/fp32": {"atol": 3e-6},
}

#: the row of each shipped preset as shipped (presets whose row is not their name)
PRESET_ROWS = {"raycast": "raycast/fp32", "pt_vertex_color": "pt_vertex_color/fp32",
               "westermann1997": "vsbuffer/westermann1997", "vsbuffer_best": "vsbuffer/vsbuffer_best"}


#: the presets that promise the exact reference to float32 (the tests that sweep "every exact preset" use these)
EXACT_PRESETS = ("raycast", "harc_best", "pt_best", "vsbuffer_best")

#: rows for a preset on a scene class its own row does not cover: (preset, variant) -> row
VARIANT_ROWS = {("roettger2002_cylindrical", "stiff"): "roettger2000_3d/stiff"}


def preset_tolerance(name: str, variant: str | None = None) -> dict:
    """The tolerance row of the shipped preset ``name`` (its own name, else :data:`PRESET_ROWS`); with
    ``variant`` (e.g. ``"stiff"``) the row ``<row>/<variant>`` where the table has one (or
    :data:`VARIANT_ROWS`), else the preset's row."""
    row = PRESET_ROWS.get(name, name)
    if variant is not None:
        row = VARIANT_ROWS.get((name, variant), row + "/" + variant if f"{row}/{variant}" in TOLERANCES else row)
    return TOLERANCES[row]
