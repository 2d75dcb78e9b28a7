"""Meshes as solvers and ParaView write them: a ``.pvtu`` whose pieces carry ghost cells, and hexahedra
collapsed onto an O-grid axis. Each is read as the mesh it describes, renders within the exact presets'
tolerances of the reference of that mesh, and the report says what was left out."""

import warnings

import numpy as np
import pytest

from helpers import scene
from tolerances import TOLERANCES
from warpvol.errors import MeshError
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.camera import Camera
from warpvol.scene.loaders import load_mesh
from warpvol.scene.mesh import TetMesh, signed_volumes
from warpvol.scene.split_cells import VTK_HEXAHEDRON, split_cells
from warpvol.scene.transfer import TransferFunction

TF = TransferFunction([[0.0, 0.2, 0.4, 1.0, 0.8], [0.5, 1.0, 0.5, 0.2, 1.6], [1.0, 1.0, 1.0, 1.0, 0.4]])
CAM = Camera(eye=[2.2, 1.7, 2.9], target=[0.5, 0.5, 0.5], width_px=24, height_px=24)


def write_pvtu(folder, grid, n_pieces=2, layers=1, axis=0):
    """``grid`` cut into ``n_pieces`` slabs along ``axis``, each written as a ``.vtu`` piece with
    ``layers`` layers of ghost cells from its neighbours, and the ``.pvtu`` naming them. Ghosts come from
    VTK's vtkGhostCellsGenerator (as ParaView writes them) for hexahedra; for tets, for which it makes
    none, they are marked the same way here: the other pieces' cells that share a point with the piece
    (``layers`` times), flagged ``DUPLICATECELL``, and their points the piece does not own
    ``DUPLICATEPOINT``. Returns the ``.pvtu`` path and the ghost-cell count."""
    import pyvista as pv
    import vtk

    centres = grid.cell_centers().points[:, axis]
    cuts = np.quantile(centres, np.linspace(0, 1, n_pieces + 1)[1:-1])
    piece = np.searchsorted(cuts, centres, side="right")
    parts = vtk.vtkPartitionedDataSet()
    for i in range(n_pieces):
        p = grid.extract_cells(np.flatnonzero(piece == i))
        for data in (p.point_data, p.cell_data):
            for k in [k for k in data.keys() if k.startswith("vtk")]:
                del data[k]
        parts.SetPartition(i, p)
    gen = vtk.vtkGhostCellsGenerator()
    gen.SetInputData(parts)
    gen.SetNumberOfGhostLayers(layers)
    gen.BuildIfRequiredOff()
    gen.Update()
    out = [pv.wrap(gen.GetOutput().GetPartition(i)) for i in range(n_pieces)]
    if not any((np.asarray(o.cell_data["vtkGhostType"]) & 1).any() for o in out if "vtkGhostType" in o.cell_data):
        out = [_ghost_piece(grid, piece, i, layers) for i in range(n_pieces)]
    ghosts = 0
    for i, o in enumerate(out):
        o.save(folder / f"piece{i}.vtu")
        ghosts += int((np.asarray(o.cell_data["vtkGhostType"]) & 1).sum())
    pieces = "".join(f'<Piece Source="piece{i}.vtu"/>' for i in range(n_pieces))
    path = folder / "mesh.pvtu"
    path.write_text(f'''<?xml version="1.0"?>
<VTKFile type="PUnstructuredGrid" version="0.1" byte_order="LittleEndian">
<PUnstructuredGrid GhostLevel="{layers}">
<PPointData Scalars="s"><PDataArray type="Float64" Name="s"/><PDataArray type="UInt8" Name="vtkGhostType"/></PPointData>
<PCellData><PDataArray type="UInt8" Name="vtkGhostType"/></PCellData>
<PPoints><PDataArray type="Float64" NumberOfComponents="3"/></PPoints>
{pieces}
</PUnstructuredGrid></VTKFile>''')
    return path, ghosts


def _ghost_piece(grid, piece, i, layers):
    conn = np.asarray(grid.cells).reshape(grid.n_cells, -1)[:, 1:]
    mine = piece == i
    cells = mine.copy()
    for _ in range(layers):
        cells |= np.isin(conn, conn[cells]).any(axis=1)
    owner = np.full(grid.n_points, n_max := int(piece.max()) + 1)
    for c in range(n_max):  # a point belongs to the lowest piece that uses it
        owner[np.unique(conn[piece == c])] = np.minimum(owner[np.unique(conn[piece == c])], c)
    sel = np.flatnonzero(cells)
    p = grid.extract_cells(sel)
    p.cell_data["vtkGhostType"] = np.where(mine[sel], 0, 1).astype(np.uint8)
    p.point_data["vtkGhostType"] = np.where(owner[np.asarray(p.point_data["vtkOriginalPointIds"])] == i, 0,
                                            1).astype(np.uint8)
    for data in (p.point_data, p.cell_data):
        for k in [k for k in data.keys() if k.startswith("vtkOriginal")]:
            del data[k]
    return p


def _grid(dims, tets: bool):
    import pyvista as pv

    g = pv.ImageData(dimensions=dims, spacing=[1.0 / (d - 1) for d in dims]).cast_to_unstructured_grid()
    if tets:
        g = g.triangulate()
    g.point_data["s"] = np.sin(3 * g.points[:, 0]) * 0.4 + g.points[:, 1] * g.points[:, 2] * 0.5 + 0.2
    return g


@pytest.mark.parametrize("dims,tets,n_pieces,layers,axis", [
    ((7, 5, 5), False, 2, 1, 0), ((6, 6, 4), True, 2, 2, 1), ((5, 7, 6), False, 3, 1, 2)])
def test_pvtu_ghost_cells_are_dropped_and_counted(tmp_path, dims, tets, n_pieces, layers, axis):
    g = _grid(dims, tets)
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
        assert np.abs(res.image - ref).max() <= TOLERANCES[name if name != "raycast" else "raycast/fp32"]["max_abs"]
        assert res.report["mesh_notes"]["ghost_cells_dropped"] == ghosts


def test_hidden_points_drop_their_cells():
    g = _grid((4, 4, 4), False)
    gt = np.zeros(g.n_points, np.uint8)
    gt[0] = 2  # HIDDENPOINT: the one cell at the corner goes
    g.point_data["vtkGhostType"] = gt
    m = TetMesh.from_pyvista(g, "s")
    assert m.load_notes == {"hidden_cells_dropped": 1}
    assert signed_volumes(m.points, m.tets).sum() / 6 == pytest.approx(26 / 27)


def ogrid(nr, nt, nz):
    """A cylinder as a structured O-grid: the cells at the axis have a face collapsed onto the axis."""
    import pyvista as pv

    r, t, z = np.linspace(0, 1, nr), np.linspace(0, 2 * np.pi, nt + 1), np.linspace(0, 1, nz)
    R, T, Z = np.meshgrid(r, t, z, indexing="ij")
    X, Y = R * np.cos(T), R * np.sin(T)
    X[0], Y[0] = 0.0, 0.0
    sg = pv.StructuredGrid(X, Y, Z)
    sg.point_data["s"] = 0.5 + 0.4 * np.sin(2 * sg.points[:, 0] + sg.points[:, 2]) * sg.points[:, 1]
    return sg


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
    assert np.abs(res.image - ref).max() <= TOLERANCES["raycast/fp32"]["max_abs"]
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
