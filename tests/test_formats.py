"""Number formats: exhaustive checks of every code against NumPy, kernels against the NumPy twins."""

import numpy as np
import pytest

from helpers import DEVICES
from warpvol.errors import ConfigError
from warpvol.gpu.formats import (
    FP16,
    FP32,
    Pair16,
    SNorm,
    Split12,
    UNorm,
    decode_warp,
    encode_warp,
    get_format,
    quantize_warp,
)

BITS = (8, 12, 16)


def _product(x, n):
    """float32(x) * float32(n) exactly as the encoder computes it, as float64."""
    return (np.float32(x) * np.float32(n)).astype(np.float64)


@pytest.mark.parametrize("bits", BITS)
@pytest.mark.parametrize("device", DEVICES)
def test_unorm_every_code_round_trips(bits, device):
    f = UNorm(bits)
    codes = np.arange(2**bits)
    values = f.decode(codes)
    assert values.dtype == np.float32
    np.testing.assert_array_equal(values, (codes.astype(np.float32) / np.float32(2**bits - 1)))
    assert values[0] == 0.0 and values[-1] == 1.0 and np.all(np.diff(values) > 0)
    for rounding in ("nearest", "nearest_even", "truncate"):
        g = UNorm(bits, rounding=rounding)
        if rounding != "truncate":  # truncation of c/N*N may fall just below c: not a round trip by design
            np.testing.assert_array_equal(g.encode(values), codes)
        np.testing.assert_array_equal(encode_warp(g, values, device), g.encode(values))
    np.testing.assert_array_equal(decode_warp(f, codes, device), values)
    np.testing.assert_array_equal(quantize_warp(f, values, device), values)


@pytest.mark.parametrize("bits", BITS)
@pytest.mark.parametrize("device", DEVICES)
def test_unorm_rounding_ties(bits, device):
    n = 2**bits - 1
    c = np.arange(n)
    # float32 inputs whose float32 product with n is exactly c + 0.5 (a true tie)
    cand = np.concatenate([np.nextafter(((c + 0.5) / n).astype(np.float32), d, dtype=np.float32) for d in (-1, 1)]
                          + [((c + 0.5) / n).astype(np.float32)])
    cc = np.concatenate([c, c, c])
    tie = _product(cand, n) == cc + 0.5
    x, lo = cand[tie], cc[tie]
    assert tie.sum() > n // 4, "too few exact ties found for the test to mean anything"
    expect = {"nearest": lo + 1, "nearest_even": np.where(lo % 2 == 0, lo, lo + 1), "truncate": lo}
    for rounding, e in expect.items():
        g = UNorm(bits, rounding=rounding)
        np.testing.assert_array_equal(g.encode(x), e, err_msg=rounding)
        np.testing.assert_array_equal(encode_warp(g, x, device), e, err_msg=rounding)
    # just off the tie: all nearest modes agree, truncation does not round up
    below = np.nextafter(x, np.float32(-1), dtype=np.float32)
    ok = _product(below, n) < lo + 0.5
    for rounding in ("nearest", "nearest_even"):
        np.testing.assert_array_equal(UNorm(bits, rounding=rounding).encode(below[ok]), lo[ok])


@pytest.mark.parametrize("device", DEVICES)
def test_unorm_random_inputs_kernel_equals_numpy(device):
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.uniform(-0.5, 1.5, 400_000), rng.uniform(-1e6, 1e6, 1000), [np.nan, np.inf, -np.inf]])
    x = x.astype(np.float32)
    for name in ("unorm8", "unorm12", "unorm16", "unorm8_wrap", "unorm12_trunc", "unorm16_even_wrap", "unorm4",
                 "snorm8", "snorm16", "snorm8_wrap", "snorm12_trunc"):
        f = get_format(name)
        np.testing.assert_array_equal(encode_warp(f, x, device), f.encode(x), err_msg=name)
        np.testing.assert_array_equal(quantize_warp(f, x, device), f.quantize(x), err_msg=name)
    # every result is a valid code, NaN -> 0
    c = UNorm(12).encode(x)
    assert c.min() == 0 and c.max() == 4095 and c[-3] == 0


@pytest.mark.parametrize("bits", BITS)
@pytest.mark.parametrize("device", DEVICES)
def test_saturate_versus_wrap_every_16bit_integer(bits, device):
    """Integer-valued inputs k/N for k in [-2^16, 2^16): saturate clamps, wrap keeps the low bits."""
    n = 2**bits - 1
    k = np.arange(-(2**16), 2**16)
    x = (k.astype(np.float64) / n).astype(np.float32)
    assert np.all(np.rint(_product(x, n)) == k)  # the inputs really encode the integers k
    sat, wrap = UNorm(bits), UNorm(bits, overflow="wrap")
    np.testing.assert_array_equal(sat.encode(x), np.clip(k, 0, n))
    np.testing.assert_array_equal(wrap.encode(x), k & n)
    np.testing.assert_array_equal(encode_warp(sat, x, device), np.clip(k, 0, n))
    np.testing.assert_array_equal(encode_warp(wrap, x, device), k & n)


def test_radeon_mask_extracts_the_low_bits_geforce_saturates():
    """Guthe et al.: a 12-bit value v = k / (16 * 255) times 256, stored to 8 bits: the Radeon's bit mask
    (wrap) keeps exactly its low 4 bits (the Split12 low channel); GeForce saturation loses them."""
    k = np.arange(4096)
    v = (k / (16.0 * 255.0)).astype(np.float32)
    wrapped = UNorm(8, overflow="wrap").encode(v * np.float32(256.0))
    np.testing.assert_array_equal(wrapped, (k & 15) << 4)
    np.testing.assert_array_equal(wrapped[:4081], Split12().channels(k[:4081] / 4080.0)[1])
    saturated = UNorm(8).encode(v * np.float32(256.0))
    np.testing.assert_array_equal(saturated, np.minimum(16 * k, 255))


@pytest.mark.parametrize("device", DEVICES)
def test_snorm_every_code(device):
    for bits in BITS:
        f = SNorm(bits)
        m = 2 ** (bits - 1) - 1
        codes = np.arange(-m - 1, m + 1)
        vals = f.decode(codes)
        assert vals[0] == -1.0 and vals[1] == -1.0 and vals[-1] == 1.0 and vals[m + 1] == 0.0
        np.testing.assert_array_equal(f.encode(vals[1:]), codes[1:])
        np.testing.assert_array_equal(f.encode(-vals[1:]), -codes[1:])  # symmetric
        np.testing.assert_array_equal(encode_warp(f, vals, device), f.encode(vals))
        np.testing.assert_array_equal(decode_warp(f, codes, device), vals)
        w = SNorm(bits, overflow="wrap")
        k = np.arange(-(2**bits) - 5, 2**bits + 5)
        x = (k / m).astype(np.float32)
        np.testing.assert_array_equal(w.encode(x), ((k + m + 1) & (2**bits - 1)) - m - 1)
        np.testing.assert_array_equal(f.encode(x), np.clip(k, -m, m))


def test_split12_every_code():
    s = Split12()
    k = np.arange(4096)
    hi, lo = s.split(k)
    np.testing.assert_array_equal(hi, k // 16)
    np.testing.assert_array_equal(lo, k % 16)
    np.testing.assert_array_equal(s.join(hi, lo), k)
    k = k[:4081]  # value k / 4080: 255 in the high channel alone is 1.0 (Guthe et al.)
    x = s.decode12(k)
    h8, l8 = s.channels(x)
    assert h8.max() == 255 and l8.max() == 240 and np.all(l8 % 16 == 0)
    np.testing.assert_array_equal(s.from_channels(h8, l8), x)
    np.testing.assert_array_equal(s.encode12(x), k)
    # the ping-pong kernel's reading H + L / 256 of the two channels is the same value
    np.testing.assert_allclose(h8 / 255.0 + (l8 / 255.0) / 256.0, x, rtol=0, atol=1e-7)
    # the high channel alone is the value truncated to 8 bits (error < 16 codes of 4080)
    assert np.all((x - h8 / 255.0 >= -1e-7) & (x - h8 / 255.0 < 16 / 4080.0))
    with pytest.raises(ConfigError, match="code12"):
        s.split([4096])


def test_pair16_every_code():
    p = Pair16()
    c = np.arange(2**16)
    a, l = p.encode(UNorm(16).decode(c))
    np.testing.assert_array_equal(a, c >> 8)
    np.testing.assert_array_equal(l, c & 255)
    v = p.decode(a, l)
    np.testing.assert_allclose(v, c / 65535.0, atol=2e-7, rtol=0)
    np.testing.assert_array_equal(UNorm(16).encode(v), c)  # the formula is a true 16-bit value
    # linear in (A, L): the interpolation of two channel pairs is the interpolation of the values
    t = np.float32(0.375)
    mix = p.value((1 - t) * a[:-1] / 255 + t * a[1:] / 255, (1 - t) * l[:-1] / 255 + t * l[1:] / 255)
    np.testing.assert_allclose(mix, (1 - t) * v[:-1] + t * v[1:], atol=3e-7)


@pytest.mark.parametrize("device", DEVICES)
def test_fp16_every_code_and_ties_to_even(device):
    bits = np.arange(2**16, dtype=np.uint16)
    h = bits.view(np.float16)
    fin = np.isfinite(h)
    vals = FP16.decode(bits[fin])
    np.testing.assert_array_equal(FP16.encode(vals).view(np.uint16), bits[fin])
    np.testing.assert_array_equal(quantize_warp(FP16, vals, device), vals)
    # exact midpoints between neighbouring positive halves: must go to the even significand
    pos = np.unique(h[fin & (h >= 0)].astype(np.float64))
    mid = (pos[:-1] + pos[1:]) / 2
    ok = mid.astype(np.float32).astype(np.float64) == mid  # exactly representable in fp32
    mid32 = mid[ok].astype(np.float32)
    assert ok.sum() > 30000
    got = quantize_warp(FP16, mid32, device)
    np.testing.assert_array_equal(got, FP16.quantize(mid32))
    gb = got.astype(np.float16).view(np.uint16)
    assert np.all(gb % 2 == 0)  # even significand
    rng = np.random.default_rng(2)
    x = np.concatenate([rng.uniform(-7e4, 7e4, 100_000), rng.normal(0, 1e-5, 10_000)]).astype(np.float32)
    with np.errstate(over="ignore"):
        ref = x.astype(np.float16).astype(np.float32)
    np.testing.assert_array_equal(quantize_warp("fp16", x, device), ref)


def test_fp32_identity():
    x = np.random.default_rng(3).normal(size=1000).astype(np.float32)
    np.testing.assert_array_equal(FP32.quantize(x), x)
    np.testing.assert_array_equal(FP32.decode(FP32.encode(x)), x)


def test_format_names_and_errors_name_the_argument():
    assert get_format("unorm12") == UNorm(12)
    assert get_format("unorm10_trunc_wrap") == UNorm(10, rounding="truncate", overflow="wrap")
    assert get_format("snorm8").max_code == 127
    with pytest.raises(ConfigError, match=r"bits.*\[1, 16\]"):
        UNorm(17)
    with pytest.raises(ConfigError, match=r"rounding.*'nearest'"):
        UNorm(8, rounding="up")
    with pytest.raises(ConfigError, match=r"overflow.*'saturate', 'wrap'"):
        UNorm(8, overflow="clip")
    with pytest.raises(ConfigError, match=r"fb_fmt: unknown format 'rgb565'"):
        get_format("rgb565", name="fb_fmt")
    with pytest.raises(ConfigError, match=r"fmt: 'unorm20'"):
        get_format("unorm20")
    with pytest.raises(ConfigError, match="quantize_warp"):
        encode_warp("fp16", [0.5])
