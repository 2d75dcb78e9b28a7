"""Per-cell visibility under the transfer function, the skip switch and the report's ``left_out``."""

import numpy as np
import pytest

from helpers import box_mesh
from warpvol.conditioning.visibility import cell_visibility, per_cell, scalar_interval_visible
from warpvol.scene.camera import Camera
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction


def _shell_tf(emission="color_extinction", colour_outside=0.0):
    """Zero extinction except a hat on (-0.15, 0.15) peaking at 0; colour ``colour_outside`` elsewhere."""
    c = colour_outside
    return TransferFunction([[-1.0, c, c, c, 0.0], [-0.15, c, c, c, 0.0], [0.0, 1.0, 0.5, 0.2, 3.0],
                             [0.15, c, c, c, 0.0], [1.0, c, c, c, 0.0]], emission)


def _sampled_visible(lo, hi, tf, n=4001):
    """Brute force: the TF's contribution sampled densely over each interval (and its ends and knots)."""
    out = []
    for a, b in zip(lo, hi):
        s = np.concatenate([np.linspace(a, b, n), tf.s[(tf.s >= a) & (tf.s <= b)]])
        v = tf.evaluate(s)
        c = v[:, 3] if tf.emission == "color_extinction" else np.abs(v).max(axis=1)
        out.append(bool((c > 0).any()))
    return np.array(out)


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_interval_visibility_matches_dense_sampling(emission):
    rng = np.random.default_rng(3)
    for _ in range(20):
        k = rng.integers(2, 8)
        s = np.sort(rng.uniform(-1, 1, k))
        vals = rng.uniform(0, 1, (k, 4)) * (rng.uniform(size=(k, 1)) < 0.4)  # most points zero
        tf = TransferFunction(np.column_stack([s, vals]), emission)
        a = rng.uniform(-1.2, 1.2, 200)
        b = a + rng.exponential(0.2, 200) * (rng.uniform(size=200) < 0.8)  # some intervals a single point
        np.testing.assert_array_equal(scalar_interval_visible(a, b, tf), _sampled_visible(a, b, tf))


def test_zero_at_both_ends_is_zero_inside():
    tf = TransferFunction([[0, 1, 1, 1, 0], [0.5, 1, 1, 1, 0], [0.6, 1, 1, 1, 2], [1, 1, 1, 1, 2]])
    # [0, 0.5]: zero at both ends, no contributing knot inside; [0.2, 0.51]: just past the zero knot
    assert scalar_interval_visible([0.0, 0.2, 0.7], [0.5, 0.51, 0.7], tf).tolist() == [False, True, True]
    # colour without extinction: nothing under color_extinction, visible under emission_density
    col = TransferFunction([[0, 1, 0, 0, 0], [1, 1, 0, 0, 0]], "color_extinction")
    emi = TransferFunction([[0, 1, 0, 0, 0], [1, 1, 0, 0, 0]], "emission_density")
    assert not scalar_interval_visible([0.0], [1.0], col)[0]
    assert scalar_interval_visible([0.0], [1.0], emi)[0]
    with pytest.raises(ValueError):
        scalar_interval_visible([1.0], [0.0], tf)


def _layered_mesh(n=10):
    """Unit cube in ``n`` layers along z, scalar = z: every tet of layer k holds [z_k, z_k+1]
    (the Kuhn tets of a grid cell all span its z range)."""
    return box_mesh(dims=(3, 3, n + 1), scalar=lambda p: p[:, 2].copy())


@pytest.mark.parametrize("emission,colour,want_layers", [("color_extinction", 0.0, 2),
                                                          ("color_extinction", 0.7, 2),
                                                          ("emission_density", 0.0, 2),
                                                          ("emission_density", 0.7, 10)])
def test_known_visible_fraction(emission, colour, want_layers):
    mesh = _layered_mesh(10)  # layer boundaries at -1, -0.8, ..., 1; the hat (-0.15, 0.15) meets 2 layers
    vis = cell_visibility(mesh, _shell_tf(emission, colour))
    per_layer = mesh.n_tets // 10
    assert vis.sum() == want_layers * per_layer
    z = mesh.points[mesh.tets][:, :, 2].mean(axis=1)
    if want_layers == 2:
        assert np.array_equal(vis, np.abs(z) < 0.2)


def test_pad_is_conservative():
    mesh = _layered_mesh(8)  # layer boundaries at multiples of 0.25, exact in binary
    tf = TransferFunction([[-1, 1, 1, 1, 0], [0.25, 1, 1, 1, 0], [0.3, 1, 1, 1, 1], [1, 1, 1, 1, 1]])
    exact = cell_visibility(mesh, tf, pad=0.0)
    padded = cell_visibility(mesh, tf)  # the layer ending at 0.25 touches the zero knot: padding keeps it
    assert exact.sum() == 3 * (mesh.n_tets // 8)
    assert padded.sum() == 4 * (mesh.n_tets // 8)
    assert not (exact & ~padded).any()


def test_per_cell():
    assert per_cell(np.array([False, True, False, False, True]), np.array([0, 2, 4, 5])).tolist() == [True, False, True]
    assert per_cell(np.array([True, False]), None).tolist() == [True, False]


def _scene(emission="color_extinction", px=16):
    cam = Camera(projection="orthographic", eye=(0.3, 0.2, 5), target=(0, 0, 0), up=(0, 1, 0), ortho_height=3.0,
                 width_px=px, height_px=px)
    return Scene(mesh=_layered_mesh(10), transfer=_shell_tf(emission), camera=cam, name="layers")


def test_stage_reports_cost_and_cache_and_switch():
    from warpvol.pipeline import Pipeline

    pipe = Pipeline.load("pt_best")
    sc = _scene()
    r = pipe.render(sc, quiet=True)
    st = r.report["stats"]["visibility"]
    assert (st["cells"], st["visible"], st["cached"]) == (sc.mesh.n_tets, sc.mesh.n_tets // 5, False)
    assert r.report["skip"] is True
    assert "visibility" in r.report["stage_timing"] and r.report["stage_timing"]["visibility"]["setup"]
    r2 = pipe.render(sc, quiet=True)
    assert r2.report["stats"]["visibility"]["cached"] is True
    off = pipe.render(sc, quiet=True, skip=False)
    assert off.report["skip"] is False and "visibility" not in off.report.get("stats", {})
    assert any(s["stage"] == "visibility" and "skipping is off" in s["reason"] for s in off.report["skipped"])
    assert "left_out" not in off.report
    plan = {p["stage"]: p for p in pipe.plan(sc)}
    assert plan["visibility"]["run"] and plan["visibility"]["leaves_out"].startswith("192 of 240 cells (80.0 %)")
    assert all(p["leaves_out"] is None for p in pipe.plan(sc, skip=False))


def test_cli_no_skip(tmp_path, capsys):
    import json

    from warpvol.cli import main

    rep = tmp_path / "r.json"
    assert main(["render", "builtin:box", "--pipeline", "pt_best", "-o", str(tmp_path / "a.exr"), "--width", "8",
                 "--height", "8", "--report", str(rep), "--no-skip", "--quiet"]) == 0
    assert json.loads(rep.read_text())["skip"] is False
    assert main(["plan", "builtin:box", "--pipeline", "pt_best", "--no-measure", "--width", "8", "--height", "8",
                 "--quiet"]) == 0
    assert "leaves out:" in capsys.readouterr().out
