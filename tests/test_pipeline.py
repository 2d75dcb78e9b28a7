"""Stage framework: registry, config validation, planner report, presets."""

import subprocess
import sys

import pytest

from helpers import box_mesh, scene
from warpvol.errors import ConfigError
from warpvol.pipeline import Pipeline, get_stage_class, list_presets
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction
from warpvol.stage import STAGES, Stage


def test_unknown_stage_names_it_and_lists_allowed():
    with pytest.raises(ConfigError, match=r"stages\[1\].stage: unknown stage 'raycats'; allowed: .*raycast"):
        Pipeline.from_config({"stages": [{"stage": "cell_setup"}, {"stage": "raycats"}]})


def test_unknown_key_is_an_error_naming_it():
    with pytest.raises(ConfigError, match=r"unknown key\(s\) 'max_step' \(did you mean 'max_steps'\?\); allowed: 'max_steps'"):
        Pipeline.from_config({"stages": [{"stage": "raycast", "max_step": 3}]})
    with pytest.raises(ConfigError, match=r"pipeline: unknown key\(s\) 'stage'"):
        Pipeline.from_config({"stage": []})


def test_bad_parameter_value_names_range():
    with pytest.raises(ConfigError, match=r"raycast.*early_termination: 2.0 is outside the allowed range \[0, 1\]"):
        Pipeline.from_config({"stages": [{"stage": "raycast", "early_termination": 2.0}]})
    with pytest.raises(ConfigError, match=r"tile: expected an integer"):
        Pipeline.from_config({"stages": [{"stage": "entry_bins", "tile": 2.5}]})


def test_empty_or_missing_pipeline():
    with pytest.raises(ConfigError, match="non-empty list"):
        Pipeline.from_config({"stages": []})
    with pytest.raises(ConfigError, match="neither a preset nor a file"):
        Pipeline.load("no-such-preset")
    with pytest.raises(ConfigError, match="file not found"):
        Pipeline.load("missing/pipe.toml")


def test_pipeline_file_with_bad_toml(tmp_path):
    p = tmp_path / "p.toml"
    p.write_text("[[stages]\nstage=1")
    with pytest.raises(ConfigError, match="invalid TOML"):
        Pipeline.load(p)


def test_presets_listed_and_loadable():
    names = dict(list_presets())
    assert "raycast" in names and names["raycast"]
    for n in names:
        Pipeline.load(n)


def test_report_has_contract_fields_and_skips():
    tf = TransferFunction([[0, 1, 1, 1, 1.0], [2, 1, 1, 1, 1.0]])
    cam = Camera(projection="orthographic", eye=[0, 0, 5], ortho_height=3, width_px=8, height_px=8)
    res = Pipeline.load("raycast").render(scene(box_mesh(), tf, cam), quiet=True, reference=None)
    r = res.report
    assert r["pipeline"] == "raycast"
    assert set(r["stages"]) == {"condition", "visibility", "cell_setup", "entry_bins", "raycast"}
    assert all(v >= 0 for v in r["stages"].values()) and r["total_s"] >= sum(r["stages"].values()) * 0.99
    assert r["skipped"] == [{"stage": "peel", "reason": "mesh boundary is convex: every ray enters the mesh at most once"}]
    res2 = Pipeline.load("raycast").render(scene(box_mesh(), tf, cam), quiet=True, reference=res.image)
    assert res2.report["error"]["rmse"] == 0 and res2.report["error"]["psnr"] is None
    assert "exact match" in res2.report["error"]["psnr_note"]


def test_every_registered_stage_documents_its_parameters():
    get_stage_class("raycast")
    for name, cls in STAGES.items():
        assert issubclass(cls, Stage) and cls.summary, name
        doc = cls.__doc__ or ""
        for p in cls.params:
            assert p.name in doc, f"stage {name}: parameter {p.name} missing from its docstring table"


def test_top_level_kernels_package_is_not_importable(tmp_path):
    # kernels/ is installed as warpvol.kernels only
    code = "import importlib.util, sys; print(importlib.util.find_spec('kernels') is None, importlib.util.find_spec('warpvol.kernels') is not None)"
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "True"]


def test_unavailable_device_is_a_named_error():
    with pytest.raises(ConfigError, match=r"device 'cuda:7' is not available here; available: cpu"):
        Pipeline.load("raycast", device="cuda:7")


@pytest.mark.parametrize("stages, message", [
    (["raycast"], r"stages\[0\] \(raycast\) needs 'cells', 'entry_bins', which no stage before it provides "
                  r"\(stages that provide it: 'cell_setup', 'entry_bins'\)"),
    (["entry_bins", "raycast", "peel"], r"stages\[1\] \(raycast\) needs 'cells',"),
    (["cell_setup", "entry_bins", "peel"], r"stages\[2\] \(peel\) needs 'march'.*'raycast'"),
    (["raycast", "cell_setup", "entry_bins"], r"stages\[0\] \(raycast\) needs 'cells', 'entry_bins'"),  # order counts
    (["cell_setup", "entry_bins"], r"no stage writes the image \(stages that provide it: .*'peel', .*'raycast'.*\)"),
    (["table_exact", "vertex"], r"no stage writes the image"),
])
def test_stages_lacking_what_they_need_are_rejected_when_loaded(stages, message, tmp_path):
    with pytest.raises(ConfigError, match=message):
        Pipeline.from_config({"stages": [{"stage": s} for s in stages]})
    p = tmp_path / "p.toml"
    p.write_text("".join(f'[[stages]]\nstage = "{s}"\n' for s in stages))
    with pytest.raises(ConfigError, match=message):
        Pipeline.load(p)
    with pytest.raises(ConfigError, match=message.split(r"\) needs ")[-1]):  # stages built directly
        Pipeline([get_stage_class(s)() for s in stages])


def test_every_stage_declares_what_it_needs_and_provides():
    get_stage_class("raycast")
    for name, cls in STAGES.items():
        assert cls.provides, f"stage {name} provides nothing"
    # a parameter-named key resolves per instance: a table stored under another name is provided under it
    assert get_stage_class("table_exact")(output="t2").config["output"] == "t2"
    from warpvol.pipeline import _names

    st = get_stage_class("table_exact")(output="t2")
    assert _names(st.provides, st.config) == ["t2"]


def test_the_raycast_preset_passes_the_check_and_its_stages_chain():
    pipe = Pipeline.load("raycast")
    assert [s.name for s in pipe.stages] == ["condition", "visibility", "cell_setup", "entry_bins", "raycast", "peel"]


def test_an_old_parameter_name_is_still_accepted_with_a_deprecation_note():
    """raycast's early termination was ``t_min``: pipeline files that still say so keep working (warned)."""
    with pytest.warns(DeprecationWarning, match="'t_min' is the old name of 'early_termination'"):
        p = Pipeline.from_config({"stages": [{"stage": "cell_setup"}, {"stage": "entry_bins"},
                                             {"stage": "raycast", "t_min": 0.0}]})
    st = p.stages[-1]
    assert st.config["early_termination"] == 0.0 and st.t_min == 0.0 and "t_min" not in st.config
    with pytest.raises(ConfigError, match="'early_termination' and its old name 't_min' both given"):
        Pipeline.from_config({"stages": [{"stage": "raycast", "t_min": 0.0, "early_termination": 0.0}]})
