"""pt_best's fragment colour (kernels/pt.py exact_color, one-piece shortcut) against the shared
integrator it stands for: the same bits as integrate_segment on segments within one TF interval,
crossing control points, ending on them, outside the TF's range, of zero or negative length."""

import numpy as np
import pytest
import warp as wp

from warpvol.kernels import integrate as ki
from warpvol.kernels import pt as kpt
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
