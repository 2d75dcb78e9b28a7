"""The shipped presets grouped by purpose, as ``warpvol pipelines`` lists them: exact and fast, cell
projection as VTK does it, then each paper's faithful reproduction, every preset with a short line.

Examples
--------
>>> groups = preset_groups()
>>> groups[0][0], [name for name, _, _ in groups[0][1]][:2]
('exact and fast', ['raycast', 'harc_best'])
"""

from __future__ import annotations

from warpvol.family import family_declaration, family_packages
from warpvol.pipeline import list_presets

#: ``warpvol pipelines``: the presets by purpose, each with a short line (the full description with --long)
PRESET_FAMILIES: tuple[tuple[str, dict[str, str]], ...] = (
    ("exact and fast", {
        "raycast": "default; float32 ray casting through the cells, exact segment integrals",
        "harc_best": "hardware ray casting (rasterised start, peeling), raycast's exact walk",
        "pt_best": "cell projection with exact visibility and an exact per-fragment integral",
        "vsbuffer_best": "VSBUFFER sweep made exact, hexahedra drawn whole; slow (plane by plane)",
    }),
    ("cell projection as VTK does it", {
        "pt_vertex_color": "projected tetrahedra, averaged per-vertex colour, 8-bit blending",
    }),
    ("Westermann & Ertl 1997", {
        "westermann1997": "VSBUFFER as published: ID buffers per scanline, trapezoidal rule",
    }),
    ("Roettger, Kraus & Ertl 2000; Roettger & Ertl 2002", {
        "roettger2000_3d": "pre-integrated PT, software 64^3 table in an RGBA8 3D texture",
        "roettger2002_hw": "pre-integrated PT, table built by emulated 12-bit Octane MXI hardware",
        "roettger2002_cylindrical": "pre-integrated PT, the 3D table as cylindrical 2D alpha-planes",
    }),
    ("Guthe et al. 2002", {
        "guthe2002_linear": "2D multi-texturing, separated opacity, colour linear in thickness",
        "guthe2002_quadratic_gf4": "as guthe2002_linear, colour of degree 2 (GeForce4, 4 texture units)",
        "guthe2002_quartic_radeon": "as guthe2002_linear, colour of degree 4 (Radeon 8500, 6 units)",
    }),
    ("Weiler et al. 2003", {
        "weiler2003_vicp": "view-independent cell projection, 128^3 8-bit pre-integration table",
    }),
    ("Kraus, Qiao & Ebert 2004", {
        "kraus2004_basic": "pre-integrated PT, 8-bit 256x256x16 table, screen-space attributes",
        "kraus2004_full": "perspective-correct attributes, HILO16 log-thickness table, fp16 buffer",
    }),
    ("Espinha & Celes 2005", {
        "espinha2005_full": "hardware ray casting with a full 128^3 RGBA8 pre-integration table",
        "espinha2005_partial": "hardware ray casting with partial pre-integration (iso-crossing, psi)",
    }),
)
#: the preset tables of README.md and docs/guide/presets.md (``scripts/preset_tables.py`` writes both):
#: (purpose, paper page under docs/papers/ or None, presets, what they are)
PRESET_TABLE: tuple[tuple[str, str | None, tuple[str, ...], str], ...] = (
    ("exact and fast", None, ("raycast",),
     "float32 ray casting through the cell adjacency, exact segment integrals for the piecewise-linear transfer "
     "function, re-entry for non-convex meshes; handles the eye inside the mesh; walks only the cells the transfer "
     "function makes visible and stops a ray once its transmittance is below 1e-6 (`--no-skip`: every cell, every "
     "ray to its end)"),
    ("exact and fast", None, ("harc_best",),
     "hardware ray casting (rasterised ray start, depth peeling) made exact: `raycast`'s walk and integrals in the "
     "HARC pipeline, leaving out the same"),
    ("exact and fast", None, ("pt_best",),
     "cell projection with exact visibility at the pixel centres, perspective-correct attributes and an exact "
     "per-fragment integral (no table)"),
    ("exact", None, ("vsbuffer_best",),
     "the VSBUFFER sweep with hexahedra, wedges and pyramids drawn whole, every missed cell recovered and the rays "
     "through cells too thin for float32 traced in float64; slow, since the sweep is emulated plane by plane"),
    ("cell projection as VTK does it", None, ("pt_vertex_color",),
     "projected tetrahedra (Shirley & Tuchman 1990), averaged per-vertex colour, 8-bit blending"),
    ("Westermann & Ertl 1997", "westermann1997.md", ("westermann1997",),
     "VSBUFFER as published: ID buffers per scanline, trapezoidal rule, missed cells counted"),
    ("Röttger, Kraus & Ertl 2000; Röttger & Ertl 2002", "roettger2002.md",
     ("roettger2000_3d", "roettger2002_hw", "roettger2002_cylindrical"),
     "pre-integrated projected tetrahedra: software 3D table, emulated 12-bit hardware table, cylindrical 2D "
     "planes"),
    ("Guthe et al. 2002", "guthe2002.md", ("guthe2002_linear", "guthe2002_quadratic_gf4", "guthe2002_quartic_radeon"),
     "2D multi-texturing with a separated opacity and a colour polynomial of degree 1, 2 or 4"),
    ("Weiler et al. 2003", "espinha2005.md", ("weiler2003_vicp",),
     "view-independent cell projection with a 128³ 8-bit table (Espinha & Celes' baseline)"),
    ("Kraus, Qiao & Ebert 2004", "kraus2004.md", ("kraus2004_basic", "kraus2004_full"),
     "pre-integrated projected tetrahedra without and with perspective-correct attributes, HILO16 table on a "
     "logarithmic thickness axis and an fp16 buffer"),
    ("Espinha & Celes 2005", "espinha2005.md", ("espinha2005_full", "espinha2005_partial"),
     "hardware ray casting with a full 3D table or with partial pre-integration"),
)
#: columns of ``warpvol pipelines`` lines
PIPELINES_WIDTH = 100


def preset_groups() -> list[tuple[str, list[tuple[str, str, str]]]]:
    """``(family, [(preset, short line, full description)])`` of every shipped preset: the families of
    :data:`PRESET_FAMILIES`, then "other" for presets they do not name (short line: the description cut)."""

    full = dict(list_presets())
    groups, named = [], set()
    for family, items in PRESET_FAMILIES:
        rows = [(n, short, full[n]) for n, short in items.items() if n in full]
        named.update(items)
        if rows:
            groups.append((family, rows))
    for package in family_packages():  # the groups families declare (``FAMILY["title"]``, ``["presets"]``)
        decl = family_declaration(package)
        rows = [(n, short, full[n]) for n, short in decl.get("presets", {}).items() if n in full and n not in named]
        named.update(n for n, _, _ in rows)
        if rows:
            groups.append((decl.get("title", package), rows))
    other = [(n, d, d) for n, d in full.items() if n not in named]
    if other:
        groups.append(("other", other))
    return groups


def fit_line(text: str, width: int = PIPELINES_WIDTH) -> str:
    """``text`` cut to ``width`` columns (ending in ``...`` when cut)."""
    return text if len(text) <= width else text[:width - 3].rstrip() + "..."
