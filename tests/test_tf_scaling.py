"""Transfer functions with many control points: the merged upload (kernels.tf.device_points), the
searches on float32 control points with steps and jumps, segment integrals over thousands of pieces,
banded table builds (progress, Ctrl-C) and renders with a densely sampled TF."""

import numpy as np
import pytest
import warp as wp

import warpvol
from tolerances import TOLERANCES, preset_tolerance
from warpvol.kernels import integrate as ki
from warpvol.kernels import tf as ktf
from warpvol.reference.numpy_render import integrate_segments
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.transfer import TransferFunction
from warpvol.tables import common

TOL = TOLERANCES["segment/fp32"]


@wp.kernel
def k_search(q: wp.array(dtype=float), q2: wp.array(dtype=float), tf_s: wp.array(dtype=float),
             out: wp.array(dtype=wp.vec4i)):
    i = wp.tid()
    out[i] = wp.vec4i(ktf.tf_upper(q[i], tf_s), ktf.tf_lower(q[i], tf_s), ktf.tf_first_break(q[i], q2[i], tf_s),
                      ktf.tf_upper_from(q[i], (i * 7919) % (tf_s.shape[0] + 1), tf_s))


def dense(tf8: TransferFunction, n: int) -> TransferFunction:
    """``n`` uniform samples of ``tf8`` plus its own control points (the same function)."""
    lo, hi = tf8.srange
    s = np.union1d(np.linspace(lo, hi, n - len(tf8.s)), tf8.s)
    return TransferFunction(np.column_stack([s, tf8.evaluate(s)]), tf8.emission)


def smooth8(lo, hi, emission="color_extinction", seed=0):
    rng = np.random.default_rng(seed)
    s = np.linspace(lo, hi, 8)
    return TransferFunction(np.column_stack([s, 0.2 + 0.8 * rng.random((8, 3)), 0.3 + 2.0 * rng.random(8)]), emission)


def max_chord_deviation(p, keep):
    """Largest |original - merged| per channel at the original control points (the function's largest
    deviation: both are piecewise linear and the merged knots are a subset)."""
    merged = np.column_stack([np.interp(p[:, 0], p[keep, 0], p[keep, c]) for c in range(1, p.shape[1])])
    return np.abs(merged - p[:, 1:]).max(axis=0)


# ------------------------------------------------------------------------------------------------
# merging collinear control points
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [2, 3, 5, 64, 1000, 20000])
def test_sampled_linear_tf_merges_back_to_its_knots(n):
    tf8 = smooth8(-1.0, 3.0, seed=n)
    tf = dense(tf8, max(n, 9)) if n > 8 else TransferFunction(tf8.points[:n])
    p = ktf.device_points(tf.points)
    want = tf8.points if n > 8 else tf.points
    assert p.shape == want.shape
    np.testing.assert_allclose(p, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("n", [3, 10, 257, 5000])
def test_merge_stays_within_tolerance_and_keeps_curvature(n):
    rng = np.random.default_rng(n)
    s = np.sort(rng.random(n)) * 4.0
    s[1:] = np.maximum(s[1:], s[:-1] + 1e-9)  # strictly ascending
    v = np.column_stack([np.sin(3 * s) ** 2, np.cos(s) ** 2, s / 4, 10 * (1 + np.sin(5 * s))])
    v[rng.random(n) < 0.1] *= 0.5  # a few kinks
    p = np.column_stack([s, v])
    tol = ktf.MERGE_REL * np.abs(v).max(axis=0)
    keep = ktf.merge_collinear(s, v, tol)
    assert keep[0] == 0 and keep[-1] == n - 1 and (np.diff(keep) > 0).all()
    assert (max_chord_deviation(p, keep) <= tol * (1 + 1e-9)).all()
    # greedy maximality: extending any run by one point breaks the tolerance
    for a, b in list(zip(keep[:-1], keep[1:]))[:50]:
        if b + 1 < n:
            sub = np.arange(a, b + 2)
            dev = max_chord_deviation(p[sub], np.array([0, len(sub) - 1]))
            assert (dev > tol).any()


def test_merge_keeps_steps_and_jumps():
    # a step (two points 1e-9 apart) inside otherwise linear runs, and a flat run
    s = np.concatenate([np.linspace(0, 1, 500), [1 + 1e-9], np.linspace(1.5, 3, 300), np.linspace(3.01, 4, 50)])
    v = np.zeros((len(s), 4))
    v[:, 0] = np.where(s <= 1, s, 2.0)
    v[:, 3] = np.where(s <= 1, 0.5, 5.0 - (s - 1))
    v[s > 3, 3] = 0.0
    v[:, 1] = 0.25
    p = np.column_stack([s, v])
    keep = ktf.merge_collinear(s, v, ktf.MERGE_REL * np.abs(v).max(axis=0))
    kept = set(s[keep].tolist())
    assert {0.0, 1.0, 1 + 1e-9, 4.0} <= kept
    assert len(keep) <= 8
    assert (max_chord_deviation(p, keep) <= ktf.MERGE_REL * np.abs(v).max(axis=0) * (1 + 1e-9)).all()


# ------------------------------------------------------------------------------------------------
# device searches (float32 control points may coincide: steps) and segment integrals
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [2, 3, 17, 1000, 20000])
def test_searches_match_numpy_with_duplicate_float32_points(n):
    rng = np.random.default_rng(n)
    s = np.sort(rng.random(n)).astype(np.float32)
    if n > 3:
        s[n // 2] = s[n // 2 - 1]  # a float32 step (two points at one scalar)
        s[n // 3:n // 3 + 3] = s[n // 3]
    q = np.concatenate([s, rng.random(4000).astype(np.float32), np.float32([-1, 2, s[0], s[-1]])])
    q2 = np.roll(q, 17)
    out = wp.zeros(len(q), dtype=wp.vec4i, device="cpu")
    wp.launch(k_search, dim=len(q), device="cpu", inputs=[wp.array(q), wp.array(q2), wp.array(s), out])
    o = out.numpy()
    up = np.searchsorted(s, q, side="right")
    lw = np.searchsorted(s, q, side="left")
    np.testing.assert_array_equal(o[:, 0], up)
    np.testing.assert_array_equal(o[:, 1], lw)
    np.testing.assert_array_equal(o[:, 3], up)
    # first control point strictly between q and q2 walking from q
    fb = np.where(q2 > q, np.where((up < n) & (s[np.minimum(up, n - 1)] < q2), up, -1),
                  np.where((lw - 1 >= 0) & (s[np.maximum(lw - 1, 0)] > q2) & (q2 < q), lw - 1, -1))
    np.testing.assert_array_equal(o[:, 2], fb)


def segments(tf_s, tf_v, model, sf, sb, ln):
    out = wp.zeros(len(sf), dtype=wp.vec4, device="cpu")
    wp.launch(ki.integrate_segments_kernel, dim=len(sf), device="cpu",
              inputs=[wp.array(sf.astype(np.float32)), wp.array(sb.astype(np.float32)),
                      wp.array(ln.astype(np.float32)), tf_s, tf_v, model, out])
    return out.numpy().astype(np.float64)


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
@pytest.mark.parametrize("n", [2, 100, 2000, 20000])
def test_segment_integrals_over_many_pieces_match_closed_form(n, emission):
    """Segments crossing up to all ``n`` pieces (unmerged: every control point a piece boundary) and
    the merged upload both equal the float64 closed form (warpvol.reference.numpy_render)."""
    rng = np.random.default_rng(n)
    s = np.linspace(0.0, 1.0, n)
    v = np.column_stack([0.5 + 0.5 * np.sin(40 * s), 0.5 + 0.5 * np.cos(17 * s), s, 2.0 + 1.5 * np.sin(9 * s)])
    if n > 2:
        v[n // 2:, 3] += 1.0  # a jump in extinction (the point after it is 1/n away)
    tf = TransferFunction(np.column_stack([s, v]), emission)
    m = 200
    sf, sb = rng.uniform(-0.1, 1.1, m), rng.uniform(-0.1, 1.1, m)
    sf[:20], sb[:20] = 0.0, 1.0  # the whole range
    sb[20:40] = sf[20:40]  # constant scalar
    ln = rng.uniform(0.01, 2.0, m)
    rgb, tau = integrate_segments(sf.astype(np.float32), sb.astype(np.float32), ln.astype(np.float32), tf)
    model = 0 if emission == "color_extinction" else 1
    full = (wp.array(s.astype(np.float32)), wp.array(v.astype(np.float32), dtype=wp.vec4))
    for arrays in (full, tf.to_warp("cpu")):
        got = segments(*arrays, model, sf, sb, ln)
        np.testing.assert_allclose(got[:, 3], tau, rtol=TOL["rtol"], atol=TOL["atol"])
        np.testing.assert_allclose(got[:, :3], rgb, rtol=TOL["rtol"], atol=TOL["atol"])


# ------------------------------------------------------------------------------------------------
# banded table builds: identical texels, progress, Ctrl-C
# ------------------------------------------------------------------------------------------------


def test_banded_table_builds_are_bit_identical(monkeypatch):
    from warpvol.tables.exact import build_exact3d
    from warpvol.tables.guthe2d import build_guthe2d

    tf = builtin_scene("concave").transfer
    a = build_exact3d(tf, n_s=24, n_l=5, lmax=1.5)
    g = build_guthe2d(tf, n_s=24, lmax=1.5, degree=2)
    monkeypatch.setattr(common, "BAND_WORK", 1)  # one row per launch
    b = build_exact3d(tf, n_s=24, n_l=5, lmax=1.5)
    h = build_guthe2d(tf, n_s=24, lmax=1.5, degree=2)
    assert np.array_equal(a.data, b.data)
    assert np.array_equal(g.data, h.data)


def test_long_table_build_reports_progress(monkeypatch):
    from warpvol.tables.exact import build_exact3d

    monkeypatch.setattr(common, "BAND_WORK", 1)
    monkeypatch.setattr(common, "PROGRESS_EVERY", 0.0)
    msgs = []
    with common.progress_to(msgs.append):
        build_exact3d(builtin_scene("concave").transfer, n_s=8, n_l=2)
    assert msgs and all("exact table 2x8x8" in m and "/16 blocks" in m for m in msgs)


def test_ctrl_c_stops_a_banded_build(monkeypatch):
    from warpvol.tables.exact import build_exact3d

    monkeypatch.setattr(common, "BAND_WORK", 1)
    calls = []
    real = common.launch_bands

    def interrupting(kernel, n_l, n_rows, n_cols, device, inputs, **kw):
        def inp(*a):
            calls.append(a)
            if len(calls) == 3:
                raise KeyboardInterrupt
            return inputs(*a)
        return real(kernel, n_l, n_rows, n_cols, device, inp, **kw)

    monkeypatch.setattr("warpvol.tables.exact.launch_bands", interrupting)
    with pytest.raises(KeyboardInterrupt):
        build_exact3d(builtin_scene("concave").transfer, n_s=32, n_l=8)
    # the blocks not started were dropped: the failing one and at most one in flight per other thread
    from warpvol.parallel import cpu_threads

    assert len(calls) <= 3 + cpu_threads()


# ------------------------------------------------------------------------------------------------
# renders: a densely sampled TF gives the image of the TF it samples
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("pipeline", ["raycast", "harc_best", "pt_best", "weiler2003_vicp"])
def test_render_with_2000_point_tf_equals_8_point_render(pipeline):
    scene = builtin_scene("concave").with_camera(width_px=24, height_px=24)
    tf8 = smooth8(*scene.transfer.srange)
    tf2k = dense(tf8, 2000)
    a = warpvol.render(scene, transfer=tf8, pipeline=pipeline).image
    b = warpvol.render(scene, transfer=tf2k, pipeline=pipeline).image
    err = np.abs(a.astype(np.float64) - b)
    assert err.max() <= preset_tolerance(pipeline)["max_abs"] * 1e-2  # same function: far inside the preset's row
    assert a[..., 3].max() > 0.1  # something drawn


def test_render_with_curved_2000_point_tf_matches_reference():
    """Nothing to merge (a curved TF): every piece is walked, and the image is the reference's."""
    scene = builtin_scene("concave").with_camera(width_px=20, height_px=20)
    lo, hi = scene.transfer.srange
    s = np.linspace(lo, hi, 2000)
    x = (s - lo) / (hi - lo)
    tf = TransferFunction(np.column_stack([s, 0.5 + 0.5 * np.sin(30 * x), x, 1 - x, 1.0 + np.sin(21 * x) ** 2]))
    assert len(ktf.device_points(tf.points)) > 1000
    r = warpvol.render(scene, transfer=tf, pipeline="raycast", reference=True)
    assert r.error["max_abs"] <= preset_tolerance("raycast")["max_abs"]
    assert r.error["rmse"] <= preset_tolerance("raycast")["rmse"]
