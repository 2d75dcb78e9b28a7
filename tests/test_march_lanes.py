"""The march with several rays per thread (:mod:`warpvol.kernels.lanes`; ``harc_best``'s through
:mod:`warpvol.kernels.harc_lanes`) draws the same bits as one ray per thread: images, counters (the same float64 redo
counts) on built-in scenes and the quick stress classes, for the CPU's lane count and for 4 lanes (a CPU without
AVX-512 or AVX2)."""

from __future__ import annotations

import pytest

from test_walk_pins import BUILTIN, STRESS, render_pin

SCENES = [b for b, _ in BUILTIN] + list(STRESS)
PRESETS = ("raycast", "peel", "harc_best")
#: further quick stress classes (warpvol/tools/stress.py) for raycast and harc_best: thick and thin pieces, the emission model, a
#: constant field, slivers of extreme edge ratio, an orthographic eye inside the mesh
MORE_STRESS = ("extinction_1e+02", "extinction_1e-02", "emission_density_scale_1e-12", "constant_scalars",
               "edge_ratio_1e6", "ortho_eye_inside")


def render_with_lanes(scene: str, preset: str, lanes: int) -> dict:
    """:func:`test_walk_pins.render_pin` with the march's rays per thread set to ``lanes``."""
    from warpvol.raycasting.stages import raycast as stage

    old = stage.MARCH_LANES
    stage.MARCH_LANES = lanes
    try:
        return render_pin(scene, preset)
    finally:
        stage.MARCH_LANES = old


def lane_counts() -> list[int]:
    from warpvol.kernels.lanes import device_lanes

    return sorted({device_lanes("cpu"), 4})


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("preset", PRESETS)
def test_lanes_bit_identical(scene, preset):
    one = render_with_lanes(scene, preset, 1)
    for lanes in lane_counts():
        assert render_with_lanes(scene, preset, lanes) == one, lanes


@pytest.mark.parametrize("scene", MORE_STRESS)
@pytest.mark.parametrize("preset", ("raycast", "harc_best"))
def test_lanes_bit_identical_stress(scene, preset):
    one = render_with_lanes(scene, preset, 1)
    for lanes in lane_counts():
        assert render_with_lanes(scene, preset, lanes) == one, lanes


def test_harc_best_marches_in_lanes(monkeypatch):
    """harc_best's pass takes the lane kernel (``harc=True``) when lanes are on, raycast's count; the faithful HARC
    presets never do."""
    from warpvol.kernels import lanes_march

    made = []
    real = lanes_march.march_lanes_kernel

    def spy(lanes, segs=False, harc=False):
        made.append((lanes, harc))
        return real(lanes, segs, harc)

    monkeypatch.setattr(lanes_march, "march_lanes_kernel", spy)
    render_with_lanes("sphere", "espinha2005_partial", 4)
    assert made == []
    render_with_lanes("sphere", "harc_best", 4)
    assert made and all(m == (4, True) for m in made)


def test_device_lanes():
    from warpvol.kernels.lanes import device_lanes
    from warpvol.raycasting.stages.raycast import march_lanes

    assert device_lanes("cuda:0") == 1
    assert march_lanes("cuda:0") == 1
    assert device_lanes("cpu") in (4, 8, 16)
