"""Fixed-point fragment arithmetic units: the GeForce3/4 register combiners and the Radeon 8500
fragment shader, as Guthe et al. 2002's polynomial colour program ran on them.

Every instruction result passes through :func:`warpvol.kernels.formats.reg_fixed` (clamp to the
register range, round to the register precision) once, after its scale modifier — the hardware
applied the output scale (combiner ``SCALE_BY_TWO`` / ``FOUR`` / ``ONE_HALF``; ATI destination
modifiers ``2X`` .. ``8X``, ``HALF`` .. ``EIGHTH``) before the clamp.

The program (``guthe_poly``), degree ``n``, texels ``t_i`` holding ``C~_i / s_i``:

* ``x = reg(l / lmax)`` (an interpolated register input);
* ``acc = reg(t_0 w_0)``; for i = 1..n: ``x^i = reg(x^(i-1) x)``, ``acc = reg(acc + reg(t_i x^i w_i))``
  with ``w_i = s_i / s_acc`` (a power of two, applied by the scale modifier);
* ``C = reg(acc alpha s_acc)`` (``alpha = reg(alpha1D)``), the output clamped to [0, 1].

``s_acc`` is the accumulator's scale: 1 on the Radeon 8500 (its [-8, 8] range holds the partial
sums), ``max s_i`` on the combiners (their [-1, 1] range does not: the sum is kept divided by
``s_acc`` and scaled back by the last stage's output scale).
"""

import warp as wp

from .formats import reg_fixed
from .pt import guthe_fetch
from .texture import Atlas, Tex1D, atlas_sample

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.func
def reg3(v: wp.vec3, rng: float, unit: float) -> wp.vec3:
    return wp.vec3(reg_fixed(v[0], rng, unit), reg_fixed(v[1], rng, unit), reg_fixed(v[2], rng, unit))


@wp.func
def guthe_term(acc: wp.vec3, t: wp.vec3, xi: float, w: float, rng: float, unit: float) -> wp.vec3:
    """``reg(acc + reg(t xi w))``: one polynomial term multiplied in (product and scale modifier in
    one instruction) and added to the accumulator (a second instruction)."""
    return reg3(acc + reg3(t * (xi * w), rng, unit), rng, unit)


@wp.func
def guthe_finish(acc: wp.vec3, alpha: float, s_acc: float, rng: float, unit: float) -> wp.vec4:
    """``C = reg(acc alpha s_acc)``, alpha as a register value; output clamped to [0, 1]."""
    a = reg_fixed(alpha, rng, unit)
    c = reg3(acc * (a * s_acc), rng, unit)
    return wp.vec4(wp.clamp(c[0], 0.0, 1.0), wp.clamp(c[1], 0.0, 1.0), wp.clamp(c[2], 0.0, 1.0),
                   wp.clamp(a, 0.0, 1.0))


@wp.kernel
def k_frag_guthe_fixed(attrs: wp.array2d(dtype=wp.float32), mode: int, ortho: int, z_off: float, coef: Atlas,
                       alpha1d: Tex1D, s_off: float, s_inv: float, s_a: float, s_b: float, l_inv: float,
                       a_a: float, a_b: float, degree: int, w: wp.array(dtype=wp.float32), s_acc: float,
                       rng: float, unit: float, out: wp.array(dtype=wp.vec4)):
    """Guthe et al. 2002 fragment program in fixed-point register arithmetic (module docstring);
    the texture fetches and the dependent alpha1D coordinate ``x rho_hat`` are those of
    ``k_frag_guthe`` (:func:`~warpvol.kernels.pt.guthe_fetch`)."""
    f = wp.tid()
    u, v, x, t0, alpha = guthe_fetch(attrs, f, mode, ortho, z_off, coef, alpha1d, s_off, s_inv, s_a, s_b, l_inv,
                                     a_a, a_b)
    xq = reg_fixed(x, rng, unit)
    acc = reg3(wp.vec3(t0[0], t0[1], t0[2]) * w[0], rng, unit)
    xi = float(1.0)
    for i in range(1, degree + 1):
        xi = reg_fixed(xi * xq, rng, unit)
        ti = atlas_sample(coef, i, u, v)
        acc = guthe_term(acc, wp.vec3(ti[0], ti[1], ti[2]), xi, w[i], rng, unit)
    out[f] = guthe_finish(acc, alpha, s_acc, rng, unit)


@wp.kernel
def k_guthe_fixed(taps: wp.array2d(dtype=wp.vec3), x: wp.array(dtype=wp.float32), alpha: wp.array(dtype=wp.float32),
                  w: wp.array(dtype=wp.float32), s_acc: float, rng: float, unit: float, out: wp.array(dtype=wp.vec4)):
    """The same program over already fetched texels ``taps[k, i]`` (``x`` clamped to [0, 1]):
    :func:`warpvol.tables.guthe2d.reconstruct`."""
    k = wp.tid()
    xq = reg_fixed(wp.clamp(x[k], 0.0, 1.0), rng, unit)
    acc = reg3(taps[k, 0] * w[0], rng, unit)
    xi = float(1.0)
    for i in range(1, taps.shape[1]):
        xi = reg_fixed(xi * xq, rng, unit)
        acc = guthe_term(acc, taps[k, i], xi, w[i], rng, unit)
    out[k] = guthe_finish(acc, alpha[k], s_acc, rng, unit)
