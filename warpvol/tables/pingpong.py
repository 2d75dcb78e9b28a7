"""Guthe et al. 2002 §4: hardware pre-integration by ping-pong filtering at 12 bits, on the emulated
GPU (texture unit for the TF texture, :mod:`warpvol.gpu.formats` for every channel write).

A 12-bit value is an 8-bit high part plus 4 low bits: ``C = H + L / 256`` (H, L the channels'
normalised values, 255 in H meaning 1.0). The TF texture (RGBA8, ``n_tex`` texels, linear) holds
kappa (R high, G low) and ``a = 1 - exp(-(l/m) rho)`` (B high, A low) of one colour channel. Each
pass reconstructs C from the ping texture, runs ``per_pass = 4`` steps ``C = kappa a + (1 - a) C``
in the pixel shader and writes the 12-bit result split back into the pong texture. The Radeon 8500
masks bits outside [1/256, 1] (``overflow="wrap"``: the low bits are ``256 C`` masked); the GeForce4
saturates (``overflow="saturate"``: ``256 C`` clamps to 1, so the low part is garbage — the paper's
reason why only the Radeon can do this). One pass sequence per colour channel (3 per slice).

Opacity is not integrated here: Guthe separates it exactly (``alpha = 1 - exp(-l rho_hat)``), so
the table's alpha channel is that exact value.
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError, check_number
from warpvol.gpu import counters as cnt
from warpvol.gpu.formats import Split12, UNorm
from warpvol.gpu.texture import Texture1D
from warpvol.parallel import launch_blocks, row_blocks
from warpvol.tables.base import TABLE_FORMATS, Axis
from warpvol.tables.common import (
    check_choice,
    check_lmax,
    check_res,
    check_tf,
    farr,
    finish,
    kernels,
    scalar_axis,
    table_key,
    timed,
)

OVERFLOW = {"radeon8500": "wrap", "geforce4": "saturate"}


def split_texture_values(tf, n_tex: int, l: float, m: int, channel: int) -> np.ndarray:
    """RGBA8 texel values (n_tex, 4) of the TF texture for one colour channel (hi/lo split,
    :class:`warpvol.gpu.formats.Split12` truncating, as the shader's 8-bit writes)."""

    lo_s, hi_s = tf.srange
    x = (np.arange(n_tex) + 0.5) / n_tex
    v = tf.evaluate(lo_s + x * (hi_s - lo_s))
    kap = np.clip(v[:, channel], 0, 1).astype(np.float32)
    a = (-np.expm1(-(l / m) * v[:, 3])).astype(np.float32)
    split = Split12(rounding="truncate")
    cols = []
    for q in (kap, a):
        hi, lo = split.channels(q)
        cols += [hi / 255.0, lo / 255.0]
    return np.column_stack(cols)


def count_pingpong(jobs, m: int, per_pass: int, n_s: int) -> None:
    """Counters of the ping-pong passes: per (slice, channel) ``ceil(m / per_pass)`` passes of one
    full-slice quad; a fragment fetches the ping texel (2D RGBA8, nearest) and one TF texel per step,
    runs ``per_pass`` shader steps and writes RGBA8 (no blending); the pong buffer is copied to the
    ping texture after each pass (on the card) and the channel's last pass is read back."""

    c = cnt.active()
    if c is None:
        return
    npx = n_s * n_s
    for _, _, tex in jobs:
        np_ = -(-m // per_pass)
        c.add(passes=np_, vertices=4 * np_, primitives=2 * np_, fragments=np_ * npx, fragments_passed=np_ * npx,
              tex_2d_rgba8_nearest=np_ * npx, texels=np_ * npx, combiner_ops=m * npx, clears=1, clear_pixels=npx,
              readbacks=1, bytes_down=4 * npx)
        tex.count(m * npx, c)
        c.blend("unorm8", np_ * npx, blending=False)


def count_moments(n_s: int) -> None:
    """Host work of the exact opacity (and colour) moments: one software integral per texel."""

    cnt.count(host_texels=n_s * n_s)


def build_pingpong(tf, *, n_s: int = 128, lengths=(1.0,), lmax: float = 1.0, m: int = 128, gpu: str = "radeon8500",
                   per_pass: int = 4, n_tex: int = 2048, format: str = "fp32", device: str = "cpu", threads: int = 0,
                   emulate: bool = True):
    """Ping-pong filtered slices ``data[k, sb, sf] = (C rgb, alpha)`` at thicknesses ``lengths`` (x lmax).

    Parameters
    ----------
    tf : TransferFunction
        ``color_extinction`` model (the paper's).
    n_s : int
        Slice resolution (512 in the paper's Table 4).
    lengths : sequence of float
        Normalised thicknesses of the slices to integrate.
    lmax : float
    m : int
        Integration steps per slice (m = 128 in Fig. 6).
    gpu : str
        ``"radeon8500"`` (bit masking) or ``"geforce4"`` (saturation).
    per_pass : int
        Steps per pass in the pixel shader (4 in the paper).
    n_tex : int
        TF texture resolution ("the highest possible": 2048 on the Radeon 8500).
    format, device : str
    threads : int
        Host threads running the slices' channels (and row blocks of them) concurrently on the CPU
        (0: all cores); the result does not depend on it. Other devices run them in order.
    emulate : bool
        False: count the work but run no pass (zero colour); for the throughput model.
    """
    import warp as wp


    check_tf(tf)
    if tf.emission != "color_extinction":
        raise ConfigError("tf.emission: ping-pong pre-integration integrates kappa a + (1 - a) C, the "
                          "'color_extinction' model")
    n_s = check_res("n_s", n_s, 2)
    lmax = check_lmax(lmax)
    m = check_res("m", m, 1, 1 << 16)
    check_choice("gpu", gpu, tuple(OVERFLOW))
    per_pass = check_res("per_pass", per_pass, 1, 16)
    n_tex = check_res("n_tex", n_tex, 2, 1 << 16)
    threads = int(check_number("threads", threads, lo=0, hi=256, integer=True))
    check_choice("format", format, TABLE_FORMATS)
    ls = np.asarray(lengths, dtype=np.float64).ravel()
    if ls.size == 0 or not np.all((ls >= 0) & (ls <= 1)):
        raise ConfigError(f"lengths: expected normalised thicknesses in [0, 1], got {list(ls)}")
    k = kernels()
    ax_f = scalar_axis("sf", tf, n_s)
    ax_b = scalar_axis("sb", tf, n_s)
    key = table_key("pingpong", tf.hash, n_s=n_s, lengths=tuple(ls.tolist()), lmax=lmax, m=m, gpu=gpu,
                    per_pass=per_pass, n_tex=n_tex, format=format)
    key = key if emulate else key + (("emulate", False),)  # counting-only tables never pass for real ones
    meta = {"builder": "pingpong", "lmax": lmax, "m": m, "gpu": gpu, "passes": 0}
    fmt = UNorm(8, rounding="truncate", overflow=OVERFLOW[gpu]).kernel_params()
    x = farr(ax_f.nodes, device)
    data = np.zeros((ls.size, n_s, n_s, 4), dtype=np.float32)
    out = wp.zeros((3 * ls.size, n_s, n_s), dtype=wp.float32, device=device)  # one per (slice, channel)
    mom = wp.zeros((n_s, n_s), dtype=wp.vec4, device=device)
    tf_s, tf_v = tf.to_warp(device)
    lo, hi = tf.srange
    with timed(meta, device=device):
        # one job per (slice, colour channel), each with its own texture and output; textures built
        # up front on this thread, the draws (and the moments) split into row blocks run concurrently
        jobs = [(si, c, Texture1D(split_texture_values(tf, n_tex, float(l) * lmax, m, c), fmt="rgba8",
                                  filter="linear", device=device))
                for si, l in enumerate(ls) for c in range(3)]
        rows = row_blocks(n_s, len(jobs) + 1, threads, device)

        def launch(b: int) -> None:
            q = b // len(rows)
            r0, nr = rows[b % len(rows)]
            if q == len(jobs):
                wp.launch(k.guthe_moments, dim=(nr, n_s), device=device,
                          inputs=[x, x[r0:r0 + nr], lo, hi - lo, tf_s, tf_v, mom[r0:r0 + nr]])
            else:
                wp.launch(k.pingpong_slice, dim=(nr, n_s), device=device,
                          inputs=[jobs[q][2].struct, x, x[r0:r0 + nr], m, per_pass, fmt, fmt, out[q][r0:r0 + nr]])

        if emulate:
            launch_blocks(device, (len(jobs) + 1) * len(rows), launch, threads, modules=[k])
        res = out.numpy()
        for q, (si, c, _) in enumerate(jobs):
            data[si, ..., c] = res[q]
            meta["passes"] += -(-m // per_pass)
        count_pingpong(jobs, m, per_pass, n_s)
        count_moments(n_s)
        rho_hat = mom.numpy()[..., 3].astype(np.float64)
        for si, l in enumerate(ls):
            data[si, ..., 3] = -np.expm1(-float(l) * lmax * rho_hat)
    return finish("pingpong", data, (Axis("l", ls.size, "centred", scale=lmax), ax_b, ax_f), ("r", "g", "b", "a"),
                  format, key, meta, extra={"lengths": ls})
