"""scripts/bench_skip.py's transfer functions: the sparse one shows 5-10 % of the cells, the opaque one
makes every covered pixel of a view through the mesh opaque."""

import importlib.util
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def load_script():
    spec = importlib.util.spec_from_file_location("bench_skip", ROOT / "scripts" / "bench_skip.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_sparse_and_opaque_transfer_functions():
    from warpvol.conditioning.visibility import cell_visibility
    from warpvol.scene.builtin import builtin_scene

    bs = load_script()
    sc = builtin_scene("stiff")
    sparse, frac = bs.variant(sc, "sparse")
    assert 0.05 <= frac <= 0.10 and frac == float(cell_visibility(sc.mesh, sparse.transfer).mean())
    assert sparse.name == "stiff_sparse"
    opaque, frac = bs.variant(sc, "opaque")
    lo, hi = (np.asarray(b) for b in sc.mesh.bounds)
    assert frac == 1.0 and np.allclose(opaque.transfer.extinction, 100.0 / np.linalg.norm(hi - lo))


def test_corner_view_turns_the_camera_half_way_to_a_corner():
    from warpvol.scene.builtin import builtin_scene

    bs = load_script()
    sc = builtin_scene("stiff")
    cv = bs.corner_view(sc)
    cam, cc = sc.camera, cv.camera
    assert cv.name == "stiff_corner" and np.allclose(cc.eye, cam.eye) and sc.camera is cam  # the scene kept
    corner = 2.0 * np.asarray(cc.target) - np.asarray(cam.target)  # target half way from the old target to it
    lo, hi = (np.asarray(b) for b in sc.mesh.bounds)
    assert np.allclose(np.minimum(np.abs(corner - lo), np.abs(corner - hi)), 0.0)  # a bounding-box corner
    axes = np.asarray(cam.right) + np.asarray(cam.true_up) + np.asarray(cam.forward)
    others = [np.array([x, y, z]) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    assert corner @ axes >= max(c @ axes for c in others) - 1e-12
