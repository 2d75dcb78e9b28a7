"""The reproduction modules' tables (warpvol.reproduce.*) on tiny configurations: every row has the
declared columns, the paper's columns hold the paper's numbers, ratio columns are ours / paper, error
columns agree with the exact reference where the variant is exact; ``--json`` writes the layout
docs/hooks.py reads, and the hook turns it into a Markdown table."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import math
import re
from pathlib import Path

import pytest

from warpvol.reproduce import espinha2005, guthe2002, kraus2004, westermann1997
from warpvol.reproduce.common import table, write_tables_json
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module", autouse=True)
def _quiet():
    from warpvol.pipeline import quiet_warp

    quiet_warp()


def tiny(name="sphere", px=16, rename=None):
    sc = builtin_scene(name).with_camera(width_px=px, height_px=px)
    return dataclasses.replace(sc, name=rename) if rename else sc


def check_shape(t, columns):
    assert t["columns"] == columns
    assert t["rows"], "no rows"
    for r in t["rows"]:
        assert len(r) == len(columns)
    json.dumps(t, allow_nan=False)  # JSON-safe as the hook reads it


def col(t, name):
    i = t["columns"].index(name)
    return [r[i] for r in t["rows"]]


def load_hooks():
    spec = importlib.util.spec_from_file_location("docs_hooks_for_test", ROOT / "docs" / "hooks.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# -- kraus2004 --------------------------------------------------------------------------------------
def test_kraus_table1_and_table2():
    sc = tiny()
    t1 = kraus2004.table1(sc, n_s=16, n_l=4, repeat=1)
    check_shape(t1, kraus2004.T1_COLUMNS)
    assert col(t1, "technique") == [lab for lab, _ in kraus2004.PAPER_T1]
    assert col(t1, "paper [s]") == [p for _, p in kraus2004.PAPER_T1]
    for r in t1["rows"]:
        assert r[3] == pytest.approx(r[2] / r[1])
        assert r[4] is not None and r[5] == pytest.approx(r[4] / r[1])  # every row modelled, fp16 too
    # totals are whole frames: positive; the fp16 read-back buffer costs more than the 8-bit one
    assert t1["rows"][0][4] > 0 and t1["rows"][6][4] > t1["rows"][4][4]
    t2 = kraus2004.table2([("sphere", "blunt fin", lambda: sc)], n_s=16, n_l=4, repeat=1)
    check_shape(t2, kraus2004.T2_COLUMNS)
    r = t2["rows"][0]
    assert r[1] == sc.mesh.n_tets and r[3] == pytest.approx(r[1] / r[2])
    assert r[7:10] == list(kraus2004.PAPER_T2["blunt fin"]) and r[10] == pytest.approx(r[3] / r[9])


def test_kraus_artifacts_exact_variant_matches_reference():
    studies = kraus2004.artifact_studies(small=16, n_s=16, n_l=4, bluntfin=lambda: tiny("linear_box"))
    studies = [studies[0]]  # the interpolation study: tables and the exact per-fragment integral
    t = kraus2004.artifacts(studies)
    check_shape(t, kraus2004.ART_COLUMNS)
    rmse = dict(zip(col(t, "variant"), col(t, "RMSE")))
    # the exact per-fragment integral, perspective-correct, is near the reference (pt_best's 2.5e-4 row is
    # for its own scenes); screen-linear interpolation of the same integral is several times worse
    assert rmse["perspective-correct, no table (exact integral)"] < 1e-3
    assert rmse["linear, no table (exact integral)"] > 2 * rmse["perspective-correct, no table (exact integral)"]


# -- westermann1997 ---------------------------------------------------------------------------------
def test_westermann_table1():
    sc = builtin_scene("concave")
    cam = Camera(projection="orthographic", eye=(5, 0.3, 0.2), target=(0, 0, 0), up=(0, 0, 1), ortho_height=4,
                 width_px=16, height_px=16)
    sc = dataclasses.replace(sc, camera=cam)
    t = westermann1997.table1([("bluntfin", sc)])
    check_shape(t, westermann1997.T1_COLUMNS)
    p = westermann1997.PAPER["bluntfin"]
    for r in t["rows"]:
        d = dict(zip(t["columns"], r))
        assert [d["paper tets"], d["paper drawn"], d["paper GrOps [s]"], d["paper Int [s]"], d["paper total [s]"]] \
            == list(p)
        assert d["drawn / paper"] == pytest.approx(d["drawn tets"] / p[1])
        assert d["modelled Int / paper"] == pytest.approx(d["modelled Int [s]"] / p[3])
        assert d["role"] == "prediction"  # the calibration row is Blunt Fin at 450 px only
    best = dict(zip(t["columns"], t["rows"][1]))
    assert best["preset"] == "vsbuffer_best" and best["RMSE"] < 1e-4


# -- espinha2005 ------------------------------------------------------------------------------------
def test_espinha_tables_and_fig8():
    sc = tiny(px=16)
    runs = espinha2005.method_runs({"bluntfin": sc}, 1)
    vicp = espinha2005.vicp_runs({"bluntfin": sc}, 1)
    t2 = espinha2005.table2(runs, vicp, 16)
    check_shape(t2, espinha2005.T2_COLUMNS)
    assert col(t2, "method") == ["VICP", "VICP-GPU", "HARC-Full"]
    assert dict(zip(col(t2, "method"), col(t2, "role")))["HARC-Full"] == "calibration"
    assert dict(zip(col(t2, "method"), col(t2, "modelled / paper (tets/s)")))["HARC-Full"] == "-"
    vp = espinha2005.VICP_PAPER["bluntfin"]["VICP"]
    assert t2["rows"][0][6] == f"{vp[0][0]:.2f}-{vp[0][1]:.2f}"
    t3 = espinha2005.table3(runs, 16)
    check_shape(t3, espinha2005.T3_COLUMNS)
    assert col(t3, "method") == ["HARC-Full", "HARC-Partial-10", "HARC-Partial-255"]
    assert t3["rows"][0][4] == "1.00-1.00"  # HARC-Full relative to itself
    f8 = espinha2005.fig8(12)
    check_shape(f8, espinha2005.F8_COLUMNS)
    rmse = dict(zip(col(f8, "preset"), col(f8, "RMSE")))
    assert rmse["harc_best"] < 1e-4 and rmse["espinha2005_full"] > rmse["harc_best"]


# -- guthe2002 --------------------------------------------------------------------------------------
def test_guthe_figs_tables():
    f6 = guthe2002.fig6(None, 16, 8)
    check_shape(f6, guthe2002.F6_COLUMNS)
    f7 = guthe2002.fig7(None, 16, 6)
    check_shape(f7, guthe2002.F7_COLUMNS)
    assert col(f7, "degree") == [1, 1, 2, 2, 4]
    t4 = guthe2002.table4(None, 16, 8)
    check_shape(t4, guthe2002.T4_COLUMNS)
    for r in t4["rows"]:
        assert r[1:3] == list(guthe2002.GUTHE_T4[r[0]]) and r[8] == pytest.approx(r[7] / r[2])
    assert col(t4, "role") == ["calibration", "prediction", "prediction"]
    t5 = guthe2002.table5([tiny("linear_box", rename="Blunt Fin")], res=16)
    check_shape(t5, guthe2002.T5_COLUMNS)
    assert len(t5["rows"]) == 6
    for r in t5["rows"]:
        card, sort = r[0], r[3]
        assert r[4] == guthe2002.PAPER_T5[card]["Blunt Fin"][[s for s, _ in guthe2002.SORTS].index(sort)]
        assert r[6] == pytest.approx(r[5] / r[4]) and r[8] == pytest.approx(r[7] / r[4])


# -- JSON and the docs hook -------------------------------------------------------------------------
def test_write_json_merges_and_hook_renders(tmp_path, monkeypatch):
    path = tmp_path / "paperx.json"
    write_tables_json(path, "python a.py", {"t1": table("T1", ["row", "paper", "warpvol"], [["a", 1.0, 2.0]], "n1")})
    write_tables_json(path, "python a.py --only t2",
                      {"t2": table("T2", ["row", "ratio"], [["b", float("nan")]])})
    data = json.loads(path.read_text())
    assert data["source"] == "python a.py --only t2" and set(data["tables"]) == {"t1", "t2"}
    assert data["tables"]["t1"]["source"] == "python a.py"  # a table keeps the command that made it
    assert data["tables"]["t2"]["rows"] == [["b", "nan"]]
    with pytest.raises(ValueError, match="2 values for 3 columns"):
        table("bad", ["a", "b", "c"], [[1, 2]])
    hooks = load_hooks()
    monkeypatch.setattr(hooks, "DATA", tmp_path)
    md = hooks.paper_table("paperx/t1")
    assert "| row | paper | warpvol |" in md and "| a | 1 | 2 |" in md and "n1" in md and "python a.py" in md
    assert "not generated yet" in hooks.paper_table("paperx/t3")


def _run_script(name, args):
    spec = importlib.util.spec_from_file_location(f"script_{name}", ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod.main(args)


@pytest.mark.parametrize("name, args, tables", [
    ("reproduce_espinha2005", ["--skip-tables", "--fig8-size", "12"], {"fig8"}),
    ("reproduce_guthe2002", ["--skip", "table4,table5", "--res", "16", "--eval", "6"], {"fig6", "fig7"}),
    ("reproduce_roettger2002", ["--fig8-only", "--fig8-size", "32x24"], {"fig8", "fig8_variants", "fig8_units"}),
])
def test_script_json_option(tmp_path, monkeypatch, name, args, tables):
    out = tmp_path / "data.json"
    _run_script(name, [*args, "--out", str(tmp_path / "out"), "--json", str(out)])
    data = json.loads(out.read_text())
    assert data["source"].startswith(f"python scripts/{name}.py") and set(data["tables"]) == tables
    for t in data["tables"].values():
        assert set(t) >= {"title", "columns", "rows", "notes"}
        assert all(len(r) == len(t["columns"]) for r in t["rows"])
    if name == "reproduce_roettger2002":  # the paper's Fig. 8 rates beside the modelled ones
        f8 = {r[0]: r for r in data["tables"]["fig8"]["rows"]}
        assert f8["GeForce3"][1:3] == [47.6, 79.0] and f8["GeForce3"][5] > 0
        assert f8["Voodoo3 2000"][1] is None and f8["Voodoo3 2000"][5] is None  # no 3D textures, no profile
    hooks = load_hooks()
    monkeypatch.setattr(hooks, "DATA", tmp_path)
    for tname in tables:
        assert hooks.paper_table(f"data/{tname}").count("\n|") >= 3


def test_committed_docs_data_cover_the_markers():
    """Each ``<!-- table: PAPER/NAME -->`` marker whose docs/data/PAPER.json exists names a table in it,
    with rows of the declared width and finite JSON numbers."""
    marker = re.compile(r"<!--\s*table:\s*([^/\s]+)/(\S+)\s*-->")
    for page in sorted((ROOT / "docs" / "papers").glob("*.md")):
        for paper, name in marker.findall(page.read_text()):
            path = ROOT / "docs" / "data" / f"{paper}.json"
            if not path.is_file():
                continue
            data = json.loads(path.read_text())
            assert name in data["tables"], f"{page.name}: marker {paper}/{name} has no table in {path.name}"
            t = data["tables"][name]
            assert all(len(r) == len(t["columns"]) for r in t["rows"])
            assert all(not (isinstance(v, float) and not math.isfinite(v)) for r in t["rows"] for v in r)


def test_model_counter_cache_is_keyed_by_the_code_that_counts(tmp_path, monkeypatch, request):
    """warpvol.reproduce.model_rows keeps each configuration's counters with the hash of the code that
    counts: a counted file is read back while that code is the same, is stale (counted again) after any
    counting module, kernel, preset or scene file changes, and stays valid when only a file that prices or
    shows counters (NOT_COUNTING: the model, the profiles, the CLI) changes."""
    from warpvol.reproduce import model_rows as M

    root = tmp_path / "repo"
    for rel in ("warpvol/projection/sort.py", "kernels/sort.py", "warpvol/presets/p.toml", "scenes/s.toml",
                "warpvol/model.py", "warpvol/profiles/g.toml", "warpvol/cli.py"):
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(f"# {rel}\n")
    monkeypatch.setattr(M, "ROOT", root)
    monkeypatch.setattr(M, "CACHE", root / "out" / "counters")
    request.addfinalizer(M.code_key.cache_clear)  # the real repository's key again for later tests

    def key():
        M.code_key.cache_clear()
        return M.code_key()

    k0 = key()
    M._write("guthe/bluntfin/sort_xmpvo", {"counters": {"sort": {"boundary_fragments": 1}}, "tets": 1})
    assert M.cached("guthe/bluntfin/sort_xmpvo")["counters"] == {"sort": {"boundary_fragments": 1}}
    for rel in ("warpvol/model.py", "warpvol/profiles/g.toml", "warpvol/cli.py"):  # prices / shows counters
        (root / rel).write_text("# edited\n")
        assert key() == k0 and M.cached("guthe/bluntfin/sort_xmpvo") is not None, rel
    for rel in ("warpvol/projection/sort.py", "kernels/sort.py", "warpvol/presets/p.toml", "scenes/s.toml"):
        before = key()
        (root / rel).write_text((root / rel).read_text() + "# changed\n")
        assert key() != before and M.cached("guthe/bluntfin/sort_xmpvo") is None, rel
    before = key()
    (root / "kernels" / "new.py").write_text("")  # a new module counts too
    assert key() != before
