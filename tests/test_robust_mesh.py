"""Mesh checks the ray walk relies on (issue 7): duplicated tets, inverted tets, cracks left by dropped
zero-volume tets; the per-mesh cell cache; the float64 redo of rays the float32 walk cannot resolve."""

import warnings

import numpy as np
import pytest

from helpers import box_mesh, scene
from tolerances import preset_tolerance
from warpvol.errors import MeshError
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import TransferFunction

TOL = preset_tolerance("raycast")
TF = TransferFunction([[-1.0, 0.2, 0.4, 1.0, 0.8], [1.0, 1.0, 0.5, 0.2, 1.6], [3.0, 1.0, 1.0, 1.0, 0.4]])


def test_duplicated_tet_is_an_error_naming_both():
    pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]
    with pytest.raises(MeshError, match=r"tets\[0\] and tets\[2\] are the same tet"):
        TetMesh(pts, [[0, 1, 2, 3], [1, 2, 3, 4], [3, 1, 0, 2]], np.zeros(5), name="dup")


def test_inverted_tets_are_reoriented_and_render_like_the_originals():
    m = box_mesh(dims=(3, 3, 3), scalar=lambda p: p[:, 0] + p[:, 1] * p[:, 2])
    tets = m.tets.copy()
    flip = np.arange(len(tets)) % 3 == 0
    tets[flip] = tets[flip][:, [1, 0, 2, 3]]
    m2 = TetMesh(m.points, tets, m.scalars)
    assert m2.n_reoriented == flip.sum()
    cam = Camera(eye=[1.5, 2.0, 4.0], width_px=16, height_px=16)
    a = Pipeline.load("raycast").render(scene(m, TF, cam), quiet=True).image
    b = Pipeline.load("raycast").render(scene(m2, TF, cam), quiet=True).image
    np.testing.assert_allclose(a, b, atol=1e-6)


def kite_with_crack():
    # two tets above and two below a flat 'kite' sliver (dropped as zero-volume): a crack
    q = np.array([[-1, 0, 0], [0, -0.7, 0], [1.2, 0, 0], [0, 0.8, 1e-14]])
    pts = np.vstack([q, [0.1, 0.05, 1.0], [-0.1, 0.0, -1.0]])
    tets = [[0, 1, 2, 3], [0, 1, 3, 4], [1, 2, 3, 4], [0, 1, 2, 5], [0, 2, 3, 5]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return TetMesh(pts, tets, [0.0, 1.0, -0.5, 2.5, 0.3, -0.8])


def test_crack_from_dropped_tet_makes_mesh_non_convex_and_peel_runs():
    m = kite_with_crack()
    assert m.n_dropped == 1 and len(m.crack_faces) == 4 and not m.is_convex
    cam = Camera(projection="orthographic", eye=[0.05, 0.0, 3.0], target=[0.05, 0, 0], ortho_height=2.2,
                 width_px=24, height_px=24)
    sc = scene(m, TF, cam)
    ref = render_reference(m, TF, cam)
    res = Pipeline.load("raycast").render(sc, quiet=True)
    assert "peel" in res.report["stages"] and res.report["stats"]["peel"]["reentries"] > 0
    assert np.abs(res.image - ref).max() <= TOL["max_abs"]


def test_collapsed_tet_leaves_no_crack():
    # a tet on a repeated point has zero volume; its two copies of a face pair up its neighbours
    pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, 1], [0.3, 0.3, -1]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = TetMesh(pts, [[0, 1, 2, 3], [0, 1, 2, 2], [0, 2, 1, 4]], np.zeros(5))
    assert m.n_dropped == 1 and len(m.crack_faces) == 0 and m.is_convex


def test_cell_data_cached_per_mesh():
    cam = Camera(eye=[1.5, 2.0, 4.0], width_px=8, height_px=8)
    pipe = Pipeline.load("raycast")
    m1 = box_mesh(dims=(3, 3, 3))
    r1 = pipe.render(scene(m1, TF, cam), quiet=True)
    r2 = pipe.render(scene(m1, TF, cam.replace(eye=[2.0, 1.0, 4.0])), quiet=True)
    m2 = box_mesh(dims=(4, 3, 3), scalar=lambda p: p[:, 0])
    r3 = pipe.render(scene(m2, TF, cam), quiet=True)
    assert [r.report["stats"]["cell_setup"]["cached"] for r in (r1, r2, r3)] == [False, True, False]
    fresh = Pipeline.load("raycast").render(scene(m2, TF, cam), quiet=True)
    assert np.array_equal(r3.image, fresh.image)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_unresolved_rays_are_redone_in_float64_and_counted(projection):
    # mark rays as failed after the float32 pass: the stage must redo them exactly and count them
    from warpvol.raycasting.stages import raycast as rc
    from warpvol.stage import Context

    m = box_mesh(dims=(4, 4, 4), scalar=lambda p: np.sin(2 * p[:, 0]) + p[:, 1])
    cam = Camera(projection=projection, eye=[1.2, 1.5, 4.0], ortho_height=2.5, width_px=12, height_px=10)
    sc = scene(m, TF, cam)
    ref = render_reference(m, TF, cam)
    pipe = Pipeline.load("raycast")
    pipe.render(sc, quiet=True)
    ctx = Context(scene=sc, persistent=pipe.persistent, quiet=True)
    for st in pipe.stages[:pipe.stage_keys().index("entry_bins") + 1]:  # condition ... entry_bins
        st.run(ctx)
    state = rc.MarchState(120, "cpu")
    rc.march_pass(ctx, state, max_steps=10**6, t_min=0.0, threads=1)
    import warp as wp

    status = state.status.numpy()
    pick = np.array([0, 13, 55, 61, 119])
    already = set(np.flatnonzero(status == 2).tolist())  # rays the float32 pass itself left to the float64 redo
    status[pick] = 2  # STATUS_FAILED
    state.status = wp.array(status, dtype=wp.int32)
    assert rc.resolve_failed(ctx, state) == len(already | set(pick.tolist()))
    img = state.image(10, 12).reshape(-1, 4)
    np.testing.assert_allclose(img[pick], ref.reshape(-1, 4)[pick], atol=1e-6)
