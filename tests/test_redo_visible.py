"""The float64 redo walks only the visible sub-mesh (``render_reference_warp`` / ``redo_pixels_float64`` with
``visible``): a tet the transfer function maps to zero integrates to exactly zero colour and optical depth,
so the masked walk gives the unmasked walk's pixels bit for bit, on convex and non-convex meshes, rays that
leave and re-enter the visible part several times, and a perspective eye inside the mesh; its set-up cache
follows the mask; the exact presets' images and float64 ray counts are the same with the mask as without."""

import numpy as np
import pytest

from helpers import box_mesh
from tolerances import preset_tolerance
from warpvol.conditioning.visibility import cell_visibility
from warpvol.errors import ConfigError
from warpvol.reference import warp_render as wr
from warpvol.reference.pixels import redo_pixels_float64
from warpvol.reference.warp_render import render_reference_warp
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction

W = H = 24
OBLIQUE = dict(eye=[2.7, 1.9, 3.3], target=[0.05, -0.1, 0.02], fov_y_deg=50.0, width_px=W, height_px=H)


def zero_below(cut, top, emission="color_extinction"):
    """Zero colour and extinction up to ``cut``, a ramp above."""
    return TransferFunction([[-10.0, 0, 0, 0, 0], [cut, 0, 0, 0, 0], [top, 0.9, 0.5, 0.2, 2.5]], emission)


def bands(centres, half=0.15):
    """Hats around each of ``centres`` (colour and extinction), zero between."""
    pts = [[-10.0, 0, 0, 0, 0]]
    for c in centres:
        pts += [[c - half, 0, 0, 0, 0], [c, 0.3, 0.8, 0.5, 4.0], [c + half, 0, 0, 0, 0]]
    return TransferFunction(pts + [[10.0, 0, 0, 0, 0]])


def half_box():
    return box_mesh(dims=(5, 5, 5), scalar=lambda p: p[:, 2] + 0.2 * p[:, 0])


def slab_box():
    """s = cos(3 pi x): three visible slabs across x under ``bands([0.8])``, rays along x cross all."""
    return box_mesh(dims=(13, 4, 4), scalar=lambda p: np.cos(3 * np.pi * p[:, 0]))


def concave_shell():
    sc = builtin_scene("concave")  # s = |p|^2 in [0.25, 3.5]: one shell around s = 1.2
    return sc.mesh, bands([1.2], 0.2), sc.camera.replace(width_px=W, height_px=H)


CASES = {
    "half_box_perspective": lambda: (half_box(), zero_below(0.0, 1.5), Camera(**OBLIQUE)),
    "half_box_ortho_emission_density": lambda: (
        half_box(), zero_below(0.1, 1.5, "emission_density"),
        Camera(projection="orthographic", eye=[2.5, 2.0, 3.0], target=[0, 0, 0], ortho_height=3.2, width_px=W,
               height_px=H)),
    "slabs_along_x": lambda: (slab_box(), bands([0.8]),
                              Camera(eye=[4.0, 0.31, 0.23], target=[0, 0, 0], fov_y_deg=30.0, width_px=W, height_px=H)),
    "concave_shell": concave_shell,
    "eye_in_visible_part": lambda: (half_box(), zero_below(0.0, 1.5),
                                    Camera(eye=[0.13, 0.07, 0.6], target=[0.5, -0.4, -1.0], fov_y_deg=100.0,
                                           width_px=W, height_px=H)),
    "eye_in_invisible_part": lambda: (half_box(), zero_below(0.0, 1.5),
                                      Camera(eye=[0.13, 0.07, -0.6], target=[0.4, -0.3, 1.0], fov_y_deg=100.0,
                                             width_px=W, height_px=H)),
}


def redo(mesh, tf, cam, px, visible=None, stats=None):
    return render_reference_warp(mesh, tf, cam, device="cpu", pixels=px, visible=visible, stats=stats,
                                 show_progress=False)


@pytest.mark.parametrize("case", sorted(CASES))
def test_masked_walk_equals_the_whole_walk(case):
    mesh, tf, cam = CASES[case]()
    vis = cell_visibility(mesh, tf)
    assert 0 < vis.sum() < len(vis)
    whole = render_reference_warp(mesh, tf, cam, device="cpu", show_progress=False)
    assert whole[..., 3].max() > 0.05
    masked_whole = render_reference_warp(mesh, tf, cam, device="cpu", show_progress=False, visible=vis)
    np.testing.assert_array_equal(masked_whole, whole)
    rng = np.random.default_rng(len(case))
    for n in (W * H // 2, 5):
        px = rng.choice(W * H, n, replace=False)
        st_all, st_vis = {}, {}
        got_all = redo(mesh, tf, cam, px, stats=st_all)
        got_vis = redo(mesh, tf, cam, px, vis, st_vis)
        np.testing.assert_array_equal(got_vis, got_all)
        np.testing.assert_array_equal(got_vis, whole.reshape(-1, 4)[px])
        assert st_vis["n_steps"] < st_all["n_steps"] and st_vis["n_failed"] == 0
    if case == "slabs_along_x":  # the visible slabs are entered one after another
        assert st_vis["n_entries"] >= 2.5 * len(px)
    np.testing.assert_array_equal(redo_pixels_float64(mesh, tf, cam, px, visible=vis), got_all)


def test_set_up_follows_the_mask():
    """Two transfer functions in a row on one mesh and view: the second mask gets its own faces and walk
    (a set-up kept by mesh and view alone would walk the first mask's sub-mesh)."""
    mesh, cam = slab_box(), Camera(**OBLIQUE)
    px = np.random.default_rng(3).choice(W * H, 200, replace=False)
    for centres in ([0.8], [-0.8], [0.95]):
        tf = bands(centres)
        vis = cell_visibility(mesh, tf)
        assert 0 < vis.sum() < len(vis)
        np.testing.assert_array_equal(redo(mesh, tf, cam, px, vis), redo(mesh, tf, cam, px))
    keys = list(wr._PIXEL_SETUP[mesh])
    assert len({k[1] for k in keys}) == len(keys) >= 3  # one set-up per mask, and the unmasked one


def test_mask_of_another_transfer_function_is_refused():
    mesh, cam = half_box(), Camera(**OBLIQUE)
    vis = cell_visibility(mesh, zero_below(0.0, 1.5))
    for pixels in (np.arange(10), None):
        with pytest.raises(ConfigError, match="leaves out"):
            render_reference_warp(mesh, zero_below(-0.5, 1.5), cam, device="cpu", pixels=pixels, visible=vis,
                                  show_progress=False)
    with pytest.raises(ConfigError, match="bool array"):
        redo(mesh, zero_below(0.0, 1.5), cam, np.arange(10), vis[:-1])


@pytest.mark.parametrize("preset", ["raycast", "harc_best", "pt_best", "vsbuffer_best"])
def test_presets_redo_through_the_visible_cells(preset, monkeypatch):
    """A shell transfer function on the non-convex mesh: the rays each preset redoes in float64 go through
    the visible cells only, with the same count and the same image as a redo through every cell, within the
    preset's tolerance of the reference."""
    from warpvol.metrics import image_error
    from warpvol.pipeline import Pipeline
    from warpvol.reference.numpy_render import render_reference

    mesh, tf, cam = concave_shell()
    cam = cam.replace(width_px=64, height_px=64)
    sc = builtin_scene("concave")
    sc.transfer, sc.camera = tf, cam
    calls = []
    real = wr.render_reference_warp

    def spy(*a, **k):
        if k.get("pixels") is not None:
            calls.append((len(k["pixels"]), k.get("visible") is not None))
        return real(*a, **k)

    monkeypatch.setattr(wr, "render_reference_warp", spy)
    pipe = Pipeline.load(preset)
    masked = pipe.render(sc, quiet=True)
    assert calls and all(v for _, v in calls) and sum(n for n, _ in calls) > 0
    n_masked = list(calls)
    calls.clear()
    monkeypatch.setattr(wr, "_visible_mask", lambda mesh, visible: None)  # every cell walked
    full = pipe.render(sc, quiet=True)
    assert [n for n, _ in calls] == [n for n, _ in n_masked]
    np.testing.assert_array_equal(masked.image, full.image)
    err = image_error(masked.image, render_reference(sc.mesh, tf, cam))
    tol = preset_tolerance(preset)
    assert err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"], err
