"""The faithful presets run the formats, table sizes and programs their papers give (and say so)."""

from __future__ import annotations

import numpy as np
import pytest

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
