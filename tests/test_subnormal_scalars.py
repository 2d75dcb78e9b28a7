"""Scalars far below float64's normal range (subnormal, ~1e-311): the reference and the exact presets
render them as the same data scaled into the normal range; the pipelines that cast them to float32 as
they are decline in words before any reference; and no command writes a non-finite pixel."""

import numpy as np
import pytest

from helpers import scene
from tolerances import preset_tolerance
from warpvol.errors import NonFiniteImage
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.defaults import default_scene
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import TransferFunction

K = 1033  # 1e-311 * 2^1033 ~ 1


def _grid(tmp_path, scale=1e-311, values=None):
    import pyvista as pv

    g = pv.ImageData(dimensions=(5, 5, 5))
    g.point_data["s"] = (np.arange(125) / 124.0) * scale if values is None else values
    path = tmp_path / "sub.vti"
    g.save(path)
    return path


def _scenes(tmp_path, **kw):
    from warpvol.scene.loaders import read_mesh_file

    m = read_mesh_file(_grid(tmp_path, **kw), "s")
    sub = default_scene(m, size=(16, 16))
    pts = sub.transfer.points.copy()
    pts[:, 0] = np.ldexp(pts[:, 0], K)
    normal = TetMesh(m.points, m.tets, np.ldexp(m.scalars, K))  # the same data and TF times 2^K
    return sub, scene(normal, TransferFunction(pts, sub.transfer.emission), sub.camera)


def test_transfer_function_evaluates_on_subnormal_segments():
    tf = TransferFunction([[0.0, 0.0, 0.0, 0.0, 0.0], [3.125e-313, 1.0, 1.0, 1.0, 0.0234]])
    v = tf.evaluate([0.0, 2e-313, 3.125e-313, 1.0])
    assert np.isfinite(v).all() and v[1, 0] == pytest.approx(0.64) and v[1, 3] == pytest.approx(0.64 * 0.0234)


@pytest.mark.parametrize("values", [None, "three_steps"])
def test_reference_and_exact_presets_render_subnormal_scalars(tmp_path, values):
    vals = None if values is None else 5e-324 * np.random.default_rng(1).integers(0, 4, 125).astype(float)
    sub, normal = _scenes(tmp_path, values=vals)
    ref = render_reference(normal.mesh, normal.transfer, normal.camera)
    got = render_reference(sub.mesh, sub.transfer, sub.camera)
    assert np.isfinite(got).all() and np.abs(got - ref).max() < 1e-9 and ref[..., 3].max() > 0.1
    for name in ("raycast", "pt_best"):
        img = Pipeline.load(name).render(sub, quiet=True).image
        assert np.abs(img - ref).max() <= preset_tolerance(name)["max_abs"]


def test_reference_command_writes_the_finite_image(tmp_path):
    from warpvol.cli import main
    from warpvol.io import read_exr

    path = _grid(tmp_path)
    out = tmp_path / "ref.exr"
    assert main(["reference", str(path), "-o", str(out), "--width", "12", "--height", "12", "--quiet"]) == 0
    img = read_exr(out)
    assert np.isfinite(img).all() and img[..., 3].max() > 0.1


def test_a_float32_pipeline_declines_before_the_reference(tmp_path, monkeypatch, capsys):
    import warpvol.cli as cli

    calls = []
    monkeypatch.setattr(cli, "compute_reference", lambda *a, **k: calls.append(1))
    path = _grid(tmp_path)
    out = tmp_path / "o.exr"
    assert cli.main(["render", str(path), "--pipeline", "pt_vertex_color", "--compute-reference", "-o", str(out),
                     "--width", "8", "--height", "8", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "scalars: the scalars that matter span only 1e-311" in err and "smallest normal" in err
    assert "extinction" not in err and calls == [] and not out.exists()
    sub, _ = _scenes(tmp_path)
    with pytest.raises(Exception, match="smallest normal"):
        Pipeline.load("kraus2004_full").render(sub, quiet=True)


def test_no_command_writes_a_non_finite_pixel(tmp_path, monkeypatch, capsys):
    import warpvol.cli as cli
    from warpvol.io import write_exr, write_png

    img = np.zeros((4, 5, 4))
    img[1, 2, 0] = np.nan
    img[3, 3, 3] = np.inf
    for write, name in ((write_exr, "a.exr"), (write_png, "a.png")):
        with pytest.raises(NonFiniteImage, match="2 of 20 pixels are not finite"):
            write(tmp_path / name, img)
        assert not (tmp_path / name).exists()
    monkeypatch.setattr(cli, "compute_reference", lambda scene, *a, **k: (np.full((6, 6, 4), np.nan), 0.0))
    out = tmp_path / "ref.exr"
    assert cli.main(["reference", "builtin:box", "-o", str(out), "--width", "6", "--height", "6", "--quiet"]) == 2
    assert "36 of 36 pixels are not finite" in capsys.readouterr().err and not out.exists()


def test_the_reference_of_extreme_scalars_is_that_of_the_scaled_scene():
    from warpvol.scene.builtin import builtin_scene

    sc = builtin_scene("linear_box").with_camera(width_px=12, height_px=12)
    for k in (-1060, -700, 900):
        def scaled(e):  # the scene's scalars and control points times 2^e (rounded where subnormal)
            pts = sc.transfer.points.copy()
            pts[:, 0] = np.ldexp(np.ldexp(pts[:, 0], k), e - k)
            m = TetMesh(sc.mesh.points, sc.mesh.tets, np.ldexp(np.ldexp(sc.mesh.scalars, k), e - k))
            return render_reference(m, TransferFunction(pts, sc.transfer.emission), sc.camera)
        ref, got = scaled(0), scaled(k)
        assert np.isfinite(got).all() and ref[..., 3].max() > 0.1 and np.abs(got - ref).max() < 1e-12, k


def test_a_transfer_function_wider_than_subnormal_data_renders(tmp_path):
    # control points beyond the data's range: the TF is looked up between them (np.interp's slope was
    # inf there, and the presets declined naming an "extinction inf" the TF does not have)
    sub, normal = _scenes(tmp_path)
    pts = np.array([[0.0, 0.1, 0.2, 0.9, 0.0], [3e-311, 1.0, 0.6, 0.2, 4.0]])
    scaled = pts.copy()
    scaled[:, 0] = np.ldexp(pts[:, 0], K)
    ref = render_reference(normal.mesh, TransferFunction(scaled), normal.camera)
    img = Pipeline.load("raycast").render(scene(sub.mesh, TransferFunction(pts), sub.camera), quiet=True).image
    assert ref[..., 3].max() > 0.1 and np.abs(img - ref).max() <= preset_tolerance("raycast")["max_abs"]
