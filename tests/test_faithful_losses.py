"""Faithful presets draw what the emulated hardware computes, and say so where that may be visibly wrong:
thin cells and edge-on faces in cell projection, cells shorter than a uniform thickness axis's first step."""

import numpy as np
import pytest

from test_thin_layers import layer_scene
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.tools.stress import report_warnings
from warpvol.tools.stress_meshes import _box, _tf


def small_beside_large() -> Scene:
    """A box 16 across in coarse cells (longest edge ~13.9) and, beside it, a dense box 0.1 across."""
    big, small = _box(3, lo=-8.0, hi=8.0), _box(3, lo=-0.05, hi=0.05)
    pts = np.concatenate([big.points - [0.0, 0.0, 20.0], small.points + [9.0, 0.0, 0.0]])
    tets = np.concatenate([big.tets, small.tets + big.n_points])
    s = np.concatenate([np.full(big.n_points, -0.9), np.full(small.n_points, 0.9)])
    tf = _tf(0.0).__class__([[-1, 0.2, 0.2, 0.9, 0.0], [0.0, 0.2, 0.2, 0.9, 0.0], [1, 0.9, 0.6, 0.1, 40.0]])
    cam = Camera(eye=(9.03, 0.41, 1.0), target=(9.01, 0.0, 0.0), fov_y_deg=9.0, width_px=24, height_px=24)
    return Scene(mesh=TetMesh(pts, tets, s, name="small_beside_large"), transfer=tf, camera=cam, name="sbl")


@pytest.mark.parametrize("preset", ["roettger2000_3d", "kraus2004_basic"])
def test_uniform_thickness_axis_reports_cells_shorter_than_one_step(preset):
    sc = small_beside_large()
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load(preset).render(sc, reference=ref, quiet=True)
    warn = " ".join(report_warnings(res.report))
    assert "uniform thickness axis" in warn and "shorter than one step" in warn
    assert res.report["error"]["max_abs"] > 0.05  # the loss is real, and now reported


def test_logarithmic_thickness_axis_has_no_such_note():
    res = Pipeline.load("kraus2004_full").render(small_beside_large(), quiet=True)
    assert not any("uniform thickness axis" in w for w in report_warnings(res.report))


@pytest.mark.parametrize("preset", ["kraus2004_basic", "roettger2002_hw", "pt_vertex_color"])
def test_cell_projection_reports_thin_layers(preset):
    grazing = Camera(eye=(3.8, 0.7, 0.9), target=(0, 0, 0.15), up=(0, 0, 1), fov_y_deg=40.0, width_px=24,
                     height_px=24)
    sc = layer_scene(4e-6, 0.4, grazing)
    res = Pipeline.load(preset).render(sc, quiet=True)
    st = res.report["stats"]["pt_project"]
    assert st["thin_tets"] > 0 and st["pixels"] > 0 and "float32" in st["warning"]


def test_cell_projection_quiet_on_ordinary_meshes():
    from warpvol.scene.builtin import builtin_scene

    res = Pipeline.load("kraus2004_basic").render(builtin_scene("sphere").with_camera(width_px=24, height_px=24),
                                                  quiet=True)
    assert "warning" not in res.report["stats"].get("pt_project", {})


def _measure_script():
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "measure_fp32_setups", Path(__file__).resolve().parents[1] / "scripts" / "measure_fp32_setups.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_harc_peel_tolerance_is_stated_and_changes_nothing_through_reentries():
    """The stated size of the peel tolerance (no pixel, no lost ray) against the plain comparison."""
    for name in ("espinha2005_full", "espinha2005_partial"):
        text = Pipeline.load(name).known_losses
        assert "1e-6 of the mesh radius before the last exit" in text and "no pixel and no lost-ray count" in text
    m = _measure_script()
    (row,) = [r for r in m.measure("peel_tol", m.scene("concave", 24)) if r["preset"] == "espinha2005_full"]
    assert row["counts_faithful"]["harc_peel.reentries"] > 0  # the peel test really ran
    assert row["pixels_differ"] == 0 and row["counts_faithful"] == row["counts_plain"]


def test_vsbuffer_origin_shift_is_stated_and_within_its_stated_size():
    """The float64 origin shift against the mesh's own frame: within the stated pixel and missed-cell bounds."""
    text = Pipeline.load("westermann1997").known_losses
    assert "changes pixels by less than 2e-5" in text and "missed_cells by at most 25" in text
    m = _measure_script()
    (row,) = m.measure("origin_shift", m.scene("sphere", 24))
    assert 0 < row["max_diff"] < 2e-5  # the shift does change float32 rounding, by less than stated
    a, b = row["counts_faithful"]["vsbuffer.missed_cells"], row["counts_plain"]["vsbuffer.missed_cells"]
    assert a > 0 and abs(a - b) <= 25
