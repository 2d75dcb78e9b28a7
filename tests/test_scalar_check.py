"""The walk's bound on the crossings' scalar errors (kernels/walk.py ``scalar_step``) and the per-TF decision
that it cannot fire (``scalar_check_needed``), which turns it off."""

import numpy as np
import pytest
import warp as wp

from warpvol.kernels import integrate as ki
from warpvol.kernels import tf as ktf
from warpvol.kernels import walk as kw
from warpvol.raycasting.stages import cell_setup
from warpvol.raycasting.stages.cell_setup import scalar_check_needed

STEEP = float(kw.STEEP_ERR)
NSEG = 48


@wp.kernel
def k_scalar_walks(s: wp.array2d(dtype=float), ln: wp.array2d(dtype=float), ds: wp.array2d(dtype=float),
                   tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int, out: wp.array(dtype=float)):
    """One walk per thread: scalar_step summed over segments ``s[i, j] -> s[i, j + 1]`` (length ``ln[i, j]``,
    end scalar errors ``ds[i, j]``, ``ds[i, j + 1]``, transmittance 1), each integrated as the walk does."""
    i = wp.tid()
    err = float(0.0)
    k_in = ktf.tf_upper(s[i, 0], tf_s)
    v_in = ktf.tf_eval_upper(s[i, 0], k_in, tf_s, tf_v)
    for j in range(ln.shape[1]):
        s_out = s[i, j + 1]
        k_out = ktf.tf_upper(s_out, tf_s)
        v_out = ktf.tf_eval_upper(s_out, k_out, tf_s, tf_v)
        seg = wp.vec4(0.0)
        if k_in == k_out:
            seg = ki.integrate_piece(ln[i, j], v_in, v_out, model)
        else:
            seg = ki.integrate_segment_tf(s[i, j], s_out, v_in, v_out, ln[i, j], tf_s, tf_v, model)
        err = kw.scalar_step(err, 1.0, ln[i, j], seg[3], s[i, j], s_out, v_in, v_out, k_in, k_out, ds[i, j],
                             ds[i, j + 1], tf_s, tf_v, model)
        k_in = k_out
        v_in = v_out
    out[i] = err


def random_walks(rng, n, cps, span, radius):
    """Walks whose scalars jump anywhere in ``[0, span]``, creep by 1e-7 .. 1 of it, or straddle a control point
    by 1e-7 .. 1e-4 of it; lengths summing to the longest chord (2.1 radius); end scalar errors up to ``span``
    (the largest a crossing can have)."""
    s = np.empty((n, NSEG + 1))
    s[:, 0] = rng.uniform(0, span, n)
    for j in range(NSEG):
        kind = rng.integers(0, 3, n)
        jump = rng.uniform(0, span, n)
        creep = np.clip(s[:, j] + rng.choice([-1, 1], n) * span * 10.0 ** rng.uniform(-7, 0, n), 0, span)
        cp = rng.choice(cps, n)
        straddle = cp + np.where(s[:, j] < cp, 1, -1) * span * 10.0 ** rng.uniform(-7, -4, n)
        s[:, j + 1] = np.where(kind == 0, jump, np.where(kind == 1, creep, straddle))
        s[:, j] = np.where(kind == 2, cp - (straddle - cp) * rng.uniform(0.01, 1, n), s[:, j])
    w = rng.random((n, NSEG)) ** 3
    ln = 2.1 * radius * w / w.sum(axis=1, keepdims=True)
    ds = span * rng.choice([1.0, 1e-2, 1e-6], (n, NSEG + 1))
    return s.astype(np.float32), ln.astype(np.float32), ds.astype(np.float32)


def run_walks(s, ln, ds, tf_s, tf_v, model):
    out = wp.zeros(len(s), dtype=float)
    wp.launch(k_scalar_walks, dim=len(s), inputs=[wp.array(s, dtype=float), wp.array(ln, dtype=float),
                                                  wp.array(ds, dtype=float), wp.array(tf_s, dtype=float),
                                                  wp.array(tf_v, dtype=wp.vec4), model, out])
    return out.numpy()


def tf_points(rng, rho, slope, model):
    """Six control points in ``[0.1, 1.9]`` (spaced so that float32 extinctions resolve slopes of 1e-6):
    random colours (constant for ``emission_density``, whose density counts the largest colour channel),
    extinction ``rho`` plus steps of slope up to ``slope``."""
    s = (np.linspace(0.1, 1.9, 6) + rng.uniform(-0.05, 0.05, 6)).astype(np.float32)
    ext = rho + np.concatenate([[0.0], np.cumsum(np.diff(s.astype(np.float64)) * slope * rng.uniform(-1, 1, 5))])
    col = rng.random((6, 3)) if model == 0 else np.tile(rng.random(3), (6, 1))
    return s, np.column_stack([col, ext]).astype(np.float32)


def test_decision_follows_the_steepest_density_slope():
    span, radius = 2.0, 1.1
    s = np.array([0.0, 0.5, 1.0, 2.0], np.float32)
    col = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], np.float32)
    opaque = np.column_stack([col, np.full(4, 45.5, np.float32)])
    assert scalar_check_needed(s, opaque, 0, span, radius) == 0  # constant extinction: G = 0
    assert scalar_check_needed(s, opaque, 1, span, radius) == 1  # emission density counts the colours too
    limit = 0.5 * STEEP / (2.0 * span * 2.1 * radius)  # the largest slope G the decision lets off
    for factor, want in ((0.9, 0), (1.1, 1)):
        ext = factor * limit * np.array([0.0, 0.5, 0.0, 0.0])  # slope factor * limit on the first piece
        v = np.column_stack([np.tile([0.3, 0.3, 0.3], (4, 1)), ext]).astype(np.float32)
        g = float(np.max(np.abs(np.diff(v[:, 3].astype(np.float64))) / np.diff(s.astype(np.float64))))
        assert g == pytest.approx(factor * limit, rel=1e-3)
        assert scalar_check_needed(s, v, 0, span, radius) == want
    assert scalar_check_needed(s, opaque, 0, 0.0, radius) == 0  # constant scalars: nothing to be uncertain about


@pytest.mark.parametrize("model", [0, 1])
@pytest.mark.parametrize("rho, slope_share", [(45.5, 0.0), (1.0, 0.8), (0.05, 0.8)])
def test_a_check_turned_off_cannot_fire(model, rho, slope_share):
    """For transfer functions the decision turns the check off for (constant extinction; density slopes up to
    0.8 of the largest it lets off), random walks with crossings' scalar errors up to the whole scalar range
    and segments straddling control points by 1e-7 of it keep scalar_step's sum under STEEP_ERR / 2."""
    rng = np.random.default_rng(7 + model)
    span, radius = 2.0, 1.1
    limit = 0.5 * STEEP / (2.0 * span * 2.1 * radius)
    for _ in range(4):
        tf_s, tf_v = tf_points(rng, rho, slope_share * limit, model)
        assert scalar_check_needed(tf_s, tf_v, model, span, radius) == 0
        s, ln, ds = random_walks(rng, 512, tf_s, span, radius)
        err = run_walks(s, ln, ds, tf_s, tf_v, model)
        assert np.isfinite(err).all()
        assert err.max() <= 0.5 * STEEP, err.max()
        if slope_share:
            assert err.max() > 0.05 * STEEP  # the walks do come near the bound


@pytest.mark.parametrize("preset", ["raycast", "harc_best"])
def test_opaque_tf_renders_the_same_with_the_check_forced_on(preset, monkeypatch):
    """A constant-extinction (opaque) transfer function: the check is off, and forcing it on changes neither
    the image nor the rays redone in float64."""
    from helpers import box_mesh, scene
    from warpvol.pipeline import Pipeline
    from warpvol.scene.camera import Camera
    from warpvol.scene.transfer import TransferFunction

    rng = np.random.default_rng(5)
    m = box_mesh(dims=(5, 5, 5), scalar=lambda p: np.sin(3 * p[:, 0]) + 0.3 * rng.standard_normal(len(p)))
    tf = TransferFunction([[-2, 1, 0.2, 0.1, 4.0], [0, 0.1, 0.9, 0.2, 4.0], [2, 0.2, 0.3, 1.0, 4.0]])
    cam = Camera(eye=[0.4, 0.7, 3.0], target=[0, 0, 0], fov_y_deg=40, width_px=40, height_px=40)
    sc = scene(m, tf, cam)
    seen = []
    real = cell_setup.scalar_check_needed
    for forced in (None, 1):
        def spy(*a, forced=forced):
            seen.append(real(*a))
            return seen[-1] if forced is None else forced
        monkeypatch.setattr(cell_setup, "scalar_check_needed", spy)
        res = Pipeline.load(preset, device="cpu").render(sc, quiet=True)
        if forced is None:
            base, base_stats = res.image, res.report["stats"]
    assert seen and set(seen) == {0}
    assert np.array_equal(res.image, base)

    def counts(stats):  # the stage's counts (rays redone in float64 among them), not its times
        return {k: v for k, v in stats[preset.split("_")[0]].items() if not k.endswith("_s")}

    assert counts(res.report["stats"]) == counts(base_stats)
