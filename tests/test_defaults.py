"""Defaults for a mesh on its own (transfer function over its scalars, camera fitted to it), scenes
given in any form, gpu= and quiet= in Python, the Camera's two heights, `warpvol render mesh.vtu -o
x.png`, the demo's reference PNG and page, and error maps on one logarithmic scale."""

import json
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import pyvista as pv  # noqa: E402

import warpvol  # noqa: E402
from tolerances import preset_tolerance  # noqa: E402
from warpvol import Camera, ConfigError  # noqa: E402
from warpvol.api import as_scene  # noqa: E402
from warpvol.cli import main  # noqa: E402
from warpvol.io import composite_over, read_exr  # noqa: E402
from warpvol.metrics import ERROR_FLOOR, error_png_bytes  # noqa: E402
from warpvol.scene.defaults import DEFAULT_SIZE, colormap_rgb  # noqa: E402

TOL = preset_tolerance("raycast")


def grid(n=5):
    """A small pyvista grid, off-centre and not a cube, with a radial point field."""
    g = pv.ImageData(dimensions=(n, n, n - 1), spacing=(0.5, 0.4, 0.3), origin=(3.0, -1.0, 2.0))
    g.point_data["r"] = np.linalg.norm(g.points - g.points.mean(axis=0), axis=1)
    return g


def read_png(path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGBA"))


def test_render_grid_with_no_transfer_function_and_no_camera():
    g = grid()
    scene = as_scene(g)
    assert (scene.camera.width_px, scene.camera.height_px) == DEFAULT_SIZE == (512, 512)
    lo, hi = float(g.point_data["r"].min()), float(g.point_data["r"].max())
    tf = scene.transfer
    assert tf.srange == pytest.approx((lo, hi))
    assert tf.extinction[0] == 0.0 and tf.extinction[-1] > 0  # ParaView's ramp, rising over the range
    assert np.allclose(np.diff(tf.extinction), tf.extinction[-1] / (len(tf.s) - 1))
    assert np.allclose(tf.rgb[-1], colormap_rgb("viridis", 1.0))
    # the whole mesh in view: every vertex projects inside the image
    cam = scene.camera
    near, far = cam.depth_range(*scene.mesh.bounds)
    p = np.c_[scene.mesh.points, np.ones(scene.mesh.n_points)] @ (cam.projection_matrix(near, far)
                                                                  @ cam.view_matrix()).T
    ndc = p[:, :2] / p[:, 3:]
    assert np.abs(ndc).max() < 1.0

    r = warpvol.render(g, size=(40, 32), reference=True)
    a = r.image[..., 3]
    assert r.image.shape == (32, 40, 4)
    assert 0.2 < a.max() < 0.99 and (a > 0.01).mean() > 0.15  # neither empty nor opaque
    assert a[0].max() == a[-1].max() == a[:, 0].max() == a[:, -1].max() == 0.0  # nothing cut at the border
    assert r.error["rmse"] <= TOL["rmse"] and r.error["max_abs"] <= TOL["max_abs"]


@pytest.mark.parametrize("name, mid", [
    ("coolwarm", None),                        # matplotlib
    ("Cool to Warm", [0.865, 0.865, 0.865]),   # ParaView's default map: grey in the middle
    ("cool to warm", [0.865, 0.865, 0.865]),   # case does not matter when the name is unique
    ("Viridis (matplotlib)", None),
])
def test_colormap_and_paraview_preset_names(name, mid):
    g = grid()
    r = warpvol.render(g, name, size=12)
    tf = r.scene.transfer
    centre = tf.evaluate(0.5 * sum(tf.srange))[:3]
    want = np.asarray(mid) if mid is not None else \
        matplotlib.colormaps[{"Viridis (matplotlib)": "viridis"}.get(name, name)](0.5)[:3]
    assert np.allclose(centre, want, atol=2e-3)
    assert r.image[..., 3].max() > 0.2


@pytest.mark.parametrize("name, close", [("virdis", "'viridis'"), ("Cool to Wrm", "'Cool to Warm'"),
                                         ("blackbody", "'Black-Body Radiation'")])
def test_an_unknown_colormap_lists_close_matches(name, close):
    with pytest.raises(ConfigError, match=rf"^transfer: unknown colour map or ParaView preset {name!r}; "
                                          rf"close matches: .*{close}"):
        warpvol.render(grid(), name, size=8)


def test_scene_in_every_form(tmp_path):
    g = grid().cast_to_unstructured_grid()
    vtu = tmp_path / "m.vtu"
    g.save(vtu)
    toml = tmp_path / "s.toml"
    toml.write_text('[mesh]\nbuiltin = "linear_box"\n[camera]\nwidth_px = 10\nheight_px = 8\n')
    from_grid = warpvol.render(g, size=16)
    from_file = warpvol.render(vtu, size=16)
    assert np.array_equal(from_file.image, from_grid.image) and from_file.scene.name == "m"
    assert warpvol.render(str(toml)).image.shape == (8, 10, 4)
    assert warpvol.render("builtin:box", size=6).image.shape == (6, 6, 4)
    cmp = warpvol.compare(str(vtu), ["raycast"], repeats=0)
    assert cmp.table[0]["status"] == "ok" and cmp.results["raycast"].image.shape == (512, 512, 4)
    matplotlib.pyplot.close("all")
    with pytest.raises(ConfigError, match=r"^mesh: file not found: .*nope\.vtu"):
        warpvol.render(tmp_path / "nope.vtu")


def test_quiet_leaves_stdout_empty_from_the_first_call():
    """A fresh interpreter: fd-level stdout (Warp's banner is printed by C++ and Python alike)."""
    code = ("import sys, warpvol; warpvol.render(warpvol.builtin_scene('box').mesh, size=8, reference=True, "
            "quiet=sys.argv[1] == 'quiet')")
    quiet = subprocess.run([sys.executable, "-c", code, "quiet"], capture_output=True, text=True, timeout=300)
    assert quiet.returncode == 0, quiet.stderr
    assert quiet.stdout == ""
    loud = subprocess.run([sys.executable, "-c", code, "loud"], capture_output=True, text=True, timeout=300)
    assert loud.returncode == 0 and "Warp" in loud.stdout  # the check can fail: without quiet, the banner


def test_gpu_profile_in_python():
    scene = warpvol.builtin_scene("box").with_camera(width_px=12, height_px=12)
    plain = warpvol.render(scene, pipeline="pt_vertex_color")
    r = warpvol.render(scene, pipeline="pt_vertex_color", gpu="geforce3")
    assert r.report["gpu"] == "geforce3" and "modelled_s" in r.report
    assert r.report["modelled_s"]["stages"]["vertex"] > 0
    assert np.array_equal(r.image, plain.image)  # the model times the work; it does not change it
    with pytest.raises(ConfigError, match=r"^gpu: unknown GPU profile 'geforce99'; available: .*geforce3"):
        warpvol.render(scene, gpu="geforce99")


def test_camera_heights_cannot_be_confused():
    with pytest.raises(ConfigError, match=r"^camera\.height: Camera takes no 'height' \(got 100\): give 'ortho_height'"
                                          r" .* or 'height_px'"):
        Camera(height=100)
    cam = Camera(projection="orthographic", ortho_height=3.0, width_px=4, height_px=2)
    with pytest.raises(ConfigError, match="ortho_height.*height_px"):
        cam.replace(height=2.0)
    with pytest.raises(AttributeError, match="'ortho_height'.*'height_px'"):
        cam.height  # noqa: B018
    # the scene file keeps Contract 1's key
    assert Camera.from_config({"projection": "orthographic", "height": 2.5}).ortho_height == 2.5
    o1, _ = Camera(projection="orthographic", ortho_height=2.0, width_px=1, height_px=3).rays()
    assert np.allclose(o1[[0, 2], 0, 1], [2 / 3, -2 / 3])  # pixel centres at +-(1 - 1/3) of half the height


def test_cli_render_mesh_file_to_png(tmp_path, capsys):
    vtu, png, rep = tmp_path / "mesh.vtu", tmp_path / "x.png", tmp_path / "r.json"
    grid().cast_to_unstructured_grid().save(vtu)
    assert main(["render", str(vtu), "-o", str(png), "--width", "32", "--height", "24", "--compute-reference",
                 "--report", str(rep), "--quiet"]) == 0
    img = read_png(png)
    assert img.shape == (24, 32, 4) and img[..., :3].max() > 40
    report = json.loads(rep.read_text())
    assert report["pipeline"] == "raycast"
    assert report["error"]["rmse"] <= TOL["rmse"] and report["error"]["max_abs"] <= TOL["max_abs"]
    api = warpvol.render(vtu, size=(32, 24))
    api.save(tmp_path / "api.png")
    assert np.array_equal(read_png(tmp_path / "api.png"), img)  # the same image as Python's default
    assert main(["render", str(vtu), "-o", str(tmp_path / "y.png"), "--colormap", "virdis", "--quiet"]) == 2
    assert "colormap: unknown colour map or ParaView preset 'virdis'; close matches: 'viridis'" in capsys.readouterr().err


def test_demo_writes_reference_png_and_index_html(tmp_path):
    d = tmp_path / "demo"
    assert main(["demo", "--scene", "linear_box", "--size", "16", "-o", str(d), "--quiet"]) == 0
    ref = read_exr(d / "reference.exr").astype(np.float64)
    want = np.round(np.clip(composite_over(ref, (0.1, 0.1, 0.1)), 0, 1) * 255)
    assert np.abs(read_png(d / "reference.png")[..., :3] - want).max() <= 1
    page = (d / "index.html").read_text()
    for f in ("image.png", "reference.png", "error.png"):
        assert f'src="{f}"' in page
    assert "exact float64 ray integral" in page and "logarithmic colour scale" in page
    assert "what the raycast pipeline rendered" in page


def test_error_maps_share_one_logarithmic_scale(tmp_path):
    from matplotlib.colors import LogNorm

    scene = warpvol.builtin_scene("linear_box").with_camera(width_px=12, height_px=12)
    r = warpvol.render(scene, pipeline="pt_vertex_color", reference=True)  # 8-bit blending: errors ~1e-2
    err_axes = [ax for ax in r.plot().axes if ax.images and "error" in ax.get_title()]
    norm = err_axes[0].images[0].norm
    assert isinstance(norm, LogNorm) and norm.vmin == ERROR_FLOOR and norm.vmax == pytest.approx(r.error["max_abs"])
    assert r.error["max_abs"] > 1e-3
    cmp = warpvol.compare(scene, ["raycast", "pt_vertex_color"], repeats=0)
    norms = [ax.images[0].norm for ax in cmp.figure.axes if ax.images and "error" in ax.get_title()]
    assert len(norms) == 2 and all(isinstance(n, LogNorm) for n in norms)
    assert norms[0].vmin == norms[1].vmin == ERROR_FLOOR
    assert norms[0].vmax == norms[1].vmax == pytest.approx(max(row["max_abs"] for row in cmp.table))
    matplotlib.pyplot.close("all")
    # the PNG: the map, and beside it a colour bar running over many colours
    err = np.full((10, 10), 1e-6)
    err[0, 0] = 1e-2
    (tmp_path / "e.png").write_bytes(error_png_bytes(err))
    png = read_png(tmp_path / "e.png")
    assert png.shape[1] > png.shape[0] >= 256
    cols = [len({tuple(p) for p in png[:, j, :3]}) for j in range(png.shape[1])]
    assert max(cols[10 + 256 + 2:]) > 50  # a gradient column right of the map (10 px margin, 256 px): the colour bar
    # on a log scale 1e-6 sits two thirds up from 1e-8 to 1e-2 (linear scaling would put it at 1e-4)
    lo, hi = np.log10(ERROR_FLOOR), np.log10(1e-2)
    frac = matplotlib.colors.LogNorm(1e-8, 1e-2)(1e-6)
    assert frac == pytest.approx((-6 - lo) / (hi - lo))
