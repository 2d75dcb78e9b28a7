"""pt_best's fragment colour (kernels/pt.py exact_color, one-piece shortcut) against the shared
integrator it stands for: the same bits as integrate_segment on segments within one TF interval,
crossing control points, ending on them, outside the TF's range, of zero or negative length; the
fused draw's eight-wide attribute clamp (kernels/pt_draw.py clamp8) against clamp_attr."""

import numpy as np
import pytest
import warp as wp

from warpvol.kernels import integrate as ki
from warpvol.kernels import pt as kpt
from warpvol.kernels import pt_draw as kpd
from warpvol.scene.transfer import TransferFunction


@wp.kernel
def k_colors(sf: wp.array(dtype=float), sb: wp.array(dtype=float), length: wp.array(dtype=float),
             tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int,
             got: wp.array(dtype=wp.vec4), want: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    got[i] = kpt.exact_color(wp.vec3(sf[i], sb[i], length[i]), tf_s, tf_v, model)
    r = ki.integrate_segment(sf[i], sb[i], wp.max(length[i], 0.0), tf_s, tf_v, model)
    want[i] = wp.vec4(r[0], r[1], r[2], 1.0 - ki.exp_neg(r[3]))


def segments(tf_s, n, rng):
    """Ends drawn over and beyond the TF's range, a quarter on control points, a tenth equal ends;
    lengths from thin to optically thick, some zero or negative."""
    lo, hi = float(tf_s[0]), float(tf_s[-1])
    span = hi - lo
    sf = rng.uniform(lo - 0.2 * span, hi + 0.2 * span, n)
    sb = sf + rng.normal(0.0, 0.05 * span, n) * rng.choice([0.01, 0.1, 1.0, 10.0], n)
    on = rng.random(n) < 0.25
    sf[on] = rng.choice(tf_s, on.sum())
    on = rng.random(n) < 0.25
    sb[on] = rng.choice(tf_s, on.sum())
    same = rng.random(n) < 0.1
    sb[same] = sf[same]
    length = 10.0 ** rng.uniform(-4, 1.5, n)
    length[rng.random(n) < 0.03] = 0.0
    length[rng.random(n) < 0.03] *= -1.0
    return sf.astype(np.float32), sb.astype(np.float32), length.astype(np.float32)


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_exact_color_bit_identical_to_integrate_segment(emission):
    rng = np.random.default_rng(7)
    pts = [[0.19, 0.0, 0.0, 0.3, 0.0], [0.8, 0.1, 0.2, 0.8, 0.02], [1.05, 0.2, 0.6, 1.0, 0.05],
           [1.15, 1.0, 0.9, 0.3, 1.5], [1.25, 0.3, 0.8, 0.4, 0.05], [2.0, 0.8, 0.5, 0.2, 0.1],
           [3.5, 1.0, 0.3, 0.1, 30.0], [5.0, 1.0, 0.1, 0.05, 0.6]]
    tf = TransferFunction(pts, emission)
    tf_s, tf_v = tf.to_warp("cpu")
    sf, sb, length = segments(tf_s.numpy(), 40_000, rng)
    n = len(sf)
    got = wp.zeros(n, dtype=wp.vec4, device="cpu")
    want = wp.zeros(n, dtype=wp.vec4, device="cpu")
    wp.launch(k_colors, dim=n, device="cpu",
              inputs=[wp.array(sf), wp.array(sb), wp.array(length), tf_s, tf_v,
                      0 if emission == "color_extinction" else 1, got, want])
    g, w = got.numpy(), want.numpy()
    # the test reaches both paths: one piece (ends in one interval) and several control points crossed
    ku = np.searchsorted(tf_s.numpy(), sf, side="right"), np.searchsorted(tf_s.numpy(), sb, side="right")
    assert (ku[0] == ku[1]).sum() > n // 10 and (np.abs(ku[0] - ku[1]) >= 2).sum() > n // 10
    assert (w[:, 3] > 0.5).sum() > n // 20  # optically thick segments too
    assert np.array_equal(g, w)


@wp.kernel
def k_clamps(x: wp.array2d(dtype=float), v: wp.array3d(dtype=float), got: wp.array2d(dtype=float),
             got_m: wp.array(dtype=int), want: wp.array2d(dtype=float), want_m: wp.array(dtype=int)):
    i = wp.tid()
    xv = kpt.vec8f()
    a0 = kpt.vec8f()
    a1 = kpt.vec8f()
    a2 = kpt.vec8f()
    m = int(0)
    for k in range(8):
        xv[k] = x[i, k]
        a0[k] = v[i, 0, k]
        a1[k] = v[i, 1, k]
        a2[k] = v[i, 2, k]
        y, m = kpt.clamp_attr(x[i, k], v[i, 0, k], v[i, 1, k], v[i, 2, k], m)
        want[i, k] = y
    want_m[i] = m
    lo = wp.min(a0, wp.min(a1, a2))
    hi = wp.max(a0, wp.max(a1, a2))
    c, moved = kpd.clamp8(xv, lo, hi, kpt.CLAMP_REL * (hi - lo))
    for k in range(8):
        got[i, k] = c[k]
    got_m[i] = moved


def test_clamp8_matches_clamp_attr():
    rng = np.random.default_rng(3)
    n = 20_000
    v = rng.normal(0.0, 1.0, (n, 3, 8)).astype(np.float32)
    v[rng.random((n, 3, 8)) < 0.05] = 0.0
    lo, hi = v.min(axis=1), v.max(axis=1)
    # inside, a rounding beyond the range, well beyond, on the ends, signed zeros, infinities, NaN
    x = lo + (hi - lo) * rng.uniform(-0.02, 1.02, (n, 8)).astype(np.float32)
    r = rng.random((n, 8))
    x[r < 0.1] = np.nextafter(hi[r < 0.1], np.float32(np.inf))
    x[(r >= 0.1) & (r < 0.15)] = lo[(r >= 0.1) & (r < 0.15)]
    x[(r >= 0.15) & (r < 0.17)] = -0.0
    x[(r >= 0.17) & (r < 0.18)] = np.inf
    x[(r >= 0.18) & (r < 0.19)] = np.nan
    x = x.astype(np.float32)
    got, want = wp.zeros((n, 8), dtype=float), wp.zeros((n, 8), dtype=float)
    got_m, want_m = wp.zeros(n, dtype=int), wp.zeros(n, dtype=int)
    wp.launch(k_clamps, dim=n, inputs=[wp.array(x), wp.array(v), got, got_m, want, want_m], device="cpu")
    g, w = got.numpy(), want.numpy()
    assert np.array_equal(g.view(np.int32), w.view(np.int32))  # bits, signed zeros included
    assert np.array_equal(got_m.numpy(), want_m.numpy())
    assert 0 < want_m.numpy().sum() < n  # some fragments moved, not all
