"""Host-side float64 arithmetic that overflowed on extreme inputs computes the same values without a
floating-point warning: run under ``warnings.simplefilter("error")`` and NumPy raising on overflow, division
by zero and invalid operations."""

import warnings

import numpy as np
import pytest

from warpvol.pipeline import Pipeline
from warpvol.projection.pt_thin import project_points, unresolved_pixels
from warpvol.tools.stress_range import unused_points_scene


def strict():
    """Every warning an error, and NumPy's overflow / divide / invalid flags raise (underflow to a
    subnormal is exact enough and not checked)."""
    w = warnings.catch_warnings()
    w.__enter__()
    warnings.simplefilter("error")
    e = np.errstate(over="raise", divide="raise", invalid="raise")
    e.__enter__()
    return w, e


@pytest.fixture
def no_fp_warnings():
    w, e = strict()
    yield
    e.__exit__(None, None, None)
    w.__exit__(None, None, None)


@pytest.mark.parametrize("distance", [1e7, 1e30])
def test_window_projection_of_points_far_away_or_behind_the_eye(distance, no_fp_warnings):
    # a part keeping 8 points of its parent no cell uses at +-distance: some behind the eye, some far
    # to the side; they projected through float64 overflow (RuntimeWarning) to +-inf
    scene = unused_points_scene(16, distance=distance)
    col, row, d = project_points(scene.mesh, scene.camera)
    cam = scene.camera
    rel = np.asarray(scene.mesh.points) - cam.eye
    x, _y = rel @ cam.right, rel @ cam.true_up
    th = np.tan(np.radians(cam.fov_y_deg) / 2.0)
    front = d > 1e-3  # the plain formula, where it does not overflow
    want_col = (x[front] / (d[front] * th * cam.aspect) + 1.0) * 0.5 * cam.width_px
    np.testing.assert_array_equal(col[front][np.abs(want_col) < 1e290], want_col[np.abs(want_col) < 1e290])
    assert np.isinf(col[~front]).all() or not (~front).any()
    assert not np.isnan(col).any() and not np.isnan(row).any()
    used = np.unique(np.asarray(scene.mesh.tets))
    assert np.isfinite(col[used]).all() and np.isfinite(row[used]).all()
    assert unresolved_pixels(scene.mesh, scene.transfer, cam)["thin_tets"] == 0  # and warns nothing


@pytest.mark.parametrize("preset", ["pt_vertex_color", "kraus2004_full"])
def test_faithful_cell_projection_with_far_unused_points_warns_nothing(preset, no_fp_warnings):
    # the faithful presets' float32 check (pt_project.check_float32) projects every point of the mesh
    for distance in (1e7, 1e30):
        r = Pipeline.load(preset).render(unused_points_scene(16, distance=distance), quiet=True)
        assert np.isfinite(r.image).all()
