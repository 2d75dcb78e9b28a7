"""Meshes as solvers and ParaView write them: a ``.pvtu`` whose pieces carry ghost cells, and hexahedra
collapsed onto an O-grid axis. Each is read as the mesh it describes, renders within the exact presets'
tolerances of the reference of that mesh, and the report says what was left out."""

import warnings

import numpy as np
import pytest

from helpers import scene
from tolerances import EXACT_PRESETS, preset_tolerance
from warpvol.errors import MeshError
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.camera import Camera
from warpvol.scene.loaders import load_mesh
from warpvol.scene.mesh import TetMesh, signed_volumes
from warpvol.scene.split_cells import VTK_HEXAHEDRON, VTK_PYRAMID, VTK_WEDGE, split_cells
from warpvol.scene.transfer import TransferFunction
from warpvol.tools.stress_files import ghost_grid, ogrid, write_pvtu

TF = TransferFunction([[0.0, 0.2, 0.4, 1.0, 0.8], [0.5, 1.0, 0.5, 0.2, 1.6], [1.0, 1.0, 1.0, 1.0, 0.4]])
CAM = Camera(eye=[2.2, 1.7, 2.9], target=[0.5, 0.5, 0.5], width_px=24, height_px=24)


@pytest.mark.parametrize("dims,tets,n_pieces,layers,axis", [
    ((7, 5, 5), False, 2, 1, 0), ((6, 6, 4), True, 2, 2, 1), ((5, 7, 6), False, 3, 1, 2),
    ((9, 7, 6), False, 2, 1, 0), ((9, 6, 6), False, 3, 1, 0),  # pieces that each own their interface points
    ((11, 5, 4), False, 2, 1, 0)])
def test_pvtu_ghost_cells_are_dropped_and_counted(tmp_path, dims, tets, n_pieces, layers, axis):
    g = ghost_grid(dims, tets)
    path, ghosts = write_pvtu(tmp_path, g, n_pieces, layers, axis)
    assert ghosts > 0
    m = load_mesh({"path": str(path), "scalars": "s"})
    whole = TetMesh.from_pyvista(g, "s")
    assert m.n_tets == whole.n_tets and m.n_points == whole.n_points  # ghosts gone, pieces joined
    assert signed_volumes(m.points, m.tets).sum() / 6 == pytest.approx(1.0)
    assert m.load_notes["ghost_cells_dropped"] == ghosts
    assert len(m.crack_faces) == 0 and m.is_convex
    ref = render_reference(whole, TF, CAM)
    np.testing.assert_allclose(render_reference(m, TF, CAM), ref, atol=1e-9)
    for name in ("raycast", "pt_best"):
        res = Pipeline.load(name).render(scene(m, TF, CAM), quiet=True)
        assert np.abs(res.image - ref).max() <= preset_tolerance(name)["max_abs"]
        assert res.report["mesh_notes"]["ghost_cells_dropped"] == ghosts


@pytest.mark.parametrize("dims,tets", [((7, 5, 5), False), ((6, 6, 4), True)])
def test_a_ghost_cell_whose_copy_is_absent_is_kept(tmp_path, dims, tets):
    import pyvista as pv

    path, _ = write_pvtu(tmp_path, ghost_grid(dims, tets), 2, 1, 0)
    piece = pv.read(tmp_path / "piece0.vtu")  # one piece on its own: its ghost layer is all there is there
    n_ghost = int((np.asarray(piece.cell_data["vtkGhostType"]) & 1).sum())
    m = TetMesh.from_pyvista(piece, "s")
    assert m.load_notes == {"ghost_cells_kept": n_ghost}
    assert m.n_tets == TetMesh.from_pyvista(_without_flags(piece), "s").n_tets
    # pieces already assembled (as VTK's structured readers leave them): flags on cells that exist once
    g = ghost_grid(dims, tets)
    flags = np.zeros(g.n_cells, np.uint8)
    flags[: g.n_cells // 4] = 1
    g.cell_data["vtkGhostType"] = flags
    whole = TetMesh.from_pyvista(g, "s")
    assert whole.load_notes == {"ghost_cells_kept": g.n_cells // 4}
    assert signed_volumes(whole.points, whole.tets).sum() / 6 == pytest.approx(1.0)


def test_pieces_own_copies_of_a_point_join_where_their_data_agree():
    import pyvista as pv

    from warpvol.scene.interop import _join_piece_points

    # two hexahedra on the unit cube's face x = 1, each with its own copy of the face's four points
    a = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    pts = np.concatenate([a, a + [1, 0, 0]])
    g = pv.UnstructuredGrid(np.array([8, *range(8), 8, *range(8, 16)]), np.array([12, 12]), pts)
    for jump, joined in ((0.0, 4), (0.5, 0)):  # the field continuous across the face, or not
        g.point_data["s"] = pts[:, 0] + np.where(np.arange(16) >= 8, jump, 0.0)
        notes = {}
        weld = _join_piece_points(g, notes, pieces=True)
        assert int((weld != np.arange(16)).sum()) == joined and notes.get("piece_points_joined", 0) == joined
        if joined:
            assert np.array_equal(pts[weld], pts)  # each onto a point at its own position
    assert (_join_piece_points(g, {}, pieces=False) == np.arange(16)).all()  # not from pieces: left as they are


def _without_flags(ds):
    out = ds.copy()
    for data in (out.cell_data, out.point_data):
        if "vtkGhostType" in data:
            del data["vtkGhostType"]
    return out


def test_hidden_points_drop_their_cells():
    g = ghost_grid((4, 4, 4), False)
    gt = np.zeros(g.n_points, np.uint8)
    gt[0] = 2  # HIDDENPOINT: the one cell at the corner goes
    g.point_data["vtkGhostType"] = gt
    m = TetMesh.from_pyvista(g, "s")
    assert m.load_notes == {"hidden_cells_dropped": 1}
    assert signed_volumes(m.points, m.tets).sum() / 6 == pytest.approx(26 / 27)


@pytest.mark.parametrize("nr,nt,nz", [(3, 8, 3), (4, 12, 2), (2, 6, 4)])
def test_ogrid_axis_hexes_split_as_wedges(nr, nt, nz):
    sg = ogrid(nr, nt, nz)
    ug = sg.cast_to_unstructured_grid().clean(tolerance=1e-12)  # the axis points merged: hexes name them twice
    m = TetMesh.from_pyvista(ug, "s")
    axis_cells = nt * (nz - 1)
    assert m.load_notes["collapsed_cells"] == axis_cells and m.load_notes["collapsed_pieces_dropped"] > 0
    with warnings.catch_warnings():  # the axis points apart: the same split, its flat pieces dropped as
        warnings.simplefilter("ignore")  # zero-volume tets (and the cells meet on duplicated points)
        ms = TetMesh.from_pyvista(sg.cast_to_unstructured_grid(), "s")
    vol = signed_volumes(m.points, m.tets) / 6
    assert (vol > 0).all() and vol.sum() == pytest.approx(np.abs(signed_volumes(ms.points, ms.tets)).sum() / 6)
    cam = Camera(eye=[2.5, -1.6, 2.2], target=[0, 0, 0.5], width_px=24, height_px=24)
    ref = render_reference(m, TF, cam)
    np.testing.assert_allclose(render_reference(ms, TF, cam), ref, atol=1e-9)
    res = Pipeline.load("raycast").render(scene(m, TF, cam), quiet=True)
    assert np.abs(res.image - ref).max() <= preset_tolerance("raycast")["max_abs"]
    assert res.report["mesh_notes"]["collapsed_cells"] == axis_cells


CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)


@pytest.mark.parametrize("corners,volume,shape", [
    ([0, 1, 2, 3, 4, 4, 7, 7], 0.5, "wedge"),      # top face onto its left edge
    ([0, 1, 2, 3, 4, 4, 4, 4], 1 / 3, "pyramid"),   # top face onto a point
    ([0, 1, 2, 3, 6, 6, 6, 6], 1 / 3, "pyramid"),
    ([0, 0, 2, 3, 4, 4, 6, 7], 0.5, "wedge"),        # front face onto its left edge
    ([0, 1, 2, 2, 4, 5, 6, 6], 0.5, "wedge"),
    ([0, 1, 1, 0, 4, 5, 5, 4], 0.0, "flat"),         # flattened to a quad: nothing left
])
def test_collapsed_hexahedron_tiles_its_shape(corners, volume, shape):
    notes = {}
    pts, _, tets, _ = split_cells(CUBE, np.zeros(8), np.array([VTK_HEXAHEDRON]), np.array([0, 8]),
                                  np.array(corners), notes)
    v = signed_volumes(pts, tets) / 6 if len(tets) else np.zeros(0)
    assert (v >= 0).all() and v.sum() == pytest.approx(volume)
    assert len(np.unique(np.sort(tets, axis=1), axis=0)) == len(tets)
    assert notes["collapsed_cells"] == 1


def test_collapse_that_folds_is_refused_naming_the_cell():
    # corner 5 falls onto 7 across the top face (no edge joins them): the face x = 1 twists, and the
    # split's diagonal there makes pieces that turn opposite ways
    with pytest.raises(MeshError, match=r"cell 0 .*collapses so that the pieces of its split overlap"):
        split_cells(CUBE, np.zeros(8), np.array([VTK_HEXAHEDRON]), np.array([0, 8]),
                    np.array([0, 1, 2, 3, 7, 7, 6, 7]), {})




@pytest.mark.parametrize("case", ["ghost_layers_hex", "ghost_layers_tets", "collapsed_hexes_wedges",
                                  "collapsed_hexes_pyramids"])
def test_stress_cases_of_mesh_files_have_no_silently_wrong_row(case):
    from warpvol.tools.bench import load_pipelines
    from warpvol.tools.stress import build_case, run_case

    c = build_case(case, quick=True)
    notes = c.scene.mesh.load_notes
    assert notes.get("ghost_cells_dropped", 0) > 0 or notes.get("collapsed_cells", 0) > 0
    rows = run_case(c, load_pipelines(list(EXACT_PRESETS), "cpu", quick=True))
    assert rows[0]["status"] == "ok"
    check_exact_rows(rows[1:])


def check_exact_rows(rows):
    """Each exact preset's stress row is within its tolerance row, declined in words (a warpvol error), or
    warned in words; a crash (any other exception) or a non-finite pixel fails, whatever its message."""
    for r in rows:
        assert r["status"] in ("ok", "declined"), r  # "failed": a crash or non-finite pixels
        assert r["finite"] is not False, r
        if r["status"] == "declined":
            assert r["message"].strip(), r
            continue
        tol = preset_tolerance(r["pipeline"])
        within = r["max_abs"] is not None and r["max_abs"] <= tol["max_abs"] and r["rmse"] <= tol["rmse"]
        assert within or r["message"], r  # exact, or warned in words


def test_a_crash_or_a_non_finite_row_fails_the_stress_check():
    ok = {"pipeline": "raycast", "status": "ok", "finite": True, "max_abs": 0.0, "rmse": 0.0, "message": ""}
    declined = dict(ok, status="declined", finite=None, max_abs=None, rmse=None,
                    message="m.vtu: parts 0 and 1 overlap")
    check_exact_rows([ok, declined])
    for bad in (dict(declined, status="failed", message="AttributeError: 'MultiBlock' object has no attribute"),
                dict(ok, status="failed", finite=False, max_abs=None, rmse=None, message="non-finite pixels")):
        with pytest.raises(AssertionError):
            check_exact_rows([ok, bad])


def test_render_command_says_what_the_reader_left_out(tmp_path, capsys):
    import json

    from warpvol.cli import main

    path, ghosts = write_pvtu(tmp_path, ghost_grid((6, 5, 5)), 2, 1)
    assert main(["render", str(path), "-o", str(tmp_path / "o.png"), "--width", "12", "--height", "12",
                 "--report", str(tmp_path / "r.json"), "--quiet"]) == 0
    assert f"warpvol: mesh: ghost cells dropped: {ghosts}" in capsys.readouterr().err
    assert json.loads((tmp_path / "r.json").read_text())["mesh_notes"]["ghost_cells_dropped"] == ghosts


WEDGE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1]], float)
PYRAMID = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], float)


@pytest.mark.parametrize("pts,ctype,corners,volume", [
    (WEDGE, VTK_WEDGE, [0, 1, 2, 3, 3, 3], 1 / 6),      # top triangle onto a point: a tet
    (WEDGE, VTK_WEDGE, [0, 1, 1, 3, 4, 4], 0.0),        # onto the quad y = 0: flat
    (PYRAMID, VTK_PYRAMID, [0, 1, 2, 2, 4], 1 / 6),     # base quad onto a triangle: a tet
    (PYRAMID, VTK_PYRAMID, [0, 0, 2, 3, 4], 1 / 6)])
def test_collapsed_wedge_and_pyramid_tile_their_shape(pts, ctype, corners, volume):
    notes = {}
    p, _, tets, _ = split_cells(pts, np.zeros(len(pts)), np.array([ctype]), np.array([0, len(pts)]),
                                np.array(corners), notes)
    v = signed_volumes(p, tets) / 6 if len(tets) else np.zeros(0)
    assert (v > 0).all() and v.sum() == pytest.approx(volume) and notes["collapsed_cells"] == 1
