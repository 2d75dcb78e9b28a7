"""Blending unit and frame buffers: bit-exact against NumPy integer / half arithmetic; dithering."""

import numpy as np
import pytest

from helpers import DEVICES
from warpvol.errors import ConfigError
from warpvol.gpu.blend import FACTORS, BlendUnit, FrameBuffer, PingPong, blend_sequence
from warpvol.gpu.dither import dither_codes_np, dither_index_np, dither_table
from warpvol.gpu.formats import UNorm
from warpvol.gpu.raster import draw_textured_quads
from warpvol.gpu.texture import Texture1D

# ------------------------------------------------------------------------------------------------
# NumPy references (written independently of the kernels)
# ------------------------------------------------------------------------------------------------


def _factor(name, s, d, k, one):
    """Per-channel factor arrays (..., 4) for operands s, d, k (..., 4) in a domain where 1 == ``one``."""
    sa, da, ka = (np.broadcast_to(x[..., 3:4], x.shape) for x in (s, d, k))
    table = {"zero": 0 * s, "one": 0 * s + one, "src_color": s, "one_minus_src_color": one - s,
             "src_alpha": sa, "one_minus_src_alpha": one - sa, "dst_color": d, "one_minus_dst_color": one - d,
             "dst_alpha": da, "one_minus_dst_alpha": one - da, "constant_color": k,
             "one_minus_constant_color": one - k, "constant_alpha": ka, "one_minus_constant_alpha": one - ka}
    return table[name]


def ref_blend_unorm(layers, clear, bits, src, dst, constant=(0, 0, 0, 0), src_a=None, dst_a=None,
                    wrap=False, alpha_codes=None):
    """Integer reference: codes S, D, K; R = round((S Fs + D Fd) / N) by exact integer arithmetic."""
    n = 2**bits - 1
    enc = UNorm(bits).encode
    d = np.broadcast_to(enc(np.clip(clear, 0, 1)), layers.shape[1:]).astype(np.int64)
    k = np.broadcast_to(enc(np.clip(constant, 0, 1)), layers.shape[1:]).astype(np.int64)
    for i, layer in enumerate(layers):
        s = enc(np.clip(layer, 0, 1)).astype(np.int64)
        if alpha_codes is not None:
            s[..., 3] = alpha_codes[i]
        fs = _factor(src, s, d, k, n).copy()
        fd = _factor(dst, s, d, k, n).copy()
        if src_a is not None:
            fs[..., 3] = _factor(src_a, s, d, k, n)[..., 3]
        if dst_a is not None:
            fd[..., 3] = _factor(dst_a, s, d, k, n)[..., 3]
        num = s * fs + d * fd
        r = (2 * num + n) // (2 * n)
        d = (r & n) if wrap else np.minimum(r, n)
    return d


def ref_blend_fp16(layers, clear, src, dst, constant=(0, 0, 0, 0)):
    """binary16 reference: operands and factors in fp16, products exact in fp32, sum rounded to fp16."""
    h = lambda x: np.asarray(x, np.float32).astype(np.float16).astype(np.float32)  # noqa: E731
    d = np.broadcast_to(h(clear), layers.shape[1:]).astype(np.float32)
    k = np.broadcast_to(h(constant), layers.shape[1:]).astype(np.float32)
    for layer in layers:
        s = h(layer)
        fs, fd = h(_factor(src, s, d, k, np.float32(1))), h(_factor(dst, s, d, k, np.float32(1)))
        d = h((s * fs).astype(np.float32) + (d * fd).astype(np.float32))
    return d


PAIRS = [("one", "one_minus_src_alpha"), ("one_minus_dst_alpha", "one"), ("src_alpha", "one_minus_src_alpha"),
         ("constant_color", "one_minus_src_alpha"), ("dst_color", "src_color"),
         ("one_minus_constant_alpha", "constant_alpha"), ("one_minus_src_color", "one_minus_dst_color"),
         ("dst_alpha", "zero"), ("constant_alpha", "one_minus_constant_color")]


@pytest.mark.parametrize("bits", [8, 12])
@pytest.mark.parametrize("device", DEVICES)
def test_fixed_point_blending_is_bit_exact_over_long_sequences(bits, device):
    rng = np.random.default_rng(bits)
    K, H, W = 300, 6, 7
    layers = rng.uniform(-0.05, 1.05, (K, H, W, 4)).astype(np.float32)
    layers[..., 3] *= rng.uniform(0, 0.2, (K, H, W)).astype(np.float32)  # mostly thin layers: long accumulation
    const = (1.0, 1.0, 1.0, 0.0) if bits == 8 else (0.3, 0.6, 0.9, 0.25)
    used = set()
    for src, dst in PAIRS:
        used |= {src, dst}
        fb = FrameBuffer(W, H, f"unorm{bits}", device)
        fb.clear((0.0, 0.1, 0.5, 1.0))
        BlendUnit(src, dst, constant=const).blend_layers(fb, layers)
        ref = ref_blend_unorm(layers, (0.0, 0.1, 0.5, 1.0), bits, src, dst, const)
        np.testing.assert_array_equal(fb.codes(), ref, err_msg=f"{src}, {dst}")
    assert used == set(FACTORS)  # every factor exercised
    # separate alpha factors
    fb = FrameBuffer(W, H, f"unorm{bits}", device)
    fb.clear((0, 0, 0, 1))
    BlendUnit("one", "one_minus_src_alpha", src_alpha="zero", dst_alpha="one_minus_src_alpha").blend_layers(fb, layers)
    ref = ref_blend_unorm(layers, (0, 0, 0, 1), bits, "one", "one_minus_src_alpha", src_a="zero",
                          dst_a="one_minus_src_alpha")
    np.testing.assert_array_equal(fb.codes(), ref)


@pytest.mark.parametrize("device", DEVICES)
def test_rounding_after_every_blend_makes_8bit_buffers_band(device):
    """Many thin layers: 8-bit accumulation stalls far from the exact result, 12-bit much closer, fp32 exact."""
    K = 256
    a = 0.003  # 0.765 LSB at 8 bits: the source rounds to 1 LSB
    layers = np.full((K, 1, 1, 4), a, np.float32)
    exact = 1 - (1 - a) ** K  # 0.536
    got = {f: blend_sequence(layers, f, device=device)[0, 0, 3] for f in ("unorm8", "unorm12", "fp16", "fp32")}
    # 8 bits: D' = round(1 + D (254/255)) stops growing once D/255 >= 1/2: stuck at 128/255
    assert got["unorm8"] == pytest.approx(128 / 255)
    assert abs(got["unorm12"] - exact) < 0.01 < abs(got["unorm8"] - exact)
    assert abs(got["fp16"] - exact) < 0.01
    assert got["fp32"] == pytest.approx(exact, rel=1e-4)


@pytest.mark.parametrize("device", DEVICES)
def test_saturate_versus_wrap_in_the_blender(device):
    layers = np.full((3, 1, 2, 4), 0.4, np.float32)
    sat = blend_sequence(layers, "unorm8", "one", "one", device=device)
    wrap = blend_sequence(layers, "unorm8_wrap", "one", "one", device=device)
    assert UNorm(8).encode(sat[0, 0]).tolist() == [255] * 4
    assert UNorm(8).encode(wrap[0, 0]).tolist() == [(3 * 102) & 255] * 4
    ref = ref_blend_unorm(layers, (0, 0, 0, 0), 8, "one", "one", wrap=True)
    np.testing.assert_array_equal(UNorm(8).encode(wrap), ref)


@pytest.mark.parametrize("device", DEVICES)
def test_fp16_and_fp32_blending_bit_exact(device):
    rng = np.random.default_rng(4)
    K, H, W = 300, 5, 6
    layers = rng.uniform(0, 1, (K, H, W, 4)).astype(np.float32)
    layers[..., 3] *= 0.1
    for src, dst in PAIRS:
        fb = FrameBuffer(W, H, "fp16", device)
        fb.clear((0.0, 0.1, 0.5, 1.0))
        BlendUnit(src, dst, constant=(0.3, 0.6, 0.9, 0.25)).blend_layers(fb, layers)
        ref = ref_blend_fp16(layers, (0.0, 0.1, 0.5, 1.0), src, dst, (0.3, 0.6, 0.9, 0.25))
        np.testing.assert_array_equal(fb.readback(), ref, err_msg=f"{src}, {dst}")
        assert fb.codes().dtype == np.uint16
    fb = FrameBuffer(W, H, "fp32", device)
    fb.clear((0, 0, 0, 0))
    BlendUnit.under().blend_layers(fb, layers)
    d = np.zeros((H, W, 4), np.float32)
    for s in layers:
        d = (s * (np.float32(1) - d[..., 3:4])).astype(np.float32) + d
    np.testing.assert_array_equal(fb.readback(), d)


@pytest.mark.parametrize("device", DEVICES)
def test_over_and_under_agree_up_to_rounding(device):
    rng = np.random.default_rng(5)
    layers = rng.uniform(0, 1, (40, 4, 4, 4)).astype(np.float32)
    layers[..., :3] *= layers[..., 3:4]  # premultiplied
    over = blend_sequence(layers[::-1], "fp32", "one", "one_minus_src_alpha", device=device)
    under = blend_sequence(layers, "fp32", "one_minus_dst_alpha", "one", device=device)
    np.testing.assert_allclose(over, under, atol=1e-5)
    d = np.zeros(layers.shape[1:], np.float32)  # fp32 "under" is s * (1 - d.a) + d per channel, bit for bit
    for s in layers:
        d = s * (np.float32(1) - d[..., 3:4]) + d
    np.testing.assert_array_equal(under, d)
    over8 = blend_sequence(layers[::-1], "unorm8", "one", "one_minus_src_alpha", device=device)
    assert np.abs(over8 - over).max() > 0  # 8-bit differs ...
    assert np.abs(over8 - over).max() < 40 / 255  # ... by at most the accumulated rounding


@pytest.mark.parametrize("device", DEVICES)
def test_alpha_dithering_unbiased_reproducible_and_exact(device):
    H, W = 128, 128
    a = np.float32(0.3 / 255)  # 0.3 LSB: rounding to nearest always gives 0
    layers = np.zeros((1, H, W, 4), np.float32)
    layers[..., 3] = a
    plain = FrameBuffer(W, H, "unorm8", device)
    BlendUnit("one", "zero").blend_layers(plain, layers)
    assert plain.codes()[..., 3].max() == 0
    fb = FrameBuffer(W, H, "unorm8", device)
    BlendUnit("one", "zero", dither=True, seed=7).blend_layers(fb, layers)
    codes = fb.codes()[..., 3]
    mean = codes.mean() / 255
    sigma = np.sqrt(0.3 * 0.7) / 255 / np.sqrt(H * W)
    assert abs(mean - a) < 4 * sigma  # unbiased
    # reproducible from the seed, different for another seed
    fb2 = FrameBuffer(W, H, "unorm8", device)
    BlendUnit("one", "zero", dither=True, seed=7).blend_layers(fb2, layers)
    np.testing.assert_array_equal(fb2.codes(), fb.codes())
    fb3 = FrameBuffer(W, H, "unorm8", device)
    BlendUnit("one", "zero", dither=True, seed=8).blend_layers(fb3, layers)
    assert (fb3.codes() != fb.codes()).any()
    # bit-exact against the NumPy twin of the table lookup, over a long "over" sequence
    K = 60
    rng = np.random.default_rng(6)
    seq = rng.uniform(0, 1, (K, 8, 9, 4)).astype(np.float32)
    seq[..., 3] *= 0.05
    fb4 = FrameBuffer(9, 8, "unorm8", device)
    BlendUnit.over(dither=True, seed=3, table_size=1024).blend_layers(fb4, seq, prim0=5)
    table = dither_table(3, 1024)
    yy, xx = np.mgrid[0:8, 0:9]
    alpha = np.stack([dither_codes_np(seq[k, ..., 3], 255, table[dither_index_np(xx, yy, 5 + k, 3, 1023)])
                      for k in range(K)])
    ref = ref_blend_unorm(seq, (0, 0, 0, 0), 8, "one", "one_minus_src_alpha", alpha_codes=alpha)
    np.testing.assert_array_equal(fb4.codes(), ref)


@pytest.mark.parametrize("device", DEVICES)
def test_dithering_removes_the_bias_of_long_8bit_sequences(device):
    """Kraus et al.: accumulated opacity of many thin layers; mean error -> 0 with dithering."""
    H, W, K, a = 64, 64, 30, 0.0015  # 0.38 LSB per layer
    layers = np.zeros((K, H, W, 4), np.float32)
    layers[..., 3] = a
    exact = 1 - (1 - a) ** K
    fb = FrameBuffer(W, H, "unorm8", device)
    BlendUnit.under().blend_layers(fb, layers)
    plain_err = fb.readback()[..., 3].mean() - exact
    fb.clear((0, 0, 0, 0))
    BlendUnit.under(dither=True, seed=1).blend_layers(fb, layers)
    dith_err = fb.readback()[..., 3].mean() - exact
    assert plain_err == pytest.approx(-exact)  # 8-bit rounding loses every contribution below 0.5 LSB
    assert abs(dith_err) < 0.05 * abs(plain_err)  # what is left: the blend's own rounding of (1 - D) a


@pytest.mark.parametrize("device", DEVICES)
def test_hardware_preintegration_quads_match_integer_reference(device):
    """Roettger & Ertl: n rectangles sampled from a 1D texture, dst = src.rgb + (1 - src.a) dst, 8/12 bits."""
    rng = np.random.default_rng(9)
    m, n, S = 16, 24, 8
    tf = rng.uniform(0, 1, (m, 4))
    tf[:, 3] *= 0.2
    tex = Texture1D(tf, fmt="rgba8", filter="nearest", device=device)
    # corners (sf, sb) in {0,1}^2 at window (0,0), (W,0), (0,H), (W,H): x = sf, y = sb
    i = np.arange(n)[:, None]
    sf = np.array([0, 1, 0, 1])[None]
    sb = np.array([0, 0, 1, 1])[None]
    corners = sb + i / (n - 1) * (sf - sb)
    for bits in (8, 12):
        fb = FrameBuffer(S, S, f"unorm{bits}", device)
        fb.clear((0, 0, 0, 1))
        draw_textured_quads(fb, BlendUnit("constant_color", "one_minus_src_alpha", constant=(1, 1, 1, 0)), tex,
                            corners)
        # reference: the texel each pixel centre samples, then integer blending
        fx = ((np.arange(S) + 0.5) / S).astype(np.float32)
        gx, gy = np.meshgrid(fx, fx)
        layers = []
        for c in corners.astype(np.float32):
            top = c[0] + gx * (c[1] - c[0])
            bot = c[2] + gx * (c[3] - c[2])
            u = (top + gy * (bot - top)).astype(np.float32)
            k = np.clip(np.floor((u * np.float32(m)).astype(np.float64)).astype(int), 0, m - 1)
            layers.append(tex.values[k])
        ref = ref_blend_unorm(np.array(layers), (0, 0, 0, 1), bits, "constant_color", "one_minus_src_alpha",
                              (1, 1, 1, 0))
        np.testing.assert_array_equal(fb.codes(), ref)
    # opacity pass variant: texture modulated by primary colour (0, 0, 0, 1), buffer cleared to 1
    fb = FrameBuffer(S, S, "unorm12", device)
    fb.clear((1, 1, 1, 1))
    draw_textured_quads(fb, BlendUnit("one", "one_minus_src_alpha"), tex, corners, modulate=(0, 0, 0, 1))
    mod = np.array(layers) * np.float32([0, 0, 0, 1])
    ref = ref_blend_unorm(mod, (1, 1, 1, 1), 12, "one", "one_minus_src_alpha")
    np.testing.assert_array_equal(fb.codes(), ref)
    theta = fb.readback()[..., 0]
    assert 0 < theta.min() and theta.max() < 1


@pytest.mark.parametrize("device", DEVICES)
def test_framebuffer_clear_readback_render_to_texture_pingpong(device):
    fb = FrameBuffer(3, 2, "unorm12", device)
    fb.clear((0.5, 2.0, -1.0, 0.25))
    assert fb.codes()[1, 2].tolist() == [2048, 4095, 0, 1024]
    assert fb.readback().shape == (2, 3, 4) and fb.readback().dtype == np.float32
    fb.write(np.full((2, 3, 4), 0.1))
    assert fb.codes()[0, 0, 0] == 410
    tex = fb.to_texture()
    assert tex.fmt == "rgba32f"
    np.testing.assert_array_equal(tex.sample([[0.5 / 3, 0.25]])[0], fb.readback()[0, 0])
    fb8 = FrameBuffer(2, 2, "unorm8", device)
    fb8.write(np.random.default_rng(0).uniform(0, 1, (2, 2, 4)))
    t8 = fb8.to_texture()
    assert t8.fmt == "rgba8"
    np.testing.assert_array_equal(t8.values, fb8.readback())
    pp = PingPong(2, 2, "unorm8", device)
    pp.target.clear((1, 0, 0, 1))
    pp.swap()
    pp.target.clear((0, 1, 0, 1))
    assert pp.target.codes()[0, 0].tolist() == [0, 255, 0, 255]
    assert pp.source.codes()[0, 0].tolist() == [255, 0, 0, 255]
    np.testing.assert_array_equal(pp.source_texture().values[0, 0], [1, 0, 0, 1])


def test_blend_validation_names_the_argument():
    with pytest.raises(ConfigError, match=r"dst: unknown blend factor 'half'; allowed: zero, one"):
        BlendUnit("one", "half")
    with pytest.raises(ConfigError, match=r"src_alpha: unknown blend factor"):
        BlendUnit("one", "zero", src_alpha="bogus")
    with pytest.raises(ConfigError, match=r"fmt: snorm8 is not a frame-buffer format"):
        FrameBuffer(2, 2, "snorm8")
    with pytest.raises(ConfigError, match=r"dither: alpha dithering needs a fixed-point frame buffer"):
        BlendUnit("one", "zero", fmt="fp16", dither=True)
    with pytest.raises(ConfigError, match=r"fb: frame buffer format unorm12 differs"):
        BlendUnit.over(fmt="unorm8").blend_layers(FrameBuffer(1, 1, "unorm12"), np.zeros((1, 1, 1, 4)))
    with pytest.raises(ConfigError, match=r"constant: expected 4 finite numbers"):
        BlendUnit(constant=(1, 2))
    with pytest.raises(ConfigError, match=r"layers: expected shape \(K, 2, 2, 4\)"):
        BlendUnit().blend_layers(FrameBuffer(2, 2), np.zeros((1, 2, 3, 4)))
    with pytest.raises(ConfigError, match=r"size: 1000 is not a power of two"):
        dither_table(0, 1000)
    assert BlendUnit("GL_ONE", "GL_ONE_MINUS_SRC_ALPHA").dst_code == FACTORS["one_minus_src_alpha"]


@pytest.mark.parametrize("device", DEVICES)
def test_llvmpipe_arithmetic_exhaustive_8bit(device):
    """Every (colour, alpha) byte pair through (src_alpha, zero) and premultiplied "over": the
    ``llvmpipe`` arithmetic rounds each product with ``(ab + (ab >> 8) + 128) >> 8`` and adds with
    saturation; ``exact`` rounds ``ab / 255`` once. They differ in exactly 24 products."""
    s, a = np.meshgrid(np.arange(256), np.arange(256), indexing="ij")
    layer = np.stack([s, s, s, a], -1)[None].astype(np.float32) / 255
    ab = s * a
    per_product = (ab + (ab >> 8) + 128) >> 8
    exact = (2 * ab + 255) // 510
    got = {}
    for arith in ("exact", "llvmpipe"):
        fb = FrameBuffer(256, 256, "unorm8", device)
        fb.clear((0, 0, 0, 0))
        BlendUnit("src_alpha", "zero", arithmetic=arith).blend_layers(fb, layer)
        got[arith] = fb.codes()[..., 0]
    np.testing.assert_array_equal(got["exact"], exact)
    np.testing.assert_array_equal(got["llvmpipe"], per_product)
    assert (per_product != exact).sum() == 24 and np.abs(per_product - exact).max() == 1
    # premultiplied "over" of colour s, alpha a onto destination d = 200: s + mul(d, 255 - a), saturated
    fb = FrameBuffer(256, 256, "unorm8", device)
    fb.clear((200 / 255, 200 / 255, 200 / 255, 200 / 255))
    pm = np.stack([np.minimum(s, a)] * 3 + [a], -1)[None].astype(np.float32) / 255
    BlendUnit.over(arithmetic="llvmpipe").blend_layers(fb, pm)
    p = 200 * (255 - a)
    np.testing.assert_array_equal(fb.codes()[..., 0], np.minimum(np.minimum(s, a) + ((p + (p >> 8) + 128) >> 8), 255))
    with pytest.raises(ConfigError, match="arithmetic"):
        BlendUnit("one", "zero", arithmetic="approximate")
