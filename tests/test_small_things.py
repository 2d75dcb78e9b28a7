"""The command line's and the API's small courtesies: comma lists of presets, a "did you mean" for a
misspelt preset, and compare's figure keeping a row (with the reason) for a pipeline that declined."""

import matplotlib.pyplot
import pytest

import warpvol
from warpvol.cli import main
from warpvol.errors import ConfigError
from warpvol.pipeline import Pipeline
from warpvol.tools.bench import load_pipelines, resolve_pipelines


def test_pipelines_accept_comma_lists():
    assert resolve_pipelines(["raycast,pt_best"]) == ["raycast", "pt_best"]
    assert resolve_pipelines(["raycast,", "pt_best", "harc_best,vsbuffer_best"]) == \
        ["raycast", "pt_best", "harc_best", "vsbuffer_best"]
    assert [p.name for p in load_pipelines(["raycast,pt_best"])] == ["raycast", "pt_best"]


def test_plan_takes_a_comma_list(capsys):
    assert main(["plan", "builtin:box", "--width", "8", "--height", "8", "--pipeline", "raycast,pt_best",
                 "--no-measure", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "raycast on " in out and "pt_best on " in out


@pytest.mark.parametrize("typo,suggested", [("raycats", "raycast"), ("pt_bst", "pt_best"),
                                            ("kraus2004_ful", "kraus2004_full")])
def test_misspelt_preset_gets_did_you_mean(typo, suggested, capsys):
    with pytest.raises(ConfigError, match=rf"did you mean '{suggested}'"):
        Pipeline.load(typo)
    assert main(["render", "builtin:box", "--pipeline", typo, "-o", "never.png"]) == 2
    assert f"did you mean '{suggested}'" in capsys.readouterr().err


def test_compare_figure_shows_a_declined_pipeline_with_its_reason():
    # the eye inside the box: cell projection declines, ray casting renders
    scene = warpvol.builtin_scene("box").with_camera(width_px=12, height_px=10, eye=(0.1, 0.2, 0.3),
                                                     target=(1.0, 0.5, -2.0), fov_y_deg=90.0)
    fig, table = warpvol.compare(scene, ["raycast", "pt_best"], repeats=0)
    assert [r["status"] for r in table] == ["ok", "declined"]
    titles = [ax.get_title() for ax in fig.axes]
    assert "pt_best: declined" in titles
    panel = fig.axes[titles.index("pt_best: declined")]
    text = " ".join(t.get_text() for t in panel.texts).replace("\n", " ")
    assert "cross the eye plane" in text and not panel.images
    assert len([ax for ax in fig.axes if ax.images]) == 2  # raycast's image and error map
    matplotlib.pyplot.close(fig)


@pytest.mark.parametrize("which", ["distance", "wavelet"])
def test_default_transfer_function_uses_the_range(which):
    """A mesh on its own (default colour map, opacity ramp and camera) gives an image whose brightest channel
    comes near the colour map's brightness and whose mesh is neither empty nor opaque."""
    import numpy as np
    import pyvista as pv

    if which == "distance":
        grid = pv.ImageData(dimensions=(12, 12, 12), spacing=(0.2, 0.2, 0.2))
        grid.point_data["r"] = np.linalg.norm(grid.points - 1.1, axis=1)
    else:
        grid = pv.Wavelet(extent=(-5, 5, -5, 5, -5, 5))
    img = warpvol.render(grid, size=48).image
    covered = img[..., 3] > 1e-3
    assert img[..., :3].max() >= 0.6
    assert 0.35 <= img[covered][:, 3].mean() <= 0.85
