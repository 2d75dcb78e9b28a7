"""Numbers the documentation quotes from generated data stay those of the data, and the data stay those of
the code.

- Each claim is a sentence of a page with its numbers as format fields, and where each number comes from
  (``docs/data/*.json``, written by the scripts that measure them). The test formats the sentence from the
  JSON and finds it on the page: a regenerated JSON that changes a quoted number fails here until the page
  says the new number.
- performance.md: every number of its prose is generated (``<!-- value: ... -->``), a claim, found in the
  JSON its model section quotes, or a listed parameter (``NOT_MEASURED``).
- Each generated file agrees with itself (a ratio column is the quotient of the columns it names, skip.json's
  summary is its rows, a fit is its points) and, where the code computes a number in seconds (modelled
  Table 2 / Table 4 build times), with the code.
"""

import json
import re
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


def _radeon_fragment_rate() -> dict:
    """Roettger Fig. 8 on the Radeon 8500: the paper's frame rates times the fragments of our view (from the
    rows' note) against the profile's fill rate."""
    import tomllib

    from warpvol.profiles import __path__ as profile_dirs

    note = next(r[6] for r in VM["rows"]["rows"] if "M fragments" in str(r[6]) and r[1].startswith("Fig. 8"))
    frags = float(re.search(r"([\d.]+) M fragments", note).group(1))
    f3 = absolute("Fig. 8 Radeon 8500 3D texture [fps]", "paper")
    f2 = absolute("Fig. 8 Radeon 8500 2D planes [fps]", "paper")
    fill = tomllib.loads((Path(profile_dirs[0]) / "radeon8500.toml").read_text())["rates"]["pixel_fill"]["value"] / 1e9
    lo, hi = sorted((frags * f3, frags * f2))
    return dict(f3=f3, f2=f2, lo=lo, hi=hi, plo=lo / fill / 10, phi=hi / fill / 10, fill=fill)


CLAIMS.append(("performance.md", "the Radeon 8500's {f3:.1f} and {f2:.1f} fps are {lo:.0f}-{hi:.0f} M fragments/s, "
               "{plo:.0f}-{phi:.0f} % of its {fill:.1f} Gpixels/s", _radeon_fragment_rate()))


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


# -- the generated files agree with themselves -----------------------------------------------------------------
#: (file, table, ratio column, numerator column, denominator column): a ratio a table shows is the quotient
#: of the two columns it names
RATIOS = [
    ("kraus2004", "table1", "emulated / paper", "emulated [s]", "paper [s]"),
    ("kraus2004", "table1", "modelled / paper", "modelled [s]", "paper [s]"),
    ("kraus2004", "table2", "emulated / paper (tets/s)", "emulated tets/s", "paper tets/s"),
    ("kraus2004", "table2", "modelled / paper (tets/s)", "modelled tets/s", "paper tets/s"),
    ("guthe2002", "table4", "paper ratio", "paper software [s]", "paper hardware [s]"),
    ("guthe2002", "table4", "ours ratio", "ours software (exact) [s]", "ours hardware emulated (ping-pong) [s]"),
    ("guthe2002", "table4", "modelled hardware / paper", "modelled hardware [s]", "paper hardware [s]"),
    ("guthe2002", "table4", "paper software / modelled hardware", "paper software [s]", "modelled hardware [s]"),
    ("guthe2002", "table5", "emulated / paper", "emulated fps", "paper fps"),
    ("guthe2002", "table5", "modelled / paper", "modelled fps", "paper fps"),
    ("roettger2002", "table2", "modelled hardware / paper", "modelled hardware [s]", "paper hardware [s]"),
    ("roettger2002", "table2", "paper software / modelled hardware", "paper software [s]", "modelled hardware [s]"),
    ("roettger2002", "fig8", "paper 2D / 3D", "paper 2D fps", "paper 3D fps"),
    ("roettger2002", "fig8", "modelled 2D / 3D", "modelled 2D fps", "modelled 3D fps"),
    ("roettger2002", "fig8", "modelled / paper (3D)", "modelled 3D fps", "paper 3D fps"),
    ("roettger2002", "fig8", "modelled / paper (2D)", "modelled 2D fps", "paper 2D fps"),
    ("westermann1997", "table1", "modelled GrOps / paper", "modelled GrOps [s]", "paper GrOps [s]"),
    ("westermann1997", "table1", "modelled Int / paper", "modelled Int [s]", "paper Int [s]"),
    ("validate_model", "rows", "ratio", "modelled", "paper value"),
]


def _table_rows(name: str, table: str) -> list[dict]:
    t = _tables(name)[table]
    return [r if isinstance(r, dict) else dict(zip(t["columns"], r)) for r in t["rows"]]


@pytest.mark.parametrize("name, table, ratio, num, den", RATIOS, ids=[f"{r[0]}/{r[1]}/{r[2]}" for r in RATIOS])
def test_a_tables_ratio_is_the_quotient_of_its_columns(name, table, ratio, num, den):
    checked = 0
    for r in _table_rows(name, table):
        vals = (r[ratio], r[num], r[den])
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals) or not r[den]:
            continue
        assert r[ratio] == pytest.approx(r[num] / r[den], rel=2e-3), (name, table, r)
        checked += 1
    assert checked, f"no numeric row of {name}/{table} to check"


def test_validate_model_relative_ratios_are_modelled_over_paper():
    rel = VM["relative"]
    for r in rel["rows"]:
        paper, modelled, ratio = r[4:7]
        if all(isinstance(v, (int, float)) for v in (paper, modelled, ratio)):
            assert ratio == pytest.approx(modelled / paper, rel=1e-9), r[:4]


@pytest.mark.parametrize("name", ["skip", "skip_small"])
def test_skip_json_ratios_are_the_quotients_of_its_times(name):
    """docs/data/skip.json (and skip_small.json, bench_skip.py --small): each row's VTK PT / this is VTK's
    median over the row's (both rounded in the file), and the summary's cells are the rows' ratios
    (skip=False in parentheses)."""
    rows = _table_rows(name, "rows")
    vtk = {(r["view"], r["TF"], r["size"]): r["median [s]"] for r in rows if r["renderer"] == "VTK PT"}
    for r in rows:
        v, t = vtk[(r["view"], r["TF"], r["size"])], r["median [s]"]
        # times are rounded to 1 ms and ratios to 0.01: the quotient of the rounded times within that
        slack = 0.005 + (v / t) * (0.0005 / t + 0.0005 / v)
        assert abs(r["VTK PT / this"] - v / t) <= slack, r
        assert r["tolerance"] in ("ok", "-"), r
    by = {(r["view"], r["TF"], r["renderer"]): r for r in rows}
    for s in _table_rows(name, "summary"):
        for col, val in s.items():
            name = col.split(" (")[0]
            if name not in ("raycast", "harc_best", "pt_best", "vsbuffer_best") or val == "-":
                continue
            on = by[(s["view"], s["TF"], name)]["VTK PT / this"]
            want = f"{on:.2f}"
            if (s["view"], s["TF"], f"{name} no-skip") in by:
                want += f" ({by[(s['view'], s['TF'], name + ' no-skip')]['VTK PT / this']:.2f})"
            assert val == want, (s["view"], s["TF"], col)
        vtk_cell = ", ".join(f"{vtk[(s['view'], s['TF'], size)]:.3f} ({size}^2)" for size in (512, 128)
                             if (s["view"], s["TF"], size) in vtk)
        assert s["VTK PT [s]"] == vtk_cell


def test_skip_json_supports_the_pages_reading_of_it():
    """The sentences of performance.md that read the skip table without quoting a number."""
    r = {(x["view"], x["TF"], x["renderer"]): x["VTK PT / this"] for x in _table_rows("skip", "rows")}
    views = ("bluntfin_close", "spx_fill")
    for p in ("raycast", "pt_best"):  # twice VTK's speed: raycast and pt_best on both sparse views
        assert all(r[(v, "sparse", p)] >= 2 for v in views), p
    assert all(r[(v, "sparse", "harc_best")] < 2 for v in views)  # not harc_best
    assert all(r[(v, tf, p)] < 2 for v in views for tf in ("opaque", "dense")
               for p in ("raycast", "harc_best", "pt_best"))  # nor on the opaque or dense views
    for v in views:  # on the dense views skipping on and off agree to the run's noise (within 10 %)
        for p in ("raycast", "harc_best", "pt_best"):
            assert r[(v, "dense", p)] == pytest.approx(r[(v, "dense", f"{p} no-skip")], rel=0.1)


def test_skip_small_json_supports_the_pages_reading_of_it():
    """performance.md reads skip_small.json: both ray casters' lowest ratio is on a view from far off."""
    rows = _table_rows("skip_small", "rows")
    for p in ("raycast", "harc_best"):
        r = {x["view"]: x["VTK PT / this"] for x in rows if x["renderer"] == p}
        assert min(r, key=r.get) in ("spx", "spx_corner"), (p, r)


def test_scaling_shell_exponents_are_the_slopes_of_its_points():
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_scaling_for_docs", DOCS.parent / "scripts" / "bench_scaling.py")
    bs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bs)
    pts = [p for p in _table_rows("scaling_shell", "points") if p["time [s]"] is not None]
    for e in _table_rows("scaling_shell", "exponents"):
        mine = [p for p in pts if p["renderer"] == e["renderer"]]
        a = bs.slope([p["tets"] for p in mine], [p["time [s]"] for p in mine])
        v = bs.slope([p["tets"] for p in mine], [p["visible cells [%]"] / 100 * p["tets"] for p in mine])
        assert e["time ~ tets^a"] == pytest.approx(a, abs=0.006), e
        assert e["visible cells ~ tets^v"] == pytest.approx(v, abs=0.006), e


def test_bench_table_marks_and_spreads_follow_from_its_rows():
    """docs/data/bench_concave.json: the Pareto marks are those warpvol.tools.bench.mark_pareto gives the
    rows, and each median lies between the fastest and slowest timed render."""
    import copy

    from warpvol.tools.bench import mark_pareto

    doc = json.loads((DOCS / "data" / "bench_concave.json").read_text())
    rows = copy.deepcopy(doc["rows"])
    for r in rows:
        r.pop("pareto", None)
    mark_pareto(rows)
    assert [r.get("pareto") for r in rows] == [r.get("pareto") for r in doc["rows"]]
    for r in doc["rows"]:
        if r.get("status") == "ok" and "min_s" in r:
            assert r["min_s"] <= r["total_s"] <= r["max_s"], r["pipeline"]


# -- performance.md: every number in its prose is accounted for ----------------------------------------------
PERF = "performance.md"
#: the section of performance.md that quotes the throughput model: its numbers come from these files
MODEL_SECTION, MODEL_FILES = "## Modelled time against the papers", ("validate_model", "roettger2002")
#: numbers in performance.md's prose that are not measurements: (phrase as written, what it is)
NOT_MEASURED = [
    ("3.9e-3", "one 8-bit step, 1/255"),
    ("with 4- and 64-pixel bins beside its CUDA default of 8", "parameters of scripts/check_cuda.py"),
    ("the cube [-1, 1]", "the scene's definition"), ("(6 tets per cube)", "the grid's definition"),
    ("more than 4,096 cell records apart", "reorder = 'auto''s threshold"),
    ("constant extinction of 100 over the mesh", "the opaque TF's definition in bench_skip.py"),
    ("then 3 rounds", "--repeat 3"), ("Below 1.0 a preset", "the ratio's meaning"),
    ("its 8 neighbours", "the pixel's neighbourhood"), ("the 8 neighbouring pixels", "the pixel's neighbourhood"),
    ("about 1.2e-7 times its distance", "float32's relative precision"),
    ("bound passes 1e-4", "the redo threshold"), ("steepest density slope 0", "a property of a constant"),
    ("within 1e-12 of the reference's quadrature", "tests/test_redo_closed_form.py's tolerance"),
    ("under 2/256 px", "a rasteriser snapping parameter"), ("exceeds 2e-3", "the redo criterion"),
    ("(1e-4 instead of the preset's 1e-6)", "early_termination values"),
    ("optimisation level 3", "a Warp option"), ("by more than 1e-6", "the termination bound"),
    ("transmittance 1e-6", "the termination bound"), ("up to 256 per ray", "the reentries parameter"),
    ("grown by 0.05 px", "a search parameter"), ("half-width is 0.75 cell", "the shell TF's definition"),
    ("last four (view, mask) pairs", "a cache size"), ("the presets state 1e-6", "early_termination"),
]
FENCE = re.compile(r"^```.*?^```", re.S | re.M)
COMMENT = re.compile(r"<!--.*?-->", re.S)  # markers: generated from the JSON when the site is built
CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"\]\([^)]*\)|\{[^}]*\}")
#: sizes and powers (512^2, 128x128, 10^7, n^(1/3)): parameters of a run, not measurements
SIZE = re.compile(r"\d+(?:\^\d+|x\d+(?:x\d+)?)(?![\d.])|\^\(?[\d/]+\)?")
NUMBER = re.compile(r"(?<![\w.^/+-])\+?\d{1,3}(?:,\d{3})*(?:\.\d+)?(?:e-?\d+)?(?![\w^]|-[A-Za-z]|\.\d)"
                    r"|(?<![\w.^/+-])\+?\d+(?:\.\d+)?(?:e-?\d+)?(?=x\b)")
#: names with digits (GeForce3, Radeon 8500, Fig. 8, 2D, fp16, ...) are not numbers
NAMES = re.compile(r"\b(?:Radeon|Rage128|Fig\.|Table|Tables|Octane MXI|Ertl|al\.|Celes|paper's own Table|§)\s*\d+|\b\d{4}\b")


def _prose(text: str) -> str:
    for rx in (FENCE, COMMENT, CODE, LINK):
        text = rx.sub(" ", text)
    return " ".join(text.split())


def _json_numbers(name: str) -> set[str]:
    """Every number of ``docs/data/NAME.json`` as text: those written inside its strings (notes) as
    they are written, and its numeric values as written and at 1 to 3 decimals."""
    out: set[str] = set()

    def walk(v):
        if isinstance(v, dict):
            for x in v.values():
                walk(x)
        elif isinstance(v, list):
            for x in v:
                walk(x)
        elif isinstance(v, str):
            out.update(re.findall(r"\d{1,3}(?:,\d{3})+(?:\.\d+)?|\d+(?:\.\d+)?(?:e-?\d+)?", v))
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            out.update({repr(v), f"{v:.1f}", f"{v:.2f}", f"{v:.3f}"})

    walk(json.loads((DOCS / "data" / f"{name}.json").read_text()))
    return out


def unaccounted_numbers(page: str = PERF, text: str | None = None) -> list[str]:
    """The numbers of ``page``'s prose that no check accounts for: not generated by a marker, not in a
    sentence of :data:`CLAIMS` (checked against its JSON), not a parameter of :data:`NOT_MEASURED`, and,
    in the model section, not found in the JSON files that section quotes."""
    text = (DOCS / page).read_text() if text is None else text
    head, _, rest = text.partition(MODEL_SECTION)
    model, _, tail = rest.partition("\n## ")
    sections = [(head + " ## " + tail, None), (model, MODEL_FILES)]
    claims = [" ".join(s.format(**v).split()) for p, s, v in CLAIMS if p == page]
    missing = []
    for body, files in sections:
        flat = _prose(body)
        for c in claims:
            flat = flat.replace(c, " ")
        for phrase, _why in NOT_MEASURED:
            flat = flat.replace(phrase, " ")
        flat = NAMES.sub(" ", SIZE.sub(" ", flat))
        found = set().union(*(_json_numbers(f) for f in files)) if files else set()
        for m in NUMBER.finditer(flat):
            tok = m.group(0).lstrip("+")
            if tok in found:
                continue
            missing.append(f"{tok!r} in ...{flat[max(0, m.start() - 50):m.end() + 20]}...")
    return missing


def test_every_number_on_the_performance_page_comes_from_its_data():
    """Every number in performance.md's prose is generated from a docs/data JSON (``<!-- value: ... -->``,
    tables), checked against one (CLAIMS; in the model section, found in the JSON it quotes), or a stated
    parameter (NOT_MEASURED); a measurement typed into the page fails here."""
    missing = unaccounted_numbers()
    assert not missing, "numbers on performance.md that no JSON accounts for:\n" + "\n".join(missing)


def test_a_measurement_typed_into_the_page_is_caught():
    page = (DOCS / PERF).read_text()
    typed = page.replace("### Leaving out what the scene does not need",
                         "A `raycast` frame took 0.42 s (1.9x VTK) here.\n\n### Leaving out what the scene does not need")
    assert [m.split()[0] for m in unaccounted_numbers(text=typed)] == ["'0.42'", "'1.9'"]
    marked = page.replace("### Leaving out", "It took <!-- value: skip/rows view=spx_fill TF=sparse size=512 "
                          "renderer=raycast | median [s] | .3f --> s.\n\n### Leaving out")
    assert unaccounted_numbers(text=marked) == []


def test_the_performance_page_quotes_are_generated_from_the_json():
    """The page's value markers expand (each picks one row, or a range) and the expanded page keeps no
    marker; the quoted ranges are the data's."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("docs_hooks_numbers", DOCS / "hooks.py")
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    page = hooks.expand((DOCS / PERF).read_text())
    assert "<!-- value" not in page
    rows = _table_rows("skip", "rows")
    dense = [r["VTK PT / this"] for r in rows if r["view"] == "bluntfin_close" and r["TF"] == "dense"
             and r["renderer"] in ("raycast", "harc_best", "pt_best")]
    assert f"on the dense views {min(dense):.2f}-{max(dense):.2f}x" in " ".join(page.split())
    for stale in ("0.45-0.48x", "within the noise", "no time difference above the noise"):
        assert stale not in " ".join(page.split()), stale


# -- the generated files agree with what the code computes in seconds --------------------------------------
def _vm_row(row: str) -> dict:
    return ABS[row]


@pytest.fixture(scope="module")
def quiet():
    from warpvol.pipeline import quiet_warp

    quiet_warp()


def test_roettger_table2_models_are_the_codes(quiet):
    """Roettger & Ertl Table 2's modelled build times (counted, not emulated: well under a second) are what
    warpvol.reproduce.roettger2002.roettger_t2_model gives today, in roettger2002.json and in
    validate_model.json."""
    from warpvol.reproduce.roettger2002 import roettger_t2_model

    for r in _table_rows("roettger2002", "table2"):
        n = int(r["size"].split("x")[0])
        m = roettger_t2_model(n)
        assert r["modelled hardware [s]"] == pytest.approx(m["hw"], rel=1e-9), r["size"]
        assert r["modelled software [s]"] == pytest.approx(m["sw"], rel=1e-9), r["size"]
        assert _vm_row(f"T2 hardware {r['size']} [s] (Octane MXI)")["modelled"] == pytest.approx(m["hw"], rel=1e-9)
        assert _vm_row(f"T2 software {r['size']} [s] (R10K)")["modelled"] == pytest.approx(m["sw"], rel=1e-9)


def test_guthe_table4_models_are_the_codes(quiet):
    """Guthe et al. Table 4's modelled hardware set-up (counted ping-pong passes priced on the Radeon 8500,
    a few seconds) is what warpvol.reproduce.guthe2002.guthe_t4_model gives today, in guthe2002.json and
    in validate_model.json."""
    from warpvol.reproduce.guthe2002 import guthe_t4_model

    for r in _table_rows("guthe2002", "table4"):
        m = guthe_t4_model(r["n"])
        assert r["modelled hardware [s]"] == pytest.approx(m, rel=1e-9), r["n"]
        assert _vm_row(f"T4 Radeon 8500 set-up n = {r['n']} [s]")["modelled"] == pytest.approx(m, rel=1e-9)


def test_pt_spans_json_ratios_and_per_fragment_costs_are_its_quotients():
    """docs/data/pt_spans.json: VTK PT / this is VTK's median over the row's, and the per-fragment costs are
    the draw's times over its fragments (all as rounded in the file)."""
    rows = _table_rows("pt_spans", "rows")
    vtk = {(r["view"], r["TF"], r["size"]): r["median [s]"] for r in rows if r["renderer"] == "VTK PT"}
    checked = 0
    for r in rows:
        v, t = vtk[(r["view"], r["TF"], r["size"])], r["median [s]"]
        # times rounded to 0.1 ms, ratios to 0.001: the quotient of the rounded times within that
        assert abs(r["VTK PT / this"] - v / t) <= 0.0005 + (v / t) * (0.00005 / t + 0.00005 / v), r
        n = r["fragments"]
        if isinstance(n, int) and n:
            for per, total in (("ns / fragment", "draw [s]"), ("CPU ns / fragment", "draw CPU [s]")):
                assert abs(r[per] - r[total] / n * 1e9) <= 0.00005 / n * 1e9 + 1e-3 * r[per], (per, r)
            checked += 1
    assert checked
