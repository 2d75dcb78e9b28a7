"""The float64 redo stops a ray at the renderer's stated termination bound (``terminate``): each channel within
that bound of the reference's pixel (which stops at 1e-17), with fewer tet steps on an opaque medium; the
reference image itself keeps its own bound."""

import numpy as np
import pytest

from helpers import box_mesh
from warpvol.errors import ConfigError
from warpvol.reference.warp_render import render_reference_warp
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction


def opaque_case():
    # a box 3 deep along the view with extinction 40: optical depth 120, a ray's transmittance reaches 1e-6
    # after 0.35 of it
    m = box_mesh((-1, -1, -1.5), (1, 1, 1.5), (4, 4, 12), scalar=lambda p: p[:, 0] + p[:, 2])
    tf = TransferFunction([[-4, 0.9, 0.4, 0.2, 40.0], [4, 0.2, 0.6, 1.0, 40.0]])
    cam = Camera(eye=[0.2, 0.1, 6.0], target=[0, 0, 0], fov_y_deg=20, width_px=16, height_px=16)
    return m, tf, cam


@pytest.mark.parametrize("bound", [1e-6, 1e-3])
def test_redo_stops_at_the_stated_bound(bound):
    m, tf, cam = opaque_case()
    pix = np.arange(0, 256, 3)
    full_st, cut_st = {}, {}
    full = render_reference_warp(m, tf, cam, device="cpu", pixels=pix, stats=full_st, show_progress=False)
    cut = render_reference_warp(m, tf, cam, device="cpu", pixels=pix, stats=cut_st, show_progress=False,
                                terminate=bound)
    assert full[:, 3].min() > 1 - 1e-12  # every listed ray sees the opaque box
    diff = np.abs(cut - full).max()
    assert diff <= bound and diff > 1e-3 * bound  # within the bound, and the bound did cut something off
    assert cut_st["n_steps"] < 0.8 * full_st["n_steps"]


def test_reference_image_keeps_its_own_bound_and_terminate_is_checked():
    m, tf, cam = opaque_case()
    whole = render_reference_warp(m, tf, cam, device="cpu", show_progress=False)
    again = render_reference_warp(m, tf, cam, device="cpu", show_progress=False, terminate=1e-17)
    assert np.array_equal(whole, again)
    for bad in (0.0, -1e-6, 2.0):
        with pytest.raises(ConfigError, match="terminate"):
            render_reference_warp(m, tf, cam, device="cpu", pixels=np.arange(4), show_progress=False, terminate=bad)
