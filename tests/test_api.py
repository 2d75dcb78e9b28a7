"""The one-call notebook API: warpvol.render / compare / presets and top-level exports (issue 14)."""

import importlib

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import pyvista as pv  # noqa: E402

import warpvol  # noqa: E402
from tolerances import preset_tolerance  # noqa: E402
from warpvol import ConfigError, Pipeline  # noqa: E402
from warpvol.io import read_exr, write_exr  # noqa: E402
from warpvol.metrics import image_error  # noqa: E402

TOL = preset_tolerance("raycast")


def small(name="box", px=16):
    return warpvol.builtin_scene(name).with_camera(width_px=px, height_px=px)


def test_top_level_exports():
    for n in ("Scene", "load_scene", "render", "compare", "presets", "builtin_scene"):
        assert n in warpvol.__all__ and callable(getattr(warpvol, n))
        assert "Examples" in getattr(warpvol, n).__doc__  # numpydoc with a runnable example
    Pipeline.load("raycast")  # imports the preset folder through importlib.resources ...
    importlib.import_module("warpvol.presets")  # ... and so does this
    assert callable(warpvol.presets) and "raycast" in warpvol.presets()  # ... the function stays


def test_render_box_closed_form_and_result_object(tmp_path):
    warpvol.clear_cache()  # the reference is computed here, not taken from the session's cache
    r = warpvol.render(small("box"), reference=True)
    inside = r.image[8, 8]
    a = 1 - np.exp(-3.0)
    assert np.allclose(inside, [0.8 * a, 0.6 * a, 0.4 * a, a], atol=TOL["max_abs"])
    assert r.error["rmse"] <= TOL["rmse"] and r.error["max_abs"] <= TOL["max_abs"]
    assert r.report["pipeline"] == "raycast" and r.report["reference_s"] > 0
    assert r.error_image.shape == (16, 16)
    exr, png = r.save(tmp_path / "a.exr"), r.save(tmp_path / "a.png")
    assert np.array_equal(read_exr(exr), r.image)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" == r._repr_png_()[:8]
    with pytest.raises(ConfigError, match=r"path: .*'\.jpg'; supported: \.exr, \.png"):
        r.save(tmp_path / "a.jpg")
    fig = r.plot()
    assert len([ax for ax in fig.axes if ax.images]) == 2  # image and error map
    assert "RMSE" in fig.axes[0].get_title()
    assert r.show() is None and matplotlib.pyplot.get_fignums()  # drawn with pyplot (Agg keeps it)
    matplotlib.pyplot.close("all")
    write_exr(tmp_path / "ref.exr", r.reference)
    again = warpvol.render(small("box"), reference=tmp_path / "ref.exr")  # a reference given as an EXR file
    assert again.error == image_error(r.image, read_exr(tmp_path / "ref.exr")) and again.error["rmse"] > 0
    rows = warpvol.render(small("box"), {"points": [[0, 0.8, 0.6, 0.4, 1.5], [2, 0.8, 0.6, 0.4, 1.5]]})
    assert np.array_equal(rows.image, r.image)  # a scene file's [transfer] table as a dict
    with pytest.raises(ConfigError, match=r"^Scene: camera: expected a Camera, got dict"):
        warpvol.Scene(mesh=r.scene.mesh, transfer=r.scene.transfer, camera={"eye": [0, 0, 5]}, name="x")
    plain = warpvol.render(small("box"))
    assert plain.error is None and plain.error_image is None and np.array_equal(plain.image, r.image)


def test_render_from_pyvista_parts_equals_the_scene():
    """pyvista grid + VTK function pair + plotter in, the same image as the equivalent Scene."""
    s = small("linear_box", 20)
    grid = s.mesh.to_pyvista("z")
    pl = pv.Plotter(off_screen=True)
    s.camera.to_pyvista(pl)
    color, opacity = s.transfer.to_vtk()  # unit distance 1, as render reads a pair
    ref = warpvol.render(s)
    r = warpvol.render(grid, (color, opacity), pl, scalars="z")
    assert r.image.shape == (20, 20, 4) and ref.image[10, 10, 3] > 0.5
    assert np.abs(r.image - ref.image).max() < 1e-6  # TF through VTK opacities: float round-off only
    prop = pv.VolumeProperty()  # what plotter.add_volume(...).prop is
    c2, o2 = s.transfer.to_vtk(unit_distance=0.25)
    prop.SetColor(c2)
    prop.SetScalarOpacity(o2)
    prop.SetScalarOpacityUnitDistance(0.25)
    r2 = warpvol.render(grid, prop, s.camera, scalars="z")
    assert np.abs(r2.image - ref.image).max() < 1e-6
    pl.close()


@pytest.mark.parametrize("kw, match", [
    (dict(mesh=[1, 2, 3]), r"^mesh: expected a pyvista\.UnstructuredGrid.*got list"),
    (dict(mesh="cellgrid"), r"^scalars: .*'c' is a cell-data array.*cell_data_to_point_data\(\)"),
    (dict(mesh="cellgrid", scalars="nope"), r"^scalars: point-data array 'nope' not found"),
    (dict(transfer=5), r"^transfer: expected a TransferFunction"),
    (dict(transfer="virdis"), r"^transfer: unknown colour map or ParaView preset 'virdis'; close matches: 'viridis'"),
    (dict(camera=5), r"^camera: expected a warpvol Camera"),
    (dict(camera="pvcam"), r"^camera: a bare pyvista/VTK camera has no image size"),
    (dict(gpu="geforce99"), r"^gpu: unknown GPU profile 'geforce99'; available: .*geforce3"),
    (dict(device="tpu"), r"^device: device 'tpu' is not available"),
    (dict(device=0), r"^device: expected a device name"),
    (dict(pipeline="no_such"), r"^pipeline: 'no_such' is neither a preset nor a file"),
    (dict(pipeline=3), r"^pipeline: expected a preset name"),
    (dict(reference=np.zeros((3, 3, 4))), r"^reference: shape \(3, 3, 4\) does not match the image \(8, 8, 4\)"),
    (dict(split=5), r"^scalars/split: only used when mesh is a pyvista data set"),
])
def test_render_errors_name_the_argument(kw, match):
    s = small("box", 8)
    args = dict(mesh=s.mesh, transfer=s.transfer, camera=s.camera)
    args.update(kw)
    if isinstance(args["mesh"], str) and args["mesh"] == "cellgrid":
        g = pv.ImageData(dimensions=(3, 3, 3))
        g.cell_data["c"] = np.arange(g.n_cells, dtype=float)
        g.point_data["p"] = np.arange(g.n_points, dtype=float)
        args["mesh"] = g
        args.setdefault("scalars", "c")
    if isinstance(args["camera"], str):
        args["camera"] = pv.Camera()
    with pytest.raises(ConfigError, match=match):
        warpvol.render(**args)


def test_compare_one_panel_pair_per_pipeline(tmp_path, monkeypatch):
    custom = tmp_path / "raycast_tile4.toml"
    custom.write_text('[[stages]]\nstage = "condition"\n[[stages]]\nstage = "cell_setup"\n[[stages]]\nstage = "entry_bins"\ntile = 4\n'
                      '[[stages]]\nstage = "raycast"\n[[stages]]\nstage = "peel"\n')
    cmp = warpvol.compare(small("concave", 24), ["raycast", str(custom)])
    fig, table = cmp
    assert [r["pipeline"] for r in table] == ["raycast", "raycast_tile4"]
    img_axes = [ax for ax in fig.axes if ax.images]
    assert len(img_axes) == 4  # image + error map per pipeline
    titles = [ax.get_title() for ax in img_axes]
    for k, row in enumerate(table):
        assert row["rmse"] <= TOL["rmse"] and row["max_abs"] <= TOL["max_abs"] and row["time_s"] > 0
        assert f"{row['time_s']:.3f} s, RMSE {row['rmse']:.2e}" in titles[2 * k]
        assert cmp.results[row["pipeline"]].error["rmse"] == row["rmse"]
    assert np.array_equal(cmp.results["raycast"].image, cmp.results["raycast_tile4"].image)  # tiling only
    assert "| raycast_tile4 |" in cmp.markdown() and "<table>" in cmp._repr_html_()

    # names are checked before the (slow) reference is computed
    def boom(*a, **k):
        raise AssertionError("reference computed before the pipelines were checked")

    monkeypatch.setattr("warpvol.reference.numpy_render.render_reference", boom)
    with pytest.raises(ConfigError, match=r"^pipelines\[1\]: 'kraus2099_full' is neither a preset"):
        warpvol.compare(small("box", 8), ["raycast", "kraus2099_full"])  # (kraus2004_full exists since issue 10)
    with pytest.raises(ConfigError, match=r"^pipelines: expected one or more"):
        warpvol.compare(small("box", 8), [])
    with pytest.raises(ConfigError, match=r"^scene_or_parts: expected a Scene"):
        warpvol.compare(42, ["raycast"])


def test_compare_accepts_scene_files_builtin_names_and_parts():
    s = small("box", 8)
    ref = warpvol.render(s, reference=True).reference
    by_parts = warpvol.compare((s.mesh, s.transfer, s.camera), "raycast", reference=ref)
    by_name = warpvol.compare("builtin:box", ["raycast"])  # 128 x 128 default camera
    assert by_parts.table[0]["rmse"] <= TOL["rmse"] and by_name.table[0]["rmse"] <= TOL["rmse"]
    assert by_name.results["raycast"].image.shape == (128, 128, 4)
    for c in (by_parts, by_name):
        matplotlib.pyplot.close(c.figure)
