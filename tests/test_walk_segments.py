"""The shared cell walk keeps each entry's segment on request (``march_pass(segments=...)``): its front and back
ray parameter, its own colour and transmittance. Composited front to back the segments give the pixel, and
asking for them changes no pixel, status or counter."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import noisy_shell
from warpvol.pipeline import Pipeline
from warpvol.scene.builtin import builtin_scene
from warpvol.stage import Context


def first_pass(sc, cap: int):
    from warpvol.raycasting.stages import raycast as rc

    pipe = Pipeline.load("raycast")
    ctx = Context(scene=sc, persistent=pipe.persistent, quiet=True)
    for st in pipe.stages[:pipe.stage_keys().index("entry_bins") + 1]:  # condition ... entry_bins
        st.run(ctx)
    n = sc.camera.width_px * sc.camera.height_px
    state = rc.MarchState(n, "cpu")
    sg = rc.segments_struct(n, cap, "cpu") if cap else None
    c = rc.march_pass(ctx, state, max_steps=10**6, t_min=0.0, threads=1, reentries=256, segments=sg)
    return state, c, sg


@pytest.mark.parametrize("which", ["concave", "shell"])
def test_segments_composite_to_the_image(which):
    sc = builtin_scene("concave").with_camera(width_px=24, height_px=24) if which == "concave" else \
        noisy_shell(3, size=24)
    cap = 64
    state, c, sg = first_pass(sc, cap)
    plain, c0, _ = first_pass(sc, 0)
    # asking for the segments changes nothing the pass computes
    for name in ("rgb", "trans", "tcur", "status", "last"):
        np.testing.assert_array_equal(getattr(state, name).numpy(), getattr(plain, name).numpy())
    np.testing.assert_array_equal(c, c0)
    count = sg.count.numpy()
    # one segment per entry (first entries + re-entries) but the entry a failed ray gave up in
    assert count.max() <= cap and c[0] + c[7] - c[3] <= count.sum() <= c[0] + c[7]
    assert (count > 1).any()  # rays that leave and re-enter the mesh
    depth = sg.depth.numpy().reshape(-1, cap, 2)
    color = sg.color.numpy().reshape(-1, cap, 4)
    status = state.status.numpy()
    ok = (status & 3) != 2  # rays left to the float64 redo keep no walk result
    rgb, trans = state.rgb.numpy(), state.trans.numpy()
    checked = 0
    for i in np.flatnonzero(ok & (count > 0)):
        d, col = depth[i, :count[i]], color[i, :count[i]]
        assert (d[:, 0] <= d[:, 1]).all() and (d[1:, 0] >= d[:-1, 1] - 1e-5).all()  # front to back, disjoint
        acc, tr = np.zeros(3), 1.0
        for k in range(count[i]):
            acc += tr * col[k, :3]
            tr *= col[k, 3]
        np.testing.assert_allclose(acc, rgb[i], atol=2e-6)
        np.testing.assert_allclose(tr, trans[i], atol=2e-6)
        checked += 1
    assert checked > 50
    assert (trans[ok & (count == 0)] == 1.0).all()  # no segment: nothing composited


def harc_passes(sc, cap: int):
    """``harc_best``'s first pass and depth-peel passes (early termination off), each entry's segment kept with
    ``cap``; ``(state, summed counters, segments)``."""
    from warpvol.kernels import raycast as kr
    from warpvol.raycasting.harc import HarcState
    from warpvol.raycasting.stages.raycast import segments_struct
    from warpvol.shared.thin_cells import mark_unresolved

    pipe = Pipeline.load("harc_best")
    keys = pipe.stage_keys()
    ctx = Context(scene=sc, persistent=pipe.persistent, quiet=True)
    for st in pipe.stages[:keys.index("harc_raster") + 1]:  # condition ... harc_raster
        st.run(ctx)
    n = sc.camera.width_px * sc.camera.height_px
    state = HarcState(n, "cpu")
    sg = segments_struct(n, cap, "cpu") if cap else None
    run_pass, _ = pipe.stages[keys.index("harc")].pass_runner(ctx, state, t_stop=0.0, segments=sg)
    mark_unresolved(ctx, state.status, int(kr.STATUS_FAILED))
    total: dict = {}
    for _ in range(65):
        c = run_pass()
        for k, v in c.items():
            total[k] = total.get(k, 0) + v
        if c["entries"] == 0:
            break
    return state, total, sg


@pytest.mark.parametrize("which", ["concave", "shell"])
def test_harc_segments_composite_to_the_image(which):
    """harc_best's passes keep each entry's segment in the same layout as raycast's march: asking for them
    changes no pixel, status or counter, and composited front to back they give the pixel."""
    sc = builtin_scene("concave").with_camera(width_px=24, height_px=24) if which == "concave" else \
        noisy_shell(3, size=24)
    cap = 64
    state, c, sg = harc_passes(sc, cap)
    plain, c0, _ = harc_passes(sc, 0)
    for name in ("rgba", "tcur", "status", "last", "px_work"):
        np.testing.assert_array_equal(getattr(state, name).numpy(), getattr(plain, name).numpy())
    assert c == c0
    count = sg.count.numpy()
    assert count.max() <= cap and c["entries"] - c["failed"] <= count.sum() <= c["entries"]
    assert (count > 1).any()  # rays that leave and re-enter the mesh (depth-peel passes)
    depth = sg.depth.numpy().reshape(-1, cap, 2)
    color = sg.color.numpy().reshape(-1, cap, 4)
    ok = state.status.numpy() != 2  # rays left to the float64 redo keep no walk result
    rgba = state.rgba.numpy()
    checked = 0
    for i in np.flatnonzero(ok & (count > 0)):
        d, col = depth[i, :count[i]], color[i, :count[i]]
        assert (d[:, 0] <= d[:, 1]).all() and (d[1:, 0] >= d[:-1, 1] - 1e-5).all()  # front to back, disjoint
        acc, tr = np.zeros(3), 1.0
        for k in range(count[i]):
            acc += tr * col[k, :3]
            tr *= col[k, 3]
        np.testing.assert_allclose(acc, rgba[i, :3], atol=2e-6)
        np.testing.assert_allclose(1.0 - tr, rgba[i, 3], atol=2e-6)
        checked += 1
    assert checked > 50
    assert (rgba[ok & (count == 0)] == 0.0).all()  # no segment: nothing composited
