"""The faithful presets run the formats, table sizes and programs their papers give (and say so)."""

from __future__ import annotations

import numpy as np

from warpvol.pipeline import Pipeline
from warpvol.scene.builtin import builtin_scene


def _stage(pipe: Pipeline, name: str) -> dict:
    return next(s.config for s in pipe.stages if s.name == name)


def test_roettger2002_hw_runs_fig5_set_up_and_says_so():
    """Roettger & Ertl 2002 Figs. 4/5: 128 integration steps over a TF of 64 entries, 12 bits per channel on
    the Octane MXI (two passes: RGB visual). The preset's text names the 12-bit formats that run."""
    pipe = Pipeline.load("roettger2002_hw")
    t = _stage(pipe, "table_roettger_hw")
    assert (t["steps"], t["n_tex"], t["bits"], t["passes"]) == (128, 64, 12, "two")
    f = _stage(pipe, "pt_table3d")
    assert (f["texel_format"], f["format"]) == ("rgba12", "unorm12")
    for text in (pipe.known_losses, pipe.description):
        assert "12-bit" in text and "RGBA8" not in text and "8-bit frame" not in text
    assert "64-entry" in pipe.known_losses and "128 steps" in pipe.known_losses
    # what runs: 2 passes x n_l slices x 128 rectangles x n_s^2 blends, from a 64-texel TF texture
    from warpvol.tables.roettger_hw import build_roettger_hw

    sc = builtin_scene("box")
    tab = build_roettger_hw(sc.transfer, n_s=8, n_l=4, steps=t["steps"], n_tex=t["n_tex"], bits=12, emulate=False)
    assert (tab.meta["n_tex"], tab.meta["steps"], tab.meta["blends"]) == (64, 128, 2 * 4 * 128 * 8 * 8)


def test_kraus2004_full_runs_every_enhancement_on_every_scene():
    """Kraus et al. 2004 §5: the perspective division (11 instructions) and the logarithmic lookup (7)
    run in every fragment whatever the camera and the mesh's edge lengths; on an orthographic view of a
    narrow-range mesh (the box) the faithful preset still counts both."""
    from test_pt_render import preset

    tables = [s.config for s in Pipeline.load("kraus2004_full").stages if s.name == "table_incremental"]
    assert [t["axis"] for t in tables] == ["log2"] and tables[0]["applies_to"] == "any"
    assert _stage(Pipeline.load("kraus2004_full"), "pt_perspective")["orthographic"] == "run"
    pipe = preset("kraus2004_full", table_incremental={"n_s": 32})
    sc = builtin_scene("box").with_camera(width_px=16, height_px=16)
    assert sc.camera.projection == "orthographic"
    res = pipe.render(sc, quiet=True)
    assert not [s for s in res.report["skipped"] if s["stage"].startswith(("pt_perspective", "table_incremental"))]
    assert res.report["stats"]["pt"]["interpolation"] == "perspective-correct (exact thickness)"
    c = res.report["counters"]["pt_table3d"]
    # 11 division and 7 logarithmic-lookup instructions per fragment, and the read-back composite's one
    assert c["combiner_ops"] == (11 + 7 + 1) * c["fragments"] > 0
    skip = preset("kraus2004_full", table_incremental={"n_s": 32}, pt_perspective={"orthographic": "skip"})
    s = skip.render(sc, quiet=True)
    assert s.report["counters"]["pt_table3d"]["combiner_ops"] == (7 + 1) * c["fragments"]
    assert np.abs(np.asarray(s.image) - np.asarray(res.image)).max() < 1e-3  # w = 1: the same image


def test_guthe_presets_build_their_tables_as_the_paper_did():
    """Guthe et al. 2002 §4: the Radeon 8500 builds the colour slices by 12-bit ping-pong filtering (m = 128,
    4 steps per pass, one pass sequence per colour channel); the GeForce4 cannot (saturation loses the low
    bits), so its presets use the paper's software build with the same m. Exact slices are an option."""
    from test_pt_render import preset

    want = {"guthe2002_linear": ("software", None), "guthe2002_quadratic_gf4": ("software", None),
            "guthe2002_quartic_radeon": ("pingpong", "radeon8500")}
    for name, (slices, gpu) in want.items():
        t = _stage(Pipeline.load(name), "table_guthe")
        assert t["slices"] == slices and t["m"] == 128 and (gpu is None or t["gpu"] == gpu), name
    sc = builtin_scene("linear_box").with_camera(width_px=16, height_px=16)
    r = preset("guthe2002_quartic_radeon", table_guthe={"n_s": 16}).render(sc, quiet=True)
    c = r.report["counters"]["table_guthe"]
    assert c["passes"] == 4 * 3 * (128 // 4) and c["writes_unorm8"] == c["fragments"]  # 4 slices x 3 channels
    q = preset("guthe2002_quadratic_gf4", table_guthe={"n_s": 16}).render(sc, quiet=True)
    assert q.report["counters"]["table_guthe"]["sw_samples"] == 2 * 16 * 16 * 128  # 2 slices, m samples each
    e = preset("guthe2002_quadratic_gf4", table_guthe={"n_s": 16, "slices": "exact"}).render(sc, quiet=True)
    assert "sw_samples" not in e.report["counters"].get("table_guthe", {})
    assert 0 < np.abs(np.asarray(q.image) - np.asarray(e.image)).max() <= 1.5 / 255  # m = 128 samples vs exact


def test_espinha_partial_reads_the_tf_from_an_8_bit_texture():
    """Partial pre-integration reads the TF at both ends of each sub-segment; the faithful preset reads it
    from a 256-texel RGBA8 1D texture (what the throughput model prices), not from fp32 control points."""
    from test_pt_render import preset

    h = _stage(Pipeline.load("espinha2005_partial"), "harc")
    assert (h["tf_texture"], h["tf_texels"]) == ("rgba8", 256)
    sc = builtin_scene("sphere").with_camera(width_px=24, height_px=24)
    res = {t: preset("espinha2005_partial", harc={"tf_texture": t}).render(sc, quiet=True)
           for t in ("exact", "rgba8", "rgba16f")}
    c8, c16 = res["rgba8"].report["counters"]["harc"], res["rgba16f"].report["counters"]["harc"]
    assert c8["tex_1d_rgba8_linear"] == c16["tex_1d_rgba16f_linear"] > 0 and "tex_1d_rgba16f_linear" not in c8
    assert c8["tex_1d_rgba8_linear"] == res["exact"].report["counters"]["harc"]["tex_1d_rgba8_linear"]
    d8 = np.abs(np.asarray(res["rgba8"].image) - np.asarray(res["exact"].image)).max()
    d16 = np.abs(np.asarray(res["rgba16f"].image) - np.asarray(res["exact"].image)).max()
    assert 0 < d16 and 0 < d8  # the texture is what the program reads


def test_walk_listing_computes_both_scalars_per_cell_as_fig6_does():
    """Espinha & Celes Fig. 6 lines 10-11: each cell evaluates sf and sb from its own gradient (two DP4),
    as the emulated walk does; the listing carries no sf from the previous cell."""
    from warpvol.gpu import programs

    lines = [ln.split("#")[0].split() for ln in programs.WALK.strip().splitlines()]
    dp4 = [ln[1].rstrip(",") for ln in lines if ln and ln[0] == "DP4"]
    assert "sf" in dp4 and "sb" in dp4
    assert not any(ln[:2] == ["MOV", "sf,"] for ln in lines)
    assert (programs.n_alu(programs.WALK), programs.n_tex(programs.WALK)) == (30, 6)
