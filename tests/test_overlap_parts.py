"""Parts of one mesh that overlap in space (an assembly on separate points, a part written twice) are
declined in words naming the parts and the overlap's size, before any reference; parts that only touch
(non-conforming interfaces: other face triangulations, hanging nodes, a shifted block) pass and render
within the exact presets' rows."""

import numpy as np
import pytest

from helpers import scene
from tolerances import preset_tolerance
from warpvol.errors import MeshError
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.camera import Camera
from warpvol.scene.grids import grid_points, structured_to_tets, structured_to_tets5
from warpvol.scene.mesh import TetMesh
from warpvol.scene.overlap import mesh_parts, tet_overlap_depth
from warpvol.scene.transfer import TransferFunction

TF = TransferFunction([[0.0, 0.2, 0.4, 1.0, 0.8], [1.0, 1.0, 0.5, 0.2, 1.6], [2.0, 1.0, 1.0, 1.0, 0.4]])
CAM = Camera(eye=[3.4, 2.3, 2.9], target=[1.0, 0.5, 0.5], fov_y_deg=32.0, width_px=24, height_px=24)


def block(n=(4, 4, 4), lo=(0.0, 0.0, 0.0), hi=(1.0, 1.0, 1.0), five=False):
    """A box of ``n`` grid points per axis as tets (Kuhn split, or the alternating 5-tet split)."""
    pts = grid_points(*(np.linspace(a, b, k) for a, b, k in zip(lo, hi, n)))
    tets = structured_to_tets5(n) if five else structured_to_tets(n)
    return pts, tets


def assembly(*blocks, name="assembly"):
    """The blocks on separate points in one mesh, the scalar x + y / 2 + z / 4."""
    pts, tets, off = [], [], 0
    for p, t in blocks:
        pts.append(p)
        tets.append(t + off)
        off += len(p)
    p = np.concatenate(pts)
    return TetMesh(p, np.concatenate(tets), p @ [1.0, 0.5, 0.25], name=name)


def test_overlapping_boxes_are_declined_naming_both_parts():
    a, b = block(), block(lo=(0.5, 0.0, 0.0), hi=(1.5, 1.0, 1.0))
    m = assembly(a, b, name="two.vtu")
    info = m.overlapping_parts
    assert info["parts"] == [162, 162] and list(info["by_parts"]) == [(0, 1)] and info["pairs"] > 0
    lo, hi = info["box"]
    assert lo[0] == pytest.approx(0.5) and hi[0] == pytest.approx(1.0) and info["depth"] > 0.1
    with pytest.raises(MeshError, match=r"two.vtu: parts of the mesh overlap in space: part 0 \(162 tets\) and "
                                        r"part 1 \(162 tets\).* overlapping tet pair\(s\)"):
        m.check_overlap()
    with pytest.raises(MeshError, match="overlap in space"):  # the reference declines too
        render_reference(m, TF, CAM)
    with pytest.raises(MeshError, match="overlap in space"):
        Pipeline.load("raycast").render(scene(m, TF, CAM), quiet=True)


def test_a_part_written_twice_is_declined():
    a = block()
    m = assembly(a, a, block(lo=(1.0, 0.0, 0.0), hi=(2.0, 1.0, 1.0)))  # a neighbour touching it: no overlap
    info = m.overlapping_parts
    assert info["parts"] == [162, 162, 162] and list(info["by_parts"]) == [(0, 1)]
    assert info["pairs"] == 162  # each tet with its copy and nothing else (the others only touch it)
    assert info["cells"] == {0: 162, 1: 162}


def test_parts_glued_on_duplicated_points_are_one_part():
    # every cell on its own points (an "exploded" export): cells glued face to face, one part
    p, t = block((3, 3, 3))
    cells = t.reshape(-1, 6, 4)
    pts = np.concatenate([p[c.ravel()] for c in cells])
    tets = np.arange(len(pts)).reshape(-1, 4)
    with np.errstate(all="ignore"):
        parts = mesh_parts(pts, tets, TetMesh(pts, tets, pts[:, 0]).boundary_triangles())
    assert parts.max() == 0
    assert TetMesh(pts, tets, pts[:, 0]).overlapping_parts is None


def test_touching_and_shared_faces_are_not_overlaps():
    t = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]])
    for other in (t * [-1, 1, 1],                                      # a shared face
                  t * [-1, -1, 1],                                    # a shared edge
                  -t,                                                 # a shared vertex
                  t * [1, 1, -1] + [0.1, 0.1, 0.0],                   # touching on a face, shifted
                  np.array([[[0.5, 0.5, 0.0], [0.5, 0.5, 1.0], [2, 0, 0.5], [0, 2, 0.5]]])):  # edge on face
        assert tet_overlap_depth(t, other, 1e-9).tolist() == [-1.0]
    assert tet_overlap_depth(t, t + 1e-6, 1e-9)[0] > 1e-6


@pytest.mark.parametrize("kind", ["other_diagonals", "hanging_nodes", "shifted"])
def test_parts_touching_at_a_nonconforming_interface_pass_and_render(kind):
    a = block()
    b = {"other_diagonals": block((4, 4, 4), (1.0, 0.0, 0.0), (2.0, 1.0, 1.0), five=True),
         "hanging_nodes": block((3, 7, 7), (1.0, 0.0, 0.0), (2.0, 1.0, 1.0)),
         "shifted": block((4, 4, 4), (1.0, 0.3, -0.2), (2.0, 1.3, 0.8))}[kind]
    m = assembly(a, b, name=kind)
    assert len(m.nonconforming_faces) > 0 and m.overlapping_parts is None
    m.check_overlap()
    ref = render_reference(m, TF, CAM)
    for name in ("raycast", "pt_best"):
        res = Pipeline.load(name).render(scene(m, TF, CAM), quiet=True)
        err, tol = np.abs(res.image - ref), preset_tolerance(name)
        assert err.max() <= tol["max_abs"] and np.sqrt((err ** 2).mean()) <= tol["rmse"]


def test_render_command_declines_before_the_reference(tmp_path, monkeypatch, capsys):
    import pyvista as pv

    import warpvol.cli as cli

    grids = []
    for x0 in (0.0, 0.6):
        g = pv.ImageData(dimensions=(4, 4, 4), spacing=(1 / 3,) * 3, origin=(x0, 0, 0)).cast_to_unstructured_grid()
        g.point_data["s"] = g.points[:, 0]
        grids.append(g)
    path = tmp_path / "two.vtu"
    grids[0].merge(grids[1], merge_points=False).save(path)
    calls = []
    monkeypatch.setattr(cli, "compute_reference", lambda *a, **k: calls.append(1))
    for cmd in (["render", str(path), "--pipeline", "raycast", "--compute-reference"], ["reference", str(path)]):
        assert cli.main(cmd + ["-o", str(tmp_path / "o.exr"), "--width", "8", "--height", "8", "--quiet"]) == 2
        err = capsys.readouterr().err
        assert "part 0 (27 cells, 162 tets) and part 1 (27 cells, 162 tets)" in err and "overlapping tet pair" in err
    assert calls == [] and not (tmp_path / "o.exr").exists()


def test_real_data_has_one_part():
    from pathlib import Path

    from warpvol.scene.scene_file import load_scene

    path = Path(__file__).resolve().parents[1] / "scenes" / "spx.toml"
    try:
        sc = load_scene(path)
    except Exception as e:  # noqa: BLE001 - the data set lives beside the repository
        pytest.skip(f"SPX data not available: {e}")
    assert sc.mesh.overlapping_parts is None


@pytest.mark.parametrize("case", ["topology_overlapping_parts", "topology_part_twice", "topology_touching_parts",
                                  "subnormal_scalars"])
def test_stress_cases_of_overlap_and_subnormal_scalars(case):
    from test_mesh_files import check_exact_rows
    from tolerances import EXACT_PRESETS as EXACT
    from warpvol.tools.bench import load_pipelines
    from warpvol.tools.stress import build_case, run_case

    rows = run_case(build_case(case, quick=True), load_pipelines(list(EXACT), "cpu", quick=True))
    if case in ("topology_overlapping_parts", "topology_part_twice"):  # the reference and every preset decline
        assert [r["status"] for r in rows] == ["declined"] * (1 + len(EXACT))
        assert all("parts of the mesh overlap in space: part 0" in r["message"] for r in rows)
    else:
        assert rows[0]["status"] == "ok" and rows[0]["finite"]
        check_exact_rows(rows[1:])
        assert all(r["status"] == "ok" for r in rows[1:]), rows


def test_blanked_overset_blocks_pass(tmp_path):
    import pyvista as pv

    from warpvol.scene.loaders import read_mesh_file

    grids = []
    for x0 in (0.0, 2 / 3):
        g = pv.ImageData(dimensions=(4, 4, 4), spacing=(1 / 3,) * 3, origin=(x0, 0, 0)).cast_to_unstructured_grid()
        g.point_data["s"] = g.points[:, 0]
        grids.append(g)
    both = grids[0].merge(grids[1], merge_points=False)
    flags = np.zeros(both.n_cells, np.uint8)
    centres = both.cell_centers().points
    flags[27:][centres[27:, 0] < 1.0] = 32  # the second block's cells inside the first: HIDDENCELL (iblank 0)
    both.cell_data["vtkGhostType"] = flags
    path = tmp_path / "overset.vtu"
    both.save(path)
    m = read_mesh_file(path, "s")
    assert m.load_notes.get("hidden_cells_dropped") == 9 and m.overlapping_parts is None
    both.cell_data["vtkGhostType"] = np.zeros(both.n_cells, np.uint8)  # without the blanking: declined
    both.save(path)
    with pytest.raises(MeshError, match="overlap in space"):
        read_mesh_file(path, "s").check_overlap()
