"""pt_best's fused draw with its fragments in SIMD spans (``pt_integrate.lanes`` > 1,
:mod:`warpvol.kernels.pt_span`) draws the same image, bit for bit, with the same counters and float64 redo as
the one-fragment kernel (``lanes = 1``, :func:`warpvol.kernels.pt_draw.k_pt_exact_tiles`): on the built-in
scenes (both emission models, front to back with early termination and back to front without it) and on the
stress classes (thin and thick pieces, TF jumps, many control points, slivers, edge-on faces, eye inside)."""

import numpy as np
import pytest

from test_pt_render import preset
from warpvol.errors import ConfigError
from warpvol.scene.builtin import builtin_scene
from warpvol.tools.stress import build_case

#: stress classes whose fragments take each of the span draw's paths (rare ones included)
STRESS = ["thin_layer_oblique", "tf_jump", "extinction_1e+06", "extinction_1e-06", "rough_tf_4096", "slivers",
          "face_edge_on", "subpixel_specks", "silhouette_on_pixel_centres", "emission_density_scale_1e-12",
          "vertex_on_pixel_centre", "log_field_9_decades", "thin_slabs_edge_on"]


def same_draw(sc, lanes=(1, 16), skip=True, **stage):
    """Render ``sc`` with pt_best at each lane count; assert identical bits, counters and stats."""
    out = [preset("pt_best", pt_integrate={"lanes": n, **stage}).render(sc, quiet=True, skip=skip) for n in lanes]
    a = out[0]
    assert a.report["counters"]["pt_integrate"]["fragments"] > 0
    for b in out[1:]:
        assert a.image.dtype == b.image.dtype and np.array_equal(a.image.view(np.uint32), b.image.view(np.uint32))
        assert a.report["counters"] == b.report["counters"]
        assert a.report.get("left_out") == b.report.get("left_out")
        assert a.report["stats"].get("pt_integrate") == b.report["stats"].get("pt_integrate")
    return a


@pytest.mark.parametrize("name", ["box", "linear_box", "sphere", "concave", "stiff"])
def test_spans_draw_the_builtin_scenes_as_one_fragment_at_a_time(name):
    sc = builtin_scene(name).with_camera(width_px=40, height_px=40)
    a = same_draw(sc, lanes=(1, 16, 4))
    assert a.report["counters"]["pt_integrate"]["fragments"] > 1000


@pytest.mark.parametrize("name", ["concave", "sphere"])
def test_spans_draw_back_to_front_without_termination_as_one_fragment_at_a_time(name):
    same_draw(builtin_scene(name).with_camera(width_px=40, height_px=40), skip=False)


@pytest.mark.parametrize("height", [2.0, 12.0])
def test_spans_draw_an_opaque_front_with_the_same_terminations(height):
    from test_skip_pt import _slab_behind_opaque_tet

    sc, _ = _slab_behind_opaque_tet(48, height)
    a = same_draw(sc, lanes=(1, 8))
    assert a.report["left_out"]["pt_integrate"]["pixels_terminated"] > 0


@pytest.mark.parametrize("case", STRESS)
def test_spans_draw_the_stress_classes_as_one_fragment_at_a_time(case):
    same_draw(build_case(case, quick=True).scene)


def test_lanes_is_checked():
    with pytest.raises(ConfigError, match="lanes"):
        preset("pt_best", pt_integrate={"lanes": 3})
