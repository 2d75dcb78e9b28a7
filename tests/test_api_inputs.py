"""Issue 7 item 7: Python API input hygiene (types, ragged arrays, copies, device, reference shape)."""

import numpy as np
import pytest

from warpvol import Camera, ConfigError, MeshError, Pipeline, TetMesh, TransferFunction
from warpvol.scene.builtin import builtin_scene

TET_P = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]


@pytest.mark.parametrize("arg, value", [
    ("points", [[0, 0, 0], [1, 0], [0, 1, 0], [0, 0, 1]]),   # ragged
    ("points", "abc"),
    ("points", None),
    ("tets", [[0, 1, 2, 3], [0, 1]]),                        # ragged
    ("tets", [["a", "b", "c", "d"]]),
    ("tets", [[0.0, 1.0, 2.0, 3.0]]),                        # float indices
    ("scalars", [0, 1, [2, 3], 3]),                          # ragged
    ("scalars", {"a": 1}),
])
def test_tetmesh_bad_input_names_the_argument(arg, value):
    kw = dict(points=TET_P, tets=[[0, 1, 2, 3]], scalars=[0, 1, 2, 3])
    kw[arg] = value
    with pytest.raises(MeshError, match=arg):
        TetMesh(**kw, name="m")


def test_tetmesh_copies_its_inputs():
    p = np.array(TET_P, dtype=np.float64)
    t = np.array([[0, 1, 2, 3]], dtype=np.int64)
    s = np.arange(4.0)
    m = TetMesh(p, t, s)
    assert p.flags.writeable and t.flags.writeable and s.flags.writeable
    p[1, 0], s[0], t[0, 0] = 7.0, 9.0, 3
    assert m.points[1, 0] == 1.0 and m.scalars[0] == 0.0 and m.tets[0].tolist() == [0, 1, 2, 3]
    assert not m.points.flags.writeable  # the mesh's own copy is frozen


def test_camera_copies_its_inputs():
    eye = np.array([0.0, 0.0, 5.0])
    cam = Camera(eye=eye, width_px=4, height_px=4)
    eye[2] = 1.0
    assert cam.eye[2] == 5.0 and cam.eye is not eye
    with pytest.raises(ValueError):  # in place would leave forward/right/up stale: use replace()
        cam.eye[0] = 1.0
    assert cam.replace(eye=[0, 1, 5]).eye.tolist() == [0.0, 1.0, 5.0]


@pytest.mark.parametrize("kw, name", [
    (dict(eye=[0, 0]), "eye"), (dict(up="up"), "up"), (dict(width_px="512"), "width_px"),
    (dict(fov_y_deg=[30]), "fov_y_deg"), (dict(projection=3), "projection"),
])
def test_camera_bad_input_names_the_argument(kw, name):
    with pytest.raises(ConfigError, match=name):
        Camera(**kw)


def test_transfer_ragged_points_name_the_argument():
    with pytest.raises(ConfigError, match="points"):
        TransferFunction([[0, 0, 0, 0, 0], [1, 1, 1]])


def test_pipeline_render_validates_device_and_reference_before_rendering():
    scene = builtin_scene("box").with_camera(width_px=8, height_px=6)
    pipe = Pipeline.load("raycast")
    ran = []
    for st in pipe.stages:
        st.run = lambda ctx, name=st.name: ran.append(name)
    with pytest.raises(ConfigError, match=r"render\(device\).*'no_such_device'"):
        pipe.render(scene, device="no_such_device", quiet=True)
    with pytest.raises(ConfigError, match=r"render\(device\)"):
        pipe.render(scene, device=["cpu"], quiet=True)
    with pytest.raises(ConfigError, match=r"render\(reference\).*\(6, 8, 4\)"):
        pipe.render(scene, reference=np.zeros((8, 6, 4)), quiet=True)
    with pytest.raises(ConfigError, match=r"render\(reference\)"):
        pipe.render(scene, reference=[[1, 2], [3]], quiet=True)
    assert ran == []  # rejected before any stage ran
