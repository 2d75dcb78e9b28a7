"""Stress cases of mesh files as solvers and ParaView write them, and the builders the tests share:

* :func:`write_pvtu`: a grid cut into slab pieces, each written with layers of ghost cells from its
  neighbours, and the ``.pvtu`` naming them (cases ``ghost_layers_*``: read back as the one mesh);
* :func:`ogrid`: a cylinder or cone as a structured O-grid, whose axis cells are hexahedra with a face
  collapsed onto the axis (cases ``collapsed_hexes_*``: its points merged, the file's hexahedra name
  the axis points twice, as solvers write them).

:func:`file_cases` registers the cases with the helpers of :func:`warpvol.tools.stress._cases` (see
:mod:`warpvol.tools.stress_real`).
"""

from __future__ import annotations

import numpy as np

from warpvol.scene.camera import Camera
from warpvol.scene.loaders import read_mesh_file
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import TransferFunction

#: TF of these cases over the fields' range [-0.5, 1.2]: [s, r, g, b, extinction]
FILE_TF = ((-0.5, 0.2, 0.4, 1.0, 0.8), (0.5, 1.0, 0.5, 0.2, 2.4), (1.2, 1.0, 1.0, 1.0, 0.4))


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


def ghost_grid(dims, tets: bool = False):
    """A pyvista UnstructuredGrid over the unit cube: ``dims`` points, hexahedra or (``tets``) 5-6 tets
    each, point data ``"s"``."""
    import pyvista as pv

    g = pv.ImageData(dimensions=dims, spacing=[1.0 / (d - 1) for d in dims]).cast_to_unstructured_grid()
    if tets:
        g = g.triangulate()
    g.point_data["s"] = np.sin(3 * g.points[:, 0]) * 0.4 + g.points[:, 1] * g.points[:, 2] * 0.5 + 0.2
    return g


def ogrid(nr, nt, nz, cone: bool = False):
    """A cylinder (``cone``: a cone, apex at z = 1) as a structured O-grid of ``nr x nt x nz`` points: the
    cells at the axis have a face collapsed onto the axis (wedges); a cone's top layer has its top faces
    collapsed onto the apex (pyramids, and tets at the axis). Point data ``"s"``."""
    import pyvista as pv

    r, t, z = np.linspace(0, 1, nr), np.linspace(0, 2 * np.pi, nt + 1), np.linspace(0, 1, nz)
    R, T, Z = np.meshgrid(r, t, z, indexing="ij")
    if cone:
        R = R * (1.0 - Z)
    X, Y = R * np.cos(T), R * np.sin(T)
    X[0], Y[0] = 0.0, 0.0
    if cone:
        X[:, :, -1], Y[:, :, -1] = 0.0, 0.0
    sg = pv.StructuredGrid(X, Y, Z)
    sg.point_data["s"] = 0.5 + 0.4 * np.sin(2 * sg.points[:, 0] + sg.points[:, 2]) * sg.points[:, 1]
    return sg


def file_cases(simple, with_ref, sc) -> None:
    import tempfile
    import warnings
    from pathlib import Path


    tf = TransferFunction([list(p) for p in FILE_TF])

    def cam(q, eye=(2.2, 1.7, 2.9), target=(0.5, 0.5, 0.5)):
        px = 24 if q else 128
        return Camera(eye=eye, target=target, up=(0, 0, 1), fov_y_deg=30.0, width_px=px, height_px=px)

    for name, dims, tets, pieces, layers in (("ghost_layers_hex", (9, 7, 6), False, 2, 1),
                                             ("ghost_layers_tets", (7, 7, 5), True, 3, 2)):
        def ghosts(q, dims=dims, tets=tets, pieces=pieces, layers=layers, name=name):
            with tempfile.TemporaryDirectory() as d:
                path, _ = write_pvtu(Path(d), ghost_grid(dims, tets), pieces, layers)
                mesh = read_mesh_file(path, "s")
            return sc(mesh, tf, cam(q), name)
        simple(name, f"a .pvtu of {pieces} pieces of {'tets' if tets else 'hexahedra'}, each with {layers} layer(s) "
               "of ghost cells from its neighbours (vtkGhostType): read as the one mesh", ghosts)
    for name, cone in (("collapsed_hexes_wedges", False), ("collapsed_hexes_pyramids", True)):
        def collapsed(q, cone=cone, name=name):
            ug = ogrid(4, 12, 4, cone=cone).cast_to_unstructured_grid().clean(tolerance=1e-12)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the cone's flat top cells
                mesh = TetMesh.from_pyvista(ug, "s", name=name)
            return sc(mesh, tf, cam(q, eye=(2.6, -1.7, 2.3), target=(0.0, 0.0, 0.5)), name)
        simple(name, "an O-grid " + ("cone: top faces collapsed onto the apex (pyramids, tets at the axis)" if cone
                                     else "cylinder: the axis cells' faces collapsed onto the axis (wedges)")
               + ", written as hexahedra that name a point twice", collapsed)
