"""pt_best with transfer functions of thousands of rough control points (a label-like colour map).

Each fragment's front and back scalars come from attribute planes set up at the unsnapped positions
where the attributes were taken (``pt_project exact_attrs``), the pixels within the snapping of the
projected edges of tets the transfer function changes steeply across are redone in float64, and what
float32 rounding of the scalars can still cost on a very steep transfer function is estimated and
reported as a warning with that bound (``stats.pt_integrate.rounding_bound``).
"""

import numpy as np
import pytest

from tolerances import preset_tolerance
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.builtin import builtin_scene
from warpvol.tools.stress import report_warnings
from warpvol.tools.stress_range import rough_scene

TOL = preset_tolerance("pt_best")


@pytest.mark.parametrize("points,px", [(512, 32), (4096, 24), (4096, 40), (2048, 48)])
def test_pt_best_keeps_its_tolerance_on_rough_transfer_functions(points, px):
    sc = rough_scene(px, points)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load("pt_best").render(sc, reference=ref, quiet=True)
    e = res.report["error"]
    assert e["rmse"] <= TOL["rmse"] and e["max_abs"] <= TOL["max_abs"], e
    st = res.report["stats"]["pt_integrate"]
    assert st["rough_tets"] > 0 and st["rounding_bound"] <= TOL["max_abs"] and not report_warnings(res.report)


@pytest.mark.parametrize("points", [10000, 20000])
def test_pt_best_warns_with_its_bound_where_rounding_can_exceed_it(points):
    sc = rough_scene(32, points)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = Pipeline.load("pt_best").render(sc, reference=ref, quiet=True)
    st = res.report["stats"]["pt_integrate"]
    assert st["rounding_bound"] > TOL["max_abs"] and res.report["error"]["max_abs"] <= st["rounding_bound"]
    w = [x for x in report_warnings(res.report) if x.startswith("pt_integrate: ")]
    assert len(w) == 1 and "float32 rounding" in w[0] and f"up to about {st['rounding_bound']:.2g}" in w[0]


@pytest.mark.parametrize("name", ["sphere", "concave", "stiff"])
def test_smooth_transfer_functions_stay_quiet(name):
    res = Pipeline.load("pt_best").render(builtin_scene(name).with_camera(width_px=24, height_px=24), quiet=True)
    assert res.report["stats"]["pt_integrate"]["rounding_bound"] < 1e-4 and not report_warnings(res.report)


def test_attributes_are_taken_where_their_positions_say():
    # exact_attrs: the thick vertex's attribute position is the unsnapped crossing, within the snapping
    # (plus the rounding to the 1/256 grid) of the snapped thick vertex; without it none is kept
    from warpvol.conditioning.conditioning import condition_scene
    from warpvol.gpu.vertex import VertexStage
    from warpvol.projection.pt import decompose
    from warpvol.projection.sort import visibility_order

    sc, _ = condition_scene(builtin_scene("sphere").with_camera(width_px=32, height_px=32))
    vs = VertexStage.from_camera(sc.camera, *sc.camera.depth_range(*sc.mesh.bounds))
    v = vs.transform(sc.mesh.points)
    order = visibility_order(sc.mesh, sc.camera).order
    exact, snapped = decompose(sc.mesh, v, order, exact_attrs=True), decompose(sc.mesh, v, order)
    assert snapped.attr_positions is None
    ap, pos = exact.attr_positions.numpy(), exact.positions.numpy()
    n = sc.mesh.n_points
    assert np.array_equal(ap[:n], v.window.astype(np.float32))
    four = exact.tris[0::4, 0] != exact.tris[0::4, 1]  # drawn tets
    d = np.abs(ap[n:, :2] - pos[n:, :2])[four[: len(ap) - n]]
    assert d.max() <= 2.0 / 256.0 and (d > 0).any()


@pytest.mark.parametrize("dims,px,eye", [
    ((9, 7, 6), 24, (2.2, 1.7, 2.9)),                    # the stress case ghost_layers_hex's mesh and view
    ((9, 7, 6), 22, (2.809513, -1.082425, 0.545607)),
    ((8, 8, 4), 37, (0.759987, -1.997032, 1.739854)),
    ((8, 8, 4), 29, (-0.74297, -0.680711, -1.713809)),
    ((6, 5, 5), 25, (-1.0226, -1.177284, -1.145724))])
def test_pixels_the_snapped_coverage_takes_past_an_unsnapped_edge(dims, px, eye):
    # hexahedra split into tets, a smooth transfer function: some pixel centres lie within the snapping's
    # shift past an unsnapped edge of a sliver triangle the snapped coverage gives them (a tet seen with a
    # face nearly edge-on); their attributes are those of the triangle's nearest point, not the planes
    # extrapolated across the sliver's steep thickness (which past the tet's outline turns negative)
    from warpvol.scene.camera import Camera
    from warpvol.scene.mesh import TetMesh
    from warpvol.scene.scene import Scene
    from warpvol.scene.transfer import TransferFunction
    from warpvol.tools.stress_files import FILE_TF, ghost_grid

    mesh, tf = TetMesh.from_pyvista(ghost_grid(dims), "s"), TransferFunction([list(p) for p in FILE_TF])
    cam = Camera(eye=eye, target=(0.5, 0.5, 0.5), up=(0, 0, 1), fov_y_deg=30.0, width_px=px, height_px=px)
    sc = Scene(mesh=mesh, transfer=tf, camera=cam, name="hex grid")
    res = Pipeline.load("pt_best").render(sc, reference=render_reference(mesh, tf, cam), quiet=True)
    e = res.report["error"]
    assert e["rmse"] <= TOL["rmse"] and e["max_abs"] <= TOL["max_abs"], e
    assert not report_warnings(res.report)
