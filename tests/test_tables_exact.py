"""Exact and software (Roettger & Ertl 2002 eqs. 5-7) 3D tables against the float64 reference."""

import numpy as np
import pytest

from test_tables_common import TOLERANCES, random_tf, reference_at_nodes, report, smooth_tf
from warpvol.tables.exact import build_exact3d
from warpvol.tables.roettger_sw import build_roettger_sw


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
@pytest.mark.parametrize("l_axis", ["centred", "endpoint", "log2"])
def test_exact_matches_reference_at_nodes(emission, l_axis):
    tf = random_tf(emission, m=12, seed=1)
    t = build_exact3d(tf, n_s=12, n_l=6, lmax=1.7, l_axis=l_axis)
    ref = reference_at_nodes(t, tf, 1.7)
    tol = TOLERANCES["exact3d/fp32"]
    np.testing.assert_allclose(t.data, ref, rtol=tol["rtol"], atol=tol["atol"])
    report(f"exact3d/fp32 {emission} {l_axis}", max=np.abs(t.data - ref).max())


@pytest.mark.parametrize("fmt", ["fp16", "hilo16", "rgba8"])
def test_exact_stored_formats(fmt):
    tf = smooth_tf("color_extinction")
    t = build_exact3d(tf, n_s=10, n_l=5, lmax=1.0, format=fmt)
    ref = reference_at_nodes(t, tf, 1.0)
    tol = TOLERANCES[f"exact3d/{fmt}"]
    assert t.format == fmt and t.raw is not None
    np.testing.assert_allclose(t.data, ref, rtol=tol.get("rtol", 0), atol=tol["atol"])
    report(f"exact3d/{fmt}", max=np.abs(t.data - ref).max())


def test_exact_sf_equals_sb_is_slab_formula():
    # constant scalar along the segment: C = c (1 - e^{-l rho}) (colour x extinction)
    tf = smooth_tf()
    t = build_exact3d(tf, n_s=8, n_l=4, lmax=2.0)
    x = t.axes[2].physical
    v = tf.evaluate(x)
    for k, l in enumerate(t.axes[0].physical):
        a = -np.expm1(-l * v[:, 3])
        diag = t.data[k, np.arange(8), np.arange(8)]
        np.testing.assert_allclose(diag[:, 3], a, rtol=2e-5, atol=2e-6)
        np.testing.assert_allclose(diag[:, :3], v[:, :3] * a[:, None], rtol=2e-5, atol=2e-6)


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_roettger_software_error_is_bounded_and_reported(emission):
    tf = smooth_tf(emission, rho_max=2.0)
    sw = build_roettger_sw(tf, n_s=16, n_l=8, lmax=1.0)
    ex = build_exact3d(tf, n_s=16, n_l=8, lmax=1.0)
    d = sw.data.astype(np.float64) - ex.data
    rms, mx = float(np.sqrt((d ** 2).mean())), float(np.abs(d).max())
    report(f"roettger_sw/fp32 {emission} (o = 2, m = {len(tf.points)})", rms=rms, max=mx)
    tol = TOLERANCES[f"roettger_sw/fp32/{emission}"]
    assert rms <= tol["rms"] and mx <= tol["max"]
    # more samples converge to the exact table (first order)
    sw4 = build_roettger_sw(tf, n_s=16, n_l=8, lmax=1.0, n_min=256)
    assert np.abs(sw4.data - ex.data).max() < mx / 4
