"""Float64 redo of scattered pixels: the Warp reference walk over a pixel list equals the whole
reference image at those pixels, and the NumPy candidate-pair tracer."""

import numpy as np
import pytest

from warpvol.reference.pixels import redo_pixels_float64
from warpvol.reference.warp_render import render_reference_warp
from warpvol.scene.builtin import builtin_scene


@pytest.mark.parametrize("name", ["sphere", "concave"])
@pytest.mark.parametrize("n", [37, 3])
@pytest.mark.parametrize("match", ["pairs", "table"])
def test_pixel_list_matches_whole_image(name, n, match, monkeypatch):
    """Also with few pixels, where only the entry faces whose box holds a listed pixel are searched (those
    found face by pixel, or by a summed-area table of the listed pixels)."""
    from warpvol.reference import warp_render as wr

    monkeypatch.setattr(wr, "_DIRECT_PAIRS", 1 << 22 if match == "pairs" else 0)
    sc = builtin_scene(name).with_camera(width_px=24, height_px=20)
    full = render_reference_warp(sc.mesh, sc.transfer, sc.camera, device="cpu", show_progress=False)
    px = np.random.default_rng(1).choice(24 * 20, n, replace=False)
    part = render_reference_warp(sc.mesh, sc.transfer, sc.camera, device="cpu", pixels=px, show_progress=False)
    assert part.shape == (n, 4)
    np.testing.assert_array_equal(part, full.reshape(-1, 4)[px])  # each pixel computed on its own
    assert np.abs(full).max() > 0.01 and np.abs(part).max() > 0  # the view, and the listed pixels, show something


def test_redo_warp_matches_numpy_tracer():
    sc = builtin_scene("concave").with_camera(width_px=24, height_px=24)
    px = np.arange(0, 24 * 24, 7)
    a = redo_pixels_float64(sc.mesh, sc.transfer, sc.camera, px, method="numpy")
    b = redo_pixels_float64(sc.mesh, sc.transfer, sc.camera, px)
    assert np.abs(a).max() > 0.01
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-12)
    assert redo_pixels_float64(sc.mesh, sc.transfer, sc.camera, px[:0]).shape == (0, 4)
    with pytest.raises(ValueError):
        redo_pixels_float64(sc.mesh, sc.transfer, sc.camera, px, method="nope")


def test_pixel_lists_reuse_the_set_up_and_stay_exact():
    """A renderer's float64 redo (a pixel list, once or twice per frame) keeps the mesh's set-up for the
    view: later lists are computed from it (a list over most of the view keeps every entry of the view for
    the next ones), bit-identical to the whole image; another view rebuilds it."""
    from warpvol.reference import warp_render as wr

    sc = builtin_scene("concave")
    cam = sc.camera.replace(width_px=24, height_px=20)
    full = render_reference_warp(sc.mesh, sc.transfer, cam, device="cpu", show_progress=False)
    seen = set()
    for px in (np.array([5, 77, 301, 450]), np.array([3 * 24 + 11, 19 * 24 + 23]), np.arange(0, 480, 2),
               np.array([7, 8])):
        got = render_reference_warp(sc.mesh, sc.transfer, cam, device="cpu", pixels=px, show_progress=False)
        assert np.array_equal(got, full.reshape(-1, 4)[px])
        key = next(reversed(wr._PIXEL_SETUP[sc.mesh]))  # the last used
        seen.add(key)
    assert len(seen) == 1
    assert "cpu" in wr._PIXEL_SETUP[sc.mesh][key].tables  # the every-other-pixel list kept the view's entries
    moved = cam.replace(width_px=25)
    render_reference_warp(sc.mesh, sc.transfer, moved, device="cpu", pixels=np.array([0]), show_progress=False)
    assert next(reversed(wr._PIXEL_SETUP[sc.mesh])) != key
