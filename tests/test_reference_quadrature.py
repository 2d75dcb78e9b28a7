"""The Warp reference's thin-piece quadrature (kernels/reference.py ``gauss_thin``): the 5-point Gauss rule with
``exp(-x)`` by its degree-8 Taylor polynomial (``exp_thin``) on pieces of optical depth <= ``THIN_DEPTH``.

* ``exp_thin`` keeps the bound its docstring states: truncation below ``THIN_DEPTH^9 / 9!`` (asserted as a
  number, < 1e-19), measured error against libm within float64 rounding over ``[0, THIN_DEPTH]``;
* a thin piece's ``(F0, F1)`` against the analytic integral, evaluated to 40 digits by its own Taylor series
  (``decimal``, no quadrature), within 1e-12 relative for both emission models: the rule's own accuracy
  (seen 1.4e-13 at depth 0.03 under ``color_extinction``, with the polynomial as with libm's ``exp``);
* against the same 5-point rule with libm's ``exp`` (``gauss``, the arrays of Gauss nodes): within 2e-15
  relative (seen 5.7e-16), i.e. the polynomial changes nothing but rounding.
"""

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest
import warp as wp

from warpvol.kernels import reference as K


@wp.kernel(enable_backward=False)
def _exp_thin_kernel(x: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = K.exp_thin(x[i])


@wp.kernel(enable_backward=False)
def _piece_kernel(h: wp.array(dtype=wp.float64), r0: wp.array(dtype=wp.float64), r1: wp.array(dtype=wp.float64),
                  gx5: wp.array(dtype=wp.float64), gw5: wp.array(dtype=wp.float64), ed: int,
                  thin: wp.array(dtype=wp.vec2d), libm: wp.array(dtype=wp.vec2d)):
    i = wp.tid()
    thin[i] = K.gauss_thin(h[i], r0[i], r1[i], ed)
    libm[i] = K.gauss(wp.float64(0.0), h[i], r0[i], r1[i], h[i], gx5, gw5, ed)


def _arr(a):
    return wp.array(np.asarray(a, dtype=np.float64), dtype=wp.float64, device="cpu")


def test_exp_thin_error_bound():
    thin = float(K.THIN_DEPTH.value if hasattr(K.THIN_DEPTH, "value") else K.THIN_DEPTH)
    assert K.EXP_THIN_DEGREE == 8
    trunc = thin ** 9 / math.factorial(9)  # first term left out of an alternating series of decreasing terms
    assert trunc < 1e-19
    x = np.concatenate([np.linspace(0.0, thin, 20001), [1e-300, 1e-12, thin]])
    out = wp.zeros(len(x), dtype=wp.float64, device="cpu")
    wp.launch(_exp_thin_kernel, dim=len(x), inputs=[_arr(x), out], device="cpu")
    got = out.numpy()
    want = np.exp(-x)
    rel = np.abs(got - want) / want
    assert rel.max() <= 4 * np.finfo(np.float64).eps + trunc / math.exp(-thin)


def _exact_moments(h, r0, r1, ed, digits=40):
    """``(F0, F1)`` = ``h * int_0^1 (1 - x, x) w(x) exp(-phi(x)) dx``, ``w = rho`` (ed 0) or 1, ``phi(x) =
    h (r0 x + (r1 - r0) x^2 / 2)``: exp(-phi) as its Taylor series in x (coefficients by the recurrence
    ``(k + 1) c_{k+1} = -(a c_k + 2 b c_{k-1})``), integrated term by term, to ``digits`` digits."""
    getcontext().prec = digits + 10
    h, r0, r1 = Decimal(h), Decimal(r0), Decimal(r1)
    a, b = h * r0, h * (r1 - r0) / 2  # phi = a x + b x^2
    c = [Decimal(1), -a]
    for k in range(1, 200):
        c.append(-(a * c[k] + 2 * b * c[k - 1]) / (k + 1))
        if abs(c[-1]) < Decimal(10) ** (-digits - 5) and abs(c[-2]) < Decimal(10) ** (-digits - 5):
            break

    def mom(m):  # int_0^1 x^m w(x) exp(-phi) dx
        tot = Decimal(0)
        for k, ck in enumerate(c):
            if ed == 0:  # w = r0 + (r1 - r0) x
                tot += ck * (r0 / (k + m + 1) + (r1 - r0) / (k + m + 2))
            else:
                tot += ck / (k + m + 1)
        return tot

    m0, m1 = mom(0), mom(1)
    return float(h * (m0 - m1)), float(h * m1)


@pytest.mark.parametrize("ed", [0, 1])
def test_thin_piece_matches_analytic_integral(ed):
    rng = np.random.default_rng(7)
    thin = 0.03
    cases = [(1.0, 0.03, 0.03), (0.5, 0.0, 0.12), (2.0, 0.015, 0.0), (1e-3, 1.0, 2.0), (0.1, 1e-9, 0.3),
             (3e-5, 1000.0, 0.0), (1.0, 0.0, 0.0)]
    for _ in range(40):
        h = 10 ** rng.uniform(-4, 1)
        r0, r1 = rng.uniform(0, 1, 2)
        tau = 0.5 * h * (r0 + r1)
        f = rng.uniform(1e-3, 1.0) * thin / tau  # scale the extinction so the piece is thin
        cases.append((h, r0 * f, r1 * f))
    h, r0, r1 = (np.array(v) for v in zip(*cases))
    assert (0.5 * h * (r0 + r1) <= thin * (1 + 1e-15)).all()
    x5, w5 = np.polynomial.legendre.leggauss(5)
    n = len(h)
    thin_out = wp.zeros(n, dtype=wp.vec2d, device="cpu")
    libm_out = wp.zeros(n, dtype=wp.vec2d, device="cpu")
    wp.launch(_piece_kernel, dim=n, inputs=[_arr(h), _arr(r0), _arr(r1), _arr(x5), _arr(w5), ed, thin_out, libm_out],
              device="cpu")
    got, libm = thin_out.numpy(), libm_out.numpy()
    want = np.array([_exact_moments(*c, ed) for c in cases])
    scale = np.maximum(np.abs(want).max(axis=1, keepdims=True), 1e-300)
    nonzero = scale[:, 0] > 1e-300
    # the 5-point rule's own accuracy on thin pieces, both with the polynomial and with libm's exp
    assert (np.abs(got - want)[nonzero] / scale[nonzero]).max() <= 1e-12
    assert (np.abs(libm - want)[nonzero] / scale[nonzero]).max() <= 1e-12
    # the polynomial in place of exp: rounding only
    assert (np.abs(got - libm)[nonzero] / scale[nonzero]).max() <= 2e-15
    assert (got[~nonzero] == 0).all()
