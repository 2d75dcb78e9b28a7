"""Cells a float32 walk cannot resolve, for ``raycast`` and ``harc_best``: slabs 1e-9 to 1e-5 thick seen
edge-on (alone, in perspective with the rays inside the slab, and among other parts) and needles a few
thousandths of a pixel wide along the rays of a perspective view (:mod:`warpvol.tools.stress_subpixel`). The
rays that may cross them are traced in float64 from the start (``thin_cell_rays``), so the images hold the
exact rows of ``tests/tolerances.py``; ordinary meshes have no such rays."""

import pytest

from tolerances import preset_tolerance
from warpvol.metrics import image_error
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.builtin import builtin_scene
from warpvol.tools.stress_subpixel import subpixel_scene

CASES = {
    "slab_1e-9_persp": lambda: subpixel_scene("slab", 1e-9, n=1, seed=0, block=False, perspective=True),
    "slabs_1e-5_block": lambda: subpixel_scene("slab", 1e-5, n=6, seed=1),
    "slabs_1e-6_block_persp": lambda: subpixel_scene("slab", 1e-6, n=5, seed=4, perspective=True),
    "needles_2e-3_persp": lambda: subpixel_scene("needle", 2e-3, n=16, seed=1, perspective=True),
    "needles_5e-3_persp_px40": lambda: subpixel_scene("needle", 5e-3, n=24, px=40, seed=6, perspective=True),
}
STATS = {"raycast": "raycast", "harc_best": "harc"}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("pipeline", sorted(STATS))
def test_rays_through_unresolved_cells_traced_in_float64(pipeline, case):
    sc = CASES[case]()
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    assert ref[..., 3].max() > 0.5
    res = Pipeline.load(pipeline).render(sc, quiet=True)
    err = image_error(res.image, ref)
    tol = preset_tolerance(pipeline)
    assert err["max_abs"] <= tol["max_abs"] and err["rmse"] <= tol["rmse"], (case, err)
    assert res.report["stats"][STATS[pipeline]]["thin_cell_rays"] > 0


@pytest.mark.parametrize("name", ["concave", "stiff", "sphere"])
def test_ordinary_meshes_have_no_unresolved_cells(name):
    from warpvol.shared.thin_cells import unresolved_pixels

    sc = builtin_scene(name).with_camera(width_px=48, height_px=48)
    pix, tets = unresolved_pixels(sc.mesh, sc.transfer, sc.camera, face_on=False)
    assert len(pix) == 0 and tets == 0


def test_view_free_part_kept_per_mesh_and_transfer_function():
    """What the view does not change is kept in the cache for the next frame (no per-frame scan of the
    mesh's thin tets): the same pixels as without a cache, for a moved camera (the view-dependent part is
    redone) and for another transfer function (compared by value: the kept part is not reused)."""
    from warpvol.scene.transfer import TransferFunction
    from warpvol.shared import thin_cells as tc

    sc = CASES["slabs_1e-6_block_persp"]()
    cache: dict = {}
    first = tc.unresolved_pixels(sc.mesh, sc.transfer, sc.camera, face_on=False, cache=cache)
    assert len(first[0]) > 0 and "view_free" in cache
    kept = cache["view_free"]
    moved = sc.camera.replace(width_px=sc.camera.width_px + 7)
    got = tc.unresolved_pixels(sc.mesh, sc.transfer, moved, face_on=False, cache=cache)
    assert cache["view_free"] is kept  # reused
    want = tc.unresolved_pixels(sc.mesh, sc.transfer, moved, face_on=False)
    assert got[1] == want[1] and (got[0] == want[0]).all()
    clear = TransferFunction([[p[0], *p[1:4], 0.0] for p in sc.transfer.points], sc.transfer.emission)
    got = tc.unresolved_pixels(sc.mesh, clear, sc.camera, face_on=False, cache=cache)
    assert cache["view_free"] is not kept and got[1] == 0 and len(got[0]) == 0
    for face_on in (True, False):
        got = tc.unresolved_pixels(sc.mesh, sc.transfer, sc.camera, face_on=face_on, cache=cache)
        want = tc.unresolved_pixels(sc.mesh, sc.transfer, sc.camera, face_on=face_on)
        assert got[1] == want[1] and (got[0] == want[0]).all()


def test_thin_cell_candidates_are_set_up_of_the_first_frame():
    sc = CASES["slabs_1e-6_block_persp"]()
    pipe = Pipeline.load("raycast")
    first = pipe.render(sc, quiet=True)
    assert "thin-cell candidates" in first.report.get("first_use", {}).get("raycast", {}), first.report.get("first_use")
    second = pipe.render(sc, quiet=True)
    assert "first_use" not in second.report
    assert second.report["stats"]["raycast"]["thin_cell_rays"] == first.report["stats"]["raycast"]["thin_cell_rays"] > 0
