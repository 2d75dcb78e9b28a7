"""Re-entry passes launch only the active rays (``ray_blocks``): the blocks cover exactly the active pixels,
and a render whose passes launch the whole image instead gives the same image, counters and stats."""

from __future__ import annotations

import json

import numpy as np
import pytest
import warp as wp

from warpvol.pipeline import Pipeline
from warpvol.raycasting.stages import raycast as rc
from warpvol.scene.builtin import builtin_scene


class _Ctx:
    def __init__(self, scene, device="cpu"):
        self.scene, self.device = scene, device


def _covered(ids, parts, n):
    ids = ids.numpy() if ids.shape[0] else None
    out = []
    for first, count in parts:
        out.extend(range(first, first + count) if ids is None else ids[first:first + count].tolist())
    return np.asarray(out, dtype=np.int64)


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_ray_blocks_cover_exactly_the_active_rays(threads):
    sc = builtin_scene("concave").with_camera(width_px=37, height_px=23)
    ctx, n = _Ctx(sc), 37 * 23
    # every ray active: row blocks over the whole image, no list
    ids, parts = rc.ray_blocks(ctx, np.ones(n, bool), threads, rows_per_block=4)
    assert ids.shape[0] == 0
    assert np.array_equal(_covered(ids, parts, n), np.arange(n))
    assert all(count <= 4 * 37 for _, count in parts)
    rng = np.random.default_rng(threads)
    for frac in (0.9, 0.3, 0.01):
        act = rng.random(n) < frac
        act[rng.integers(n)] = True
        ids, parts = rc.ray_blocks(ctx, act, threads, rows_per_block=4)
        got = _covered(ids, parts, n)
        assert np.array_equal(got, np.flatnonzero(act))  # each active ray once, in pixel order
        assert all(0 < count <= 4 * 37 for _, count in parts)
        assert len(parts) >= min(4 * threads, -(-int(act.sum()) // 64))
    ids, parts = rc.ray_blocks(ctx, np.zeros(n, bool), threads)
    assert parts == []


def _whole_image_blocks(ctx, active, threads, rows_per_block=16):
    """The launch every pass made before: all pixels in row blocks (inactive rays return at once)."""
    cam = ctx.scene.camera
    w = cam.width_px
    parts = [(r0 * w, nr * w) for r0, nr in rc.blocks(cam.height_px, 4)]
    return wp.zeros(0, dtype=wp.int32, device=ctx.device), parts if active.any() else []


def _untimed(d):
    return {k: _untimed(v) if isinstance(v, dict) else v for k, v in d.items() if not k.endswith("_s")}


@pytest.mark.parametrize("preset", ["raycast", "harc_best", "espinha2005_partial"])
def test_compacted_passes_equal_whole_image_passes(preset, monkeypatch):
    sc = builtin_scene("concave").with_camera(width_px=40, height_px=32)
    p = Pipeline.load(preset)
    if preset == "raycast":  # one entry per pass (its threads re-enter otherwise: no pass after the first)
        cfg = {"name": preset, "stages": [dict(st.config, stage=st.name) for st in p.stages]}
        for st in cfg["stages"]:
            if st["stage"] in ("raycast", "peel"):
                st["reentries"] = 0
        p = Pipeline.from_config(cfg)
    p.render(sc, quiet=True)  # both compared renders redraw (per-mesh data and tables cached)
    res = p.render(sc, quiet=True)
    passes = res.report["stats"].get("peel", res.report["stats"].get("harc_peel", {})).get("passes", 0)
    assert passes >= 2  # the concave mesh is re-entered: the passes after the first are compacted
    monkeypatch.setattr(rc, "ray_blocks", _whole_image_blocks)
    whole = p.render(sc, quiet=True)
    assert np.array_equal(res.image, whole.image)
    assert json.dumps(res.report["counters"], sort_keys=True, default=str) == \
        json.dumps(whole.report["counters"], sort_keys=True, default=str)
    assert json.dumps(_untimed(res.report["stats"]), sort_keys=True, default=str) == \
        json.dumps(_untimed(whole.report["stats"]), sort_keys=True, default=str)
