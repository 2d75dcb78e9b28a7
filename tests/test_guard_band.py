"""A mesh far larger than the image on screen (a huge zoom): window coordinates beyond the rasteriser's
fixed-point guard band. Presets that rasterise the mesh decline in words; raycast stays exact."""

import numpy as np
import pytest

import warpvol
from tolerances import preset_tolerance
from warpvol.errors import ConfigError
from warpvol.gpu.raster import GUARD_PX, guard_band_overflow
from warpvol.reference.numpy_render import render_reference


def zoomed(px=12):
    # the box [-1, 1]^3 seen through a field of view of 3e-6 degrees: ~1e7 pixels across the image
    s = warpvol.builtin_scene("linear_box")
    return s.with_camera(eye=(0.31, -0.27, 5.0), target=(0.31, -0.27, 0.0), fov_y_deg=3e-6,
                         width_px=px, height_px=px, projection="perspective")


def test_overflow_counts_only_primitives_reaching_the_image():
    win = np.array([[1, 1, 0.5, 1], [5, 1, 0.5, 1], [1, 5, 0.5, 1], [-4e6, 2, 0.5, 1], [-3e6, -9e6, 0.5, 1],
                    [-2e6, 3, 0.5, -1]], np.float32)
    tris = np.array([[0, 1, 2], [0, 1, 3], [3, 4, 0], [4, 3, 4], [0, 1, 5]])
    n, ext = guard_band_overflow(win, tris, 8, 8)
    # [0,1,3] reaches into the image; [3,4,0] too; [4,3,4] lies wholly left of it; w <= 0 is not counted
    assert n == 2 and ext == pytest.approx(9e6) and ext > GUARD_PX


@pytest.mark.parametrize("pipeline", ["pt_best", "harc_best", "roettger2000_3d", "espinha2005_full"])
def test_rasterising_presets_decline_in_words(pipeline):
    with pytest.raises(ConfigError, match="guard band"):
        warpvol.render(zoomed(), pipeline=pipeline)


def test_raycast_exact_at_huge_zoom():
    s = zoomed()
    ref = render_reference(s.mesh, s.transfer, s.camera)
    assert ref[..., 3].min() > 0.5  # the mesh fills the image
    r = warpvol.render(s, pipeline="raycast", reference=ref)
    tol = preset_tolerance("raycast")
    assert r.error["rmse"] <= tol["rmse"] and r.error["max_abs"] <= tol["max_abs"]
