"""Roettger & Ertl 2002 §3: hardware-accelerated pre-integration, one ``l = const`` slice at a time,
run on the emulated GPU (texture unit :mod:`warpvol.gpu.texture`, blending unit and frame buffer
:mod:`warpvol.gpu.blend`).

The TF is a 1D texture ``T1D(s) = (E(s), 1 - exp(-(l/n) rho(s)))`` with ``E = (l/n) kappa``
(emission density, eq. 8) or ``kappa (1 - exp(-(l/n) rho))`` (colour times extinction, premultiplied);
``n`` rectangles the size of the slice are drawn back to front with texture coordinate
``w_i(sf, sb) = sb + i/(n-1) (sf - sb)`` and blended ``dst = src.rgb + (1 - src.a) dst`` into a
frame buffer of 8 or 12 bits per channel (every blend rounds: that is the method's error).

``passes``:
  * ``"two"``: RGB pass into a buffer cleared to (0, 0, 0); opacity pass with the texture modulated
    by the primary colour (0, 0, 0, 1) into a buffer cleared to (1, 1, 1): transparency in RGB
    (SGI Octane MXI: 12-bit RGB visual, no RGBA).
  * ``"one"``: constant blend colour (1, 1, 1, 0) in the source path, buffer cleared to (0, 0, 0, 1):
    colour in RGB, transparency in alpha.

``variant="geforce3"``: 4 texture units per pass, 3 general register-combiner steps at 12-bit internal
precision, the final combiner's output stored into an 8-bit buffer (4 steps per blend); with an
emission-density TF the texture holds kappa and the combiners apply ``l/n`` at 12 bits (``ln_in_combiner``),
``l/n`` itself a combiner constant register (``CONSTANT_COLOR0``: 8-bit unsigned, ``ln_format="unorm8"``;
``"fp32"`` keeps the exact constant, which the hardware could not hold).
``gl_dither``: OpenGL's default GL_DITHER (ordered 4x4 dither of every blend result).

The texture has ``n_tex`` texels (default: the TF's number of control points, ``m``); texel k holds the
TF at ``k / (n_tex - 1)`` of the normalised scalar (eq. 8: texel k of m is TF entry k), sampled at
texture coordinate ``(n_tex - 1)/n_tex w + 1/(2 n_tex)`` so that w = k/(m-1) hits texel k's centre;
texels in the frame buffer's precision (``rgba8`` or ``rgba12``), linear filtering.
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import check_number
from warpvol.gpu import counters as cnt
from warpvol.gpu.blend import BlendUnit, FrameBuffer
from warpvol.gpu.formats import UNORM12, get_format
from warpvol.gpu.texture import Texture1D
from warpvol.parallel import launch_blocks, row_blocks
from warpvol.tables.base import AXIS_KINDS, TABLE_FORMATS
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
from warpvol.tables.exact import length_axis

VARIANTS = ("blend", "geforce3")
FB_BUDGET = 256 << 20  # bytes of frame buffers (colour + depth) alive at once: slices are drawn in waves


def tf_texture_values(tf, n_tex: int, l: float, n: int, kappa_only: bool = False) -> np.ndarray:
    """``T1D`` texel values (n_tex, 4), float64, unquantised (eq. 8): texel k is the TF at
    ``k / (n_tex - 1)`` of its range, i.e. TF entry k when ``n_tex`` is the TF's number of entries
    (the kernel maps a scalar w to the texture coordinate ``(n_tex - 1)/n_tex w + 1/(2 n_tex)``)."""
    lo, hi = tf.srange
    x = np.arange(n_tex) / (n_tex - 1)
    v = tf.evaluate(lo + x * (hi - lo))
    a = -np.expm1(-(l / n) * v[:, 3])
    if kappa_only:  # the combiner applies l/n (emission density)
        e = v[:, :3]
    elif tf.emission == "emission_density":
        e = (l / n) * v[:, :3]
    else:
        e = v[:, :3] * a[:, None]
    return np.clip(np.column_stack([e, a]), 0.0, 1.0)


def ln_register(ln: float, ln_format: str = "unorm8") -> tuple[float, int | None]:
    """``(value, code)`` of the constant ``l/n`` in the combiner register: ``unorm8`` -> the 8-bit
    code (:mod:`warpvol.gpu.formats`, round to nearest, saturating) and its value; ``fp32`` ->
    ``(ln, None)``.

    Examples
    --------
    >>> ln_register(1.0 / 64)  # 3.98 -> code 4
    (0.01568627543747425, 4)
    >>> ln_register(0.001)[1]  # below half a code: the register holds 0, the slice emits nothing
    0
    """
    if ln_format == "fp32":
        return float(ln), None

    f = get_format("unorm8")
    code = f.encode(np.asarray([ln], dtype=np.float32))
    return float(f.decode(code)[0]), int(code[0])


def count_slice_draws(jobs, nblend: int, draw: int, group: int, n_s: int) -> None:
    """Counters of one wave of slice draws (each job: one pass of ``nblend`` full-slice rectangles,
    ``group`` texture fetches per fragment, GeForce3: ``group`` combiner steps, read back at the end)."""

    c = cnt.active()
    if c is None:
        return
    npx = n_s * n_s
    for tex, fb, *_ in jobs:
        c.add(passes=1, vertices=4 * nblend, primitives=2 * nblend, fragments=nblend * npx,
              fragments_passed=nblend * npx)
        tex.count(draw * npx, c)
        c.blend(fb.fmt, nblend * npx)
        if group > 1:  # general combiner stages (the final combiner's step is free)
            c.add(combiner_ops=nblend * (group - 1) * npx)


def make_tf_texture(values: np.ndarray, bits: int, device: str):
    """The TF as a texture of the emulated texture unit, in ``bits`` precision."""

    if bits == 8:
        return Texture1D(values, fmt="rgba8", filter="linear", device=device)
    return Texture1D(values, fmt="rgba12", filter="linear", device=device)


def build_roettger_hw(tf, *, n_s: int = 64, n_l: int = 32, lmax: float = 1.0, steps: int | None = None,
                      bits: int = 12, passes: str = "two", variant: str = "blend", n_tex: int | None = None,
                      l_axis: str = "centred", draw: int | None = None, format: str = "fp32", device: str = "cpu",
                      threads: int = 0, emulate: bool = True, ln_in_combiner: bool | None = None,
                      gl_dither: bool = False, ln_format: str = "unorm8"):
    """Hardware-emulated per-slice pre-integration.

    Parameters
    ----------
    tf : TransferFunction
    n_s, n_l : int
        Slice resolution (frame buffer ``n_s x n_s``) and number of slices.
    lmax : float
    steps : int, optional
        Rectangles per slice ``n = o m`` (paper: o = 1); default: the TF's number of points.
    bits : int
        Frame-buffer (and TF texture) depth: 8 or 12. ``variant="geforce3"`` needs 8.
    passes : str
        ``"two"`` (RGB pass + opacity pass) or ``"one"`` (constant blend colour).
    variant : str
        ``"blend"`` (one blend per step) or ``"geforce3"`` (4 steps per blend via register combiners).
    n_tex : int, optional
        TF texture resolution (default: number of TF points).
    draw : int, optional
        Draw only the first ``draw`` rectangles (intermediate frame buffers, the paper's Fig. 4).
    l_axis, format, device : str
    threads : int
        Host threads drawing slices (and row blocks of them) concurrently on the CPU (0: all cores);
        the result does not depend on it. Other devices draw in order.
    ln_in_combiner : bool, optional
        ``variant="geforce3"``, emission density: the texture holds kappa (8 bits) and the combiners
        compute ``(l/n) kappa`` at their 12-bit precision instead of an 8-bit texel holding the small
        ``(l/n) kappa``. Default (None): on for that case — it is what gives the paper's "precision
        gain equivalent to reducing the number of integration steps by a factor of 4" (64x64x32,
        Fig. 4-like TF: RMS at n steps 1.24 % vs plain 8-bit blending at n/4 steps 1.29 % for n = 32;
        with the scaled texel the gain over plain blending at n steps is only ~10 %).
    ln_format : str
        ``ln_in_combiner`` only: the constant ``l/n`` as the combiner register holds it, ``unorm8``
        (code ``round(255 l/n)``, what the GeForce3's constant colour stored; ``meta["ln_codes"]``
        lists the codes per slice) or ``fp32`` (exact).
    gl_dither : bool
        OpenGL's default ``GL_DITHER``: every blend result rounded with a 4x4 ordered dither instead
        of to nearest.
    emulate : bool
        False: set everything up and count the work (:mod:`warpvol.gpu.counters`) but draw nothing
        (the table is the cleared buffers); what the throughput model needs at the papers' sizes.

    Returns
    -------
    Table
        ``data[l, sb, sf] = (C, alpha)``, values of the frame buffer read back (then stored in ``format``).
    """
    import warp as wp


    check_tf(tf)
    n_s = check_res("n_s", n_s, 2)
    n_l = check_res("n_l", n_l, 1 if l_axis == "centred" else 2)
    lmax = check_lmax(lmax)
    steps = len(tf.points) if steps is None else check_res("steps", steps, 1, 1 << 16)
    bits = int(check_number("bits", bits, integer=True))
    check_choice("bits", bits, (8, 12))
    check_choice("passes", passes, ("two", "one"))
    check_choice("variant", variant, VARIANTS)
    if variant == "geforce3" and bits != 8:
        raise ValueError("bits: the geforce3 variant stores into an 8-bit frame buffer; use bits=8")
    if ln_in_combiner is None:
        ln_in_combiner = variant == "geforce3" and tf.emission == "emission_density"
    if ln_in_combiner and (variant != "geforce3" or tf.emission != "emission_density"):
        raise ValueError("ln_in_combiner: needs variant='geforce3' and an 'emission_density' TF")
    check_choice("ln_format", ln_format, ("unorm8", "fp32"))
    n_tex = len(tf.points) if n_tex is None else check_res("n_tex", n_tex, 2, 1 << 16)
    check_choice("l_axis", l_axis, AXIS_KINDS[:2])
    check_choice("format", format, TABLE_FORMATS)
    draw = steps if draw is None else check_res("draw", draw, 0, steps)
    threads = int(check_number("threads", threads, lo=0, hi=256, integer=True))

    k = kernels()
    ax_f = scalar_axis("sf", tf, n_s)
    ax_b = scalar_axis("sb", tf, n_s)
    ax_l = length_axis(n_l, lmax, l_axis)
    key = table_key("roettger_hw", tf.hash, n_s=n_s, n_l=n_l, lmax=lmax, steps=steps, bits=bits, passes=passes,
                    variant=variant, n_tex=n_tex, l_axis=l_axis, draw=draw, ln_in_combiner=bool(ln_in_combiner),
                    gl_dither=bool(gl_dither), format=format)
    if ln_in_combiner and ln_format != "unorm8":
        key = key + (("ln_format", ln_format),)
    key = key if emulate else key + (("emulate", False),)  # counting-only tables never pass for real ones
    meta = {"builder": "roettger_hw", "emission": tf.emission, "lmax": lmax, "steps": steps, "n_tex": n_tex, "bits": bits,
            "passes": passes, "variant": variant, "fragments": 0, "blends": 0}
    fb_fmt = f"unorm{bits}"
    group = 4 if variant == "geforce3" else 1
    comb = UNORM12.kernel_params()
    x = farr(ax_f.nodes, device)
    ua, ub = (n_tex - 1) / n_tex, 0.5 / n_tex  # eq. 8 texel placement: TF entry k at texel k's centre
    # one draw per (slice, pass), each into its own frame buffer: (clear colour, blend unit, modulate)
    if passes == "two":
        draws = [((0, 0, 0, 0), BlendUnit.over(), wp.vec4(1.0, 1.0, 1.0, 1.0)),
                 ((1, 1, 1, 1), BlendUnit.over(), wp.vec4(0.0, 0.0, 0.0, 1.0))]
    else:
        draws = [((0, 0, 0, 1), BlendUnit("constant_color", "one_minus_src_alpha", constant=(1, 1, 1, 0)),
                  wp.vec4(1.0, 1.0, 1.0, 1.0))]
    data = np.zeros((n_l, n_s, n_s, 4), dtype=np.float32)
    if ln_in_combiner:
        meta["ln_format"] = ln_format
        meta["ln_codes"] = []
    nblend = -(-draw // group)
    wave = max(1, min(n_l, FB_BUDGET // (len(draws) * n_s * n_s * 20)))  # slices per wave
    with timed(meta, device=device):
        for w0 in range(0, n_l, wave):
            lis = range(w0, min(n_l, w0 + wave))
            jobs = []  # (texture, frame buffer, blend state, modulate), built up front on this thread
            for li in lis:
                l_li = float(ax_l.physical[li])
                tex = make_tf_texture(tf_texture_values(tf, n_tex, l_li, steps, ln_in_combiner), bits, device)
                e_scale = 1.0
                if ln_in_combiner:
                    e_scale, code = ln_register(l_li / steps, ln_format)
                    meta["ln_codes"].append(code)
                for clear, unit, mod in draws:
                    fb = FrameBuffer(n_s, n_s, fb_fmt, device)
                    fb.clear(clear)
                    jobs.append((tex, fb, unit.state(fb), mod, e_scale))
            # rows of a slice are independent too (no dithering here, so a pixel's blends do not
            # depend on its row): split them when there are fewer slices than cores
            rows = row_blocks(n_s, len(jobs), threads, device)

            def launch(b: int, jobs=jobs, rows=rows) -> None:
                tex, fb, st, mod, e_scale = jobs[b // len(rows)]
                r0, nr = rows[b % len(rows)]
                wp.launch(k.hw_preint_slice, dim=(nr, n_s), device=device,
                          inputs=[tex.struct, st, fb.array[r0:r0 + nr], x, x[r0:r0 + nr], steps, draw, group, comb,
                                  mod, ua, ub, e_scale, int(gl_dither), r0])

            if emulate:
                launch_blocks(device, len(jobs) * len(rows), launch, threads, modules=[k])
            for q, li in enumerate(lis):
                if passes == "two":
                    rgb = jobs[2 * q][1].readback()[..., :3]
                    theta = jobs[2 * q + 1][1].readback()[..., 0]
                else:
                    v = jobs[q][1].readback()
                    rgb, theta = v[..., :3], v[..., 3]
                data[li, ..., :3] = rgb
                data[li, ..., 3] = 1.0 - theta
                meta["blends"] += len(draws) * nblend * n_s * n_s
            count_slice_draws(jobs, nblend, draw, group, n_s)
    meta["fragments"] = meta["blends"]
    meta["steps_integrated"] = meta["blends"] * group
    return finish("roettger_hw", data, (ax_l, ax_b, ax_f), ("r", "g", "b", "a"), format, key, meta)
