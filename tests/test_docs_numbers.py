"""Numbers the documentation quotes from generated data stay those of the data.

Each claim is a sentence of a page with its numbers as format fields, and where each number comes from
(``docs/data/*.json``, written by the scripts that measure them). The test formats the sentence from the
JSON and finds it on the page: a regenerated JSON that changes a quoted number fails here until the page
says the new number.
"""

import json
from pathlib import Path

import pytest

DOCS = Path(__file__).parents[1] / "docs"


def _tables(name: str) -> dict:
    return json.loads((DOCS / "data" / f"{name}.json").read_text())["tables"]


VM = _tables("validate_model")
ABS = {r[1]: dict(zip(("paper", "modelled", "ratio"), r[2:5])) for r in VM["rows"]["rows"]}


def absolute(row: str, col: str = "ratio") -> float:
    """An absolute row of validate_model.json: ``paper``, ``modelled`` or ``ratio``."""
    return ABS[row][col]


def relative(row: str, card: str, data: str | None = None, col: str = "modelled") -> float:
    """A relative row of validate_model.json (A over B): ``paper``, ``modelled`` or ``ratio``."""
    hits = [r for r in VM["relative"]["rows"] if r[1] == row and r[2] == card and data in (None, r[3])]
    assert len(hits) == 1, (row, card, data, len(hits))
    return dict(zip(("paper", "modelled", "ratio"), hits[0][4:7]))[col]


def at(row: str, which: str) -> float:
    """An absolute row's modelled / paper with its estimated constant halved or doubled."""
    return VM["rows"]["sensitivity"][row][which] / ABS[row]["paper"]


def rel_at(a: str, b: str, which: str) -> float:
    """A over B (speed) with the shared estimated constant halved or doubled, over the paper's A over B."""
    s = VM["rows"]["sensitivity"]
    return (s[a][which] / s[b][which]) / (ABS[a]["paper"] / ABS[b]["paper"])


def counts(rows: str, role: str) -> tuple[int, int]:
    return next((r[2], r[3]) for r in VM["counts"]["rows"] if r[:2] == [rows, role])


R02 = _tables("roettger2002")


def roettger_check(starts: str) -> float:
    """The ours column of a row of roettger2002.json's Table 1 checks."""
    return next(r[2] for r in R02["table1_checks"]["rows"] if r[0].startswith(starts))


F8 = "Fig. 8: 2D planes over 3D texture"
KD, KIV = "T1 total with alpha dithering [s]", "T1 + logarithmic lookup (iv) = frame buffer total [s]"
ESP = "T2/T3 HARC {} [fps]"


def fps(card: str, kind: str, col: str = "modelled") -> float:
    return absolute(f"Fig. 8 {card} {kind} [fps]", col)


#: (page, sentence with format fields, the fields' values)
CLAIMS = [
    ("guide/presets.md", "Fig. 8's modelled 2D-over-3D speed-ups ({g:.2f}x GeForce3, {r:.2f}x Radeon 8500, {o:.2f}x "
     "Octane MXI) against the paper's ({pg:.2f}x, {pr:.2f}x, {po:.2f}x)",
     dict(g=relative(F8, "GeForce3"), r=relative(F8, "Radeon 8500"), o=relative(F8, "Octane MXI"),
          pg=relative(F8, "GeForce3", col="paper"), pr=relative(F8, "Radeon 8500", col="paper"),
          po=relative(F8, "Octane MXI", col="paper"))),
    ("performance.md", "(three of six rows: Radeon 8500 3D {r3:.2f}x and 2D {r2:.2f}x, Octane MXI 3D\n  {o3:.2f}x; "
     "GeForce3 {g3:.2f}x and {g2:.2f}x, Octane 2D {o2:.2f}x)",
     dict(r3=fps("Radeon 8500", "3D texture", "ratio"), r2=fps("Radeon 8500", "2D planes", "ratio"),
          o3=fps("Octane MXI", "3D texture", "ratio"), g3=fps("GeForce3", "3D texture", "ratio"),
          g2=fps("GeForce3", "2D planes", "ratio"), o2=fps("Octane MXI", "2D planes", "ratio"))),
    ("performance.md", "GeForce3's 2D-over-3D speed-up ({g:.2f}x\n  against {pg:.2f}x); the Octane's relative row "
     "fails ({o:.2f}x against {po:.2f}x)",
     dict(g=relative(F8, "GeForce3"), pg=relative(F8, "GeForce3", col="paper"), o=relative(F8, "Octane MXI"),
          po=relative(F8, "Octane MXI", col="paper"))),
    ("performance.md", "**Kraus et al. 2004, alpha dithering** ({d:.2f}x)",
     dict(d=absolute("T1 total with alpha dithering [s]"))),
    ("performance.md", "**Espinha & Celes 2005, LOX Post partial pre-integration** ({p10:.2f}x and {p255:.2f}x; the "
     "full pre-integration\n  row {f:.2f}x)",
     dict(p10=absolute(ESP.format("partial, 10 TF segments LOX Post")),
          p255=absolute(ESP.format("partial, 255 TF segments LOX Post")),
          f=absolute(ESP.format("full pre-integration LOX Post")))),
    ("papers/roettger2002.md", "gives {g:.2f}x on the\nGeForce3 (paper {pg:.2f}x) and {r:.2f}x on the Radeon 8500 "
     "(paper {pr:.2f}x)",
     dict(g=relative(F8, "GeForce3"), pg=relative(F8, "GeForce3", col="paper"), r=relative(F8, "Radeon 8500"),
          pr=relative(F8, "Radeon 8500", col="paper"))),
    ("papers/roettger2002.md", "Absolute rates: {g3:.1f} and {g2:.1f} fps on the GeForce3 ({rg3:.2f}x and {rg2:.2f}x "
     "the paper's), {r3:.1f} and {r2:.1f} fps on\nthe Radeon 8500 ({rr3:.2f}x and {rr2:.2f}x), {o:.1f} fps on both "
     "Octane paths ({ro3:.2f}x and {ro2:.2f}x)",
     dict(g3=fps("GeForce3", "3D texture"), g2=fps("GeForce3", "2D planes"), rg3=fps("GeForce3", "3D texture", "ratio"),
          rg2=fps("GeForce3", "2D planes", "ratio"), r3=fps("Radeon 8500", "3D texture"),
          r2=fps("Radeon 8500", "2D planes"), rr3=fps("Radeon 8500", "3D texture", "ratio"),
          rr2=fps("Radeon 8500", "2D planes", "ratio"), o=fps("Octane MXI", "3D texture"),
          ro3=fps("Octane MXI", "3D texture", "ratio"), ro2=fps("Octane MXI", "2D planes", "ratio"))),
    ("papers/roettger2002.md", "(modelled {m3:.2f}x and {m2:.2f}x)",
     dict(m3=relative("Fig. 8 3D texture: Radeon 8500 over GeForce3", "Radeon 8500 / GeForce3"),
          m2=relative("Fig. 8 2D planes: Radeon 8500 over GeForce3", "Radeon 8500 / GeForce3"))),
    ("papers/espinha2005.md", "the model's 255-over-10 speed ratios ({b:.2f}, {lx:.2f}) match the paper's\n  "
     "({pb:.2f}, {plx:.2f})",
     dict(b=relative("HARC partial, 255 over 10 TF segments", "GeForce 6800 GT", "Blunt Fin"),
          lx=relative("HARC partial, 255 over 10 TF segments", "GeForce 6800 GT", "LOX Post"),
          pb=relative("HARC partial, 255 over 10 TF segments", "GeForce 6800 GT", "Blunt Fin", "paper"),
          plx=relative("HARC partial, 255 over 10 TF segments", "GeForce 6800 GT", "LOX Post", "paper"))),
    ("papers/espinha2005.md", "VICP-GPU over VICP is\n  {m:.2f} (paper {p:.2f}) on the Blunt Fin",
     dict(m=relative("VICP-GPU over VICP", "GeForce 6800 GT", "Blunt Fin"),
          p=relative("VICP-GPU over VICP", "GeForce 6800 GT", "Blunt Fin", "paper"))),
    ("papers/roettger2002.md", "the combiner build gains a factor of {g:.2f} in equivalent steps over plain 8-bit "
     "blending at 64 steps, not the paper's 4 ({e:.2f} with an exact fp32 `l/n`",
     dict(g=roettger_check("GeForce3 combiners at 64 steps, l/n in the 8-bit constant register"),
          e=roettger_check("GeForce3 combiners at 64 steps, l/n an exact fp32 constant"))),
    ("performance.md", "the GeForce3's Fig. 8 2D-over-3D speed-up on the texture-cache block edge (ratio {r:.2f} at 4 "
     "texels, {h:.2f} at 2, {d:.2f} at 8), Kraus' fp16 read-back total on the 10 µs per buffer rebind ({k:.2f}; "
     "{kh:.2f} at 5 µs, {kd:.2f} at 20 µs), and VICP's Blunt Fin frame rate on the host upload rate ({v:.2f}; "
     "{vh:.2f} at half the rate, {vd:.2f} at double)",
     dict(r=relative(F8, "GeForce3", col="ratio"),
          h=rel_at("Fig. 8 GeForce3 2D planes [fps]", "Fig. 8 GeForce3 3D texture [fps]", "half"),
          d=rel_at("Fig. 8 GeForce3 2D planes [fps]", "Fig. 8 GeForce3 3D texture [fps]", "double"),
          k=absolute("T1 total floating-point colour buffer (read-back) [s]"),
          kh=at("T1 total floating-point colour buffer (read-back) [s]", "half"),
          kd=at("T1 total floating-point colour buffer (read-back) [s]", "double"),
          v=absolute(ESP.format("VICP Blunt Fin").replace("HARC ", "")),
          vh=at(ESP.format("VICP Blunt Fin").replace("HARC ", ""), "half"),
          vd=at(ESP.format("VICP Blunt Fin").replace("HARC ", ""), "double"))),
    ("papers/kraus2004.md", "dithering's modelled cost (+{m:.2f} s) is a sixth\n  of the paper's (+{p:.2f} s)",
     dict(m=absolute(KD, "modelled") - absolute(KIV, "modelled"), p=absolute(KD, "paper") - absolute(KIV, "paper"))),
    ("performance.md", "the paper's dithering costs +{p:.3f} s over the\n  frame-buffer total, the counted work (ten "
     "instructions and two 2D fetches per fragment) +{m:.3f} s",
     dict(m=absolute(KD, "modelled") - absolute(KIV, "modelled"), p=absolute(KD, "paper") - absolute(KIV, "paper"))),
    ("papers/westermann1997.md", "The modelled GrOps are {b:.1f} s\n  (Blunt Fin, {rb:.2f}x the paper's {pb:.1f} s) "
     "and {f:.1f} s (fedata stand-in, {rf:.2f}x of {pf:.1f} s)",
     dict(b=absolute("T1 Blunt Fin GrOps [s] (Indigo2 IMPACT)", "modelled"),
          rb=absolute("T1 Blunt Fin GrOps [s] (Indigo2 IMPACT)"),
          pb=absolute("T1 Blunt Fin GrOps [s] (Indigo2 IMPACT)", "paper"),
          f=absolute("T1 fedata (FE-like stand-in mesh) GrOps [s] (Indigo2 IMPACT)", "modelled"),
          rf=absolute("T1 fedata (FE-like stand-in mesh) GrOps [s] (Indigo2 IMPACT)"),
          pf=absolute("T1 fedata (FE-like stand-in mesh) GrOps [s] (Indigo2 IMPACT)", "paper"))),
]


@pytest.mark.parametrize("page, sentence, values", CLAIMS, ids=[f"{c[0]}:{i}" for i, c in enumerate(CLAIMS)])
def test_quoted_number_is_the_datas(page, sentence, values):
    text = (DOCS / page).read_text()
    want = sentence.format(**values)
    flat = " ".join(text.split())
    assert " ".join(want.split()) in flat, f"{page} should say: {want!r}"


def test_pages_keep_no_stale_model_figures():
    """The counts come from the JSON's counts table (rendered, never typed); figures the pages once gave are gone."""
    a, n = counts("relative rows", "prediction")
    assert 0 < a <= n and counts("relative rows", "calibration only")[1] >= 1
    for page in ("performance.md", "guide/presets.md"):
        flat = " ".join((DOCS / page).read_text().split())
        for stale in ("28 of 29", "28/29", "1.15x GeForce3", "is not in any source"):
            assert stale not in flat, (page, stale)


def test_espinha_page_says_what_the_paper_presets_do_with_unresolved_rays():
    """The paper presets lose the rays their fp32 walk cannot resolve (``ray_setup = "paper"``) and count
    them; only ``harc_best`` redoes rays in float64."""
    import tomllib

    from warpvol.presets import __path__ as preset_dirs

    for name in ("espinha2005_full", "espinha2005_partial"):
        cfg = tomllib.loads((Path(preset_dirs[0]) / f"{name}.toml").read_text())
        assert next(s for s in cfg["stages"] if s["stage"] == "harc")["ray_setup"] == "paper"
    flat = " ".join((DOCS / "papers" / "espinha2005.md").read_text().split())
    assert "`stats.harc.lost_rays`" in flat and "are redone whole in float64 and counted" not in flat
