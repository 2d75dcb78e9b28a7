"""The HARC paper presets run the paper's fp32 set-up (issue 21 item 2): rays from the eye in fp32,
planes and gradients computed in fp32 as the paper's textures held them, and a ray the walk cannot
resolve is lost -- counted, warned and visible in the image -- while ``harc_best`` resolves it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.tolerances import preset_tolerance
from warpvol.errors import ConfigError
from warpvol.metrics import image_error
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.builtin import builtin_scene
from warpvol.tools.stress import build_case, report_warnings


def _lost(report) -> int:
    st = report["stats"]
    return st["harc"].get("lost_rays", 0) + st.get("harc_peel", {}).get("lost_rays", 0)


def test_planes_and_gradients_are_computed_in_fp32():
    from warpvol.raycasting.harc import mesh_textures, planes_fp32

    m = builtin_scene("sphere").mesh
    planes, grad = planes_fp32(m)
    assert planes.dtype == np.float32 and grad.dtype == np.float32
    # the same planes as float64's, to float32 rounding of the arithmetic ...
    np.testing.assert_allclose(planes, m.face_planes, atol=1e-5)
    np.testing.assert_allclose(grad[:, :3], m.gradients, rtol=1e-3, atol=1e-3)
    # ... but not the float64 planes cast: the texels hold what fp32 arithmetic gives
    assert (planes != m.face_planes.astype(np.float32)).any()
    _, tex = mesh_textures(m, np.zeros(3), arithmetic="fp32")
    np.testing.assert_array_equal(tex[0].values.reshape(-1, 4)[: m.n_tets], planes[:, 0])
    np.testing.assert_array_equal(tex[4].values.reshape(-1, 4)[: m.n_tets], grad)


@pytest.mark.parametrize("preset", ["espinha2005_full", "espinha2005_partial"])
def test_paper_presets_run_the_paper_setup(preset):
    p = Pipeline.load(preset)
    st = p.render(builtin_scene("concave").with_camera(width_px=16, height_px=16), quiet=True).report["stats"]
    assert st["harc"]["ray_setup"] == "paper" and st["harc"]["lost_rays"] == 0 and st["harc"]["float64_rays"] == 0
    best = Pipeline.load("harc_best").render(builtin_scene("concave").with_camera(width_px=16, height_px=16),
                                             quiet=True).report["stats"]
    assert best["harc"]["ray_setup"] == "robust" and "lost_rays" not in best["harc"]


def test_tiny_mesh_loses_rays_in_espinha_not_in_harc_best():
    # a mesh 1e-12 across: the fp32 face normals underflow (|n|^2 ~ 1e-48), the texels hold no plane,
    # the entry and exit faces give no ray parameter: the paper's walk loses those rays
    sc = build_case("mesh_scale_1e-12", quick=True).scene
    n = sc.camera.width_px * sc.camera.height_px
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load("espinha2005_full").render(sc, quiet=True)
    lost = _lost(res.report)
    assert lost > n // 4, lost  # counted ...
    assert res.report["stats"]["harc_mesh"]["degenerate_tets"] > 0
    w = res.report["stats"]["harc"]["warning"]
    assert f"{lost:,} of {n:,} rays lost" in w  # ... warned, naming the count ...
    assert any("rays lost" in x for x in report_warnings(res.report))
    # ... and visible: those pixels miss what the reference shows (no float64 redo)
    err = np.abs(res.image[..., 3] - ref[..., 3])
    assert (err > 0.1).sum() >= lost // 2 and err.max() > 0.5
    best = Pipeline.load("harc_best").render(sc, quiet=True)
    assert _lost(best.report) == 0
    e = image_error(best.image, ref)
    assert e["max_abs"] <= preset_tolerance("harc_best")["max_abs"] and e["rmse"] <= preset_tolerance("harc_best")["rmse"]


def test_far_eye_walk_steps_backwards_and_is_flagged():
    # eye 1e6 from a unit mesh: fp32 lambda' from the eye has ulps ~0.06, rounding picks exits
    # behind the entry: the rays are counted and warned (their pixels are wrong), harc_best is exact
    sc = build_case("camera_far", quick=True).scene
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load("espinha2005_full").render(sc, quiet=True)
    back = res.report["stats"]["harc"]["backward_rays"]
    assert back > 0
    assert f"{back:,} rays took a step backwards" in res.report["stats"]["harc"]["warning"]
    assert image_error(res.image, ref)["max_abs"] > preset_tolerance("espinha2005_full")["max_abs"]
    best = Pipeline.load("harc_best").render(sc, quiet=True)
    assert best.report["stats"]["harc"]["backward_rays"] == 0 and "warning" not in best.report["stats"]["harc"]
    assert image_error(best.image, ref)["max_abs"] <= preset_tolerance("harc_best")["max_abs"]


def test_paper_setup_needs_the_plane_walk_on_fp32_textures():
    sc = builtin_scene("box").with_camera(width_px=4, height_px=4)
    bad = [{"stage": "cell_setup"}, {"stage": "harc_mesh", "layout": "compact"}, {"stage": "harc_raster"},
           {"stage": "harc", "walk": "plucker", "ray_setup": "paper"}]
    with pytest.raises(ConfigError, match="ray_setup"):
        Pipeline.from_config({"stages": bad}).render(sc, quiet=True)
    mixed = [{"stage": "cell_setup"}, {"stage": "harc_mesh"}, {"stage": "harc_raster"},
             {"stage": "harc", "walk": "planes", "ray_setup": "paper"}]
    with pytest.raises(ConfigError, match="arithmetic"):
        Pipeline.from_config({"stages": mixed}).render(sc, quiet=True)


def test_partial_preintegration_splits_at_every_control_point_of_the_tf():
    """Espinha & Celes' TF is decomposed into N linear segments and a ray is split at every segment
    boundary: a TF of 16 collinear segments costs 15 more iso sub-steps per ray crossing its whole range
    than the same function as one segment (no merging of collinear runs in the faithful pipeline), and
    draws the same image to the psi table's accuracy."""
    from warpvol.reproduce.espinha2005 import resampled_tf

    sc = builtin_scene("linear_box").with_camera(width_px=16, height_px=16)
    lo, hi = sc.transfer.srange
    assert (lo, hi) == (-1.0, 1.0) and len(sc.transfer.points) == 2  # s = z: interior rays cross the whole range
    p = Pipeline.load("espinha2005_partial")
    one = p.render(sc, quiet=True)
    many = p.render(dataclasses.replace(sc, transfer=resampled_tf(sc.transfer, 16)), quiet=True)
    a, b = one.report["stats"]["harc"], many.report["stats"]["harc"]
    assert a["entries"] == b["entries"] > 0 and a["cells"] == b["cells"]
    # every ray crosses the 15 inner control points s = k / 8; 3 of them (s = -0.5, 0, 0.5) lie on the
    # grid's cell faces, where the walk steps to the next cell anyway: 12 splits inside cells per ray
    # (the centre-anchored iso table may miss one within a texel of a segment's start: iso_missed)
    extra = b["steps"] - a["steps"]
    assert 12 * b["entries"] - b["iso_missed"] <= extra <= 15 * b["entries"] and extra >= 10 * b["entries"]
    assert np.abs(one.image - many.image).max() < 2e-2
