"""VSBUFFER renderer (Westermann & Ertl 1997): whole renders vs the exact reference, cell types,
losses counted, parameter checks."""

import numpy as np
import pytest
import pyvista as pv

import warpvol
from helpers import box_mesh
from tolerances import TOLERANCES, preset_tolerance
from warpvol.errors import ConfigError
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.transfer import TransferFunction
from warpvol.vsbuffer.vsbuffer import ConvexCellMesh, render_vsbuffer, walk_column

SCENES = ["sphere", "box", "linear_box", "concave", "stiff"]  # concave: a U and a disconnected block


def _err(img, ref):
    return float(np.sqrt(((img - ref) ** 2).mean())), float(np.abs(img - ref).max())


@pytest.fixture(scope="module")
def refs():
    out = {}
    for name in SCENES:
        s = warpvol.builtin_scene(name).with_camera(width_px=32, height_px=32)
        out[name] = (s, render_reference(s.mesh, s.transfer, s.camera))
    return out


@pytest.mark.parametrize("preset", ["westermann1997", "vsbuffer_best"])
@pytest.mark.parametrize("name", SCENES)
def test_presets_within_tolerance(refs, name, preset):
    s, ref = refs[name]
    r = warpvol.render(s, pipeline=preset, quiet=True)
    rmse, mx = _err(r.image, ref)
    tol = preset_tolerance(preset)
    assert rmse <= tol["rmse"] and mx <= tol["max_abs"], (rmse, mx)
    hw, c = r.report["counters"]["vsb_sweep"], r.report["stats"]["vsbuffer"]["walk"]
    assert hw["drawn_cells"] >= s.mesh.n_tets and hw["host_cell_steps"] == c["cells_integrated"] > 0
    assert hw["passes"] == 2 * s.camera.height_px
    if preset == "vsbuffer_best":
        assert c["lost_segments"] == 0
    else:
        assert c["missed_cells"] > 0 and "warning" in r.report["stats"]["vsbuffer"]  # losses reported


def test_modelled_on_the_papers_machine(refs):
    # the hardware work is in the counters' vocabulary: the Indigo2 IMPACT profile times all of it
    s, _ = refs["concave"]
    r = warpvol.pipeline.Pipeline.load("westermann1997").render(s, quiet=True, gpu="indigo2_impact")
    m = r.report["modelled_s"]
    assert m["unmodelled"] == {} and m["stages"]["vsb_sweep"] > 0 and m["total"] == m["stages"]["vsb_sweep"]


@pytest.mark.parametrize("name", SCENES)
def test_no_silent_loss(refs, name):
    # the paper's walk (no recovery): every pixel off by more than 1e-4 has its missed crossings in
    # the audit's per-ray map; the pixels without one are exact to float32
    s, ref = refs[name]
    img, st = render_vsbuffer(ConvexCellMesh.from_tetmesh(s.mesh), s.transfer, s.camera, integration="exact")
    err = np.abs(img - ref).max(axis=-1)
    flagged = st["missed_per_ray"] > 0
    assert (err > 1e-4).any() and not ((err > 1e-4) & ~flagged).any() and err[~flagged].max() < 1e-5


def test_fine_buffer_is_exact_orthographic(refs):
    # an orthographic view of the linear box with 4 buffer rows per pixel: no cell is missed, the
    # exact segment integral leaves float32 rounding only
    s, ref = refs["linear_box"]
    img, st = render_vsbuffer(ConvexCellMesh.from_tetmesh(s.mesh), s.transfer, s.camera, integration="exact",
                              adjacency="recover", depth_res=128)
    assert _err(img, ref)[1] < 1e-6
    c = st["counters"]
    assert c["planes"] == 32 and c["id_triangles_back"] > 0 and c["exit_points_reused"] > c["entry_points_solved"]


def _hex_grid():
    g = pv.ImageData(dimensions=(4, 3, 3), spacing=(0.6, 0.7, 0.8), origin=(-0.9, -0.7, -0.8))
    g = g.cast_to_unstructured_grid()
    p = np.asarray(g.points)
    g.point_data["s"] = p[:, 0] ** 2 + 0.5 * p[:, 1] * p[:, 2] + 0.3
    return g


def test_hexahedra_rendered_directly_equal_split():
    hexes = ConvexCellMesh.from_pyvista(_hex_grid(), "s")
    tets = ConvexCellMesh.from_tetmesh(hexes.to_tetmesh())
    assert hexes.n_cells == 12 and tets.n_cells == 72 and len(hexes.boundary) == 12 * 12
    tf = TransferFunction([[0.0, 1.0, 0.5, 0.2, 1.0], [1.2, 0.2, 0.6, 1.0, 3.0]], "color_extinction")
    cam = warpvol.Camera(eye=(2.5, 1.6, 3.0), target=(0, 0, 0), fov_y_deg=40.0, width_px=24, height_px=24)
    kw = dict(integration="exact", adjacency="recover", rewalk=True, depth_res=96)
    a, sa = render_vsbuffer(hexes, tf, cam, **kw)
    b, sb = render_vsbuffer(tets, tf, cam, **kw)
    assert np.abs(a - b).max() < 2e-6
    assert sa["counters"]["cells_integrated"] < sb["counters"]["cells_integrated"]  # whole hexes, one ID each
    ref = render_reference(hexes.to_tetmesh(), tf, cam)
    tol = preset_tolerance("vsbuffer_best")
    rmse, mx = _err(a, ref)
    assert rmse <= tol["rmse"] and mx <= tol["max_abs"]


def test_thin_cells_found_or_counted():
    # a layer 1/1000 of a buffer row thick: the passes cannot see it; the neighbour check or the
    # entry/exit-face checks find it, or the loss is counted -- never silent
    z = np.array([-1.0, -0.0005, 0.0005, 1.0])
    from warpvol.scene.grids import grid_points, structured_to_tets
    from warpvol.scene.mesh import TetMesh

    x = np.linspace(-1, 1, 4)
    pts = grid_points(x, x, z)
    mesh = TetMesh(pts, structured_to_tets((4, 4, 4)), np.where(np.abs(pts[:, 2]) < 0.001, 1.0, 0.0))
    tf = TransferFunction([[0.0, 0.2, 0.2, 0.2, 0.2], [1.0, 1.0, 0.2, 0.1, 4000.0]], "color_extinction")
    cam = warpvol.Camera(projection="orthographic", eye=(0.1, 0.2, 5), target=(0.1, 0.2, 0), ortho_height=2.6,
                         width_px=16, height_px=16)
    ref = render_reference(mesh, tf, cam)
    cm = ConvexCellMesh.from_tetmesh(mesh)
    a, sa = render_vsbuffer(cm, tf, cam, integration="exact", adjacency="count")
    ca = sa["counters"]
    err = np.abs(a - ref).max(axis=-1)
    # every wrong pixel's loss is in the report, and thin cells were found or counted
    assert (err > 1e-3).sum() == 0 or ca["lost_segments"] > 0
    assert ca["neighbour_found"] + ca["lost_segments"] > 0
    b, sb = render_vsbuffer(cm, tf, cam, integration="exact", adjacency="recover")
    assert sb["counters"]["lost_segments"] == 0 and np.abs(b - ref).max() < 1e-4
    # without any check the losses are still counted
    c, sc = render_vsbuffer(cm, tf, cam, integration="exact", adjacency="count", neighbour_check=False)
    assert sc["counters"]["lost_segments"] > 0 and np.abs(c - ref).max() > 1e-3


def test_batching_does_not_change_the_image(refs):
    s, _ = refs["concave"]
    cm = ConvexCellMesh.from_tetmesh(s.mesh)
    a, _ = render_vsbuffer(cm, s.transfer, s.camera, planes_per_batch=1)
    b, _ = render_vsbuffer(cm, s.transfer, s.camera, planes_per_batch=13)
    assert np.array_equal(a, b)


def test_parameters_checked():
    with pytest.raises(ConfigError, match="integration"):
        warpvol.pipeline.Pipeline.from_config({"name": "x", "stages": [
            {"stage": "vsb_setup"}, {"stage": "vsb_sweep", "integration": "simpson"}]})
    with pytest.raises(ConfigError, match="rewalk: needs audit"):
        warpvol.pipeline.Pipeline.from_config({"name": "x", "stages": [
            {"stage": "vsb_setup"}, {"stage": "vsb_sweep", "rewalk": True, "audit": False}]})
    s = warpvol.builtin_scene("sphere").with_camera(width_px=8, height_px=8)
    with pytest.raises(ConfigError, match="in front of the eye"):
        render_vsbuffer(ConvexCellMesh.from_tetmesh(s.mesh), s.transfer, s.camera.replace(eye=(0.1, 0.0, 0.0)))
    with pytest.raises(ConfigError, match="cell types"):
        ConvexCellMesh.from_pyvista(_tri_grid(), "s")


def _tri_grid():
    g = pv.UnstructuredGrid({5: np.array([[0, 1, 2]])}, np.eye(3))
    g.point_data["s"] = np.zeros(3)
    return g


def test_trapezoid_converges_to_exact_segments():
    # the paper's trapezoidal rule with attenuation: crude with one step per cell (the faithful
    # preset), second order in the step: 64 steps per cell agree with the exact segment integral;
    # bounded for any extinction (opacity 1 - e^-tau per step)
    m = box_mesh(dims=(3, 3, 3), scalar=lambda p: 0.5 + 0.4 * p[:, 2] + 0.1 * p[:, 0])  # varies along the rays
    tf = TransferFunction([[0.0, 1.0, 0.4, 0.2, 0.5], [1.0, 0.2, 0.4, 1.0, 2.0]], "color_extinction")
    cam = warpvol.Camera(projection="orthographic", eye=(0.05, 0.1, 4), target=(0.05, 0.1, 0), ortho_height=2.4,
                         width_px=12, height_px=12)
    cm = ConvexCellMesh.from_tetmesh(m)
    kw = dict(adjacency="recover", depth_res=48)
    ex, _ = render_vsbuffer(cm, tf, cam, integration="exact", **kw)
    e1 = np.abs(render_vsbuffer(cm, tf, cam, integration="trapezoid", steps=1, **kw)[0] - ex).max()
    e64 = np.abs(render_vsbuffer(cm, tf, cam, integration="trapezoid", steps=64, **kw)[0] - ex).max()
    assert e64 < 1e-4 < e1 and e64 < e1 / 100
    thick = TransferFunction([[0.0, 1.0, 0.4, 0.2, 1e6], [1.0, 0.2, 0.4, 1.0, 2e6]], "color_extinction")
    img, _ = render_vsbuffer(cm, thick, cam, integration="trapezoid", **kw)
    assert img.max() <= 1.0 + 1e-6 and img.min() >= 0.0


def test_wedge_and_pyramid_cells():
    # a prism (wedge) and a pyramid, disconnected, each drawn as one cell; same image as their tets
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1],          # wedge
                    [1.5, 0, 0], [2.5, 0, 0], [2.5, 1, 0], [1.5, 1, 0], [2.0, 0.5, 0.9]], float)  # pyramid
    g = pv.UnstructuredGrid({13: np.array([[0, 1, 2, 3, 4, 5]]), 14: np.array([[6, 7, 8, 9, 10]])}, pts)
    g.point_data["s"] = 0.3 + pts[:, 0] * 0.2 + pts[:, 2] ** 2
    cells = ConvexCellMesh.from_pyvista(g, "s")
    assert cells.n_cells == 2 and cells.n_tets == 5 and len(cells.boundary) == 8 + 6
    tf = TransferFunction([[0.0, 0.9, 0.5, 0.2, 2.0], [2.0, 0.2, 0.5, 0.9, 4.0]], "color_extinction")
    cam = warpvol.Camera(eye=(1.2, -2.5, 2.0), target=(1.2, 0.5, 0.4), fov_y_deg=50.0, width_px=20, height_px=20)
    a, st = render_vsbuffer(cells, tf, cam, integration="exact", adjacency="recover", rewalk=True)
    ref = render_reference(cells.to_tetmesh(), tf, cam)
    assert np.abs(a - ref).max() < preset_tolerance("vsbuffer_best")["max_abs"] and a[..., 3].max() > 0.5
    assert st["counters"]["pieces_integrated"] > st["counters"]["cells_integrated"]


def test_walk_column_split_runs_and_exit_reuse(refs):
    # a column whose runs are split by drawing-order errors (Fig. 8): every cell is integrated once,
    # in order, and the pixel equals the clean column's
    s, ref = refs["linear_box"]
    cm = ConvexCellMesh.from_tetmesh(s.mesh)
    _, st = render_vsbuffer(cm, s.transfer, s.camera, integration="exact", adjacency="recover", depth_res=128,
                            keep_lists=True)
    row, col = 16, 13
    cells = [c for c in st["lists"][row, col] if c >= 0]
    assert len(cells) >= 4
    clean = np.repeat(cells, 4)
    a, ca, la = walk_column(cm, s.transfer, s.camera, clean, row, col)
    split = list(clean)
    split[6], split[10] = cells[0], cells[1]            # a cell seen again inside its successor
    split = [-1, -1] + split[:9] + [-1] + split[9:]       # and an empty pixel between runs
    b, cb, lb = walk_column(cm, s.transfer, s.camera, split, row, col)
    assert la == lb == cells and cb["split_runs_skipped"] == 4  # A B [A] [B] C [B] [C]: 4 repeats
    assert np.abs(a - ref[row, col]).max() < 1e-6 and np.array_equal(a, b)
    # consecutive cells share a face: all but the first entry point are reused exits
    assert ca["exit_points_reused"] == len(cells) - 1 and ca["entry_points_solved"] == 1


def _table_pipeline(**table):
    from warpvol.pipeline import Pipeline

    sweep = {"stage": "vsb_sweep", "integration": "table", "adjacency": "recover", "rewalk": True, "t_min": 1e-6}
    return Pipeline.from_config({"name": "vsb_table", "stages": [{"stage": "table_exact", **table},
                                                                 {"stage": "vsb_setup"}, sweep]})


@pytest.mark.parametrize("name", SCENES)
def test_table_integration_within_tolerance(refs, name):
    # pre-integration lookup of each cell piece's (sf, sb, l) through the emulated 3D texture unit
    s, ref = refs[name]
    r = _table_pipeline(l_axis="log2").render(s, quiet=True)
    rmse, mx = _err(r.image, ref)
    tol = TOLERANCES["vsbuffer/table_exact"]
    assert rmse <= tol["rmse"] and mx <= tol["max_abs"], (rmse, mx)
    walk, hw = r.report["stats"]["vsbuffer"]["walk"], r.report["counters"]["vsb_sweep"]
    # one trilinear fetch per lookup, counted by the texture unit (8 texels each)
    assert walk["table_lookups"] > 0 and walk["pieces_integrated"] > 0
    assert hw["tex_3d_rgba32f_linear"] == walk["table_lookups"] and hw["texels"] == 8 * walk["table_lookups"]


def test_fine_table_approaches_exact(refs):
    s, _ = refs["linear_box"]
    exact = warpvol.render(s, pipeline="vsbuffer_best", quiet=True).image
    coarse = _err(_table_pipeline(n_s=16, n_l=8).render(s, quiet=True).image, exact)[0]
    fine = _err(_table_pipeline(n_s=128, n_l=64).render(s, quiet=True).image, exact)[0]
    assert fine < coarse / 4 and fine < 5e-4, (coarse, fine)


def test_table_needed_before_the_sweep():
    from warpvol.pipeline import Pipeline

    with pytest.raises(ConfigError, match="needs 'table3d'"):
        Pipeline.from_config({"name": "t", "stages": [{"stage": "vsb_setup"},
                                                      {"stage": "vsb_sweep", "integration": "table"}]})


@pytest.mark.parametrize("kind", ["unstructured", "image", "mixed"])
def test_native_cells_through_the_pipeline(kind):
    # warpvol.render(grid, pipeline="vsbuffer_best"): the loader records which tets each source cell
    # was split into, vsb_setup (cells = "native") draws the cells whole; same image as the tets
    if kind == "mixed":  # a wedge and a pyramid (VTK's split), disconnected
        pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1],
                        [1.5, 0, 0], [2.5, 0, 0], [2.5, 1, 0], [1.5, 1, 0], [2.0, 0.5, 0.9]], float)
        g = pv.UnstructuredGrid({13: np.array([[0, 1, 2, 3, 4, 5]]), 14: np.array([[6, 7, 8, 9, 10]])}, pts)
        g.point_data["s"] = 0.3 + pts[:, 0] * 0.2 + pts[:, 2] ** 2
        want = {"wedge": 1, "pyramid": 1}
        cam = warpvol.Camera(eye=(1.2, -2.5, 2.0), target=(1.2, 0.5, 0.4), fov_y_deg=50.0, width_px=20, height_px=20)
    else:
        g = _hex_grid()
        if kind == "image":
            g = pv.ImageData(dimensions=(4, 3, 3), spacing=(0.6, 0.7, 0.8), origin=(-0.9, -0.7, -0.8))
            g.point_data["s"] = _hex_grid().point_data["s"]
        want = {"hex": 12}
        cam = warpvol.Camera(eye=(2.5, 1.6, 3.0), target=(0, 0, 0), fov_y_deg=40.0, width_px=24, height_px=24)
    tf = TransferFunction([[0.0, 1.0, 0.5, 0.2, 1.0], [2.0, 0.2, 0.6, 1.0, 3.0]], "color_extinction")
    native = warpvol.render(g, tf, cam, scalars="s", pipeline="vsbuffer_best", reference=False)
    st = native.report["stats"]["vsb_setup"]
    assert st["native"] and st["cells_by_type"] == want
    mesh = warpvol.TetMesh.from_pyvista(g, "s")
    split = warpvol.render(warpvol.TetMesh(mesh.points, mesh.tets, mesh.scalars), tf, cam,  # no cell groups
                           pipeline="vsbuffer_best", reference=False)
    assert split.report["stats"]["vsb_setup"]["cells_by_type"] == {"tet": mesh.n_tets}
    tol = preset_tolerance("vsbuffer_best")
    rmse, mx = _err(native.image, split.image)
    assert rmse <= tol["rmse"] and mx <= tol["max_abs"] and native.image[..., 3].max() > 0.3, (rmse, mx)
    assert (native.report["stats"]["vsbuffer"]["walk"]["cells_integrated"]
            < split.report["stats"]["vsbuffer"]["walk"]["cells_integrated"])  # one ID per whole cell


def test_westermann1997_keeps_tets():
    r = warpvol.render(_hex_grid(), warpvol.builtin_scene("box").transfer,
                       warpvol.Camera(eye=(2.5, 1.6, 3.0), target=(0, 0, 0), width_px=8, height_px=8),
                       scalars="s", pipeline="westermann1997", reference=False)
    assert r.report["stats"]["vsb_setup"]["cells_by_type"] == {"tet": 72}  # the paper's tetrahedralised data


def test_native_cells_from_a_scene_file(tmp_path):
    # a scene file's .vtu of hexahedra: vsbuffer_best draws the 12 hexes whole, same image as the tets
    _hex_grid().save(tmp_path / "hexes.vtu")
    (tmp_path / "scene.toml").write_text(
        '[mesh]\npath = "hexes.vtu"\nscalars = "s"\n'
        '[transfer]\nemission = "color_extinction"\npoints = [[0.0, 1.0, 0.5, 0.2, 1.0], [2.0, 0.2, 0.6, 1.0, 3.0]]\n'
        '[camera]\neye = [2.5, 1.6, 3.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y_deg = 40.0\nwidth_px = 16\nheight_px = 16\n')
    s = warpvol.load_scene(tmp_path / "scene.toml")
    r = warpvol.render(s, pipeline="vsbuffer_best", reference=True)
    assert r.report["stats"]["vsb_setup"]["cells_by_type"] == {"hex": 12}
    tol = preset_tolerance("vsbuffer_best")
    e = r.error  # against the exact reference of the same field (the tets)
    assert e["rmse"] <= tol["rmse"] and e["max_abs"] <= tol["max_abs"] and r.image[..., 3].max() > 0.3, e


def test_sweep_work_limit_and_tall_plane_batches():
    """A sweep over max_sweep_pixels is refused up front in words (stage, pixels, what to change); a
    depth resolution whose 16-plane batch would exceed the rasteriser's 65536 rows runs with fewer
    planes per batch (an emulation detail) instead of failing."""
    from test_pt_render import preset
    from warpvol.scene.builtin import builtin_scene

    s = builtin_scene("box").with_camera(width_px=16, height_px=16)
    with pytest.raises(ConfigError, match=r"vsb_sweep.*2\.56e\+06 pixels, over max_sweep_pixels = 1e\+06"):
        preset("westermann1997", vsb_sweep={"max_sweep_pixels": 1_000_000, "depth_res": 5000}).render(s, quiet=True)
    r = preset("westermann1997", vsb_sweep={"depth_res": 5000}).render(s, quiet=True)
    assert np.isfinite(r.image).all() and r.image[..., 3].max() > 0


def test_per_cell_selection_draws_only_cut_boxes():
    """``cell_test``: of the cells stored at the octree nodes a sweep plane cuts, every cell whose own
    bounding box the plane cuts is drawn, and besides only cells whose vertices lie within the slack of
    the plane; fewer than the node rule (every cell of a cut node). A cell the plane does not cut
    enters one clipped pass at most, never the VSBUFFER, but there it can win the depth test against a
    cut cell within float32 depth resolution: the node rule's VSBUFFER equals the per-cell one wherever
    it holds a cell, and differs only where it has such a gap (one here); the images are identical."""
    from warpvol.vsbuffer.octree import box_corners_yz, plane_box_cut
    from warpvol.vsbuffer.vsbuffer import AUDIT_SLACK, CUT_SLACK, ray_space

    s = warpvol.builtin_scene("sphere").with_camera(width_px=48, height_px=40)
    cam, cm = s.camera, ConvexCellMesh.from_tetmesh(s.mesh).drawable
    kw = dict(tree_insert="containing", keep_buffers=True)
    a, sa = render_vsbuffer(cm, s.transfer, cam, cell_test=False, **kw)
    b, sb = render_vsbuffer(cm, s.transfer, cam, cell_test=True, **kw)
    n, rows = cm.n_cells, np.arange(cam.height_px)
    y, z = box_corners_yz(*cm.cell_bounds, cam)
    cut = np.stack([plane_box_cut(y, z, cam, np.full(n, r)) for r in rows])  # (planes, cells), all pairs
    drawn, node_drawn = sb["drawn"], sa["drawn"]
    assert len(drawn) == sb["counters"]["drawn_cells"] < sa["counters"]["drawn_cells"] == len(node_drawn)
    assert len(np.unique(drawn[:, 0] * n + drawn[:, 1])) == len(drawn)  # each pair once
    dm = np.zeros_like(cut)
    dm[drawn[:, 0], drawn[:, 1]] = True
    assert not (cut & ~dm).any()  # every cell whose box a plane cuts is drawn for that plane
    pb = ray_space(cm.points, cam)[cm.pieces.tets][..., 1]
    lo = np.minimum.reduceat(pb.min(axis=1), cm.cell_start[:-1])
    hi = np.maximum.reduceat(pb.max(axis=1), cm.cell_start[:-1])
    eps, bj = max(CUT_SLACK * sb["range"], AUDIT_SLACK), rows[:, None] + 0.5
    near = (lo[None] - eps <= bj) & (bj <= hi[None] + eps)
    assert not (dm & ~cut & ~near).any()  # the others: vertices within the slack of the plane
    assert (~cut[node_drawn[:, 0], node_drawn[:, 1]]).sum() > len(drawn)  # the node rule draws many uncut
    va, vb = sa["vsbuffers"], sb["vsbuffers"]
    for v in (va, vb):  # only cells a plane cuts (within the slack) enter its VSBUFFER
        j, _, _ = np.nonzero(v >= 0)
        assert near[j, v[v >= 0]].all()
    diff = va != vb
    assert diff.sum() == 1 and (va[diff] == -1).all() and (vb[diff] >= 0).all()
    assert np.array_equal(a, b)
    with pytest.raises(ConfigError, match="cell_test"):
        warpvol.pipeline.Pipeline.from_config({"name": "x", "stages": [
            {"stage": "vsb_setup"}, {"stage": "vsb_sweep", "cell_test": "yes"}]})
