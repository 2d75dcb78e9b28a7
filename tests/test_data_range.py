"""Data as users bring it: log-scaled fields over many decades and parts that keep points no cell uses.

* The exact presets keep every transfer-function segment the data reaches apart in float32: a
  density over 3 to 12 decades with a control point per decade renders within the tolerance rows
  against the float64 reference, with no warning; segments float32 resolves too coarsely are
  reported, and control points it cannot keep apart are declined, named.
* Points no cell uses (8 of them, at +-1e3 .. +-1e30) change no bound, frame or image: every preset
  draws the part as without them, the default camera frames the part, and ``warpvol render`` of
  such a file draws it.
"""

import warnings

import numpy as np
import pytest

from tolerances import EXACT_PRESETS, preset_tolerance
from warpvol.conditioning.conditioning import condition_scene, scalar_mapping
from warpvol.errors import ConfigError
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.camera import Camera
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction
from warpvol.tools.stress import Case, report_warnings, run_case
from warpvol.tools.stress_meshes import _box
from warpvol.tools.stress_range import log_scene, rough_scene, silent_wrong, unused_points_scene


def within(err, preset):
    tol = preset_tolerance(preset)
    return err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"]


@pytest.mark.parametrize("preset", list(EXACT_PRESETS))
@pytest.mark.parametrize("decades,n", [(6, 5), (9, 6), (12, 4)])
def test_log_scaled_fields_render_exactly(preset, decades, n):
    sc = log_scene(24, decades=decades, n=n)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    assert ref[..., 3].max() > 0.5
    res = Pipeline.load(preset).render(sc, reference=ref, quiet=True)
    assert within(res.report["error"], preset), (res.report["error"], res.report["stats"]["condition"])
    assert not report_warnings(res.report)


@pytest.mark.parametrize("decades", [6, 9, 12, 15])
def test_the_offset_keeps_every_decade_apart(decades):
    # mapped about the smallest decade the data reaches: each segment [10^k, 10^(k+1)] keeps 0.9 of its far
    # end's distance (the midpoint leaves 1e-3 .. 1e-14 of it)
    sc = log_scene(8, decades=decades)
    c, info = condition_scene(sc)
    lo = sc.mesh.scalar_range[0]
    assert lo < info["scalar_offset"] <= 10.0 * lo and info["scalar_resolution"] >= 0.85
    u = np.float32(c.transfer.s)
    far = np.maximum(np.abs(u[:-1]), np.abs(u[1:]))
    assert (np.diff(u) > 0).all() and (np.diff(u) / far > 0.8).all()
    assert -1.0 <= c.mesh.scalar_range[0] and c.mesh.scalar_range[1] <= 1.0


def _two_sided(decades, n=7):
    """Control points crowding at both ends of [0, 1000] (500 * 10^-k and 1000 - 500 * 10^-k): no
    offset keeps both ends' narrowest segments apart."""
    rng = np.random.default_rng(3)

    def field(p):
        t = np.clip((np.sin(1.3 * p[:, 1]) + 0.7 * p[:, 2] + 1.7) / 3.4, 0.0, 1.0)
        g = 500.0 * 10.0 ** (-decades * (1.0 - t))
        return np.where(p[:, 0] < 0, g, 1000.0 - g)

    k = 500.0 * 10.0 ** -np.arange(decades + 1.0)
    s = np.sort(np.concatenate([k, 1000.0 - k[1:]]))
    tf = TransferFunction(np.column_stack([s, rng.uniform(0.1, 1.0, (len(s), 3)), rng.uniform(0.2, 2.5, len(s))]))
    cam = Camera(eye=(3.0, 2.0, 4.0), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=30.0, width_px=24, height_px=24)
    return Scene(mesh=_box(n, scalar=field, name="two_sided"), transfer=tf, camera=cam, name="two_sided")


@pytest.mark.parametrize("decades", [5, 6])
def test_segments_float32_resolves_coarsely_are_reported(decades):
    sc = _two_sided(decades)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load("raycast").render(sc, reference=ref, quiet=True)
    w = res.report["stats"]["condition"]["warning"]
    assert w.startswith("transfer.points: float32 keeps only") and f"{500.0 * 10.0 ** -decades:.10g}" in w
    assert res.report["error"]["max_abs"] > 1e-4 or res.report["error"]["rmse"] > 2e-6  # it is off, and says so


def test_control_points_float32_cannot_keep_apart_are_declined_by_name():
    sc = _two_sided(9)
    lo, hi = sc.mesh.scalar_range  # the narrowest segments the data reaches, at both ends
    with pytest.raises(ConfigError, match=r"transfer\.points: float32 keeps only \d step\(s\) across the segment\(s\) "
                                          r"\[.*at least 16 needed") as e:
        Pipeline.load("harc_best").render(sc, quiet=True)
    assert f"[{lo:.10g}, 5e-06]" in str(e.value) and f", {hi:.10g}]" in str(e.value)
    with pytest.raises(ConfigError, match=r"\[5e-06, 5e-05\], \[999\.99995, 999\.999995\] and 6 more"):  # up a decade
        scalar_mapping(sc.transfer, sc.mesh.scalars, sc.mesh.scalar_range)


@pytest.mark.parametrize("points", [2048, 8192])
def test_rough_transfer_functions_are_exact_or_reported(points):
    # evenly spaced control points of random colour: 8,192 leave each segment 2^-12 of the scalars' span
    # from the offset, too coarse for raycast's tolerance (seen 1.5e-4 max abs at 96^2): reported
    sc = rough_scene(48, points)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load("raycast").render(sc, reference=ref, quiet=True)
    warned = "warning" in res.report["stats"]["condition"]
    assert warned == (points == 8192)
    assert warned or within(res.report["error"], "raycast"), res.report["error"]


def test_ordinary_scenes_keep_the_midpoint_offset():
    sc = log_scene(8, decades=2)  # 10 .. 1000: every decade resolved about the midpoint of the data's range
    _, info = condition_scene(sc)
    assert info["scalar_offset"] == pytest.approx(sum(sc.mesh.scalar_range) / 2) and info["scalar_resolution"] > 2 ** -8


# ------------------------------------------------------------------------------------------------
# points no cell uses
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("preset", list(EXACT_PRESETS))
@pytest.mark.parametrize("distance", [1e3, 1e7, 1e30])
def test_unused_points_change_no_exact_render(preset, distance):
    sc = unused_points_scene(24, distance)
    assert sc.mesh.n_unused_points == 8
    assert sc.mesh.bounds[0].tolist() == [-1.0] * 3 and sc.mesh.bounds[1].tolist() == [1.0] * 3
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    assert ref[..., 3].max() > 0.5
    res = Pipeline.load(preset).render(sc, reference=ref, quiet=True)
    assert within(res.report["error"], preset), res.report["error"]
    assert not report_warnings(res.report)
    st = res.report["stats"]["condition"]
    assert st["scale"] == 1.0 and st["unused_points"] == 8
    assert -1.5 <= st["scalar_offset"] <= 1.5  # the part's scalars (-1.5 .. 1.5), not the unused 5 and -7


@pytest.mark.parametrize("preset", ["raycast", "pt_best", "kraus2004_basic", "westermann1997", "espinha2005_partial",
                                    "guthe2002_linear"])
def test_every_family_draws_the_part_as_without_its_unused_points(preset):
    sc = unused_points_scene(20, 1e7)
    used = np.unique(sc.mesh.tets)
    remap = np.full(sc.mesh.n_points, -1)
    remap[used] = np.arange(len(used))
    from warpvol.scene.mesh import TetMesh

    part = TetMesh(sc.mesh.points[used], remap[sc.mesh.tets], sc.mesh.scalars[used], name="part")
    pipe = Pipeline.load(preset)
    a = pipe.render(Scene(mesh=part, transfer=sc.transfer, camera=sc.camera, name="a"), quiet=True)
    b = pipe.render(sc, quiet=True)
    assert np.array_equal(a.image, b.image)
    assert report_warnings(a.report) == report_warnings(b.report)


def test_the_default_camera_frames_the_part():
    for d in (1e3, 1e7):
        sc = unused_points_scene(24, d, fit=True)
        part = unused_points_scene(24, 0.5, fit=True)  # the 8 points inside the part: the same fit
        assert np.allclose(sc.camera.eye, part.camera.eye) and np.allclose(sc.camera.target, part.camera.target)
        img = Pipeline.load("raycast").render(sc, quiet=True).image
        assert img[..., 3].max() > 0.5


def test_faithful_presets_decline_unused_points_beyond_float32_by_name():
    sc = unused_points_scene(16, 1e300)
    with pytest.raises(ConfigError, match=r"part_1e\+300: points: 8 points no cell uses lie up to 1e\+300"):
        Pipeline.load("kraus2004_basic").render(sc, quiet=True)
    assert Pipeline.load("raycast").render(sc, quiet=True).image[..., 3].max() > 0.5


def test_render_of_a_part_file_draws_the_part(tmp_path):
    from warpvol.cli import main
    from warpvol.io import read_exr

    g = unused_points_scene(8, 1e7).mesh.to_pyvista("density")
    g.save(tmp_path / "part.vtu")
    out = tmp_path / "part.exr"
    assert main(["render", str(tmp_path / "part.vtu"), "-o", str(out), "--width", "32", "--height", "32",
                 "--quiet"]) == 0
    assert read_exr(out)[..., 3].max() > 0.3


def test_stress_classes_show_no_silent_wrong_row():
    rows = []
    pipes = [Pipeline.load(p) for p in EXACT_PRESETS]
    for sc in (log_scene(16, decades=9, n=4), unused_points_scene(16, 1e7, n=4), rough_scene(16, 4096)):
        rows += run_case(Case(sc.name, sc, ""), pipes)
    assert all(r["status"] == "ok" for r in rows) and not silent_wrong(rows)
    bad = dict(rows[1], rmse=1e-3, message="")
    assert silent_wrong([bad]) == [bad] and not silent_wrong([dict(bad, message="condition: ...")])


def test_mesh_bounds_and_ranges_come_from_used_points():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sc = unused_points_scene(8, 1e7)
    m = sc.mesh
    assert m.scalar_range == pytest.approx((-1.494998886271481, 1.494998886271481))
    assert m.point_used.sum() == m.n_points - 8 and _box(3).point_used is None
