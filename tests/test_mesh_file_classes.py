"""Mesh files of the kinds users bring, read as the one data set they describe or declined in words:
VTK's reserved arrays (ghost flags, ids, masks) never taken as the scalars, a vector array as the active
scalars, multi-block files nested or with empty blocks (Exodus II element blocks)."""

import numpy as np
import pytest

from warpvol.cli import main
from warpvol.errors import ConfigError
from warpvol.scene.defaults import scene_from_spec
from warpvol.scene.loaders import load_mesh
from warpvol.scene.mesh import TetMesh


def _grid(dims=(4, 4, 4)):
    import pyvista as pv

    g = pv.ImageData(dimensions=dims, spacing=[1.0 / (d - 1) for d in dims])
    g.point_data["s"] = np.sin(3 * g.points[:, 0]) * 0.4 + g.points[:, 1] * g.points[:, 2] * 0.5
    return g


def _same(a: TetMesh, b: TetMesh) -> None:
    assert np.array_equal(a.points, b.points) and np.array_equal(a.tets, b.tets)
    assert np.array_equal(a.scalars, b.scalars)


def _cli(args, capfd):
    capfd.readouterr()
    rc = main(args)
    out, err = capfd.readouterr()
    assert "Traceback" not in err + out
    return rc, err


def _render(path, tmp_path, *more):
    return ["render", str(path), "-o", str(tmp_path / "o.png"), "--width", "8", "--height", "8", "--quiet", *more]


# -- VTK's reserved arrays are never the scalars ----------------------------------------------------
@pytest.mark.parametrize("reserved", ["vtkGhostType", "vtkValidPointMask", "vtkOriginalPointIds", "GlobalNodeId"])
def test_reserved_point_arrays_are_never_the_scalars(tmp_path, reserved):
    g = _grid()
    g.point_data[reserved] = np.zeros(g.n_points, np.uint8 if reserved.startswith("vtkG") else np.int64)
    g.save(tmp_path / "m.vti")
    # the one data array is the scalars, as when it is the only array
    _same(scene_from_spec(tmp_path / "m.vti").mesh, TetMesh.from_pyvista(_grid(), "s"))
    _same(TetMesh.from_pyvista(g), TetMesh.from_pyvista(_grid(), "s"))
    with pytest.raises(ConfigError, match=rf"mesh\.scalars: '{reserved}' in .*m\.vti is an array VTK reserves "
                                          r".*not data; point arrays with data: \['s'\]"):
        load_mesh({"path": "m.vti", "scalars": reserved}, tmp_path)


def test_ghost_flags_beside_cell_data_get_the_cell_data_message(tmp_path, capfd):
    g = _grid()
    del g.point_data["s"]
    g.point_data["vtkGhostType"] = np.zeros(g.n_points, np.uint8)  # the only point array: flags
    g.cell_data["c"] = np.arange(g.n_cells, dtype=float)
    g.save(tmp_path / "m.vti")
    rc, err = _cli(_render(tmp_path / "m.vti", tmp_path), capfd)
    assert rc == 2
    assert err.startswith(f"warpvol: error: {tmp_path / 'm.vti'}: the data set has cell data only ('c'); ")
    assert "cell_data_to_point_data" in err and "vtkGhostType" not in err and err.count("\n") == 1


# -- a vector as the active scalars -------------------------------------------------------------------
def _vector_file(tmp_path, ones=("a", "b")):
    g = _grid()
    del g.point_data["s"]
    g.point_data["velocity"] = g.points.copy()
    for k in ones:
        g.point_data[k] = g.points[:, len(k) - 1]
    g.point_data["vtkGhostType"] = np.zeros(g.n_points, np.uint8)
    g.point_data.active_scalars_name = "velocity"
    g.save(tmp_path / "v.vti")
    return tmp_path / "v.vti"


def test_vector_active_scalars_name_the_scalar_arrays_and_the_option(tmp_path, capfd):
    path = _vector_file(tmp_path)
    rc, err = _cli(_render(path, tmp_path), capfd)
    assert rc == 2 and err.count("\n") == 1
    assert err.startswith(f"warpvol: error: {path}: its active scalars 'velocity' have 3 components; ")
    assert "one-component point arrays in the data set: 'a', 'b'; pick one with --scalars NAME" in err
    assert "mesh file" not in err and "vtkGhostType" not in err
    assert _cli(_render(path, tmp_path, "--scalars", "a"), capfd)[0] == 0
    rc, err = _cli(_render(path, tmp_path, "--scalars", "velocity"), capfd)
    assert rc == 2 and err.startswith(f"warpvol: error: --scalars: array 'velocity' in {path} has 3 components")
    with pytest.raises(ConfigError, match=r"v\.vti: its active scalars .velocity. .*pick one with scalars=\"NAME\""):
        scene_from_spec(path)
    with pytest.raises(ConfigError, match=r"mesh\.scalars: array 'velocity' .*'a', 'b'; pick one with "
                                          r"mesh\.scalars = \"NAME\" in the scene file"):
        load_mesh({"path": "v.vti", "scalars": "velocity"}, tmp_path)
    rc, err = _cli(_render(_vector_file(tmp_path, ones=()), tmp_path), capfd)
    assert rc == 2 and "has no one-component point array" in err


# -- multi-block files: nested, with empty blocks ---------------------------------------------------------
def _nested(tmp_path, tree, name="n.vtm"):
    import pyvista as pv

    def build(t):
        if isinstance(t, list):
            return pv.MultiBlock([build(x) for x in t])
        return t
    mb = build(tree)
    mb.save(tmp_path / name)
    return tmp_path / name


def test_nested_multiblock_with_one_data_set_is_unwrapped(tmp_path, capfd):
    import pyvista as pv

    g = _grid()
    whole = TetMesh.from_pyvista(g, "s")
    empty = pv.UnstructuredGrid()
    for tree in ([[g]], [[[g]]], [[], [None, [g]], [empty]]):
        path = _nested(tmp_path, tree)
        _same(load_mesh({"path": path.name, "scalars": "s"}, tmp_path), whole)
        _same(TetMesh.from_pyvista(pv.read(path), "s"), whole)
    assert _cli(_render(path, tmp_path), capfd)[0] == 0


def test_nested_multiblock_with_several_data_sets_is_refused_in_words(tmp_path, capfd):
    g, h = _grid(), _grid()
    h.origin = (2.0, 0.0, 0.0)
    path = _nested(tmp_path, [[g], [[h]]])
    rc, err = _cli(_render(path, tmp_path), capfd)
    assert rc == 2 and err.count("\n") == 1
    assert f"{path} holds 2 blocks with cells; warpvol needs a single data set: combine the blocks" in err
    with pytest.raises(ConfigError, match=r"mesh: a MultiBlock with 2 blocks of cells; pass a single data set"):
        from warpvol.api import as_mesh
        import pyvista as pv
        as_mesh(pv.read(path))


def test_exodus_like_empty_element_blocks_do_not_count(tmp_path):
    import pyvista as pv

    # as the Exodus II reader returns a file: 'Element Blocks' (8, 7 of them empty), then the sets
    g = _grid().cast_to_unstructured_grid()
    blocks = [pv.UnstructuredGrid() for _ in range(8)]
    blocks[5] = g
    mb = pv.MultiBlock({"Element Blocks": pv.MultiBlock(blocks), "Face Blocks": pv.MultiBlock(),
                        "Node Sets": pv.MultiBlock()})
    mb.save(tmp_path / "e.vtm")
    whole = TetMesh.from_pyvista(_grid(), "s")
    m = load_mesh({"path": "e.vtm", "scalars": "s"}, tmp_path)
    assert m.n_tets == whole.n_tets and np.isclose(m.scalars.sum(), whole.scalars.sum())
    assert TetMesh.from_pyvista(mb, "s").n_tets == whole.n_tets
