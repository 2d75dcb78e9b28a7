"""Faithful hardware arithmetic of the table presets (Guthe's fragment registers, Roettger's
combiner constant, Kraus' fp16 buffer read back as a texture): each test shows what the paper's
hardware did and that it differs from the float arithmetic where it should."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warpvol.scene.transfer import TransferFunction


def _reg_fixed(x, rng, unit):
    from warpvol.kernels import formats as kf

    x = np.asarray(x, np.float32)
    out = wp.zeros(x.shape[0], dtype=wp.float32, device="cpu")
    wp.launch(kf.k_reg_fixed, dim=x.shape[0], inputs=[wp.array(x, dtype=wp.float32, device="cpu"), rng, unit, out],
              device="cpu")
    return out.numpy()


def _wiggly_tf():
    """Colour and extinction alternating between neighbouring entries: the colour slices C_hat(l)
    swing, so the degree-4 coefficients exceed 4 at lmax = 1."""
    k = (np.arange(16) % 2).astype(float)
    return TransferFunction.from_table(np.column_stack([k, np.zeros(16), np.full(16, 0.5), 40 * k + 0.1]),
                                       (0.0, 1.0), "color_extinction")


# ---------------------------------------------------------------- item 3: Guthe's fragment arithmetic


def test_combiner_register_saturates_and_rounds_to_9_bits():
    from warpvol.tables.guthe2d import ARITH

    rng, unit = ARITH["nv_combiner"]
    v = _reg_fixed([1.7, -3.0, 0.5, 0.3, 100.0 / 255 + 0.4 / 255, -0.001], rng, unit)
    assert v[0] == 1.0 and v[1] == -1.0  # saturation, not wrap
    np.testing.assert_allclose(v[2:], [128 / 255, 77 / 255, 100 / 255, 0.0], atol=1e-7)
    rng, unit = ARITH["ati_fs"]
    v = _reg_fixed([9.5, -20.0, 7.9, 1.0 / 8192 * 0.9], rng, unit)
    np.testing.assert_allclose(v, [8.0, -8.0, round(7.9 * 4096) / 4096, 0.0], atol=1e-7)


def test_coefficient_scales_are_the_hardware_ops_and_beyond_them_saturate():
    from warpvol.tables.guthe2d import build_guthe2d

    tf = _wiggly_tf()
    free = build_guthe2d(tf, n_s=32, degree=4, lmax=1.0)
    nv = build_guthe2d(tf, n_s=32, degree=4, lmax=1.0, scales="nv_combiner")
    ati = build_guthe2d(tf, n_s=32, degree=4, lmax=1.0, scales="ati_fs")
    mag = np.abs(nv.extra["coef"]).reshape(5, -1, 3).max(axis=1).max(axis=1)
    assert mag.max() > 4.0  # this TF needs more than the combiners' x4
    s_nv = np.asarray(nv.meta["coef_scale"])[:, 0]
    s_ati = np.asarray(ati.meta["coef_scale"])[:, 0]
    assert set(s_nv) <= {0.5, 1.0, 2.0, 4.0} and set(s_ati) <= {0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0}
    np.testing.assert_array_equal(s_nv, np.minimum(4.0, [min(v for v in (0.5, 1, 2, 4) if v >= m) if m <= 4 else 4
                                                          for m in mag]))
    # the combiners saturate the coefficient texels beyond x4, the Radeon's x8 holds them
    over = np.abs(nv.extra["coef"]) > 4.0
    assert nv.meta["coef_saturated"] == int(over.sum()) > 0 and ati.meta["coef_saturated"] == 0
    i = np.argwhere(over)[0]
    assert abs(nv.data[i[0], i[1], i[2], i[3]]) == 1.0  # stored at full scale (snorm8 +-1)
    # free scales are the per-channel maxima (the float shader)
    m = np.abs(free.extra["coef"]).reshape(5, -1, 3).max(axis=1)
    np.testing.assert_allclose(np.asarray(free.meta["coef_scale"]), np.where(m > 0, m, 1.0), rtol=1e-6)


def test_register_arithmetic_matches_closed_form_and_differs_from_fp32():
    """reconstruct() through the emulated combiners equals a numpy transcription of the combiner
    program (every result clamped to [-1, 1] and rounded to 1/255); the output colours are register
    values (multiples of 1/255) and differ from the fp32 shader's."""
    from warpvol.reproduce.guthe2002 import guthe_tf
    from warpvol.tables.guthe2d import build_guthe2d, reconstruct, textures

    tf = guthe_tf(64)
    g = build_guthe2d(tf, n_s=32, degree=2, lmax=1.0, scales="nv_combiner")
    rs = np.random.default_rng(3)
    sf, sb, l = rs.random(300), rs.random(300), rs.random(300)
    hw = reconstruct(g, sf, sb, l)
    fp = reconstruct(g, sf, sb, l, arith="fp32")
    # closed form of the register program on the same texels
    tx = textures(g)
    uv = np.stack([g.axes[2].coord(sf), g.axes[1].coord(sb)], -1).astype(np.float32)
    taps = [t.sample(uv)[:, :3].astype(np.float64) for t in tx["coef"]]

    def reg(v):
        return np.round(np.clip(v, -1, 1) * 255) / 255

    s = np.asarray(g.meta["coef_scale"])[:, 0]
    s_acc = max(1.0, s.max())
    x = reg(np.clip(l, 0, 1))[:, None]
    acc = reg(taps[0] * s[0] / s_acc)
    xi = np.ones_like(x)
    for i in (1, 2):
        xi = reg(xi * x)
        acc = reg(acc + reg(taps[i] * xi * (s[i] / s_acc)))
    a = reg(hw[:, 3])
    np.testing.assert_allclose(hw[:, 3], a, atol=1e-7)
    np.testing.assert_allclose(hw[:, :3], np.clip(reg(acc * a[:, None] * s_acc), 0, 1), atol=2e-6)
    assert np.abs(hw[:, :3] * 255 - np.round(hw[:, :3] * 255)).max() < 1e-3
    assert np.abs(fp[:, :3] * 255 - np.round(fp[:, :3] * 255)).max() > 0.1
    assert np.abs(hw - fp).max() > 1.0 / 255


def test_guthe_presets_run_their_cards_arithmetic():
    from warpvol.errors import ConfigError
    from warpvol.pipeline import Pipeline
    from warpvol.scene.builtin import builtin_scene

    sc = builtin_scene("box").with_camera(width_px=16, height_px=16)
    want = {"guthe2002_linear": "nv_combiner", "guthe2002_quadratic_gf4": "nv_combiner",
            "guthe2002_quartic_radeon": "ati_fs"}
    from test_pt_render import preset

    for name, arith in want.items():
        r = preset(name, table_guthe={"n_s": 64}).render(sc, quiet=True)  # shipped 512^2: the same programs
        st = r.report["stats"]["pt_guthe"]
        assert st["arith"] == arith and st["coef_saturated"] == 0
        assert np.asarray(r.image).max() > 0
    # a combiner program on a Radeon, or on a table with float scales, is refused naming the field
    stages = [{"stage": "vertex"}, {"stage": "sort", "method": "centroid"},
              {"stage": "table_guthe", "n_s": 16, "degree": 2, "scales": "nv_combiner"}, {"stage": "pt_project"},
              {"stage": "pt_guthe", "gpu": "radeon8500", "arith": "nv_combiner"}]
    with pytest.raises(ConfigError, match="arith"):
        Pipeline.from_config({"name": "t", "stages": stages}).render(sc, quiet=True)
    stages[2]["scales"], stages[4]["gpu"] = "free", "geforce4"
    with pytest.raises(ConfigError, match="scales"):
        Pipeline.from_config({"name": "t", "stages": stages}).render(sc, quiet=True)


# ---------------------------------------------------------------- item 5: GeForce3 combiner constant l/n


def test_geforce3_combiner_holds_l_over_n_as_an_8_bit_register():
    from warpvol.reproduce.roettger2002 import fig4_tf
    from warpvol.tables.roettger_hw import build_roettger_hw, ln_register

    tf = fig4_tf(0.15)
    kw = dict(n_s=8, n_l=4, lmax=1.0, steps=16, bits=8, passes="one", variant="geforce3")
    hw = build_roettger_hw(tf, **kw)
    ex = build_roettger_hw(tf, ln_format="fp32", **kw)
    ls = hw.axes[0].physical
    codes = hw.meta["ln_codes"]
    assert hw.meta["ln_format"] == "unorm8" and codes == [int(np.floor(255 * v / 16 + 0.5)) for v in ls]
    assert all(ln_register(v / 16)[0] == np.float32(c / 255) for v, c in zip(ls, codes))
    assert np.abs(hw.data[..., :3] - ex.data[..., :3]).max() > 0  # the register value changes the colours
    np.testing.assert_array_equal(hw.data[..., 3], ex.data[..., 3])  # opacity does not use l/n in the combiner
    # a slice whose l/n is below half a code: the register holds 0 and the slice emits nothing
    tiny = build_roettger_hw(tf, n_s=8, n_l=1, lmax=0.05, steps=64, bits=8, passes="one", variant="geforce3")
    assert tiny.meta["ln_codes"] == [0] and tiny.data[..., :3].max() == 0.0


# ---------------------------------------------------------------- item 7: Kraus' fp16 buffer without fp16 blending


def test_fp16_program_compositing_rounds_only_the_write():
    """The Quadro FX 3000 path: fp16(C + (1 - a) D) in fp32 (C, a unrounded); NV40 blending rounds
    C, a and the factor to binary16 first."""
    from warpvol.gpu.blend import BlendUnit, FrameBuffer

    rs = np.random.default_rng(7)
    layers = rs.random((6, 4, 8, 4)).astype(np.float32) * np.float32(0.37)
    out = {}
    for arith in ("program", "exact"):
        fb = FrameBuffer(8, 4, "fp16")
        fb.clear((0, 0, 0, 0))
        BlendUnit.over(arithmetic=arith).blend_layers(fb, layers)
        out[arith] = fb.readback()
    d = np.zeros((4, 8, 4), np.float32)
    n = np.zeros((4, 8, 4), np.float32)
    h = lambda v: np.asarray(v, np.float32).astype(np.float16).astype(np.float32)  # noqa: E731
    for s in layers:
        d = h(s + d * (np.float32(1) - s[..., 3:4]))
        sh = h(s)
        n = h(sh + n * h(np.float32(1) - sh[..., 3:4]))
    np.testing.assert_array_equal(out["program"], d)
    np.testing.assert_array_equal(out["exact"], n)
    assert np.abs(out["program"] - out["exact"]).max() > 0
    with pytest.raises(Exception, match="program"):
        BlendUnit.over(arithmetic="program").state(FrameBuffer(2, 2, "unorm8"))


def test_kraus_full_reads_the_fp16_buffer_back_per_fan_and_keeps_nv40_blending_by_name():
    from warpvol.errors import ConfigError
    from warpvol.pipeline import Pipeline
    from warpvol.scene.builtin import builtin_scene

    sc = builtin_scene("box").with_camera(width_px=24, height_px=24)
    cfg = {"name": "k", "stages": [{"stage": "vertex"}, {"stage": "sort", "method": "mpvo"},
                                   {"stage": "table_incremental", "n_s": 32, "n_l": 8, "format": "hilo16"},
                                   {"stage": "pt_project"}, {"stage": "pt_perspective", "thickness": "exact"},
                                   {"stage": "pt_table3d", "texel_format": "rgba16", "format": "fp16",
                                    "blend": "readback"}]}
    rb = Pipeline.from_config(cfg).render(sc, quiet=True)
    c = rb.report["counters"]["pt_table3d"]
    drawn = rb.report["stats"]["pt_table3d"]["fb_texture_rebinds"]
    assert c["fb_texture_rebinds"] == drawn > 0
    assert c["tex_2d_rgba16f_nearest"] == c["fragments"] > 0  # one buffer-texel fetch per fragment
    assert c.get("writes_fp16", 0) == c["fragments"] and not c.get("blends_fp16")
    cfg["stages"][-1]["blend"] = "unit"  # NV40: fp16 blending in the blending unit
    nv = Pipeline.from_config(cfg).render(sc, quiet=True)
    assert nv.report["counters"]["pt_table3d"]["blends_fp16"] == c["fragments"]
    assert "fb_texture_rebinds" not in nv.report["counters"]["pt_table3d"]
    d = np.abs(np.asarray(rb.image) - np.asarray(nv.image))
    assert 0 < d.max() < 2e-3  # rounding of the fragment before the blend, nothing else
    cfg["stages"][-1].update(blend="readback", format="unorm8")
    with pytest.raises(ConfigError, match="blend"):
        Pipeline.from_config(cfg).render(sc, quiet=True)
    assert Pipeline.load("kraus2004_full").stages[-1].config["blend"] == "readback"


def test_roettger_software_table_diagonal_eq6_as_printed_or_steins_step():
    """Emission density, a TF constant over the scalar range: on the diagonal the paper's sample count gives
    n = 1. Eq. 6 as printed (the paper's build, the default) then gives C = l kappa, growing without bound
    with l; Stein et al.'s step (``step="stein"``) is exact, kappa (1 - exp(-l rho)) / rho <= kappa / rho."""
    import numpy as np

    from warpvol.scene.transfer import TransferFunction
    from warpvol.tables.roettger_sw import build_roettger_sw

    kappa, rho = np.array([0.6, 0.3, 0.9]), 4.0
    tf = TransferFunction([[0.0, *kappa, rho], [1.0, *kappa, rho]], emission="emission_density")
    eq6 = build_roettger_sw(tf, n_s=8, n_l=4, lmax=3.0, m=2)
    stein = build_roettger_sw(tf, n_s=8, n_l=4, lmax=3.0, m=2, step="stein")
    for k, l in enumerate(eq6.axes[0].physical):
        assert np.allclose(eq6.data[k, 3, 3, :3], l * kappa, rtol=1e-5)
        assert np.allclose(stein.data[k, 3, 3, :3], kappa * (1 - np.exp(-l * rho)) / rho, rtol=1e-5)
        assert np.all(stein.data[k, 3, 3, :3] <= kappa / rho + 1e-6)
