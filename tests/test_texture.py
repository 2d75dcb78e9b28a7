"""Texture units: filtering against hand-computed texel weights, per texel format; atlas; dependent lookups."""

import numpy as np
import pytest

from helpers import DEVICES
from warpvol.errors import ConfigError
from warpvol.gpu.formats import Pair16, UNorm
from warpvol.gpu.texture import (
    TEXEL_FORMATS,
    Texture1D,
    Texture2D,
    Texture3D,
    TextureAtlas,
    expand_rgba,
    sample_dependent,
)

FORMATS = sorted(TEXEL_FORMATS)


def _data(fmt, shape, seed=0):
    num, ch, _ = TEXEL_FORMATS[fmt]
    rng = np.random.default_rng(seed)
    lo = -1.0 if num.kind == 1 else 0.0
    return rng.uniform(lo, 1.0, shape + (ch,))


def _texels(fmt, data):
    """What the texels hold: the data rounded to the format, expanded to RGBA (NumPy only)."""
    num, _, layout = TEXEL_FORMATS[fmt]
    return expand_rgba(num.quantize(np.asarray(data, np.float32)), layout)


def _weights(t, n, bits):
    """Hand computation of OpenGL linear filtering on one axis: indices and weight of the upper texel.

    The texel-space coordinate is ``float32(u) * float32(n)`` (one fp32 multiply, as in the unit)."""
    t = (np.asarray(t, np.float32) * np.float32(n)).astype(np.float64) - 0.5
    k = np.floor(t)
    f = t - k
    if bits is not None:
        f = np.floor(f * 2**bits) / 2**bits
    k = k.astype(int)
    return np.clip(k, 0, n - 1), np.clip(k + 1, 0, n - 1), f


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("device", DEVICES)
def test_1d_filtering_per_format(fmt, device):
    n = 7
    data = _data(fmt, (n,), seed=hash(fmt) % 1000)
    T = _texels(fmt, data)
    centres = (np.arange(n) + 0.5) / n
    for bits in (8, None):
        lin = Texture1D(data, fmt=fmt, filter="linear", device=device, weight_bits=bits)
        near = Texture1D(data, fmt=fmt, filter="nearest", device=device)
        # texel values are the format's values, expanded as the table says
        np.testing.assert_array_equal(lin.values, T)
        # at texel centres both filters return the texel exactly
        np.testing.assert_array_equal(lin.sample(centres), T)
        np.testing.assert_array_equal(near.sample(centres), T)
        # edges and outside: clamp to edge
        np.testing.assert_array_equal(lin.sample([0.0, -0.3, 0.5 / n]), T[[0, 0, 0]])
        np.testing.assert_array_equal(lin.sample([1.0, 1.7, 1 - 0.5 / n]), T[[-1, -1, -1]])
        # between texels: hand-computed weights
        u = np.array([(k + 0.5 + f) / n for k in range(n - 1) for f in (0.25, 0.3, 0.5, 0.8125, 0.97)], np.float32)
        k0, k1, w = _weights(u, n, bits)
        expect = (1 - w)[:, None] * T[k0] + w[:, None] * T[k1]
        np.testing.assert_allclose(lin.sample(u), expect, atol=2e-6, rtol=0)
        # nearest: the texel containing u
        np.testing.assert_array_equal(near.sample(u), T[np.clip(np.floor(u.astype(np.float64) * n).astype(int), 0, n - 1)])


@pytest.mark.parametrize("device", DEVICES)
def test_weight_quantisation_is_visible_and_documented(device):
    t8 = Texture1D([0.0, 1.0], fmt="l8", device=device, weight_bits=8)
    t4 = Texture1D([0.0, 1.0], fmt="l8", device=device, weight_bits=4)
    tf = Texture1D([0.0, 1.0], fmt="l8", device=device, weight_bits=None)
    u = np.float32((0.5 + 0.3) / 2)  # fraction 0.3 between the two texel centres
    assert tf.sample([u])[0, 0] == pytest.approx(0.3, abs=1e-6)
    assert t8.sample([u])[0, 0] == pytest.approx(np.floor(0.3 * 256) / 256, abs=1e-7)  # 0.296875
    assert t4.sample([u])[0, 0] == pytest.approx(np.floor(0.3 * 16) / 16, abs=1e-7)  # 0.25


@pytest.mark.parametrize("fmt", ["rgba8", "la8", "rgba12", "hilo16", "rgba16f", "rgba8s"])
@pytest.mark.parametrize("device", DEVICES)
def test_2d_and_3d_filtering_against_hand_weights(fmt, device):
    rng = np.random.default_rng(5)
    data2 = _data(fmt, (5, 6), seed=1)
    T2 = _texels(fmt, data2)
    tex2 = Texture2D(data2, fmt=fmt, filter="linear", device=device)
    uv = rng.uniform(-0.1, 1.1, (300, 2)).astype(np.float32)
    i0, i1, fx = _weights(uv[:, 0], 6, 8)
    j0, j1, fy = _weights(uv[:, 1], 5, 8)
    e2 = ((1 - fy) * (1 - fx))[:, None] * T2[j0, i0] + ((1 - fy) * fx)[:, None] * T2[j0, i1] \
        + (fy * (1 - fx))[:, None] * T2[j1, i0] + (fy * fx)[:, None] * T2[j1, i1]
    np.testing.assert_allclose(tex2.sample(uv), e2, atol=3e-6, rtol=0)
    cx, cy = (np.arange(6) + 0.5) / 6, (np.arange(5) + 0.5) / 5
    gx, gy = np.meshgrid(cx, cy)
    np.testing.assert_array_equal(tex2.sample(np.stack([gx, gy], -1)), T2)

    data3 = _data(fmt, (3, 4, 5), seed=2)
    T3 = _texels(fmt, data3)
    tex3 = Texture3D(data3, fmt=fmt, filter="linear", device=device, weight_bits=None)
    uvr = rng.uniform(-0.1, 1.1, (300, 3)).astype(np.float32)
    a0, a1, wx = _weights(uvr[:, 0], 5, None)
    b0, b1, wy = _weights(uvr[:, 1], 4, None)
    c0, c1, wz = _weights(uvr[:, 2], 3, None)
    e3 = np.zeros((300, 4))
    for ci, cw in ((c0, 1 - wz), (c1, wz)):
        for bi, bw in ((b0, 1 - wy), (b1, wy)):
            for ai, aw in ((a0, 1 - wx), (a1, wx)):
                e3 += (cw * bw * aw)[:, None] * T3[ci, bi, ai]
    np.testing.assert_allclose(tex3.sample(uvr), e3, atol=3e-6, rtol=0)
    near = Texture3D(data3, fmt=fmt, filter="nearest", device=device)
    idx = [np.clip(np.floor(uvr[:, d].astype(np.float64) * s).astype(int), 0, s - 1) for d, s in enumerate((5, 4, 3))]
    np.testing.assert_array_equal(near.sample(uvr), T3[idx[2], idx[1], idx[0]])


@pytest.mark.parametrize("device", DEVICES)
def test_float_textures_can_be_forced_nearest(device):
    data = [[0.0], [1.0]]
    old = Texture1D(data, fmt="r32f", filter="linear", float_linear=False, device=device)
    new = Texture1D(data, fmt="r32f", filter="linear", device=device)
    assert old.effective_filter == "nearest" and new.effective_filter == "linear"
    assert old.sample([0.49])[0, 0] == 0.0 and old.sample([0.51])[0, 0] == 1.0
    assert new.sample([0.5])[0, 0] == pytest.approx(0.5)
    # fixed-point textures keep their filter
    assert Texture1D(data, fmt="l8", filter="linear", float_linear=False).effective_filter == "linear"


@pytest.mark.parametrize("device", DEVICES)
def test_la8_pair16_is_a_true_16bit_lookup(device):
    """Guthe et al.: 16-bit alpha in A (high byte) and L (low byte); filtering stays linear in the value."""
    rng = np.random.default_rng(7)
    v = rng.uniform(0, 1, 16)
    a, l = Pair16().encode(v)
    tex = Texture1D(np.stack([l / 255, a / 255], -1), fmt="la8", device=device, weight_bits=None)
    u = rng.uniform(0, 1, 500).astype(np.float32)
    s = tex.sample(u)
    got = Pair16.value(s[:, 3], s[:, 0])
    k0, k1, w = _weights(u, 16, None)
    v16 = UNorm(16).quantize(v).astype(np.float64)
    np.testing.assert_allclose(got, (1 - w) * v16[k0] + w * v16[k1], atol=1e-6)
    assert np.abs(got - ((1 - w) * v[k0] + w * v[k1])).max() < 2e-5  # 16-bit accurate, far below 1/255


@pytest.mark.parametrize("device", DEVICES)
def test_dependent_lookup(device):
    rng = np.random.default_rng(8)
    first = Texture2D(rng.uniform(0, 1, (4, 4, 4)), fmt="rgba8", device=device)
    second = Texture1D(rng.uniform(0, 1, (32, 4)), fmt="rgba8", device=device)
    uv = rng.uniform(0, 1, (200, 2)).astype(np.float32)
    for ch in (0, 3):
        expect = second.sample(first.sample(uv)[:, ch])
        np.testing.assert_array_equal(sample_dependent(first, second, uv, channel=ch), expect)
    first1 = Texture1D(rng.uniform(0, 1, (8, 2)), fmt="la8", device=device)
    np.testing.assert_array_equal(sample_dependent(first1, second, uv[:, 0], channel=3),
                                  second.sample(first1.sample(uv[:, 0])[:, 3]))


@pytest.mark.parametrize("device", DEVICES)
def test_atlas_tiles_equal_separate_textures(device):
    rng = np.random.default_rng(9)
    tiles = rng.uniform(0, 1, (5, 6, 7, 4))
    atlas = TextureAtlas(tiles, fmt="rgba8", device=device, weight_bits=None)
    assert atlas.cols == 3 and atlas.texture.shape == (2 * 8, 3 * 9)
    uv = np.concatenate([rng.uniform(-0.2, 1.2, (200, 2)), [[0, 0], [1, 1], [0, 1], [1, 0]]]).astype(np.float32)
    for k in range(5):
        ref = Texture2D(tiles[k], fmt="rgba8", device=device, weight_bits=None).sample(uv)
        np.testing.assert_allclose(atlas.sample(np.full(len(uv), k), uv), ref, atol=2e-6, rtol=0)
    # with 8-bit weights on a dyadic grid the atlas is bit-identical to the separate texture
    g = (np.arange(0, 65) / 64.0).astype(np.float32)
    uv8 = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    atlas8 = TextureAtlas(tiles[:, :4, :4], fmt="rgba8", device=device, cols=2)
    for k in range(5):
        ref = Texture2D(tiles[k, :4, :4], fmt="rgba8", device=device).sample(uv8)
        np.testing.assert_array_equal(atlas8.sample(np.full(len(uv8), k), uv8), ref)
    with pytest.raises(ConfigError, match=r"tiles: indices must be in \[0, 4\]"):
        atlas.sample([5], [[0.5, 0.5]])


def test_texture_validation_names_the_argument():
    with pytest.raises(ConfigError, match=r"fmt: unknown value 'rgb8'"):
        Texture1D([0.0, 1.0], fmt="rgb8")
    with pytest.raises(ConfigError, match=r"filter: unknown value 'cubic'"):
        Texture1D([0.0, 1.0], fmt="l8", filter="cubic")
    with pytest.raises(ConfigError, match=r"data: expected shape \(n, 4\)"):
        Texture1D([0.0, 1.0], fmt="rgba8")
    with pytest.raises(ConfigError, match=r"weight_bits: 0 is outside the allowed range \[1, 16\]"):
        Texture1D([0.0, 1.0], fmt="l8", weight_bits=0)
    with pytest.raises(ConfigError, match="data: texel data holds NaN"):
        Texture2D([[0.0, np.nan]], fmt="l8")
    with pytest.raises(ConfigError, match=r"coords: expected shape \(\.\.\., 2\)"):
        Texture2D([[0.0, 1.0]], fmt="l8").sample([0.5, 0.5, 0.5])
