"""Throughput model and GPU profiles (warpvol.model): hand-computed pass times, capability errors."""

import numpy as np
import pytest

from helpers import box_mesh, scene
from warpvol.errors import ConfigError
from warpvol.gpu.blend import BlendUnit, FrameBuffer
from warpvol.model import check_caps, list_profiles, load_profile, model_counters, model_report
from warpvol.pipeline import Pipeline
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction
from warpvol.stage import STAGES, Param, Stage, register_stage


def test_every_profile_loads_and_every_number_has_a_source():
    names = [n for n, _, _ in list_profiles()]
    assert {"geforce3", "octane_mxi", "geforce4_ti4600", "radeon8500", "quadro_fx3000", "geforce6800gt",
            "indigo2_impact"} <= set(names)
    for n in names:
        p = load_profile(n)
        for sec in (p.rates, p.caps, p.host):
            for k, e in sec.items():
                assert e["source"].split(":")[0].split(" ")[0] in ("vendor", "derived", "estimate", "calibrated",
                                                                   "Roettger", "Guthe", "Kraus", "Espinha"), (n, k)
    with pytest.raises(ConfigError, match="unknown GPU profile 'geforce9'; available: .*radeon8500"):
        load_profile("geforce9")


def test_synthetic_pass_equals_hand_computation():
    p = load_profile("geforce3")
    c = {"passes": 3, "fragments": 1_000_000, "tex_3d_rgba8_linear": 2_000_000, "blends_unorm8": 1_000_000,
         "bytes_down": 266_000, "fragments_passed": 1_000_000, "texels": 16_000_000}
    r = model_counters(c, p)
    # texture: 2e6 trilinear fetches / 0.8e9 = 2.5 ms (raster 1.25 ms, rop 1.25 ms, memory 8e6 B / 7.36e9 = 1.09 ms)
    hand = 2e6 / 0.8e9 + 3 * 0.5e-3 + 266_000 / 266e6
    assert r["bound"] == "texture" and r["s"] == pytest.approx(hand, rel=1e-12)
    # alike passes: the sum over passes of (slowest unit per pass + overhead) is the same number
    per_pass = max(2e6 / 3 / 0.8e9, 1e6 / 3 / 800e6) + 0.5e-3
    assert r["gpu_s"] - 266_000 / 266e6 == pytest.approx(3 * per_pass, rel=1e-12)


def test_sections_are_modelled_as_their_own_groups_and_host_work_adds():
    p = load_profile("octane_mxi")
    c = {"a/fragments": 133_000_000, "b/tex_2d_rgba8_linear": 133_000_000, "sw_samples": 207_240}
    r = model_counters(c, p)
    assert r["s"] == pytest.approx(1.0 + 1.0 + 1.0, rel=1e-12)  # two groups of 1 s each + 1 s host


def test_unmodelled_work_is_named_not_zero():
    p = load_profile("geforce3")
    r = model_counters({"cell_steps": 10, "blends_fp16": 5, "frobs": 1}, p)
    assert r["s"] is None
    assert any("cell_step_rate" in u for u in r["unmodelled"]) and any("frobs" in u for u in r["unmodelled"])
    rep = model_report({"x": {"fragments": 800}, "y": {}}, p)
    assert rep["total"] == pytest.approx(1e-6) and rep["uncounted"] == ["y"]


class _Fp16Composite(Stage):
    """Test stage: blends a layer into an fp16 frame buffer and writes the image (``tex3d``: the 3D
    texture size it declares it needs)."""

    name = "_test_fp16_composite"
    summary = "test only"
    provides = ("image",)
    params = (Param("tex3d", int, 0, "3D texture size it asks for", lo=0),)

    def requires_caps(self):
        return {"max_tex3d": self.config["tex3d"]} if self.config["tex3d"] else {}

    def run(self, ctx):
        cam = ctx.scene.camera
        fb = FrameBuffer(cam.width_px, cam.height_px, "fp16")
        fb.clear((0, 0, 0, 0))
        BlendUnit.over().blend_layers(fb, np.full((1, cam.height_px, cam.width_px, 4), 0.5, np.float32))
        ctx.image = fb.readback()


@pytest.fixture(autouse=True)
def _test_stage():
    register_stage(_Fp16Composite)  # registered for this module's tests only
    yield
    STAGES.pop(_Fp16Composite.name, None)


def _scene():
    tf = TransferFunction.from_table(np.full((4, 4), 0.5), (0.0, 2.0))
    return scene(box_mesh(), tf, Camera(eye=[0, 0, 6], target=[0, 0, 0], width_px=8, height_px=6, fov_y_deg=40))


def test_capability_errors_name_stage_and_capability():
    pipe = Pipeline.from_config({"stages": [{"stage": "_test_fp16_composite"}]})
    with pytest.raises(ConfigError, match=r"_test_fp16_composite.*needs fp16 blending.*GeForce4 Ti 4600"):
        pipe.render(_scene(), quiet=True, gpu="geforce4_ti4600")
    res = pipe.render(_scene(), quiet=True, gpu="geforce6800gt")  # NV40 blends fp16 (at half rate)
    assert res.report["gpu"] == "geforce6800gt"
    st = res.report["modelled_s"]["stages"]["_test_fp16_composite"]
    # 48 fp16 blends (8-byte pixels, read + write) and a 48-pixel clear: memory 960 B / 32 GB/s bounds
    # the ROP (48 / 2.8e9 + 48 / 5.6e9); the 384-byte read-back is serial
    assert st == pytest.approx((48 * 8 * 2 + 48 * 4) / 32e9 + 384 / 266e6, rel=1e-12)
    big = Pipeline.from_config({"stages": [{"stage": "_test_fp16_composite", "tex3d": 1024}]})
    with pytest.raises(ConfigError, match=r"needs 3D texture size >= 1024.*has max_tex3d = 512"):
        big.render(_scene(), quiet=True, gpu="geforce6800gt")
    for stage, gpu, what in [({"stage": "table_guthe", "degree": 4}, "geforce4_ti4600", "texture units >= 6"),
                             ({"stage": "table_roettger_hw", "bits": 12}, "geforce3", "frame-buffer format 'unorm12'"),
                             ({"stage": "table_roettger_hw", "bits": 8, "variant": "geforce3"}, "octane_mxi",
                              "texture units >= 4"),
                             ({"stage": "table_roettger_hw", "passes": "one"}, "octane_mxi", "rgba12_visual"),
                             ({"stage": "table_pingpong"}, "geforce4_ti4600", "texture units >= 5"),
                             ({"stage": "table_pingpong", "per_pass": 3}, "geforce4_ti4600",
                              "frame-buffer overflow behaviour 'wrap'")]:
        p = Pipeline.from_config({"stages": [stage, {"stage": "_test_fp16_composite"}]})
        with pytest.raises(ConfigError, match=rf"stages\[0\] \({stage['stage']}\): needs {what}"):
            p.render(_scene(), quiet=True, gpu=gpu)


def test_report_modelled_per_stage_and_total():
    cfg = {"stages": [{"stage": "table_roettger_hw", "n_s": 4, "n_l": 2, "steps": 3, "lmax": 1.0},
                      {"stage": "cell_setup"}, {"stage": "entry_bins"}, {"stage": "raycast"}]}
    with pytest.raises(ConfigError, match=r"\(raycast\): needs dynamic loops in fragment programs.*Octane"):
        Pipeline.from_config(cfg).render(_scene(), quiet=True, gpu="octane_mxi")  # no HARC on an Octane
    cfg["stages"][0]["bits"] = 8  # no 12-bit buffers on NV40
    res = Pipeline.from_config(cfg).render(_scene(), quiet=True, gpu="geforce6800gt")
    m = res.report["modelled_s"]
    p = load_profile("geforce6800gt")
    tab = model_counters(res.report["counters"]["table_roettger_hw"], p)["s"]
    assert m["stages"]["table_roettger_hw"] == pytest.approx(tab) and tab > 0
    steps = res.report["counters"]["raycast"]["cell_steps"]
    assert m["stages"]["raycast"] == pytest.approx(steps / 38.41e6)
    assert m["total"] == pytest.approx(sum(m["stages"].values()))
    assert m["uncounted"] == ["cell_setup", "entry_bins"]


def test_check_caps_kinds():
    p = load_profile("radeon8500")
    check_caps(p, "s", {"texture_units": 6, "fb_formats": "unorm8", "tex3d": True, "fp16_blend": False})
    with pytest.raises(ConfigError, match="s: needs texture units >= 7"):
        check_caps(p, "s", {"texture_units": 7})


def test_cli_gpus_and_render_gpu(tmp_path, capsys):
    import json

    from warpvol.cli import main

    assert main(["gpus"]) == 0
    out = capsys.readouterr().out
    assert "radeon8500" in out and "Pentium 4" in out
    rep = tmp_path / "r.json"
    args = ["render", "builtin:sphere", "--pipeline", "raycast", "-o", str(tmp_path / "i.exr"), "--width", "16",
            "--height", "12", "--quiet", "--report", str(rep)]
    assert main(args + ["--gpu", "geforce6800gt"]) == 0
    r = json.loads(rep.read_text())
    assert r["gpu"] == "geforce6800gt" and r["modelled_s"]["total"] > 0 and "raycast" in r["counters"]
    assert main(args + ["--gpu", "voodoo2"]) == 2
    assert "unknown GPU profile 'voodoo2'" in capsys.readouterr().err


def test_every_profile_number_names_a_source_kind_and_calibrations_name_their_row():
    """Every rate, capability and host number says where it comes from; a calibrated one names the paper
    row it was fitted to (and is then marked 'calibration on this row' by scripts/validate_model.py)."""
    for n, _, _ in list_profiles():
        p = load_profile(n)
        for sec in (p.rates, p.host):
            for k, e in sec.items():
                src = e["source"]
                assert len(src) > 20, (n, k)
                if src.startswith("calibrated"):
                    assert any(w in src for w in ("Table", "§", "text")), (n, k, src)
                if src.startswith("estimate"):
                    assert ":" in src and len(src.split(":", 1)[1].strip()) > 10, (n, k)  # the reason


def test_loop_groups_price_issue_slots_and_fp16_readback_rebinds():
    from warpvol.gpu import programs

    p = load_profile("geforce6800gt")
    walk = programs.n_alu(programs.WALK) + programs.n_tex(programs.WALK)
    full = programs.n_alu(programs.FULL) + programs.n_tex(programs.FULL)
    part = programs.n_alu(programs.PARTIAL_SUB) + programs.n_tex(programs.PARTIAL_SUB)
    assert (walk, full) == (36, 5) and part > full  # partial pre-integration does more per step
    n = 1000
    c_full = {"cell_steps": n, "combiner_ops": n * 34, "tex_2d_rgba32f_nearest": 6 * n, "tex_3d_rgba8_linear": n}
    r = model_counters(c_full, p)
    assert r["s"] == pytest.approx(41 * n / 1.920e9, rel=1e-12) and r["bound"] == "shader"
    # lock-step batches: the loop runs as long as each batch's longest ray (slots as batched / as run)
    r2 = model_counters({**c_full, "loop_slots": 41 * n, "loop_slots_batch1024": 50 * n}, p)
    assert r2["s"] == pytest.approx(50 * n / 1.920e9, rel=1e-12)
    # ... only on a card whose fragment processor runs such batches (its cap names the batch size)
    p.caps.pop("fragment_batch_pixels")
    assert model_counters({**c_full, "loop_slots": 41 * n, "loop_slots_batch1024": 50 * n}, p)["s"] == r["s"]
    # the exact walk without a program: cell_step_rate = loop_issue_rate / 41 slots / the calibration's 1.219
    assert model_counters({"cell_steps": n}, p)["s"] == pytest.approx(n / 38.41e6, rel=1e-12)
    q = load_profile("quadro_fx3000")
    base = {"fragments": 1000, "tex_3d_rgba8_linear": 1000, "combiner_ops": 18_000}
    t0 = model_counters(base, q)["s"]
    # NV3x: texture fetches and instructions share the issue: times add (18000 / 1.6e9 + 1000 / 1.6e9)
    assert t0 == pytest.approx(19_000 / 1.6e9, rel=1e-12)
    t1 = model_counters({**base, "fb_texture_rebinds": 10}, q)["s"]
    assert t1 - t0 == pytest.approx(10 * 10e-6, rel=1e-9)
    assert model_counters({**base, "fb_texture_rebinds": 10}, load_profile("geforce3"))["s"] is None


def test_numeric_sort_is_cheaper_than_the_mpvo_graph_and_xmpvo_adds_constraints():
    p = load_profile("geforce4_ti4600")
    cells = 187_318
    numeric = model_counters({"cells_sorted": cells}, p)["host_s"]
    mpvo = model_counters({"cells_sorted": cells, "graph_edges": 367_917}, p)["host_s"]
    xmpvo = model_counters({"cells_sorted": cells, "graph_edges": 367_980, "ray_constraints": 63,
                            "boundary_fragments": 476_094}, p)["host_s"]
    assert numeric == pytest.approx(cells / 1.191e6) and mpvo == pytest.approx(cells / 1.0e6)
    assert numeric < mpvo < xmpvo


def _validate_model_script():
    """scripts/validate_model.py as a module (scripts/ is not a package)."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("validate_model", Path(__file__).parents[1] / "scripts" /
                                                  "validate_model.py")
    vm = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(vm)
    return vm


def test_validation_rows_compute_and_relative_rows_keep_the_papers_sign():
    """scripts/validate_model.py on counters of small stand-ins: every absolute row computes, and the
    relative rows whose counts are synthetic here keep the paper's sign (partial pre-integration slower
    than full on the same walk; the numeric sort faster than MPVO)."""
    from warpvol.gpu import programs

    vm = _validate_model_script()
    m = vm.Model("cpu", refresh=False)
    cells, steps = 100_000, 102_000  # partial: iso splits add sub-steps
    full = {"harc": {"cell_steps": cells, "combiner_ops": cells * 34, "tex_2d_rgba32f_nearest": 6 * cells,
                     "tex_3d_rgba8_linear": cells}}
    part = {"harc": {"cell_steps": steps, "combiner_ops": cells * 30 + steps * programs.n_alu(programs.PARTIAL_SUB),
                     "tex_2d_rgba32f_nearest": 6 * cells + steps, "tex_2d_rgba16f_linear": steps,
                     "tex_1d_rgba8_linear": 2 * steps}}
    tf, _ = m.seconds(full, "geforce6800gt")
    tp, _ = m.seconds(part, "geforce6800gt")
    paper_rel = vm._mid(*vm.ESPINHA["partial10"]["bluntfin"]) / vm._mid(*vm.ESPINHA["full"]["bluntfin"])
    assert paper_rel < 1 and tf / tp < 1 and 0.5 <= (tf / tp) / paper_rel <= 2.0
    gpu = {"pt": {"fragments": 1_000_000, "tex_2d_rgba8_linear": 3_000_000, "combiner_ops": 4_000_000}}
    tn, _ = m.seconds({**gpu, "sort": {"cells_sorted": 187_318}}, "geforce4_ti4600")
    tm, _ = m.seconds({**gpu, "sort": {"cells_sorted": 187_318, "graph_edges": 367_917}}, "geforce4_ti4600")
    assert vm.GUTHE_T5["geforce4"]["bluntfin"][0] > vm.GUTHE_T5["geforce4"]["bluntfin"][1] and tm > tn
    assert m.seconds(None, "geforce3") == (None, "skipped (data or configuration unavailable)")
    assert "Blunt Fin" in vm.DATA.values()


def test_validation_notes_derive_from_the_papers_own_rows():
    """The notes on the rows outside [0.5, 2] are arithmetic on the paper's figures and the profiles: Kraus'
    dithering against Table 1's own increments, the Radeon 8500 against the GeForce3 of the same figure."""
    vm = _validate_model_script()
    # 10 x 0.048 / 11 + 2 x 0.031 = 0.1056, 10 x 0.040 / 7 + 2 x 0.031 = 0.1191; Table 1: 0.621 - 0.314
    assert vm.kraus_dither_note().endswith("+0.106 to +0.119 s; the paper has +0.307 s")
    fig8 = {(prof, "3d"): {"paper_value": pv, "modelled": mv, "note": ""}
            for prof, pv, mv in (("geforce3", 47.6, 60.0), ("radeon8500", 33.8, 90.0), ("octane_mxi", 8.5, 20.0))}
    vm.roettger_f8_notes(fig8, None)  # fragments not counted: no Octane note
    assert fig8[("geforce3", "3d")]["note"] == "" and fig8[("octane_mxi", "3d")]["note"] == ""
    note = fig8[("radeon8500", "3d")]["note"]
    assert "paper: 0.71x the GeForce3's fps, modelled 1.50x" in note
    assert "1.38x its fill rate" in note and "1.20x its memory bandwidth" in note
    vm.roettger_f8_notes(fig8, 2_258_196)  # 8.5 fps x 2.258 M fragments
    assert "19.2 M trilinear lookups/s for our 2.26 M fragments" in fig8[("octane_mxi", "3d")]["note"]


def test_relative_rows_take_their_role_from_their_absolute_rows():
    """A relative row made only of calibration rows is no prediction and is not counted; one with a
    calibration row is counted apart; the count is over rows whose two absolute rows are predictions."""
    vm = _validate_model_script()
    cal, pred = "calibration on this row", "prediction"
    assert vm.relative_role(cal, cal) == "calibration only" and vm.relative_role(pred, pred) == "prediction"
    assert vm.relative_role(cal, pred) == vm.relative_role(pred, cal) == "one calibration row"
    assert vm.relative_role("-", pred) is None

    def row(name, pv, mv, role):
        return {"paper": "Guthe 2002", "row": name, "paper_value": pv, "modelled": mv, "ratio": mv / pv,
                "role": role, "note": ""}

    absolute = [row(f"T5 {vm.CARD[c]} {vm.DATA[d]} {la} [fps]", 2.0 + i / 10, 2.0 + i / 10, pred)
                for i, (c, d, (la, _)) in enumerate((c, d, s) for c in vm.GUTHE_T5 for d in ("bluntfin", "bucky")
                                                    for s in vm.SORTS)]
    absolute[0]["role"] = absolute[1]["role"] = cal  # GeForce4, Blunt Fin: numeric and MPVO fitted
    rel = [r for r in vm.relative_rows(None, absolute) if r["paper"] == "Guthe 2002" and r["row"].startswith("T5")]
    first = next(r for r in rel if r["row"] == "T5 numeric over MPVO" and r["card"] == vm.GF4
                 and r["data"] == "Blunt Fin")
    assert first["role"] == "calibration only" and "calibration: " in first["note"]
    counts = vm.relative_counts(rel)
    n_cal_only = sum(r["role"] == "calibration only" for r in rel)
    n_one = sum(r["role"] == "one calibration row" for r in rel)
    assert n_cal_only == 1 and n_one > 0
    assert counts["prediction"][1] == len(rel) - n_cal_only - n_one
    assert "calibration only" not in vm.count_lines(absolute, rel)[1]


def test_shipped_validation_json_counts_follow_from_its_absolute_rows():
    """docs/data/validate_model.json: every relative row, its role and the counts are what the script
    builds from the JSON's own absolute rows (nothing typed in, nothing counted twice)."""
    import json
    from pathlib import Path

    vm = _validate_model_script()
    path = Path(__file__).parents[1] / "docs" / "data" / "validate_model.json"
    shipped = json.loads(path.read_text())["tables"]
    absolute, notes, _, view = vm.absolute_from(str(path))
    rebuilt = vm.to_json(absolute, vm.relative_rows(None, absolute, view), {}, notes)["tables"]
    for key in ("relative", "counts", "relative_guthe2002", "counts_espinha2005"):
        assert shipped[key]["rows"] == rebuilt[key]["rows"], key
        assert shipped[key]["notes"] == rebuilt[key]["notes"], key
    by_role = {(r[0], r[1]): r[2:4] for r in shipped["counts"]["rows"]}
    n_pred = sum(r[8] == "prediction" and r[7] is not None for r in shipped["relative"]["rows"])
    assert by_role[("relative rows", "prediction")][1] == n_pred
    gf4 = next(r for r in shipped["relative"]["rows"] if r[1:4] == ["T5 numeric over MPVO", vm.GF4, "Blunt Fin"])
    assert gf4[8] == "calibration only"  # both of its rows fitted the GeForce4's sort rates
    assert "assumed" in vm.GF4  # the paper says "GeForce4"; the Ti 4600 is the model's assumption
    ind = shipped["counts"]["independent"]
    assert (ind["relative_rows"], ind["prediction_rows"]) == (len([r for r in shipped["relative"]["rows"]
                                                                    if r[6] is not None]), n_pred)
    assert ind["independent_ratios"] < ind["relative_rows"] and "independent ratios" in shipped["counts"]["notes"]
    # VICP-GPU on the LOX Post: most of its time is the host sort fitted to the VICP LOX Post row
    roles = {r[1]: r[5] for r in shipped["rows"]["rows"]}
    assert roles["T2/T3 VICP-GPU LOX Post [fps]"] == f"calibration on {vm.VICP_LOX}"
    assert roles["T2/T3 VICP-GPU Blunt Fin [fps]"] == "prediction"
    vv = next(r for r in shipped["relative"]["rows"] if r[1] == "VICP-GPU over VICP" and r[3] == "LOX Post")
    assert vv[8] == "calibration only"


def test_relative_rows_rest_on_fewer_independent_ratios():
    """A relative row's ratio is its A row's over its B row's: rows over one set of absolute rows span at
    most (rows used) - (linked groups) independent ratios; a one-calibration row's ratio is the predicted
    row's over the calibration row's (not the predicted row's unless the fit is exact)."""
    vm = _validate_model_script()

    def rel(a, b, role="prediction"):
        return {"a": ("P", a), "b": ("P", b), "ratio": 1.0, "role": role}

    rows = [rel("x", "y"), rel("y", "z"), rel("x", "z"), rel("u", "v"), rel("u", "v", "one calibration row")]
    assert vm.independent_ratios(rows) == (5, 3)  # {x, y, z}: 2, {u, v}: 1
    assert vm.independent_ratios(rows, "prediction") == (4, 3)
    assert vm.independent_ratios([{**rows[0], "ratio": None}]) == (0, 0)

    def row(name, pv, mv, role):
        return {"paper": "Guthe 2002", "row": name, "paper_value": pv, "modelled": mv, "ratio": mv / pv,
                "role": role, "note": ""}

    absolute = [row(f"T5 {vm.CARD[c]} {vm.DATA[d]} {la} [fps]", 2.0, 2.0, "prediction")
                for c in vm.GUTHE_T5 for d in ("bluntfin", "bucky") for la, _ in vm.SORTS]
    absolute[1] = {**absolute[1], "modelled": 2.0 * 1.047, "ratio": 1.047, "role": "calibration on this row"}
    absolute[2] = {**absolute[2], "modelled": 2.0 * 0.9, "ratio": 0.9}
    one = next(r for r in vm.relative_rows(None, absolute) if r["row"] == "T5 MPVO over XMPVO"
               and r["card"] == vm.GF4 and r["data"] == "Blunt Fin")
    assert one["role"] == "one calibration row" and one["ratio"] == pytest.approx(1.047 / 0.9)
    assert "repeats" not in " ".join(vm.count_lines(absolute, [one]))



def test_agreements_resting_on_one_estimate_show_it():
    """Rows whose agreement rests on one guessed constant carry the ratio at half and double it, and a
    relative row built on such rows carries the same for the relation (from the rows' values alone)."""
    vm = _validate_model_script()
    assert vm.sensitivity(2.0, (1.0, None), "k") == "sensitivity: ratio 0.50 at half, - at double k"

    def row(name, pv, mv, at=None):
        return {"paper": "Roettger 2002", "row": name, "paper_value": pv, "modelled": mv, "ratio": mv / pv,
                "role": "prediction", "note": "", "at": at and {"constant": vm.BLOCK_EDGE, "half": at[0],
                                                               "double": at[1]}}

    absolute = [row(f"Fig. 8 {vm.CARD[p]} {k} [fps]", 10.0, 12.0, (15.0, 8.0) if k == "3D texture" else (18.0, 12.0))
                for p in vm.ROETTGER_F8 for k in ("3D texture", "2D planes")]
    rel = next(r for r in vm.relative_rows(None, absolute) if r["row"] == "Fig. 8: 2D planes over 3D texture")
    # 2D over 3D: 12/12 as counted, 18/15 at half the block edge, 12/8 at double; the paper's 10/10
    assert rel["ratio"] == 1.0 and rel["note"].endswith(f"ratio 1.20 at half, 1.50 at double {vm.BLOCK_EDGE}")


def test_shipped_validation_json_shows_the_estimates_agreements_rest_on():
    import json
    from pathlib import Path

    vm = _validate_model_script()
    t = json.loads((Path(__file__).parents[1] / "docs" / "data" / "validate_model.json").read_text())["tables"]
    notes = {r[1]: r[6] for r in t["rows"]["rows"]}
    for name, const in (("Fig. 8 GeForce3 3D texture [fps]", vm.BLOCK_EDGE), ("Fig. 8 Radeon 8500 2D planes [fps]",
                                                                             vm.BLOCK_EDGE),
                        (f"T1 {vm.KRAUS_LABEL['fp16']} [s]", vm.FB_REBIND), ("T2/T3 VICP Blunt Fin [fps]", vm.UPLOAD)):
        assert f"at double {const}" in notes[name], name
        assert t["rows"]["sensitivity"][name]["constant"] == const
    f8 = next(r for r in t["relative"]["rows"] if r[1] == "Fig. 8: 2D planes over 3D texture" and r[2] == "GeForce3")
    assert f"at double {vm.BLOCK_EDGE}" in f8[-1]


def test_uploads_cost_the_bus_and_where_profiled_the_host_issuing_them():
    """``bytes_up`` go over the bus (GPU, serial) and, where the host has ``upload_rate``, cost the CPU
    issuing them too: VICP (uploads every frame) minus VICP-GPU (cells resident) is exactly that."""
    p = load_profile("geforce6800gt")
    b = 248_133_936  # VICP's per-frame upload of the Blunt Fin (12 vertices x 92 bytes per cell)
    r = model_counters({"bytes_up": b}, p)
    assert r["gpu_s"] == pytest.approx(b / 2.133e9, rel=1e-12) and r["host_s"] == pytest.approx(b / 694e6, rel=1e-12)
    assert "Kraus" in p.source("host", "upload_rate") and p.source("host", "upload_rate").startswith("derived")
    gpu_work = {"fragments": 5_208_110, "tex_3d_rgba8_linear": 5_208_110, "blends_unorm8": 5_208_110}
    vicp = model_counters({**gpu_work, "bytes_up": b}, p)["s"]
    vicp_gpu = model_counters(gpu_work, p)["s"]
    assert vicp - vicp_gpu == pytest.approx(b / 2.133e9 + b / 694e6, rel=1e-9)
    # a host without the rate: the bus alone (no silent host term)
    o = model_counters({"bytes_up": 1_600_000}, load_profile("octane_mxi"))
    assert o["host_s"] == 0.0 and o["s"] == pytest.approx(1e-3, rel=1e-12)


def test_texture_cache_misses_are_memory_traffic():
    p = load_profile("geforce4_ti4600")
    r = model_counters({"fragments": 1_200_000, "tex_miss_bytes": 10_400_000_000}, p)
    assert r["bound"] == "memory" and r["s"] == pytest.approx(1.0, rel=1e-12)  # 10.4 GB at 10.4 GB/s
    assert model_counters({"tex_miss_bytes": 1}, load_profile("octane_mxi"))["s"] == 0.0  # no memory figure: no unit


def test_cost_table_sums_what_each_count_took(monkeypatch):
    """validate_model's cost table: each configuration's recorded count (wall, CPU, load at start and end)
    by group and in all; no table while a configuration's cost is unknown."""
    from warpvol.reproduce import model_rows

    vm = _validate_model_script()
    cost = {k: {"seconds": 10.0 * (i + 1), "cpu_s": 5.0, "load": [1.0 + i / 10, 2.0]}
            for i, k in enumerate(vm.MODEL_KEYS)}
    monkeypatch.setattr(model_rows, "count_cost", cost.get)
    t = vm.cost_table({vm.MODEL_KEYS[0]: 10.0})
    rows = {r[0]: r[1:] for r in t["rows"]}
    n = len(vm.MODEL_KEYS)
    assert rows["all"] == [n, round(sum(10.0 * (i + 1) for i in range(n))), round(5.0 * n), f"1.0-{1 + (n - 1) / 10:.1f}"]
    assert sum(r[1] for r in t["rows"][:-1]) == n and rows["Guthe Table 5 renders (1280x960)"][0] == 4
    assert rows["Guthe Table 5 sorts alone"][0] == 6 and "counted 1 of 29" in t["notes"]
    monkeypatch.setattr(model_rows, "count_cost", lambda k: None)
    assert vm.cost_table({}) is None
