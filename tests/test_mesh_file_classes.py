"""Mesh files of the kinds users bring, read as the one data set they describe or declined in words:
VTK's reserved arrays (ghost flags, ids, masks) never taken as the scalars, a vector array as the active
scalars, multi-block files nested or with empty blocks (Exodus II element blocks)."""

import numpy as np
import pytest

from warpvol.cli import main
from warpvol.errors import ConfigError
from warpvol.scene.loaders import load_mesh
from warpvol.scene.mesh import TetMesh
from warpvol.scene.spec import scene_from_spec
from warpvol.tools.stress_file_classes import write_pvd


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
        import pyvista as pv

        from warpvol.api import as_mesh
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


# -- blanked structured grids: hidden cells and points dropped -------------------------------------------
def _write_structured(g, kind, folder):
    """``g`` (an ImageData) written as ``kind``: .vti, .vts, .vtr, or in 2 pieces as .pvti / .pvts."""
    import pyvista as pv
    import vtk

    path = folder / f"m.{kind}"
    if kind == "vti":
        g.save(path)
    elif kind in ("vts", "pvts"):
        sg = g.cast_to_structured_grid()
        if kind == "vts":
            sg.save(path)
        else:
            w = vtk.vtkXMLPStructuredGridWriter()
            w.SetInputData(sg)
    elif kind == "vtr":
        x, y, z = (g.origin[a] + g.spacing[a] * np.arange(g.dimensions[a]) for a in range(3))
        r = pv.RectilinearGrid(x, y, z)
        r.point_data.update(g.point_data)
        r.cell_data.update(g.cell_data)
        r.save(path)
    if kind == "pvti":
        w = vtk.vtkXMLPImageDataWriter()
        w.SetInputData(g)
    if kind.startswith("p"):
        w.SetFileName(str(path))
        w.SetNumberOfPieces(2)
        w.SetStartPiece(0)
        w.SetEndPiece(1)
        w.SetGhostLevel(1)
        w.Write()
    return path


def _blanked(flag):
    """A 7 x 6 x 5 image over [0, 1.2] x [0, 1] x [0, 0.8] whose cells with centre x > 0.7 (``flag``
    'cell': HIDDENCELL) or whose points with x > 0.75 (``flag`` 'point': HIDDENPOINT, their values NaN, as
    a blanked solver writes them) are hidden; and the (C,) bool of the cells hidden."""
    g = _grid((7, 6, 5))
    g.spacing = (0.2, 0.2, 0.2)
    g.point_data["s"] = np.sin(3 * g.points[:, 0]) * 0.4 + g.points[:, 1] * g.points[:, 2] * 0.5 + 0.2
    clean = g.copy()
    if flag == "cell":
        hidden = g.cell_centers().points[:, 0] > 0.7  # two columns of cells
        g.cell_data["vtkGhostType"] = np.where(hidden, 32, 0).astype(np.uint8)
    else:
        hp = g.points[:, 0] > 0.75
        g.point_data["vtkGhostType"] = np.where(hp, 2, 0).astype(np.uint8)
        g.point_data["s"] = np.where(hp, np.nan, g.point_data["s"])
        hidden = np.repeat([[False, False, False, True, True, True]], 4 * 5, axis=0).ravel()  # corner x >= 0.8
    return g, clean, hidden


@pytest.mark.parametrize("kind", ["vti", "vts", "vtr", "pvts", "pvti"])
@pytest.mark.parametrize("flag", ["cell", "point"])
def test_hidden_cells_of_structured_grids_are_dropped_and_counted(tmp_path, kind, flag):
    from helpers import scene
    from tolerances import preset_tolerance
    from warpvol.pipeline import Pipeline
    from warpvol.reference.numpy_render import render_reference
    from warpvol.scene.camera import Camera
    from warpvol.scene.transfer import TransferFunction

    g, clean, hidden = _blanked(flag)
    m = load_mesh({"path": _write_structured(g, kind, tmp_path).name, "scalars": "s"}, tmp_path)
    assert m.load_notes == {"hidden_cells_dropped": int(hidden.sum())}
    full = TetMesh.from_pyvista(clean, "s")  # the same data with the hidden cells' tets taken out
    keep = np.repeat(~hidden, 6)
    expect = TetMesh(full.points, full.tets[keep], full.scalars)
    assert m.n_tets == expect.n_tets and np.isclose(np.abs(m.face_planes).sum(), np.abs(expect.face_planes).sum())
    tf = TransferFunction([[0.0, 0.2, 0.4, 1.0, 0.8], [0.5, 1.0, 0.5, 0.2, 1.6], [1.0, 1.0, 1.0, 1.0, 0.4]])
    cam = Camera(eye=[2.4, 1.9, 2.6], target=[0.6, 0.5, 0.4], width_px=20, height_px=20)
    ref = render_reference(expect, tf, cam)
    np.testing.assert_allclose(render_reference(m, tf, cam), ref, atol=1e-9)
    if kind == "vts" and flag == "point":
        res = Pipeline.load("raycast").render(scene(m, tf, cam), quiet=True)
        assert np.abs(res.image - ref).max() <= preset_tolerance("raycast")["max_abs"]
        assert res.report["mesh_notes"] == {"hidden_cells_dropped": int(hidden.sum())}


def test_blanked_image_says_what_was_dropped(tmp_path, capfd):
    g, _, hidden = _blanked("cell")
    rc, err = _cli(_render(_write_structured(g, "vti", tmp_path), tmp_path), capfd)
    assert rc == 0 and f"warpvol: mesh: hidden cells dropped: {int(hidden.sum())}" in err
    g.cell_data["vtkGhostType"] = np.full(g.n_cells, 32, np.uint8)
    rc, err = _cli(_render(_write_structured(g, "vti", tmp_path), tmp_path), capfd)
    assert rc == 2 and "every cell is hidden" in err and err.count("\n") == 1


def test_resample_to_image_outside_its_source_is_dropped():
    """ParaView's Resample To Image on a box larger than its source: the points outside it are invalid
    (vtkValidPointMask 0) and hidden; the cells with such a corner go, every point left is valid."""
    import pyvista as pv
    from vtkmodules.vtkFiltersCore import vtkResampleToImage

    src = pv.ImageData(dimensions=(5, 5, 5), spacing=(0.5, 0.5, 0.5), origin=(-1, -1, -1)).cast_to_unstructured_grid()
    src.point_data["s"] = src.points[:, 0] + 2.0
    r = vtkResampleToImage()
    r.SetInputDataObject(src)
    r.SetSamplingDimensions(9, 9, 9)
    r.SetUseInputBounds(False)
    r.SetSamplingBounds(-1.3, 1.3, -1.3, 1.3, -1.3, 1.3)
    r.Update()
    img = pv.wrap(r.GetOutput())
    valid = np.asarray(img.point_data["vtkValidPointMask"]).astype(bool)
    assert not valid.all()
    m = TetMesh.from_pyvista(img, "s")
    from warpvol.scene.grids import cell_corners
    bad = ~valid[cell_corners(img.dimensions)].all(axis=1)
    assert m.load_notes == {"hidden_cells_dropped": int(bad.sum())}
    assert m.n_tets == 6 * int((~bad).sum()) and (m.scalars > 0.5).all()  # no outside point's 0 is left


# -- zero-volume cells (cohesive layers) -----------------------------------------------------------------
def _cohesive(kind):
    """Two slabs of hexahedra (``kind`` 'hex') or wedges ('wedge') on separate points, z in [0, 0.5] and
    [0.5, 1], joined by a layer of zero-thickness cells of the same kind on the two slabs' points at
    z = 0.5 (a cohesive layer, as fracture codes write it). Returns the grid with the layer, the grid
    without it and the layer's cell count."""
    import pyvista as pv

    from warpvol.scene.split_cells import VOXEL_TO_HEX

    a = pv.ImageData(dimensions=(4, 4, 3), spacing=(1 / 3, 1 / 3, 0.25))
    pa = np.asarray(a.points)
    hexes = np.asarray(a.cast_to_unstructured_grid().cells).reshape(-1, 9)[:, 1:][:, VOXEL_TO_HEX]
    n = a.n_points
    pts = np.concatenate([pa, pa + [0, 0, 0.5]])
    cells = np.concatenate([hexes, hexes + n])
    top = hexes[np.isclose(pa[hexes[:, 4], 2], 0.5)][:, 4:]  # slab a's top faces (z = 0.5)
    layer = np.concatenate([top, top - 32 + n], axis=1)      # ... and slab b's bottom faces (z = 0.5)
    cells = np.concatenate([cells, layer])
    ctype = 12
    if kind == "wedge":
        cells = np.concatenate([cells[:, [0, 1, 2, 4, 5, 6]], cells[:, [0, 2, 3, 4, 6, 7]]])
        ctype, n_layer = 13, 2 * len(layer)
        order = np.argsort(np.concatenate([np.arange(len(cells) // 2)] * 2), kind="stable")
        cells = cells[order]
    else:
        n_layer = len(layer)
    width = cells.shape[1]

    def grid(c):
        g = pv.UnstructuredGrid(np.hstack([np.full((len(c), 1), width), c]).ravel(),
                                np.full(len(c), ctype, np.uint8), pts)
        g.point_data["s"] = np.sin(3 * pts[:, 0]) * 0.4 + pts[:, 1] * pts[:, 2] * 0.5 + 0.2
        return g
    flat = np.zeros(len(cells), bool)
    flat[-n_layer:] = True
    return grid(cells), grid(cells[~flat]), n_layer


@pytest.mark.parametrize("kind", ["hex", "wedge"])
def test_zero_volume_cells_are_counted_as_file_cells_without_a_warning(tmp_path, capfd, kind):
    import warnings

    from warpvol.reference.numpy_render import render_reference
    from warpvol.scene.camera import Camera
    from warpvol.scene.transfer import TransferFunction

    g, without, n_layer = _cohesive(kind)
    g.save(tmp_path / "c.vtu")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_mesh({"path": "c.vtu", "scalars": "s"}, tmp_path)
        bare = TetMesh.from_pyvista(without, "s")
    assert m.load_notes == {"zero_volume_cells_dropped": n_layer}
    assert m.n_tets == bare.n_tets
    tf = TransferFunction([[0.0, 0.2, 0.4, 1.0, 0.8], [0.5, 1.0, 0.5, 0.2, 1.6], [1.0, 1.0, 1.0, 1.0, 0.4]])
    cam = Camera(eye=[2.2, 1.7, 2.9], target=[0.5, 0.5, 0.5], width_px=16, height_px=16)
    np.testing.assert_allclose(render_reference(m, tf, cam), render_reference(bare, tf, cam), atol=1e-9)
    rc, err = _cli(_render(tmp_path / "c.vtu", tmp_path), capfd)
    assert rc == 0 and f"warpvol: mesh: zero volume cells dropped: {n_layer}\n" in err
    assert "Warning" not in err and "zero-volume tet" not in err
    rc, err = _cli(_render(tmp_path / "c.vtu", tmp_path, "--strict"), capfd)
    assert rc == 2 and "zero-volume" in err and "strict" in err


# -- time series: which step, and the user's pick ----------------------------------------------------------
def _series(tmp_path, times=(0.0, 0.5, 1.0)):
    """A .pvd of ``len(times)`` steps of one grid, the field at step ``i`` scaled by ``i + 1`` (files
    ``t<i>.vti``), written by the stress suite's builder."""
    steps = []
    for i, t in enumerate(times):
        g = _grid()
        g.point_data["s"] = g.point_data["s"] * (i + 1) + 2.0
        steps.append((t, g))
    return write_pvd(tmp_path / "series.pvd", steps, stem="t")


def _step_mesh(tmp_path, i):
    g = _grid()
    g.point_data["s"] = g.point_data["s"] * (i + 1) + 2.0
    return TetMesh.from_pyvista(g, "s")


def test_time_series_says_which_step_and_takes_the_users_pick(tmp_path, capfd):
    import warpvol
    from warpvol.scene.scene_file import load_scene

    path = _series(tmp_path)
    m = load_mesh({"path": path.name, "scalars": "s"}, tmp_path)
    _same(m, _step_mesh(tmp_path, 0))
    assert m.load_notes == {"time_step": "0 of 3 (time 0; steps 0 to 2, times 0 to 1)"}
    for cfg, i in (({"step": 2}, 2), ({"time": 0.5}, 1), ({"time": 1}, 2), ({"step": 0}, 0)):
        m = load_mesh({"path": path.name, "scalars": "s", **cfg}, tmp_path)
        _same(m, _step_mesh(tmp_path, i))
        assert m.load_notes["time_step"].startswith(f"{i} of 3 ")
    rc, err = _cli(_render(path, tmp_path), capfd)
    assert rc == 0 and "warpvol: mesh: time step: 0 of 3 (time 0; steps 0 to 2, times 0 to 1)\n" in err
    rc, err = _cli(_render(path, tmp_path, "--step", "1", "--report", str(tmp_path / "r.json")), capfd)
    assert rc == 0 and "time step: 1 of 3 (time 0.5;" in err
    import json
    assert json.loads((tmp_path / "r.json").read_text())["mesh_notes"]["time_step"].startswith("1 of 3")
    assert _cli(_render(path, tmp_path, "--time", "1.0"), capfd)[0] == 0
    rc, err = _cli(["reference", str(path), "-o", str(tmp_path / "ref.exr"), "--width", "8", "--height", "8",
                    "--quiet", "--step", "2"], capfd)
    assert rc == 0 and "warpvol: mesh: time step: 2 of 3 (time 1;" in err
    scene = tmp_path / "s.toml"
    scene.write_text(f'[mesh]\npath = "{path.name}"\nscalars = "s"\ntime = 0.5\n')
    _same(load_scene(scene).mesh, _step_mesh(tmp_path, 1))
    r = warpvol.render(path, size=8, step=2)
    assert r.report["mesh_notes"]["time_step"].startswith("2 of 3")


@pytest.mark.parametrize("args,words", [
    (["--step", "3"], "--step: 3 is outside the time steps of {p}: 0 to 2 (3 steps, times 0 to 1)"),
    (["--step", "-1"], "--step: -1 is outside the time steps of {p}: 0 to 2 (3 steps, times 0 to 1)"),
    (["--time", "0.3"], "--time: {p} has no step at time 0.3; its 3 times run from 0 to 1: 0, 0.5, 1 (or name a "
                        "step with --step, 0 to 2)"),
    (["--step", "1", "--time", "0.5"], "--step/--time: give one of them, not both"),
])
def test_a_time_step_outside_the_series_is_refused_naming_the_range(tmp_path, capfd, args, words):
    path = _series(tmp_path)
    rc, err = _cli(_render(path, tmp_path, *args), capfd)
    assert rc == 2 and err == f"warpvol: error: {words.format(p=path)}\n"
    assert not (tmp_path / "o.png").exists()


def test_step_and_time_belong_to_time_series_files(tmp_path, capfd):
    path = _series(tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.step: 7 is outside the time steps of .*series\.pvd: 0 to 2"):
        load_mesh({"path": path.name, "scalars": "s", "step": 7}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.step: expected a whole number .* got 1\.5"):
        load_mesh({"path": path.name, "scalars": "s", "step": 1.5}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.time: .*has no step at time 2"):
        load_mesh({"path": path.name, "scalars": "s", "time": 2.0}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.step: .*t1\.vti is not a time series .*leave mesh\.step out"):
        load_mesh({"path": "t1.vti", "scalars": "s", "step": 1}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.time: only used with 'path'"):
        load_mesh({"builtin": "box", "time": 1.0}, tmp_path)
    rc, err = _cli(["render", "builtin:box", "--step", "1", "-o", str(tmp_path / "o.png")], capfd)
    assert rc == 2 and "--step: only used with a mesh file" in err
    with pytest.raises(ConfigError, match=r"^step/time: only used when mesh is a mesh file"):
        from warpvol.api import as_scene
        as_scene(_grid(), scalars="s", step=1)


# -- the stress suite's file classes ------------------------------------------------------------------
FILE_CLASS_CASES = {"hidden_cells_resampled": "hidden_cells_dropped", "hidden_cells_overset": "hidden_cells_dropped",
                    "pvts_pieces": None, "nested_multiblock": None, "empty_element_blocks": None,
                    "time_series_step": "time_step", "cohesive_layer": "zero_volume_cells_dropped"}


@pytest.mark.parametrize("case", sorted(FILE_CLASS_CASES))
def test_stress_cases_of_file_classes_have_no_silently_wrong_row(case):
    from test_mesh_files import check_exact_rows
    from tolerances import EXACT_PRESETS as EXACT
    from warpvol.tools.bench import load_pipelines
    from warpvol.tools.stress import CASES, build_case, run_case

    assert case in CASES
    c = build_case(case, quick=True)
    if FILE_CLASS_CASES[case]:
        assert FILE_CLASS_CASES[case] in c.scene.mesh.load_notes
    rows = run_case(c, load_pipelines(list(EXACT), "cpu", quick=True))
    assert rows[0]["status"] == "ok"
    check_exact_rows(rows[1:])


_EXODUS_WRITER = """
import sys
import numpy as np, pyvista as pv, vtk
controller = vtk.vtkDummyController()  # the (parallel) writer needs one; kept alive while it writes
vtk.vtkMultiProcessController.SetGlobalController(controller)
g = pv.ImageData(dimensions=(4, 4, 4), spacing=(1 / 3,) * 3).cast_to_unstructured_grid()
g.point_data["s"] = np.sin(3 * g.points[:, 0]) * 0.4 + g.points[:, 1] * g.points[:, 2] * 0.5
g.point_data["GlobalNodeId"] = np.arange(1, g.n_points + 1, dtype=np.int64)
g.cell_data["GlobalElementId"] = np.arange(1, g.n_cells + 1, dtype=np.int64)
w = vtk.vtkExodusIIWriter()
w.SetFileName(sys.argv[1])
w.SetInputData(g)
w.WriteAllTimeStepsOff()
w.Write()
"""


def test_exodus_file_reads_as_its_one_element_block(tmp_path, capfd):
    """An Exodus II file as VTK writes it: 8 top-level blocks (element blocks, face blocks, ..., node
    sets), 7 of them empty, and the reader's GlobalNodeId beside the data: the one element block is read
    and its one data array rendered."""
    import subprocess
    import sys

    import pyvista as pv

    path = tmp_path / "m.exo"
    run = subprocess.run([sys.executable, "-c", _EXODUS_WRITER, str(path)], capture_output=True, text=True)
    if run.returncode != 0 or not path.is_file():  # (the writer runs apart: a crash there cannot end this run)
        pytest.skip(f"VTK's Exodus II writer failed here: {run.stderr[-300:]}")
    top = pv.read(path)
    assert top.n_blocks == 8 and "GlobalNodeId" in top[0][0].point_data.keys()
    m = scene_from_spec(path).mesh
    g = _grid().cast_to_unstructured_grid()
    assert m.n_tets == TetMesh.from_pyvista(g, "s").n_tets and m.load_notes == {}
    np.testing.assert_allclose(np.sort(m.scalars), np.sort(TetMesh.from_pyvista(g, "s").scalars), atol=1e-12)
    assert _cli(_render(path, tmp_path), capfd)[0] == 0
