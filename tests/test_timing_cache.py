"""Timings split by cause (kernel compilation, per-mesh set-up, the frame) and the session caches of
:func:`warpvol.render` / :func:`warpvol.compare`."""

import numpy as np
import pytest

import warpvol
from warpvol import cache
from warpvol.errors import ConfigError
from warpvol.timing import CompileClock, split_times


def small(name, px=16):
    return warpvol.builtin_scene(name).with_camera(width_px=px, height_px=px)


@pytest.mark.parametrize("pipeline", ["raycast", "harc_best", "pt_best", "roettger2000_3d"])
def test_split_accounts_for_the_total(pipeline):
    r = warpvol.Pipeline.load(pipeline).render(small("concave"), quiet=True)
    rep = r.report
    assert rep["compile_s"] >= 0 and rep["setup_s"] >= 0 and rep["render_s"] > 0
    assert rep["compile_s"] + rep["setup_s"] + rep["render_s"] == pytest.approx(rep["total_s"], rel=1e-12, abs=1e-12)
    rows = rep["stage_timing"]
    assert set(rep["stages"]) <= set(rows)
    assert all(0 <= v["compile_s"] <= v["s"] for v in rows.values())


def test_second_render_reuses_setup_and_tables():
    warpvol.clear_cache()
    for pipeline, setup_stages in (("raycast", {"cell_setup"}), ("harc_best", {"cell_setup", "harc_mesh"}),
                                   ("roettger2000_3d", {"table_roettger_sw"})):
        # a new mesh object each call, equal content: found by its content hash
        a = warpvol.render(small("sphere"), pipeline=pipeline)
        b = warpvol.render(small("sphere"), pipeline=pipeline)
        assert not setup_stages & set(a.report["cached"]), pipeline
        assert setup_stages <= set(b.report["cached"]), (pipeline, b.report["cached"])
        assert np.array_equal(a.image, b.image)
    # another TF on the same mesh: the per-mesh data is reused, the TF table is built again
    s = small("sphere")
    tf = warpvol.TransferFunction(s.transfer.points * [1, 1, 1, 1, 2.0])
    c = warpvol.render(s, transfer=tf, pipeline="roettger2000_3d")
    assert "table_roettger_sw" not in c.report["cached"]


def test_reference_cached_by_scene_content():
    warpvol.clear_cache()
    a = warpvol.render(small("box"), reference=True)
    b = warpvol.render(small("box"), reference=True)
    assert a.report["reference_cached"] is False and b.report["reference_cached"] is True
    assert np.array_equal(a.reference, b.reference)
    c = warpvol.render(small("box", 17), reference=True)  # another camera: another reference
    assert c.report["reference_cached"] is False


def test_cache_budget_evicts_least_recently_used():
    warpvol.clear_cache()
    try:
        warpvol.render(small("box"), reference=True)
        warpvol.render(small("sphere"), reference=True)
        info = warpvol.cache_info()
        assert info["reference"]["entries"] == 2 and info["mesh"]["entries"] == 2
        warpvol.set_cache_budget(info["reference"]["bytes"] // 2 + 1)
        after = warpvol.cache_info()
        total = sum(after[k]["bytes"] for k in ("mesh", "pipeline", "reference"))
        assert total <= after["budget_bytes"] and after["reference"]["entries"] < 2
        with pytest.raises(ConfigError, match="set_cache_budget"):
            warpvol.set_cache_budget(-1)
    finally:
        warpvol.set_cache_budget(2 << 30)
        warpvol.clear_cache()
    assert all(warpvol.cache_info()[k]["entries"] == 0 for k in ("mesh", "pipeline", "reference"))


def test_edited_pipeline_file_is_a_new_pipeline(tmp_path):
    f = tmp_path / "p.toml"
    f.write_text('[[stages]]\nstage = "cell_setup"\n[[stages]]\nstage = "entry_bins"\ntile = 4\n'
                 '[[stages]]\nstage = "raycast"\n')
    a = warpvol.render(small("box"), pipeline=str(f))
    f.write_text('[[stages]]\nstage = "cell_setup"\n[[stages]]\nstage = "entry_bins"\ntile = 8\n'
                 '[[stages]]\nstage = "raycast"\n')
    b = warpvol.render(small("box"), pipeline=str(f))
    key_a = [k for k in cache._caches["pipeline"] if k[0][0] == "file"]
    assert len(key_a) == 2 and np.array_equal(a.image, b.image)


def test_compile_clock_counts_a_module_load():
    import warp as wp

    # a module made for this test: its first load on the CPU is a compilation (or a kernel-cache load)
    src = "import warp as wp\n@wp.kernel\ndef k(a: wp.array(dtype=float)):\n    a[wp.tid()] = 2.0 * a[wp.tid()] + %r\n"
    import importlib.util
    import sys
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "wv_clock_probe.py"
        path.write_text(src % float(np.random.default_rng().integers(1 << 30)))
        spec = importlib.util.spec_from_file_location("wv_clock_probe", path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules["wv_clock_probe"] = mod
        spec.loader.exec_module(mod)
        a = wp.zeros(4, dtype=float, device="cpu")
        with CompileClock() as clock:
            wp.launch(mod.k, dim=4, inputs=[a], device="cpu")
        with CompileClock() as again:
            wp.launch(mod.k, dim=4, inputs=[a], device="cpu")
        del sys.modules["wv_clock_probe"]
    assert clock.available and clock.seconds > 0 and "wv_clock_probe" in clock.modules[0]
    assert again.seconds == 0 and again.modules == []


def test_compile_clock_starts_no_thread_for_a_loaded_module(monkeypatch):
    """Warp calls its loader on every launch; for a module already loaded the wrapped loader returns
    without starting the timer that announces a slow compilation (a thread per launch otherwise)."""
    import warp as wp

    import warpvol.timing as timing
    from warpvol.kernels import blend

    wp.load_module(blend, device="cpu")
    started = []
    monkeypatch.setattr(timing.threading, "Timer", lambda *a, **k: started.append(a) or pytest.fail("timer"))
    with CompileClock() as clock:
        for _ in range(3):
            wp.load_module(blend, device="cpu")
    assert clock.available and started == [] and clock.modules == []


def test_split_times_adds_up():
    rows = {"a": {"s": 1.0, "compile_s": 0.5, "setup": True}, "b": {"s": 0.25, "compile_s": 0.0, "setup": False}}
    out = split_times(rows, 1.5)
    assert out == {"compile_s": 0.5, "setup_s": 0.5, "render_s": 0.5, "total_s": 1.5}


def test_compare_keeps_declining_presets_and_reports_warm_and_cold():
    s = small("box").with_camera(eye=(0.01, 0.02, 0.03), target=(1, 0.5, -2), fov_y_deg=90.0)
    cmp = warpvol.compare(s, ["raycast", "pt_best", "raycast"], repeats=2)
    rows = {r["pipeline"]: r for r in cmp.table}
    assert list(rows) == ["raycast", "pt_best", "raycast#2"]
    assert rows["pt_best"]["status"] == "declined" and "eye" in rows["pt_best"]["reason"]
    assert rows["raycast"]["status"] == "ok" and rows["raycast"]["cold_s"] > 0 and rows["raycast"]["time_s"] > 0
    assert set(cmp.results) == {"raycast", "raycast#2"} and "| pt_best | declined |" in cmp.markdown()
