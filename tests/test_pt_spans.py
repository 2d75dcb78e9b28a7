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


def _tf_scene(name, ext, emission, points=9):
    """Built-in scene ``name`` with a TF of ``points`` control points spread over its scalars (colours changing at
    each, extinction ``ext(k)``): fragments inside one interval, across one point and across several."""
    import copy

    from warpvol.scene.transfer import TransferFunction

    sc = copy.copy(builtin_scene(name).with_camera(width_px=40, height_px=40))
    s = np.asarray(sc.mesh.scalars, np.float64)
    xs = np.linspace(s.min(), s.max(), points)
    pts = [[x, (k % 3) / 2.0, ((k + 1) % 3) / 2.0, ((k + 2) % 3) / 2.0, ext(k)] for k, x in enumerate(xs)]
    sc.transfer = TransferFunction(pts, emission)
    return sc


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
@pytest.mark.parametrize("ext", ["constant_thick", "varying_thick", "thin"])
def test_spans_draw_crossing_and_thick_fragments_as_one_fragment_at_a_time(emission, ext):
    """The span's rare lanes (a control point inside the segment, an optically thick piece: integrated with the
    lane's TF intervals and values, no search) give the one-fragment kernel's bits."""
    f = {"constant_thick": lambda k: 60.0, "varying_thick": lambda k: 20.0 + 15.0 * (k % 4),
         "thin": lambda k: 0.05 * (1 + k % 3)}[ext]
    for name in ("sphere", "concave"):
        same_draw(_tf_scene(name, f, emission), lanes=(1, 16, 8))


def test_exact_color_given_the_intervals_is_exact_color():
    """:func:`~warpvol.kernels.pt.exact_color_upper` with ``tf_upper`` / ``tf_eval_upper`` of both ends is
    :func:`~warpvol.kernels.pt.exact_color`, bit for bit (segments inside one interval, across one or several control
    points, on a control point, thin and thick, empty; both emission models)."""
    import warp as wp

    from warpvol.kernels import pt as kpt
    from warpvol.kernels.tf import tf_eval_upper, tf_upper

    @wp.kernel
    def k_both(seg: wp.array(dtype=wp.vec3), tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int,
               a: wp.array(dtype=wp.vec4), b: wp.array(dtype=wp.vec4)):
        i = wp.tid()
        x = seg[i]
        kf = tf_upper(x[0], tf_s)
        kb = tf_upper(x[1], tf_s)
        a[i] = kpt.exact_color(x, tf_s, tf_v, model)
        b[i] = kpt.exact_color_upper(x, kf, kb, tf_eval_upper(x[0], kf, tf_s, tf_v),
                                     tf_eval_upper(x[1], kb, tf_s, tf_v), tf_s, tf_v, model)

    rng = np.random.default_rng(4)
    ts = np.array([0.0, 0.1, 0.35, 0.4, 0.8, 1.0], np.float32)
    tv = rng.uniform(0.0, 1.0, (6, 4)).astype(np.float32) * np.array([1, 1, 1, 50], np.float32)
    n = 4000
    seg = np.stack([rng.uniform(-0.1, 1.1, n), rng.uniform(-0.1, 1.1, n), rng.uniform(-0.01, 0.3, n)], 1)
    seg[:200, 0] = ts[rng.integers(0, 6, 200)]  # starting on a control point
    seg[200:400, 1] = seg[200:400, 0]  # no change of scalar
    seg = seg.astype(np.float32)
    for model in (0, 1):
        a, b = (wp.zeros(n, dtype=wp.vec4) for _ in range(2))
        wp.launch(k_both, dim=n, inputs=[wp.array(seg, dtype=wp.vec3), wp.array(ts), wp.array(tv, dtype=wp.vec4), model,
                                         a, b])
        assert np.array_equal(a.numpy().view(np.uint32), b.numpy().view(np.uint32))


def test_rows_stepped_with_adds_are_row_span():
    """:func:`~warpvol.kernels.pt_span.edge_start` / :func:`~warpvol.kernels.pt_span.edge_next` step each edge's
    ``floor(e / |sj|)`` from row to row with exact int64 adds; :func:`~warpvol.kernels.pt_span.edge_lo` /
    :func:`~warpvol.kernels.pt_span.edge_hi` give the run :func:`~warpvol.kernels.raster.row_span` finds at every
    row (edges increasing, decreasing and constant along the row, negative and positive steps between rows)."""
    import warp as wp

    from warpvol.kernels import pt_span
    from warpvol.kernels.raster import row_span, vec3l

    rows = 24

    @wp.kernel
    def k_rows(e: wp.array(dtype=vec3l), sj: wp.array(dtype=vec3l), si: wp.array(dtype=vec3l),
               n: wp.array(dtype=wp.int32), a: wp.array2d(dtype=wp.vec2i), b: wp.array2d(dtype=wp.vec2i)):
        i = wp.tid()
        x = e[i]
        s = sj[i]
        m = n[i]
        f0, r0, d0, q0, p0 = pt_span.edge_start(x[0], s[0], si[i][0])
        f1, r1, d1, q1, p1 = pt_span.edge_start(x[1], s[1], si[i][1])
        f2, r2, d2, q2, p2 = pt_span.edge_start(x[2], s[2], si[i][2])
        for k in range(rows):
            a[i, k] = row_span(x, s, m)
            x = x + si[i]
            lo = wp.max(wp.max(pt_span.edge_lo(f0, s[0], m), pt_span.edge_lo(f1, s[1], m)), pt_span.edge_lo(f2, s[2], m))
            hi = wp.min(wp.min(pt_span.edge_hi(f0, s[0], m), pt_span.edge_hi(f1, s[1], m)), pt_span.edge_hi(f2, s[2], m))
            b[i, k] = wp.vec2i(lo, hi)
            f0, r0 = pt_span.edge_next(f0, r0, q0, p0, d0)
            f1, r1 = pt_span.edge_next(f1, r1, q1, p1, d1)
            f2, r2 = pt_span.edge_next(f2, r2, q2, p2, d2)

    rng = np.random.default_rng(11)
    m = 6000
    scale = rng.choice([1, 256, 65536, 3 * 2**20], (m, 3))
    sj = rng.integers(-40, 41, (m, 3)) * scale
    si = rng.integers(-40, 41, (m, 3)) * scale
    e = rng.integers(-2**40, 2**40, (m, 3)) // rng.choice([1, 2**8, 2**20, 2**30], (m, 3))
    e[:1000] = -sj[:1000] * rng.integers(0, 64, (1000, 3))  # zero at a pixel: the run's ends exactly there
    e[1000:1500] = -si[1000:1500] * rng.integers(0, rows, (500, 3))  # zero at a row
    n = rng.integers(1, 65, m).astype(np.int32)
    a, b = (wp.zeros((m, rows), dtype=wp.vec2i) for _ in range(2))
    wp.launch(k_rows, dim=m, inputs=[wp.array(e, dtype=vec3l), wp.array(sj, dtype=vec3l), wp.array(si, dtype=vec3l),
                                     wp.array(n), a, b])
    ra, rb = a.numpy(), b.numpy()
    full = ra[..., 0] <= ra[..., 1]
    assert np.array_equal(full, rb[..., 0] <= rb[..., 1])  # the same rows have a run
    assert np.array_equal(ra[full], rb[full])  # and the same run
    assert ((ra[..., 0] > 0) & full).sum() > 1000 and ((ra[..., 1] < n[:, None] - 1) & full).sum() > 1000
