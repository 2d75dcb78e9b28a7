"""The float64 redo's closed form for pieces of one colour under ``color_extinction``
(``render_reference_warp(closed_form=True)``, what ``redo_pixels_float64`` asks for): the same pixels as the
quadrature of the reference image to 1e-12, from optically thin to stiff pieces; the reference image itself
keeps its quadrature (covered bit for bit by test_redo_pixels)."""

import numpy as np
import pytest

from helpers import box_mesh
from warpvol.reference.pixels import redo_pixels_float64
from warpvol.reference.warp_render import render_reference_warp
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction


def hat(peak: float, colour=(0.8, 0.5, 0.2), emission="color_extinction"):
    """A narrow hat of one colour (the ray casters' sparse views), extinction ``peak`` at its top, plus a
    piece of another colour (taken by quadrature in both)."""
    return TransferFunction([[-4, *colour, 0.0], [-0.3, *colour, 0.0], [0.0, *colour, peak], [0.3, *colour, 0.0],
                             [1.0, 0.1, 0.9, 0.4, 0.5 * peak], [4, 0.1, 0.9, 0.4, 0.0]], emission)


@pytest.mark.parametrize("peak", [0.05, 3.0, 400.0])
def test_closed_form_pixels_match_the_reference_image(peak):
    m = box_mesh((-1, -1, -1.5), (1, 1, 1.5), (3, 3, 6), scalar=lambda p: p[:, 0] + 0.7 * p[:, 2])
    cam = Camera(eye=[0.3, 0.2, 6.0], target=[0, 0, 0], fov_y_deg=24, width_px=20, height_px=18)
    tf = hat(peak)
    full = render_reference_warp(m, tf, cam, device="cpu", show_progress=False).reshape(-1, 4)
    px = np.arange(0, 20 * 18, 3)
    closed = render_reference_warp(m, tf, cam, device="cpu", pixels=px, show_progress=False, closed_form=True)
    quad = render_reference_warp(m, tf, cam, device="cpu", pixels=px, show_progress=False)
    assert np.array_equal(quad, full[px])  # off: the reference image's own values
    assert full[px, 3].max() > 0.05  # the view shows the hat
    np.testing.assert_allclose(closed, full[px], rtol=0, atol=1e-12)
    np.testing.assert_allclose(redo_pixels_float64(m, tf, cam, px), full[px], rtol=0, atol=1e-12)


def test_closed_form_leaves_emission_density_to_the_quadrature():
    """Under ``emission_density`` the radiance of a piece is ``c int T dt`` (no closed form taken): bit for bit."""
    m = box_mesh((-1, -1, -1.5), (1, 1, 1.5), (2, 2, 4), scalar=lambda p: p[:, 0] + 0.7 * p[:, 2])
    cam = Camera(eye=[0.3, 0.2, 6.0], target=[0, 0, 0], fov_y_deg=24, width_px=12, height_px=10)
    tf = hat(3.0, emission="emission_density")
    px = np.arange(0, 120, 5)
    a = render_reference_warp(m, tf, cam, device="cpu", pixels=px, show_progress=False, closed_form=True)
    b = render_reference_warp(m, tf, cam, device="cpu", pixels=px, show_progress=False)
    assert np.abs(b).max() > 0.01
    assert np.array_equal(a, b)
