"""Transfer functions from and to ParaView presets and VTK functions (issue 14)."""

import json

import numpy as np
import pytest
from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

from warpvol import ConfigError, TransferFunction
from warpvol.scene.scene_file import scene_from_config
from warpvol.scene.transfer import DEFAULT_RESAMPLE, OPACITY_MAX

# a ParaView-exported preset: colour nodes and opacity nodes at different scalars
PRESET = {
    "Name": "two ramps",
    "ColorSpace": "RGB",
    "NanColor": [1, 1, 0],
    "RGBPoints": [0.0, 0.0, 0.0, 1.0, 0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0],
    "Points": [0.0, 0.0, 0.5, 0.0, 0.25, 0.2, 0.5, 0.0, 1.0, 0.9, 0.5, 0.0],
}
COOL_TO_WARM = {  # ParaView's "Cool to Warm" (Diverging colour space)
    "Name": "Cool to Warm", "ColorSpace": "Diverging",
    "RGBPoints": [0, 0.23137254902, 0.298039215686, 0.752941176471,
                  0.5, 0.865, 0.865, 0.865, 1, 0.705882352941, 0.0156862745098, 0.149019607843],
    "Points": [0, 0, 0.5, 0, 1, 1, 0.5, 0],
}


def test_paraview_preset_file_loads_to_expected_control_points(tmp_path):
    f = tmp_path / "p.json"
    f.write_text(json.dumps([PRESET]))
    tf = TransferFunction.from_paraview(f, unit_distance=2.0)
    assert tf.s.tolist() == [0.0, 0.25, 0.5, 1.0]  # union of colour and opacity nodes
    assert np.allclose(tf.rgb, [[0, 0, 1], [0.5, 0.5, 1], [1, 1, 1], [1, 0, 0]])
    a = np.array([0.0, 0.2, 0.2 + 0.7 * (0.25 / 0.75), 0.9])  # opacity interpolated at the colour node 0.5
    assert np.allclose(tf.extinction, -np.log(1 - a) / 2.0, rtol=1e-14)
    assert tf.emission == "color_extinction"
    # back out: same nodes, opacities recovered, and a ParaView-importable file
    out = tf.to_paraview(tmp_path / "back.json", name="back", unit_distance=2.0)
    back = json.loads((tmp_path / "back.json").read_text())
    assert back == [out] and out["Name"] == "back" and out["ColorSpace"] == "RGB"
    pts = np.array(out["Points"]).reshape(-1, 4)
    assert np.allclose(pts[:, 1], a, rtol=0, atol=1e-15) and (pts[:, 2] == 0.5).all() and (pts[:, 3] == 0).all()
    assert np.array_equal(np.array(out["RGBPoints"]).reshape(-1, 4), tf.points[:, :4])
    again = TransferFunction.from_paraview(tmp_path / "back.json", unit_distance=2.0)
    assert np.allclose(again.points, tf.points, rtol=1e-13, atol=0)


def test_paraview_range_rescales_like_paraview():
    tf = TransferFunction.from_paraview(PRESET, range=(-2.0, 6.0))
    assert tf.s.tolist() == [-2.0, 0.0, 2.0, 6.0]
    assert tf.srange == (-2.0, 6.0)


def test_paraview_diverging_colour_space_is_sampled_with_vtk():
    tf = TransferFunction.from_paraview(COOL_TO_WARM)
    assert len(tf.points) == DEFAULT_RESAMPLE + 1  # 256 uniform samples plus the midpoint node 0.5
    ctf = vtkColorTransferFunction()
    ctf.SetColorSpaceToDiverging()
    for x, r, g, b in np.reshape(COOL_TO_WARM["RGBPoints"], (-1, 4)):
        ctf.AddRGBPoint(x, r, g, b)
    assert np.allclose(tf.rgb, [ctf.GetColor(s) for s in tf.s], rtol=0, atol=1e-12)
    # the diverging midpoint is not the RGB average: linear RGB would be wrong here
    k = int(np.argmin(np.abs(tf.s - 0.25)))
    assert np.abs(tf.rgb[k] - (np.array(ctf.GetColor(0.0)) + ctf.GetColor(0.5)) / 2).max() > 0.02


def _vtk_pair():
    c, o = vtkColorTransferFunction(), vtkPiecewiseFunction()
    for x, r, g, b in [(-1, 0.1, 0.2, 0.3), (0.5, 0.9, 0.8, 0.1), (2, 0.3, 0.3, 1.0)]:
        c.AddRGBPoint(x, r, g, b)
    for x, a in [(-1, 0.0), (1.0, 0.4), (2, 1.0)]:
        o.AddPoint(x, a)
    return c, o


def test_vtk_pair_loads_and_round_trips():
    c, o = _vtk_pair()
    tf = TransferFunction.from_vtk(c, o, unit_distance=0.25)
    assert tf.s.tolist() == [-1.0, 0.5, 1.0, 2.0]
    assert np.allclose(tf.rgb[1], [0.9, 0.8, 0.1]) and np.allclose(tf.rgb[2], c.GetColor(1.0))
    assert np.allclose(tf.extinction[:3], -np.log(1 - np.array([0.0, 0.3, 0.4])) / 0.25, rtol=1e-14)
    assert np.isclose(tf.extinction[3], -np.log(1 - OPACITY_MAX) / 0.25)  # opacity 1 -> capped, finite
    c2, o2 = tf.to_vtk(unit_distance=0.25)
    for s in tf.s:  # same functions at every node (opacity 1 comes back as 1)
        assert np.allclose(c2.GetColor(s), c.GetColor(s), atol=1e-15)
        assert np.isclose(o2.GetValue(s), o.GetValue(s), rtol=0, atol=1e-14)
    assert o2.GetValue(2.0) == 1.0
    back = TransferFunction.from_vtk(c2, o2, unit_distance=0.25)
    assert np.allclose(back.points, tf.points, rtol=1e-13, atol=0)


def test_vtk_midpoint_sharpness_is_sampled():
    c, o = _vtk_pair()
    o.RemoveAllPoints()
    o.AddPoint(-1, 0.0, 0.2, 0.5)  # midpoint 0.2, sharpness 0.5: not linear
    o.AddPoint(2, 0.8)
    tf = TransferFunction.from_vtk(c, o, resample=33)
    alpha = 1 - np.exp(-tf.extinction)
    assert len(tf.s) >= 33
    assert np.allclose(alpha, [o.GetValue(s) for s in tf.s], atol=1e-12)


def test_scene_file_paraview_key(tmp_path):
    (tmp_path / "preset.json").write_text(json.dumps([PRESET, COOL_TO_WARM]))
    (tmp_path / "one.json").write_text(json.dumps(PRESET))
    s = scene_from_config({"mesh": {"builtin": "box"}, "transfer": {"paraview": "one.json"}}, tmp_path)
    assert np.allclose(s.transfer.points, TransferFunction.from_paraview(PRESET).points, rtol=0, atol=0)
    cfg = {"mesh": {"builtin": "box"},
           "transfer": {"paraview": {"file": "preset.json", "name": "two ramps", "range": [0, 2], "unit_distance": 0.5}}}
    s = scene_from_config(cfg, tmp_path)
    assert s.transfer.srange == (0.0, 2.0)
    assert np.allclose(s.transfer.points, TransferFunction.from_paraview(PRESET, range=(0, 2), unit_distance=0.5).points)


@pytest.mark.parametrize("transfer, match", [
    ({"paraview": "preset.json"}, r"transfer\.paraview: .* holds 2 presets; pass name= one of \['two ramps', 'Cool to Warm'\]"),
    ({"paraview": "missing.json"}, r"transfer\.paraview\.file: file not found"),
    ({"paraview": {"file": "preset.json", "name": "x"}}, r"transfer\.paraview: name: no preset 'x'"),
    ({"paraview": {"file": "preset.json", "colour": 1}}, r"transfer\.paraview: unknown key\(s\) 'colour'"),
    ({"paraview": "one.json", "emission": "emission_density"}, r"transfer\.paraview: .*'color_extinction'"),
    ({"paraview": "one.json", "points": [[0, 0, 0, 0, 0], [1, 0, 0, 0, 0]]}, r"exactly one of 'points', 'table' or 'paraview'"),
    ({"paraview": "cmap.json"}, r"has no opacity 'Points'.*opacity="),
    ({"paraview": "bad.json"}, r"ColorSpace: unknown value 'CMYK'"),
])
def test_scene_file_paraview_errors(tmp_path, transfer, match):
    (tmp_path / "preset.json").write_text(json.dumps([PRESET, COOL_TO_WARM]))
    (tmp_path / "one.json").write_text(json.dumps(PRESET))
    (tmp_path / "cmap.json").write_text(json.dumps({k: v for k, v in PRESET.items() if k != "Points"}))
    (tmp_path / "bad.json").write_text(json.dumps(dict(PRESET, ColorSpace="CMYK")))
    with pytest.raises(ConfigError, match=match):
        scene_from_config({"mesh": {"builtin": "box"}, "transfer": transfer}, tmp_path, where="s.toml")


def test_colour_map_only_with_constant_opacity_and_wrong_arguments():
    cmap = {k: v for k, v in PRESET.items() if k != "Points"}
    tf = TransferFunction.from_paraview(cmap, opacity=0.5)
    assert np.allclose(tf.extinction, np.log(2.0))
    with pytest.raises(ConfigError, match="color: expected a vtkColorTransferFunction"):
        TransferFunction.from_vtk("red", vtkPiecewiseFunction())
    with pytest.raises(ConfigError, match="opacity: expected a vtkPiecewiseFunction"):
        TransferFunction.from_vtk(vtkColorTransferFunction(), [0, 1])
    with pytest.raises(ConfigError, match="unit_distance"):
        TransferFunction.from_paraview(PRESET, unit_distance=0)
    with pytest.raises(ConfigError, match="range"):
        TransferFunction.from_paraview(PRESET, range=(1, 1))
    with pytest.raises(ConfigError, match="RGBPoints: expected a flat list of 4-tuples"):
        TransferFunction.from_paraview(dict(PRESET, RGBPoints=[0, 1, 2]))
    with pytest.raises(ConfigError, match="emission.*no VTK/ParaView counterpart"):
        TransferFunction([[0, 1, 1, 1, 1], [1, 1, 1, 1, 1]], "emission_density").to_vtk()
