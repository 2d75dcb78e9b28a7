"""Shared fixtures and THE tolerance table of the pre-integration table tests.

Every table test takes its bound from ``TOLERANCES`` (``TABLE_TOLERANCES`` of ``tests/tolerances.py``,
the one table of bounds; values on colour/opacity, absolute unless ``rtol``). Faithful low-precision builders are not "exact": their rows bound the error the method
itself makes, and the tests print the measured error (run pytest with ``-s`` to see it) so it is
reported, not hidden.

=============================  ===============================================================
key                            meaning of the bound
=============================  ===============================================================
exact3d/fp32                   exact table vs float64 reference at nodes (rtol + atol)
exact3d/fp16 | hilo16 | rgba8  stored format: half an LSB of the format (+ fp32 error)
roettger_sw/fp32/<model>       eqs. 5-7 vs exact: the method's Riemann-sum error (o = 2), smooth TF;
                               large near sf = sb for emission density (n = 1: C = l kappa)
roettger_hw/<bits>             hardware slice vs the same-step float integration: <= steps LSBs
                               (each blend and each texel rounds by <= 1/2 LSB)
geforce3/8                     combiners: <= steps/4 blends of 8-bit LSB + 12-bit combiner LSBs
pingpong/radeon8500            ping-pong vs same-step float: <= passes x 1/4080 + texel truncation
incremental/<axis>             incremental vs exact at nodes (bilinear resampling, smooth TF)
cylindrical/<n>x               plane reconstruction vs trilinear 3D table (interpolation error)
guthe/<degree>                 reconstruction at the interpolation slices (alpha1D lookup only)
psi/fp32                       psi table vs float64 quadrature
=============================  ===============================================================
"""

import numpy as np
import pytest

from tolerances import TABLE_TOLERANCES as TOLERANCES  # noqa: F401 (the table tests import it here)
from warpvol.reference.numpy_render import integrate_segments
from warpvol.scene.transfer import TransferFunction


def smooth_tf(emission="color_extinction", m=16, rho_max=4.0):
    """A smooth TF (bounded second derivatives) over [-1, 2]; values in [0, 1], extinction <= rho_max."""
    s = np.linspace(-1.0, 2.0, m)
    x = np.linspace(0, 1, m)
    rgb = np.column_stack([0.5 + 0.4 * np.sin(2 * np.pi * x), 0.5 + 0.4 * np.cos(3 * x), x])
    rho = rho_max * (0.55 + 0.45 * np.sin(2.5 * np.pi * x + 0.3))
    return TransferFunction(np.column_stack([s, rgb, rho]), emission)


def random_tf(emission="color_extinction", m=12, seed=0, rho_max=5.0):
    rng = np.random.default_rng(seed)
    s = np.sort(rng.uniform(0, 1, m))
    s[0], s[-1] = 0.0, 1.0
    return TransferFunction(np.column_stack([s, rng.random((m, 3)), rho_max * rng.random(m)]), emission)


def reference_at_nodes(table, tf, lmax):
    """float64 (C, alpha) at every node of a 3D table (texture order)."""
    ax_l, ax_b, ax_f = table.axes
    L, B, F = np.meshgrid(ax_l.nodes, ax_b.physical, ax_f.physical, indexing="ij")
    rgb, tau = integrate_segments(F.ravel(), B.ravel(), L.ravel() * lmax, tf)
    out = np.concatenate([rgb, -np.expm1(-tau)[:, None]], axis=1)
    return out.reshape(L.shape + (4,))


def report(name, **errs):
    print(f"\n[table error] {name}: " + ", ".join(f"{k} = {v:.3e}" for k, v in errs.items()))


@pytest.fixture(scope="session")
def tf_smooth():
    return smooth_tf()
