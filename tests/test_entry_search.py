"""The ray casters' entry search (``raycast``'s ``tile_entry`` over the faces binned by ``entry_bins``): faces
sorted by depth within a tile, skipped when wholly before the search's start, the search stopped at the first
face beyond the best crossing -- the same entries, bit for bit, as testing every face of the tile."""

import numpy as np
import pytest

from helpers import noisy_shell
from warpvol.pipeline import Pipeline
from warpvol.raycasting.stages import entry_bins
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera


def test_item_depths_sorts_each_tile_by_nearest_depth_with_suffix_maxima():
    rng = np.random.default_rng(1)
    tid = rng.integers(0, 7, 200)
    z = rng.normal(10.0, 3.0, (200, 3))
    order, depth = entry_bins.item_depths(tid, z)
    t, lo, hi = tid[order], z.min(axis=1)[order], z.max(axis=1)[order]
    assert np.all(np.diff(t) >= 0)
    for k in np.unique(t):
        sel = t == k
        assert np.all(np.diff(lo[sel]) >= 0)  # nearest depth ascending within the tile
        # the farthest depth from each item on, over this tile only (no leak from the tiles after it)
        assert np.allclose(depth[sel, 2], np.maximum.accumulate(hi[sel][::-1])[::-1], rtol=1e-5, atol=1e-4)
    assert np.all(depth[:, 0] <= lo) and np.all(depth[:, 1] >= hi)  # rounded outward to float32
    assert np.all(depth[:, 2] >= hi)
    empty_order, empty = entry_bins.item_depths(np.zeros(0, np.int64), np.zeros((0, 3)))
    assert len(empty_order) == 0 and empty.shape == (0, 3)


def every_face(tid, z):
    """The bins as tested before depth ordering: a tile's faces in index order, no depth bound."""
    order = np.argsort(tid, kind="stable")
    depth = np.tile(np.array([-np.inf, np.inf, np.inf], np.float32), (len(tid), 1))
    return order, depth


def eye_between_shells():
    sc = builtin_scene("sphere")
    sc.camera = Camera(eye=[0.3, 0.45, 0.2], target=[0.9, 0.1, -0.4], fov_y_deg=70, width_px=32, height_px=28)
    return sc


SCENES = {
    "perspective": lambda: noisy_shell(0, 48),
    "orthographic": lambda: noisy_shell(4, 48, projection="orthographic", ortho_height=3.0),
    "eye_inside": eye_between_shells,
}


def render_raycast(sc, tile):
    p = Pipeline.load("raycast")
    cfg = {"name": "t", "stages": [dict(st.config, stage=st.name) for st in p.stages]}
    for st in cfg["stages"]:
        if st["stage"] == "entry_bins":
            st["tile"] = tile
    return Pipeline.from_config(cfg).render(sc, quiet=True)


def counts(report):
    return {k: (v.get("entries"), v.get("cell_steps")) for k, v in report["counters"].items()}, \
        {k: report["stats"][k]["float64_rays"] for k in ("raycast", "peel")}


@pytest.mark.parametrize("tile", [4, 32])
@pytest.mark.parametrize("name", list(SCENES))
def test_depth_ordered_search_finds_the_entries_of_the_full_search(name, tile, monkeypatch):
    sc = SCENES[name]()
    got = render_raycast(sc, tile)
    with monkeypatch.context() as mp:
        mp.setattr(entry_bins, "item_depths", every_face)
        want = render_raycast(sc, tile)
    assert want.report["stats"]["peel"]["reentries"] > 0 or name == "eye_inside"
    assert np.array_equal(got.image, want.image)
    assert counts(got.report) == counts(want.report)
