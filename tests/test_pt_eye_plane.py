"""Cell projection and the eye plane: every preset with the ``vertex`` and ``pt_project`` stages gives
a transparent image when nothing is in view, and refuses (a :class:`~warpvol.errors.ConfigError`
naming the alternatives) a view where tets cross the eye plane, which projected tetrahedra cannot
draw -- never a silently wrong image. :func:`warpvol.projection.pt.eye_plane_check` is the one place deciding."""

import numpy as np
import pytest

from helpers import box_mesh, merge, scene
from tolerances import preset_tolerance
from warpvol.errors import ConfigError
from warpvol.metrics import image_error
from warpvol.pipeline import Pipeline, list_presets
from warpvol.projection.pt import eye_plane_check
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh
from warpvol.tools.bench import quick_pipeline
from warpvol.tools.stress import build_case, run_case


def pt_presets():
    out = []
    for name, _ in list_presets():
        names = [st.name for st in Pipeline.load(name).stages]
        if "vertex" in names and ("pt_project" in names or "vicp" in names):  # cell projection
            out.append(name)
    return out


PT_PRESETS = pt_presets()


def test_pt_presets_found():
    assert {"pt_vertex_color", "pt_best", "weiler2003_vicp", "roettger2002_cylindrical"} <= set(PT_PRESETS)


def _box_scene(**cam):
    sc = builtin_scene("box")
    return scene(sc.mesh, sc.transfer, Camera(width_px=12, height_px=10, **cam), name="box")


LOOKING_AWAY = {
    "persp_behind": dict(eye=(0.2, 0.1, 4.0), target=(0.2, 0.1, 5.0)),
    "persp_beside": dict(eye=(0.2, 0.1, 4.0), target=(1.2, 0.1, 4.0), fov_y_deg=40.0),
    "ortho_behind": dict(projection="orthographic", eye=(0.2, 0.1, 4.0), target=(0.2, 0.1, 5.0)),
    "ortho_beside": dict(projection="orthographic", eye=(5.0, 0.0, 0.0), target=(5.0, 0.0, -1.0), ortho_height=2.0),
}


@pytest.mark.parametrize("view", sorted(LOOKING_AWAY))
def test_check_nothing_in_view(view):
    sc = _box_scene(**LOOKING_AWAY[view])
    r = eye_plane_check(sc.mesh, sc.camera)
    assert r.status == "empty" and "transparent" in r.message
    assert r.behind + r.outside >= sc.mesh.n_tets - r.crossing
    assert (render_reference(sc.mesh, sc.transfer, sc.camera) == 0).all()


@pytest.mark.parametrize("view", ["persp_behind", "ortho_beside"])
@pytest.mark.parametrize("name", PT_PRESETS)
def test_looking_away_is_transparent(name, view):
    sc = _box_scene(**LOOKING_AWAY[view])
    res = quick_pipeline(Pipeline.load(name)).render(sc, quiet=True)
    assert res.image.shape == (10, 12, 4) and (res.image == 0).all()
    assert "transparent" in res.report["stats"]["pt"]["note"]
    assert res.report["counters"]["vertex"]["primitives_culled"] == sc.mesh.n_tets
    ran = set(res.report["stages"])
    skipped = {s["stage"] for s in res.report["skipped"]}
    assert ran - {"condition", "visibility"} == {"vertex"} and (skipped >= {"pt_project"} or skipped >= {"vicp"})


CROSSING = {
    "eye_inside": dict(eye=(0.1, 0.2, 0.3), target=(1.0, 0.5, -2.0), fov_y_deg=90.0),
    "near_plane_cuts_cells": dict(eye=(0.1, 0.2, 1.0001), target=(0.0, 0.0, 0.0), fov_y_deg=120.0),
    "ortho_eye_plane_cuts": dict(projection="orthographic", eye=(0.1, 0.05, 0.3), target=(0.3, -0.05, -0.7),
                                 ortho_height=1.5),
    # every vertex in front, but the nearest 1e-7 of the depth range from the eye: no float32 window
    "vertex_at_eye": dict(eye=(-1.0 - 1e-7, 0.0, 0.0), target=(1.0, 0.3, 0.2), fov_y_deg=60.0),
}


@pytest.mark.parametrize("view", sorted(CROSSING))
def test_crossing_is_refused(view):
    sc = _box_scene(**CROSSING[view])
    r = eye_plane_check(sc.mesh, sc.camera)
    assert r.status == "refuse" and r.crossing > 0
    assert "cross the eye plane" in r.message and "raycast or harc_best" in r.message
    with pytest.raises(ConfigError, match=r"\(vertex\): .*tets cross the eye plane.* use raycast or harc_best"):
        Pipeline.load("pt_vertex_color").render(sc, quiet=True)


@pytest.mark.parametrize("case", ["camera_inside", "near_plane_cuts_cells", "ortho_eye_inside",
                                  "camera_looking_away"])
def test_stress_cases_declined_or_exact(case):
    """``warpvol stress`` rows: the crossing cases 'declined' with the reason, looking away 'ok' and exact."""
    pipes = [quick_pipeline(Pipeline.load(n)) for n in ("pt_vertex_color", "pt_best", "roettger2002_hw")]
    rows = run_case(build_case(case, quick=True), pipes)[1:]
    for row in rows:
        if case == "camera_looking_away":
            assert row["status"] == "ok" and row["rmse"] == 0 and row["max_abs"] == 0, row
        else:
            assert row["status"] == "declined" and "cross the eye plane" in row["message"], row


def test_close_tet_is_drawn():
    """A tet fully in front, 0.02 from the eye, with another 400 away (the bounds' near plane,
    1e-4 x far = 0.04, would lie behind the close tet): both drawn, as the reference shows them."""
    near = TetMesh([[-0.004, -0.004, -0.02], [0.005, -0.003, -0.021], [0.0, 0.005, -0.022], [0.0005, 0.0, -0.05]],
                   [[0, 1, 2, 3]], [0.2, 0.8, 0.5, 1.0])
    far = box_mesh(lo=(10, -40, -420), hi=(150, 40, -380), dims=(2, 2, 2), scalar=lambda p: np.full(len(p), 0.5))
    mesh = merge(near, far)
    sc = builtin_scene("box")
    cam = Camera(eye=(0, 0, 0), target=(0, 0, -1), fov_y_deg=60.0, width_px=24, height_px=24)
    tf = sc.transfer.__class__([[0.0, 1.0, 0.5, 0.2, 20.0], [1.0, 0.2, 0.6, 1.0, 40.0]])
    s = scene(mesh, tf, cam)
    r = eye_plane_check(mesh, cam)
    assert r.status == "draw" and 0 < r.near <= 0.99 * 0.02 and cam.depth_range(*mesh.bounds)[0] > 0.02
    ref = render_reference(mesh, tf, cam)
    assert ref[12, 12, 3] > 0.1 and ref[12, 17, 3] > 0.1  # the close tet in the centre, the far box right
    res = Pipeline.load("pt_best").render(s, reference=ref, quiet=True)
    tol = preset_tolerance("pt_best")
    err = image_error(res.image, ref)
    assert err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"], err
