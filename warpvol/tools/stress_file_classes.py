"""Stress cases of mesh-file classes read through the loader (:func:`warpvol.scene.loaders.read_mesh_file`),
each written to a temporary folder as a user would bring it:

* ``hidden_cells_resampled``: ParaView's Resample To Image of a hexahedral block into a larger box (the
  points outside its source hidden, ``vtkGhostType`` HIDDENPOINT): only the cells inside are rendered;
* ``hidden_cells_overset``: a curvilinear ``.vts`` with a blanked hole (HIDDENCELL, as overset solvers
  write iblank): the hole is empty space a ray leaves and re-enters;
* ``pvts_pieces``: a curvilinear grid written as a ``.pvts`` of three pieces with a ghost level;
* ``nested_multiblock``: a ``.vtm`` whose one data set sits two MultiBlocks deep beside empty blocks;
* ``empty_element_blocks``: Exodus-like element blocks, seven of eight empty, in a ``.vtm``;
* ``time_series_step``: a ``.pvd`` of three steps, its last step picked;
* ``cohesive_layer``: hexahedra with a layer of zero-thickness hexahedra between two slabs on separate
  points (dropped, counted in the file's cells).

:func:`file_class_cases` registers them with the helpers of :func:`warpvol.tools.stress._cases`.
"""

from __future__ import annotations

import numpy as np

from warpvol.scene.camera import Camera
from warpvol.scene.grids import cell_corners
from warpvol.scene.loaders import read_mesh_file
from warpvol.scene.split_cells import VOXEL_TO_HEX
from warpvol.scene.transfer import TransferFunction
from warpvol.tools.stress_files import FILE_TF


def _field(pts: np.ndarray) -> np.ndarray:
    return np.sin(3 * pts[:, 0]) * 0.4 + pts[:, 1] * pts[:, 2] * 0.5 + 0.2


def _image(dims, spacing=None, origin=(0.0, 0.0, 0.0)):
    import pyvista as pv

    g = pv.ImageData(dimensions=dims, spacing=spacing or [1.0 / (d - 1) for d in dims], origin=origin)
    g.point_data["s"] = _field(np.asarray(g.points))
    return g


def _curvilinear(dims):
    """A gently bent curvilinear grid over about the unit cube, point data ``"s"``."""
    sg = _image(dims).cast_to_structured_grid()
    p = np.asarray(sg.points).copy()
    p[:, 2] += 0.15 * np.sin(np.pi * p[:, 0]) * p[:, 1]
    sg.points = p
    sg.point_data["s"] = _field(p)
    return sg


def resampled(dims=(9, 9, 9)):
    """vtkResampleToImage of a hexahedral block [0.2, 0.8]^3 into the box [0, 1]^3."""
    import pyvista as pv
    from vtkmodules.vtkFiltersCore import vtkResampleToImage

    src = _image((5, 5, 5), spacing=(0.15, 0.15, 0.15), origin=(0.2, 0.2, 0.2)).cast_to_unstructured_grid()
    r = vtkResampleToImage()
    r.SetInputDataObject(src)
    r.SetSamplingDimensions(*dims)
    r.SetUseInputBounds(False)
    r.SetSamplingBounds(0.0, 1.0, 0.0, 1.0, 0.0, 1.0)
    r.Update()
    return pv.wrap(r.GetOutput())


def overset(dims=(9, 8, 7)):
    """A curvilinear grid whose cells with centre within 0.22 of (0.5, 0.5, 0.5) are HIDDENCELL, the
    values at the points only they use a fill value (-999), as a blanked solver writes them."""
    sg = _curvilinear(dims)
    c = np.asarray(sg.cell_centers().points)
    hole = np.linalg.norm(c - [0.5, 0.5, 0.5], axis=1) < 0.22
    sg.cell_data["vtkGhostType"] = np.where(hole, 32, 0).astype(np.uint8)

    used = np.zeros(sg.n_points, dtype=bool)
    used[cell_corners(dims)[~hole].ravel()] = True
    sg.point_data["s"] = np.where(used, sg.point_data["s"], -999.0)
    return sg


def write_pvts(folder, sg, pieces=3, ghost=1):
    import vtk

    w = vtk.vtkXMLPStructuredGridWriter()
    w.SetInputData(sg)
    w.SetFileName(str(folder / "grid.pvts"))
    w.SetNumberOfPieces(pieces)
    w.SetStartPiece(0)
    w.SetEndPiece(pieces - 1)
    w.SetGhostLevel(ghost)
    w.Write()
    return folder / "grid.pvts"


def write_pvd(path, steps, stem="step"):
    """A ``.pvd`` collection at ``path`` of ``steps``, ``(time, data set)`` pairs: each data set saved beside it
    as ``<stem><i>.vti`` and named with its time step; returns ``path``."""
    entries = []
    for i, (t, g) in enumerate(steps):
        g.save(path.parent / f"{stem}{i}.vti")
        entries.append(f'<DataSet timestep="{t}" part="0" file="{stem}{i}.vti"/>')
    path.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1"><Collection>'
                    + "".join(entries) + "</Collection></VTKFile>")
    return path


def write_series(folder, n=3):
    """A ``.pvd`` of ``n`` steps of one image, the field at step ``i`` scaled by ``(i + 1) / n``."""
    steps = []
    for i in range(n):
        g = _image((7, 6, 6))
        g.point_data["s"] = g.point_data["s"] * (i + 1) / n
        steps.append((0.25 * i, g))
    return write_pvd(folder / "series.pvd", steps)


def cohesive(dims=(5, 5, 3)):
    """Two slabs of hexahedra (z in [0, 0.5] and [0.5, 1]) on separate points joined by a layer of
    zero-thickness hexahedra on the two slabs' points at z = 0.5."""
    import pyvista as pv

    a = _image(dims, spacing=(1.0 / (dims[0] - 1), 1.0 / (dims[1] - 1), 0.5 / (dims[2] - 1)))
    pa = np.asarray(a.points)
    hexes = np.asarray(a.cast_to_unstructured_grid().cells).reshape(-1, 9)[:, 1:][:, VOXEL_TO_HEX]
    n, layer_pts = a.n_points, dims[0] * dims[1] * (dims[2] - 1)
    pts = np.concatenate([pa, pa + [0, 0, 0.5]])
    top = hexes[np.isclose(pa[hexes[:, 4], 2], 0.5)][:, 4:]
    cells = np.concatenate([hexes, hexes + n, np.concatenate([top, top - layer_pts + n], axis=1)])
    g = pv.UnstructuredGrid(np.hstack([np.full((len(cells), 1), 8), cells]).ravel(),
                            np.full(len(cells), 12, np.uint8), pts)
    g.point_data["s"] = _field(pts)
    return g


def file_class_cases(simple, with_ref, sc) -> None:
    import tempfile
    from pathlib import Path


    tf = TransferFunction([list(p) for p in FILE_TF])

    def cam(q):
        px = 24 if q else 128
        return Camera(eye=(2.2, 1.7, 2.9), target=(0.5, 0.5, 0.5), up=(0, 0, 1), fov_y_deg=30.0, width_px=px,
                      height_px=px)

    def through_file(name, write, **read):
        def build(q):
            with tempfile.TemporaryDirectory() as d:
                mesh = read_mesh_file(write(Path(d), q), "s", **read)
            return sc(mesh, tf, cam(q), name)
        return build

    def save(ds, file):
        def write(folder, q):
            ds(q).save(folder / file)
            return folder / file
        return write

    def nested(q):
        import pyvista as pv
        g = _curvilinear((6, 5, 5) if q else (12, 10, 10))
        return pv.MultiBlock([pv.MultiBlock(), pv.MultiBlock([None, pv.MultiBlock([g])]), pv.UnstructuredGrid()])

    def element_blocks(q):
        import pyvista as pv
        blocks = [pv.UnstructuredGrid() for _ in range(8)]
        blocks[3] = _image((6, 5, 5) if q else (12, 10, 10)).cast_to_unstructured_grid()
        return pv.MultiBlock({"Element Blocks": pv.MultiBlock(blocks), "Face Blocks": pv.MultiBlock(),
                              "Node Sets": pv.MultiBlock()})

    for name, doc, build in (
            ("hidden_cells_resampled", "ParaView's Resample To Image of a block into a larger box: the points "
             "outside its source hidden (vtkGhostType HIDDENPOINT), their cells dropped",
             through_file("hidden_cells_resampled", save(lambda q: resampled((9, 9, 9) if q else (21, 21, 21)),
                                                         "r.vti"))),
            ("hidden_cells_overset", "a curvilinear .vts with a blanked hole (HIDDENCELL, fill values at its points): "
             "rays leave the data at the hole and re-enter",
             through_file("hidden_cells_overset", save(lambda q: overset((9, 8, 7) if q else (19, 17, 15)),
                                                       "o.vts"))),
            ("pvts_pieces", "a curvilinear grid as a .pvts of 3 pieces with a ghost level, read whole",
             through_file("pvts_pieces", lambda f, q: write_pvts(f, _curvilinear((9, 7, 6) if q else (21, 17, 15))))),
            ("nested_multiblock", "a .vtm whose one grid sits two MultiBlocks deep beside empty blocks",
             through_file("nested_multiblock", save(nested, "n.vtm"))),
            ("empty_element_blocks", "Exodus-like element blocks in a .vtm, 7 of 8 empty: the one with cells is read",
             through_file("empty_element_blocks", save(element_blocks, "e.vtm"))),
            ("time_series_step", "a .pvd of 3 steps, the last picked (step = 2)",
             through_file("time_series_step", lambda f, q: write_series(f), step=2)),
            ("cohesive_layer", "two slabs of hexahedra joined by a layer of zero-thickness hexahedra on separate "
             "points: the layer dropped, counted in the file's cells",
             through_file("cohesive_layer", save(lambda q: cohesive((5, 5, 3) if q else (11, 11, 5)), "c.vtu")))):
        simple(name, doc, build)
