"""Cells a float32 walk cannot resolve, for ``raycast`` and ``harc_best``: slabs 1e-9 to 1e-5 thick seen
edge-on (alone, in perspective with the rays inside the slab, and among other parts) and needles a few
thousandths of a pixel wide along the rays of a perspective view (:mod:`warpvol.tools.stress_subpixel`). The
rays that may cross them are traced in float64 from the start (``thin_cell_rays``), so the images hold the
exact rows of ``tests/tolerances.py``; ordinary meshes have no such rays."""

import pytest

from tolerances import TOLERANCES
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
ROWS = {"raycast": "raycast/fp32", "harc_best": "harc_best"}
STATS = {"raycast": "raycast", "harc_best": "harc"}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("pipeline", sorted(ROWS))
def test_rays_through_unresolved_cells_traced_in_float64(pipeline, case):
    sc = CASES[case]()
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    assert ref[..., 3].max() > 0.5
    res = Pipeline.load(pipeline).render(sc, quiet=True)
    err = image_error(res.image, ref)
    tol = TOLERANCES[ROWS[pipeline]]
    assert err["max_abs"] <= tol["max_abs"] and err["rmse"] <= tol["rmse"], (case, err)
    assert res.report["stats"][STATS[pipeline]]["thin_cell_rays"] > 0


@pytest.mark.parametrize("name", ["concave", "stiff", "sphere"])
def test_ordinary_meshes_have_no_unresolved_cells(name):
    from warpvol.raycasting.thin_cells import unresolved_pixels

    sc = builtin_scene(name).with_camera(width_px=48, height_px=48)
    pix, tets = unresolved_pixels(sc.mesh, sc.transfer, sc.camera, face_on=False)
    assert len(pix) == 0 and tets == 0
