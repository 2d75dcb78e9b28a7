"""Transfer function (NumPy vs @wp.func), camera matrices vs Contract 2 rays, image I/O, Blunt Fin."""

from pathlib import Path

import numpy as np
import pytest
import warp as wp

from tolerances import preset_tolerance
from warpvol.io import read_exr, write_exr, write_png
from warpvol.kernels import tf as ktf
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


@wp.kernel
def _eval_kernel(s: wp.array(dtype=float), tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4),
                 out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    out[i] = ktf.tf_eval(s[i], tf_s, tf_v)


def test_tf_eval_device_matches_numpy_including_clamping():
    rng = np.random.default_rng(0)
    # float32-representable control points: the device holds float32
    pts = np.column_stack([np.cumsum(rng.random(17) + 0.01), rng.random((17, 4))]).astype(np.float32).astype(float)
    tf = TransferFunction(pts)
    s = np.concatenate([np.linspace(pts[0, 0] - 1, pts[-1, 0] + 1, 1001), pts[:, 0]]).astype(np.float32)
    tf_s, tf_v = tf.to_warp("cpu")
    out = wp.zeros(len(s), dtype=wp.vec4, device="cpu")
    wp.launch(_eval_kernel, dim=len(s), inputs=[wp.array(s, device="cpu"), tf_s, tf_v, out], device="cpu")
    np.testing.assert_allclose(out.numpy(), tf.evaluate(s.astype(np.float64)), atol=2e-6)


@wp.kernel
def _upper_kernel(s: wp.array(dtype=float), k0: wp.array(dtype=wp.int32), tf_s: wp.array(dtype=float),
                  out: wp.array2d(dtype=wp.int32)):
    i = wp.tid()
    out[i, 0] = ktf.tf_upper(s[i], tf_s)
    out[i, 1] = ktf.tf_upper_from(s[i], k0[i], tf_s)


def test_tf_upper_from_any_start_equals_binary_search():
    # every start index 0..K against scalars at, between and beyond the control points, inf and NaN
    cps = np.array([0.19, 0.9, 1.5, 2.5, 5.0], dtype=np.float32)
    vals = np.concatenate([cps, np.nextafter(cps, -np.inf), np.nextafter(cps, np.inf), [-1.0, 1.0, 7.0],
                           [np.inf, -np.inf, np.nan]]).astype(np.float32)
    s = np.repeat(vals, len(cps) + 1)
    k0 = np.tile(np.arange(len(cps) + 1, dtype=np.int32), len(vals))
    out = wp.zeros((len(s), 2), dtype=wp.int32, device="cpu")
    wp.launch(_upper_kernel, dim=len(s), inputs=[wp.array(s, device="cpu"), wp.array(k0, device="cpu"),
                                                 wp.array(cps, device="cpu"), out], device="cpu")
    got = out.numpy()
    np.testing.assert_array_equal(got[:, 1], got[:, 0])
    want = np.where(np.isnan(s), len(cps), np.searchsorted(cps, s, side="right"))
    np.testing.assert_array_equal(got[:, 0], want)


def test_tf_hash_changes_with_content_and_model():
    a = TransferFunction([[0, 1, 1, 1, 1], [1, 0, 0, 0, 2]])
    b = TransferFunction([[0, 1, 1, 1, 1], [1, 0, 0, 0, 2]])
    c = TransferFunction([[0, 1, 1, 1, 1], [1, 0, 0, 0, 2.5]])
    d = TransferFunction([[0, 1, 1, 1, 1], [1, 0, 0, 0, 2]], "emission_density")
    assert a.hash == b.hash and len({a.hash, c.hash, d.hash}) == 3


def test_tf_table_file(tmp_path):
    p = tmp_path / "tf.csv"
    p.write_text("0,0,0,0\n1,0.5,0,2\n1,1,1,4\n")
    tf = TransferFunction.from_config({"table": {"file": "tf.csv", "range": [10, 20]}}, tmp_path)
    np.testing.assert_array_equal(tf.s, [10, 15, 20])
    np.testing.assert_allclose(tf.evaluate(12.5), [0.5, 0.25, 0, 1.0])


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_matrices_project_each_pixel_ray_to_its_pixel_centre(projection):
    cam = Camera(projection=projection, eye=[1.0, 2.0, 6.0], target=[0.2, -0.1, 0.3], up=[0.1, 1, 0],
                 fov_y_deg=35, ortho_height=2.5, width_px=13, height_px=7)
    o, d = cam.rays()
    pts = o + 3.7 * d  # any point on each ray
    m = cam.viewport_matrix() @ cam.projection_matrix(0.5, 20.0) @ cam.view_matrix()
    h = np.c_[pts.reshape(-1, 3), np.ones(pts.size // 3)] @ m.T
    win = (h[:, :2] / h[:, 3:4]).reshape(7, 13, 2)
    jj, ii = np.meshgrid(np.arange(13) + 0.5, np.arange(7) + 0.5)
    np.testing.assert_allclose(win[..., 0], jj, atol=1e-9)
    np.testing.assert_allclose(win[..., 1], ii, atol=1e-9)
    # depth in [0, 1] between near and far, increasing along the ray
    z = (h[:, 2] / h[:, 3])
    assert ((z > 0) & (z < 1)).all()


def test_exr_round_trip_and_png(tmp_path):
    img = np.random.default_rng(1).random((5, 7, 4)).astype(np.float32)
    write_exr(tmp_path / "a.exr", img)
    np.testing.assert_array_equal(read_exr(tmp_path / "a.exr"), img)
    write_png(tmp_path / "a.png", img, background=(1, 1, 1))
    back = read_exr(tmp_path / "a.png")
    want = img[..., :3] + (1 - img[..., 3:4])
    np.testing.assert_allclose(back[..., :3], np.clip(want, 0, 1), atol=0.5 / 255 + 1e-6)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.exr", "a.png"]  # no temporaries left


@pytest.mark.skipif(not DATA.is_dir(), reason=f"reference data folder {DATA} not present")
@pytest.mark.parametrize("name", ["bluntfin", "loxpost", "combustor"])
def test_real_meshes_raycast_matches_reference(name):
    import warnings

    from warpvol.metrics import image_error
    from warpvol.pipeline import Pipeline
    from warpvol.reference.numpy_render import render_reference
    from warpvol.scene.scene_file import load_scene

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = load_scene(Path(__file__).resolve().parents[1] / "scenes" / f"{name}.toml")
    dropped = [str(w.message) for w in caught if "zero-volume" in str(w.message)]
    assert (len(dropped) == 1 and "115 zero-volume" in dropped[0]) if name == "bluntfin" else not dropped
    sc.camera = sc.camera.replace(width_px=96, height_px=96)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load("raycast").render(sc, reference=ref, quiet=True)
    assert ref[..., 3].mean() > 0.02
    tol = preset_tolerance("raycast")
    assert res.report["error"]["rmse"] <= tol["rmse"], res.report["error"]
    assert res.report["error"]["max_abs"] <= tol["max_abs"], res.report["error"]
    assert image_error(res.image, ref) == res.report["error"]
