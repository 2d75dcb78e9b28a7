"""Numerical stability of every builder at the degenerate corners named in the issue.

Documented behaviour: no NaN/Inf anywhere; sf = sb needs no division (Guthe's C_hat = C / alpha and
the cylindrical inverse special-case it); l -> 0 gives (0, 0); alpha saturates to 1 without overflow;
psi -> 0 as gamma -> 1; a TF jump (two control points 1e-7 apart) is a piece boundary like any other.
"""

import numpy as np
import pytest

from test_tables_common import reference_at_nodes, report
from warpvol.scene.transfer import TransferFunction
from warpvol.tables.base import isfinite_table
from warpvol.tables.cylindrical import build_cylindrical, to_cylinder
from warpvol.tables.exact import build_exact3d
from warpvol.tables.guthe2d import build_guthe2d
from warpvol.tables.guthe2d import reconstruct as guthe_reconstruct
from warpvol.tables.incremental import build_incremental
from warpvol.tables.isocross import build_isocross
from warpvol.tables.psi import build_psi, psi_exact
from warpvol.tables.roettger_hw import build_roettger_hw
from warpvol.tables.roettger_sw import build_roettger_sw


def all_tables(tf, n=8):
    out = [build_exact3d(tf, n_s=n, n_l=4), build_roettger_sw(tf, n_s=n, n_l=4),
           build_incremental(tf, n_s=n, n_l=4), build_cylindrical(tf, n_s=n),
           build_roettger_hw(tf, n_s=n, n_l=2, steps=16, n_tex=64), build_isocross(tf, n=n)]
    if tf.emission == "color_extinction":
        out.append(build_guthe2d(tf, n_s=n, degree=2))
    return out


def test_sf_equals_sb_no_division_by_zero():
    tf = TransferFunction([[0, 1, 0, 0, 0], [0.5, 0, 1, 0, 0], [1, 0, 0, 1, 3]])  # zero extinction region
    g = build_guthe2d(tf, n_s=16, degree=2)
    assert isfinite_table(g)
    x = g.axes[2].nodes
    r = guthe_reconstruct(g, x, x, np.full_like(x, 0.5))
    assert np.isfinite(r).all()
    c = to_cylinder(x, x, np.zeros_like(x))
    np.testing.assert_array_equal(c[:, :2], 0.0)
    np.testing.assert_array_equal(c[:, 2], x)
    for t in all_tables(tf):
        assert isfinite_table(t), t


def test_l_to_zero_and_l_at_lmax():
    tf = TransferFunction([[0, 1, 1, 1, 2], [1, 0.5, 0.2, 0.1, 5]])
    t = build_exact3d(tf, n_s=8, n_l=5, lmax=1.0, l_axis="endpoint")
    np.testing.assert_array_equal(t.data[0], 0.0)  # l = 0: nothing
    ref = reference_at_nodes(t, tf, 1.0)
    np.testing.assert_allclose(t.data[-1], ref[-1], rtol=2e-5, atol=2e-6)  # l = lmax
    tiny = build_exact3d(tf, n_s=8, n_l=2, lmax=1e-6, l_axis="endpoint")
    np.testing.assert_allclose(tiny.data[-1], reference_at_nodes(tiny, tf, 1e-6)[-1], rtol=1e-4, atol=1e-12)


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_extinction_saturates_alpha_in_one_step(emission):
    tf = TransferFunction([[0, 0.2, 0.4, 0.6, 1e4], [1, 0.8, 0.6, 0.4, 1e4]], emission)
    for t in all_tables(tf):
        assert isfinite_table(t), t
    t = build_exact3d(tf, n_s=8, n_l=4)
    np.testing.assert_allclose(t.data[..., 3], 1.0)
    ref = reference_at_nodes(t, tf, 1.0)
    np.testing.assert_allclose(t.data, ref, rtol=1e-4, atol=1e-6)
    sw = build_roettger_sw(tf, n_s=8, n_l=4)
    report(f"roettger_sw at extinction 1e4 ({emission})", max=np.abs(sw.data - ref).max())


def test_psi_gamma_to_one():
    g = np.array([0.0, 0.5, 1 - 1e-4, 1 - 1e-7, 1.0])
    p = psi_exact(g[:, None], g[None, :])
    assert np.isfinite(p).all() and (p >= 0).all() and (p <= 1).all()
    assert p[-1, 0, 0] == 0.0 and p[0, -1, 0] == 0.0
    assert p[3, 0, 0] < 1e-5  # gamma_f -> 1: psi ~ 1 / T_f
    assert isfinite_table(build_psi(n=64))


def test_tf_with_a_jump():
    tf = TransferFunction([[0, 0, 0, 1, 0.1], [0.5, 0, 0, 1, 0.1], [0.5 + 1e-7, 1, 0, 0, 8.0], [1, 1, 0, 0, 8.0]])
    for t in all_tables(tf, n=10):
        assert isfinite_table(t), t
    t = build_exact3d(tf, n_s=10, n_l=3)
    np.testing.assert_allclose(t.data, reference_at_nodes(t, tf, 1.0), rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("m", [2, 1024])
def test_tf_of_2_and_1024_points(m):
    rng = np.random.default_rng(m)
    s = np.linspace(0, 1, m)
    tf = TransferFunction(np.column_stack([s, rng.random((m, 3)), 3 * rng.random(m)]))
    for t in all_tables(tf, n=8):
        assert isfinite_table(t), t
    t = build_exact3d(tf, n_s=8, n_l=3)
    np.testing.assert_allclose(t.data, reference_at_nodes(t, tf, 1.0), rtol=1e-4, atol=1e-5)
