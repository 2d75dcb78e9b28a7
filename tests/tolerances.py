"""Tolerances of whole renders against the exact reference, one row per pipeline / number format.

Every test that compares a render with ``warpvol.reference.numpy_render`` takes its bounds from here, so the
accuracy each pipeline promises is stated in one place. Values are on premultiplied RGBA in [0, 1].

The rows of a family's presets are declared by the family, in its folder (``FAMILY["tolerances"]`` in
``warpvol/<family>/__init__.py``, each row with why it is what it is; ``FAMILY["tolerance_rows"]`` names a
preset's row where it is not the preset's name): :data:`TOLERANCES` gathers them
(:func:`warpvol.family.family_tolerances`), with the rows below, which belong to no one family.

=====================  ===========  ===========  ==================================================
key                    rmse         max_abs      why
=====================  ===========  ===========  ==================================================
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

from warpvol.family import family_papers, family_tolerances

#: the rows that belong to no one family (the families' rows are added below)
SHARED_TOLERANCES = {
    "segment/fp32": {"rtol": 2e-5, "atol": 1e-6},
    "planner/skip": {"rmse": 1e-6, "max_abs": 1e-5},
    "skip/on_off": {"rmse": 1e-6, "max_abs": 1e-5},
    "pieces/raycast": {"rmse": 1e-5, "max_abs": 1e-4},
    "pieces/harc_best": {"rmse": 1e-5, "max_abs": 1e-4},
    "pieces/reference": {"max_abs": 1e-12},
}
_FAMILY_ROWS, _FAMILY_PRESET_ROWS = family_tolerances()
_twice = sorted(set(SHARED_TOLERANCES) & set(_FAMILY_ROWS))
assert not _twice, f"tolerance rows declared here and by a family: {_twice}"
#: every row: those above and the families' (their bounds; the ``why`` stays in the declaration)
TOLERANCES = {**SHARED_TOLERANCES,
              **{k: {b: v for b, v in row.items() if b != "why"} for k, row in _FAMILY_ROWS.items()}}

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

#: the row of each shipped preset as shipped (presets whose row is not their name; the families declare them)
PRESET_ROWS = {k: v for k, v in _FAMILY_PRESET_ROWS.items() if "/" not in k}

#: the presets that promise the exact reference to float32 (the tests that sweep "every exact preset" use these):
#: those of the paper entries the families declare ``"exact": True``
EXACT_PRESETS = tuple(n for paper in family_papers() if paper.get("exact") for n in paper.get("presets", {}))

#: rows for a preset on a scene class its own row does not cover: (preset, variant) -> row (the families
#: declare them as "preset/variant")
VARIANT_ROWS = {tuple(k.split("/", 1)): v for k, v in _FAMILY_PRESET_ROWS.items() if "/" in k}


def preset_tolerance(name: str, variant: str | None = None) -> dict:
    """The tolerance row of the shipped preset ``name`` (its own name, else :data:`PRESET_ROWS`); with
    ``variant`` (e.g. ``"stiff"``) the row ``<row>/<variant>`` where the table has one (or
    :data:`VARIANT_ROWS`), else the preset's row."""
    row = PRESET_ROWS.get(name, name)
    if variant is not None:
        row = VARIANT_ROWS.get((name, variant), row + "/" + variant if f"{row}/{variant}" in TOLERANCES else row)
    return TOLERANCES[row]
