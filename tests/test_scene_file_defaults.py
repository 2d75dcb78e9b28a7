"""A scene file without ``[transfer]`` / ``[camera]`` gets what the same mesh given on its own gets, and
unknown keys anywhere in a scene file are named all in one message, each with a did-you-mean."""

import numpy as np
import pytest

from test_scene import UNIT_TET, write_scene, write_vtu
from warpvol.cli import main
from warpvol.errors import ConfigError
from warpvol.scene.scene_file import load_scene
from warpvol.scene.spec import scene_from_spec

CAM = "[camera]\neye = [0.3, 0.2, 4]\ntarget = [0.25, 0.25, 0.25]\nwidth_px = 8\nheight_px = 8\n"


@pytest.fixture
def tet_file(tmp_path):
    write_vtu(tmp_path / "m.vtu", UNIT_TET, [[0, 1, 2, 3]], point_data={"s": np.array([0.0, 1.0, 2.0, 4.0])})
    return tmp_path / "m.vtu"


def test_scene_file_without_transfer_gets_the_mesh_files_default(tet_file):
    scene = load_scene(write_scene(tet_file.parent, '[mesh]\npath = "m.vtu"\nscalars = "s"\n' + CAM, "notf.toml"))
    alone = scene_from_spec(str(tet_file), scalars="s")  # as `warpvol render m.vtu`
    assert np.array_equal(scene.transfer.points, alone.transfer.points)
    assert scene.transfer.emission == alone.transfer.emission
    assert scene.transfer.srange == (0.0, 4.0)
    assert scene.camera.width_px == 8 and scene.camera.eye.tolist() == [0.3, 0.2, 4.0]  # its own camera kept


def test_scene_file_with_only_a_mesh_gets_the_fitted_camera_and_renders(tet_file, capsys):
    p = write_scene(tet_file.parent, '[mesh]\npath = "m.vtu"\nscalars = "s"\n', "mesh_only.toml")
    scene, alone = load_scene(p), scene_from_spec(str(tet_file), scalars="s")
    for key in ("eye", "target", "up"):
        assert np.array_equal(getattr(scene.camera, key), getattr(alone.camera, key)), key
    assert (scene.camera.fov_y_deg, scene.camera.width_px, scene.camera.height_px) == \
        (alone.camera.fov_y_deg, alone.camera.width_px, alone.camera.height_px)
    out = tet_file.parent / "img.exr"
    assert main(["render", str(p), "-o", str(out), "--width", "8", "--height", "8", "--compute-reference"]) == 0
    assert out.is_file() and "rmse=" in capsys.readouterr().out


def test_unknown_keys_in_every_table_are_named_in_one_message_with_did_you_mean(tet_file, capsys):
    text = ('nmae = "x"\n[mesh]\npath = "m.vtu"\nscalar = "s"\n[trasnfer]\npoints = []\n'
            '[camera]\nfov = 30\neyes = [0, 0, 5]\nsun = 2\n')
    p = write_scene(tet_file.parent, text, "typos.toml")
    with pytest.raises(ConfigError) as e:
        load_scene(p)
    msg = str(e.value)
    assert msg.startswith(f"{p}: unknown key(s) 'nmae' (did you mean 'name'?), 'trasnfer' (did you mean "
                          "'transfer'?); allowed: 'mesh', 'transfer', 'camera', 'name'. ")
    assert "mesh: unknown key(s) 'scalar' (did you mean 'scalars'?); allowed: " in msg
    assert ("camera: unknown key(s) 'fov' (did you mean 'fov_y_deg'?), 'eyes' (did you mean 'eye'?), "
            "'sun'; allowed: ") in msg
    # the command line: the same, on one line, exit 2, before the mesh is read
    assert main(["render", str(p), "-o", str(tet_file.parent / "never.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"warpvol: error: {msg}" and "\n" not in err


def test_nested_tables_are_checked_too(tmp_path):
    p = write_scene(tmp_path, '[mesh]\nraw = { path = "v.raw", dims = [2, 2, 2], dtype = "uint8", spacing = [1, 1, 1], '
                    'orign = [0, 0, 0] }\n[transfer]\ntable = { file = "t.csv", rnage = [0, 1] }\n', "nested.toml")
    with pytest.raises(ConfigError, match=r"nested\.toml: mesh\.raw: unknown key\(s\) 'orign' \(did you mean "
                       r"'origin'\?\); allowed: .*\. transfer\.table: unknown key\(s\) 'rnage' \(did you mean 'range'\?\)"):
        load_scene(p)
