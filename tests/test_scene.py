"""Scene files, mesh loaders (PLOT3D, raw, pyvista files) and built-in scenes."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from warpvol.errors import ConfigError, MeshError
from warpvol.scene.builtin import BUILTIN_SCENES, builtin_mesh, builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.grids import structured_to_tets, structured_to_tets5
from warpvol.scene.loaders import (
    PLOT3D_FUNCTIONS,
    load_mesh,
    plot3d_function,
    read_plot3d,
    read_plot3d_grid,
    read_plot3d_solution,
    read_raw,
)
from warpvol.scene.mesh import TetMesh, signed_volumes
from warpvol.scene.scene import Scene
from warpvol.scene.scene_file import load_scene, scene_from_config
from warpvol.scene.transfer import TransferFunction

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


@pytest.fixture(scope="module")
def data():
    if not DATA.is_dir():
        pytest.skip(f"reference data folder {DATA} (../shared/data relative to the repository) is absent")
    return DATA


def analytic_boundary(dims) -> int:
    """Boundary triangles of a conforming split of a (ni, nj, nk)-point grid: 2 per boundary quad."""
    a, b, c = (d - 1 for d in dims)
    return 4 * (a * b + b * c + a * c)


# -- helpers that write small files --------------------------------------------------------------
UNIT_TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)


def write_vtu(path, points, tets, point_data=None, cell_data=None):
    import pyvista as pv

    grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.asarray(tets, dtype=np.int64).reshape(-1, 4)},
                               np.asarray(points, dtype=float))
    for k, v in (point_data or {}).items():
        grid.point_data[k] = np.asarray(v)
    for k, v in (cell_data or {}).items():
        grid.cell_data[k] = np.asarray(v)
    grid.save(path)
    return path


def write_plot3d(tmp, dims, xyz, q, *, iblank=None, q_trailing=0, header=(0.5, 0.0, 1e6, 0.0)):
    n = int(np.prod(dims))
    gx, gq = tmp / "g.xyz", tmp / "g.q"
    with open(gx, "wb") as f:
        f.write(np.asarray(dims, ">i4").tobytes())
        f.write(np.asarray(xyz, ">f4").T.reshape(3 * n).tobytes())
        if iblank is not None:
            f.write(np.asarray(iblank, ">i4").tobytes())
    with open(gq, "wb") as f:
        f.write(np.asarray(dims, ">i4").tobytes())
        f.write(np.asarray(header, ">f4").tobytes())
        f.write(np.asarray(q, ">f4").reshape(5 * n).tobytes())
        f.write(b"\0" * q_trailing)
    return gx, gq


def small_grid(dims=(3, 2, 2)):
    ni, nj, nk = dims
    zz, yy, xx = np.meshgrid(np.arange(nk), np.arange(nj), np.arange(ni), indexing="ij")
    xyz = np.column_stack([xx.ravel() * 1.0, yy.ravel() * 2.0, zz.ravel() * 0.5])
    n = len(xyz)
    rng = np.random.default_rng(1)
    rho = 1.0 + rng.random(n)
    vel = rng.random((n, 3)) - 0.5
    rhoE = 3.0 + rng.random(n)
    q = np.vstack([rho, rho * vel[:, 0], rho * vel[:, 1], rho * vel[:, 2], rhoE])
    return xyz, q.astype(np.float32).astype(float)


def write_scene(tmp, text, name="scene.toml"):
    p = tmp / name
    p.write_text(text)
    return p


# -- reference data sets ---------------------------------------------------------------------------
def test_blunt_fin_counts_and_collapsed_edge(data):
    assert len(structured_to_tets((40, 32, 32))) == 224_874
    cfg = {"plot3d": {"xyz": "bluntfinxyz.bin", "q": "bluntfinq.bin", "function": 100}}
    with pytest.warns(UserWarning, match="115 zero-volume tet"):
        m = load_mesh(cfg, data)
    # the grid collapses its (j=0, j=1) rows onto each other along the k=0 wall for i >= 1: those
    # 39 points are welded and the 115 tets that collapse with them are dropped
    assert m.n_input_tets == m.n_tets + m.n_dropped == 224_874
    assert (m.n_dropped, m.n_tets) == (115, 224_759)
    lo, hi = m.scalar_range
    assert lo == pytest.approx(0.1926, abs=1e-3) and hi == pytest.approx(4.9775, abs=1e-3)
    assert (signed_volumes(m.points, m.tets) > 0).all()
    # boundary = grid surface minus the 39 collapsed wall quads: no crack of unconnected faces left
    assert len(m.boundary_faces) == analytic_boundary((40, 32, 32)) - 2 * 39
    with pytest.raises(MeshError, match="115 zero-volume.*strict"):
        load_mesh({**cfg, "strict": True}, data)


def test_lox_post_velocity_magnitude(data):
    m = load_mesh({"plot3d": {"xyz": "postxyz.bin", "q": "postq.bin", "function": 153}}, data)
    assert m.n_tets == 616_050 and m.n_dropped == 0
    lo, hi = m.scalar_range
    assert lo == pytest.approx(0.0, abs=1e-6) and hi == pytest.approx(1.391, abs=2e-3)
    # O-grid: the j = 0 and j = 75 faces coincide and are welded, so they are interior faces
    assert len(m.boundary_faces) == analytic_boundary((38, 76, 38)) - 4 * 37 * 37
    dims, _, iblank = read_plot3d_grid(data / "postxyz.bin")
    assert dims == (38, 76, 38) and iblank is not None and iblank.shape == (109_744,)
    _, q = read_plot3d_solution(data / "postq.bin", dims)
    assert np.all(plot3d_function(q, 100) == 1.0)  # density is constant: why function 153 is used


def test_combustor(data):
    m = load_mesh({"plot3d": {"xyz": "combxyz.bin", "q": "combq.bin"}}, data)
    assert m.n_tets == 258_048 and m.n_dropped == 0
    assert m.scalar_range == pytest.approx((0.198, 0.710), abs=1e-3)
    assert len(m.boundary_faces) == analytic_boundary((57, 33, 25))


def test_bluntfin_q_has_trailing_bytes_tolerated(data):
    size = (data / "bluntfinq.bin").stat().st_size
    assert size - (28 + 20 * 40 * 32 * 32) == 484
    header, q = read_plot3d_solution(data / "bluntfinq.bin", (40, 32, 32))
    assert header[0] == pytest.approx(2.95) and q.shape == (5, 40_960)


def test_bucky_raw(data):
    m = load_mesh({"raw": {"path": "bucky.raw", "dims": [32, 32, 32], "dtype": "uint8", "spacing": [1, 1, 1]}},
                  data)
    assert m.n_tets == 178_746
    assert m.scalar_range == (0.0, 255.0)
    assert m.is_convex
    assert len(m.boundary_faces) == analytic_boundary((32, 32, 32))


def test_spx_vtk(data):
    m = load_mesh({"path": "spx.vtk", "scalars": "scalars"}, data)
    assert (m.n_points, m.n_tets) == (2896, 12_936)
    assert m.scalar_range == pytest.approx((0.0, 2.254), abs=1e-3)
    assert not m.is_convex


def test_scene_file_with_reference_data(data, tmp_path):
    p = write_scene(tmp_path, f"""
name = "combustor"
[mesh]
plot3d = {{ xyz = "{data / 'combxyz.bin'}", q = "{data / 'combq.bin'}", function = 100 }}
[transfer]
points = [[0.2, 0, 0, 1, 1.0], [0.7, 1, 0, 0, 4.0]]
[camera]
eye = [20, 10, 30]
target = [8, 0, 0]
width_px = 64
height_px = 48
""")
    s = load_scene(p)
    assert s.name == "combustor" and s.mesh.n_tets == 258_048 and s.source == p
    assert (s.camera.width_px, s.camera.height_px) == (64, 48)


# -- PLOT3D reader on small synthetic files ----------------------------------------------------------
def test_plot3d_functions_and_order(tmp_path):
    dims = (3, 2, 2)
    xyz, q = small_grid(dims)
    gx, gq = write_plot3d(tmp_path, dims, xyz, q, q_trailing=16)
    d, pts, ib = read_plot3d_grid(gx)
    assert d == dims and ib is None
    np.testing.assert_allclose(pts, xyz)  # i fastest, then j, then k
    rho, v2 = q[0], (q[1] ** 2 + q[2] ** 2 + q[3] ** 2) / q[0] ** 2
    expected = {100: rho, 110: 0.4 * (q[4] - 0.5 * rho * v2), 144: 0.5 * v2, 153: np.sqrt(v2), 163: q[4]}
    assert set(expected) == set(PLOT3D_FUNCTIONS)
    for fn, want in expected.items():
        m = read_plot3d(gx, gq, fn)
        assert m.n_tets == 6 * 2 * 1 * 1
        np.testing.assert_allclose(m.scalars, want, rtol=1e-6)


def test_plot3d_iblank_detected_and_cells_kept(tmp_path):
    dims = (3, 2, 2)
    xyz, q = small_grid(dims)
    ib = np.ones(12, int)
    ib[:4] = 0
    gx, gq = write_plot3d(tmp_path, dims, xyz, q, iblank=ib)
    _, _, got = read_plot3d_grid(gx)
    np.testing.assert_array_equal(got, ib)
    assert read_plot3d(gx, gq).n_tets == 12  # blanked cells are kept


def test_plot3d_errors(tmp_path):
    dims = (3, 2, 2)
    xyz, q = small_grid(dims)
    gx, gq = write_plot3d(tmp_path, dims, xyz, q)
    with pytest.raises(ConfigError, match=r"function: unsupported PLOT3D function 999; supported: 100 .*153"):
        read_plot3d(gx, gq, 999)
    short = tmp_path / "short.q"
    short.write_bytes(gq.read_bytes()[:-8])
    with pytest.raises(ConfigError, match=r"plot3d\.q: .*short\.q is too short: \d+ bytes.*needs at least"):
        read_plot3d(gx, short)
    short_x = tmp_path / "short.xyz"
    short_x.write_bytes(gx.read_bytes()[:40])
    with pytest.raises(ConfigError, match=r"plot3d\.xyz: .*short\.xyz is too short"):
        read_plot3d(short_x, gq)
    other = tmp_path / "other"
    other.mkdir()
    xyz2, q2 = small_grid((2, 3, 2))
    _, gq2 = write_plot3d(other, (2, 3, 2), xyz2, q2)
    with pytest.raises(ConfigError, match=r"plot3d\.q: dims \[2, 3, 2\] in .* disagree with the grid dims \[3, 2, 2\]"):
        read_plot3d(gx, gq2)
    with pytest.raises(ConfigError, match=r"mesh\.plot3d\.q: file not found: .*nope\.q"):
        load_mesh({"plot3d": {"xyz": "g.xyz", "q": "nope.q"}}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.plot3d: unknown key\(s\) 'fn'"):
        load_mesh({"plot3d": {"xyz": "g.xyz", "q": "g.q", "fn": 100}}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.scalars: only used with 'path'"):
        load_mesh({"plot3d": {"xyz": "g.xyz", "q": "g.q"}, "scalars": "rho"}, tmp_path)


# -- raw volumes --------------------------------------------------------------------------------------
def test_raw_volume_order_endianness_and_errors(tmp_path):
    vals = np.arange(2 * 3 * 4, dtype=np.uint16) * 300
    (tmp_path / "v.raw").write_bytes(vals.astype(">u2").tobytes())
    m = read_raw(tmp_path / "v.raw", [2, 3, 4], ">u2", [1.0, 0.5, 2.0], origin=[1, 2, 3])
    np.testing.assert_array_equal(m.scalars, vals)
    assert m.n_tets == 6 * 1 * 2 * 3
    # x fastest: sample 1 sits at x = origin + sx, sample 2 at y = origin + sy
    np.testing.assert_allclose(m.points[[0, 1, 2, 6]], [[1, 2, 3], [2, 2, 3], [1, 2.5, 3], [1, 2, 5]])
    little = read_raw(tmp_path / "v.raw", [2, 3, 4], "uint16", [1, 1, 1])
    assert not np.array_equal(little.scalars, vals)  # default is little endian
    with pytest.raises(ConfigError, match=r"raw\.path: file .*v\.raw holds 48 bytes, dims .* need 96"):
        read_raw(tmp_path / "v.raw", [2, 3, 4], "float32", [1, 1, 1])
    with pytest.raises(ConfigError, match=r"raw\.dtype: unsupported sample type 'int64'; allowed: 'uint8'"):
        read_raw(tmp_path / "v.raw", [2, 3, 4], "int64", [1, 1, 1])
    with pytest.raises(ConfigError, match=r"mesh\.raw\.spacing\[1\]: 0 is outside"):
        load_mesh({"raw": {"path": "v.raw", "dims": [2, 3, 4], "dtype": ">u2", "spacing": [1, 0, 1]}}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.raw: missing key 'spacing'"):
        load_mesh({"raw": {"path": "v.raw", "dims": [2, 3, 4], "dtype": ">u2"}}, tmp_path)


# -- files pyvista reads ----------------------------------------------------------------------------
def test_vtu_missing_file_and_scalar_array(tmp_path):
    with pytest.raises(ConfigError, match=r"mesh\.path: file not found: .*nope\.vtu"):
        load_mesh({"path": "nope.vtu", "scalars": "s"}, tmp_path)
    write_vtu(tmp_path / "a.vtu", UNIT_TET, [[0, 1, 2, 3]], point_data={"density": np.arange(4.0)})
    with pytest.raises(ConfigError, match=r"mesh\.scalars: point-data array 'temp' not found in .*a\.vtu; "
                                          r"available point arrays: \['density'\]"):
        load_mesh({"path": "a.vtu", "scalars": "temp"}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.scalars: required with 'path'.*\['density'\]"):
        load_mesh({"path": "a.vtu"}, tmp_path)
    m = load_mesh({"path": str(tmp_path / "a.vtu"), "scalars": "density"}, "/nonexistent")  # absolute path
    assert m.n_tets == 1 and m.scalars.tolist() == [0, 1, 2, 3]


def test_vtu_cell_data_only(tmp_path):
    write_vtu(tmp_path / "c.vtu", UNIT_TET, [[0, 1, 2, 3]], cell_data={"density": [1.0]})
    with pytest.raises(ConfigError, match=r"c\.vtu has cell data only \('density'\).*point-data"):
        load_mesh({"path": "c.vtu", "scalars": "density"}, tmp_path)


@pytest.mark.filterwarnings("ignore:The VTK reader")  # VTK stores an Inf range key it cannot read back
@pytest.mark.parametrize("where,bad", [("points", np.nan), ("points", np.inf), ("scalars", np.nan),
                                       ("scalars", -np.inf)])
def test_vtu_non_finite(tmp_path, where, bad):
    pts, s = UNIT_TET.copy(), np.arange(4.0)
    if where == "points":
        pts[2, 1] = bad
    else:
        s[2] = bad
    write_vtu(tmp_path / "nf.vtu", pts, [[0, 1, 2, 3]], point_data={"s": s})
    with pytest.raises(MeshError, match=rf"nf\.vtu: {where}: 1 non-finite value"):
        load_mesh({"path": "nf.vtu", "scalars": "s"}, tmp_path)


def test_legacy_vtk_index_out_of_range(tmp_path):
    (tmp_path / "oor.vtk").write_text(
        "# vtk DataFile Version 3.0\nbad\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n"
        "0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 99\nCELL_TYPES 1\n10\n"
        "POINT_DATA 4\nSCALARS s float 1\nLOOKUP_TABLE default\n0 1 2 3\n")
    with pytest.raises(MeshError, match=r"oor\.vtk: tet index out of range: tets\[0\]\[3\] = 99"):
        load_mesh({"path": "oor.vtk", "scalars": "s"}, tmp_path)


def test_vtu_face_shared_by_three_tets(tmp_path):
    pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.3, 0.3, -1], [1, 1, 1]]
    write_vtu(tmp_path / "nm.vtu", pts, [[0, 1, 2, 3], [0, 1, 2, 4], [0, 1, 2, 5]], point_data={"s": np.zeros(6)})
    with pytest.raises(MeshError, match=r"nm\.vtu: face \[0, 1, 2\] is shared by 3 tets"):
        load_mesh({"path": "nm.vtu", "scalars": "s"}, tmp_path)


def test_vtu_empty_mesh(tmp_path):
    import pyvista as pv

    g = pv.UnstructuredGrid(np.empty(0, np.int64), np.empty(0, np.uint8), UNIT_TET)
    g.point_data["s"] = np.zeros(4)
    g.save(tmp_path / "e.vtu")
    with pytest.raises(MeshError, match=r"e\.vtu: empty mesh \(4 points, 0 tets\)"):
        load_mesh({"path": "e.vtu", "scalars": "s"}, tmp_path)


def test_zero_volume_tets_dropped_with_warning_or_strict_error(tmp_path):
    pts = np.vstack([UNIT_TET, [[5, 0, 0], [6, 0, 0], [5, 1, 0], [6, 1, 0]]])  # last 4 coplanar
    write_vtu(tmp_path / "z.vtu", pts, [[0, 1, 2, 3], [4, 5, 6, 7]], point_data={"s": np.arange(8.0)})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a file's flat cells are counted in its load notes, not warned about
        m = load_mesh({"path": "z.vtu", "scalars": "s"}, tmp_path)
    assert (m.n_tets, m.n_dropped) == (1, 1) and m.load_notes == {"zero_volume_cells_dropped": 1}
    with pytest.raises(MeshError, match=r"z\.vtu: 1 zero-volume tet.*strict"):
        load_mesh({"path": "z.vtu", "scalars": "s"}, tmp_path, strict=True)
    with pytest.raises(MeshError, match=r"zero-volume.*strict"):
        load_mesh({"path": "z.vtu", "scalars": "s", "strict": True}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.strict: expected true or false, got 'yes'"):
        load_mesh({"path": "z.vtu", "scalars": "s", "strict": "yes"}, tmp_path)


def test_inverted_tets_reoriented(tmp_path):
    pts = np.vstack([UNIT_TET, [[0, 0, -1]]])
    tets = [[0, 2, 1, 3], [0, 2, 1, 4]]  # the first is inverted, the second is not
    assert (np.sign(signed_volumes(pts, np.array(tets))) == [-1, 1]).all()
    write_vtu(tmp_path / "inv.vtu", pts, tets, point_data={"s": np.arange(5.0)})
    m = load_mesh({"path": "inv.vtu", "scalars": "s"}, tmp_path)
    assert m.n_reoriented == 1
    assert (signed_volumes(m.points, m.tets) > 0).all()
    assert sorted(map(sorted, m.tets.tolist())) == sorted(map(sorted, tets))  # same vertex sets


@pytest.mark.parametrize("kind", ["voxel", "hexahedron"])
def test_hex_cells_triangulated_conforming(tmp_path, kind):
    import pyvista as pv

    img = pv.ImageData(dimensions=(4, 3, 3), spacing=(0.5, 1.0, 2.0))
    ug = img.cast_to_unstructured_grid()
    assert set(ug.celltypes.tolist()) == {pv.CellType.VOXEL}
    if kind == "hexahedron":  # same cells in hexahedron corner order
        vox = np.asarray(ug.cells).reshape(-1, 9)[:, 1:]
        ug = pv.UnstructuredGrid({pv.CellType.HEXAHEDRON: vox[:, [0, 1, 3, 2, 4, 5, 7, 6]]}, ug.points)
    ug.point_data["s"] = ug.points[:, 0] + 2 * ug.points[:, 2]
    ug.save(tmp_path / "hex.vtu")
    m = load_mesh({"path": "hex.vtu", "scalars": "s"}, tmp_path)
    vol = signed_volumes(m.points, m.tets)
    assert (vol > 0).all() and vol.sum() / 6 == pytest.approx(1.5 * 2.0 * 4.0)
    assert len(m.boundary_faces) == analytic_boundary((4, 3, 3))  # conforming across cells
    np.testing.assert_allclose(m.gradients, np.tile([1.0, 0.0, 2.0], (m.n_tets, 1)), atol=1e-9)


def test_structured_and_image_grids_use_six_tet_split(tmp_path):
    import pyvista as pv

    x, y, z = np.meshgrid(np.linspace(0, 1, 4), np.linspace(0, 2, 3), np.linspace(0, 1, 5), indexing="ij")
    sg = pv.StructuredGrid(x + 0.1 * z, y, z)  # sheared curvilinear grid
    sg.point_data["s"] = sg.points[:, 0] - sg.points[:, 1]
    sg.save(tmp_path / "g.vts")
    m = load_mesh({"path": "g.vts", "scalars": "s"}, tmp_path)
    assert m.n_tets == 6 * 3 * 2 * 4 and len(m.boundary_faces) == analytic_boundary((4, 3, 5))
    np.testing.assert_allclose(m.gradients, np.tile([1.0, -1.0, 0.0], (m.n_tets, 1)), atol=1e-9)
    img = pv.ImageData(dimensions=(3, 3, 2), spacing=(1, 1, 1))
    img.point_data["s"] = np.arange(img.n_points, dtype=float)
    img.save(tmp_path / "i.vti")
    assert load_mesh({"path": "i.vti", "scalars": "s"}, tmp_path).n_tets == 6 * 2 * 2 * 1
    sph = pv.Sphere()
    sph.point_data["s"] = sph.points[:, 2]
    sph.save(tmp_path / "surf.vtp")
    with pytest.raises(ConfigError, match=r"mesh\.path: .*surf\.vtp is a PolyData, which has no volume cells"):
        load_mesh({"path": "surf.vtp", "scalars": "s"}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.scalars: array 'Normals' in .*surf\.vtp has 3 components"):
        load_mesh({"path": "surf.vtp", "scalars": "Normals"}, tmp_path)


def test_mesh_table_key_errors(tmp_path):
    with pytest.raises(ConfigError, match=r"mesh: unknown key\(s\) 'file'"):
        load_mesh({"file": "a.vtu"}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh: give exactly one of .*got 'path', 'builtin'"):
        load_mesh({"path": "a.vtu", "builtin": "box"}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh: give exactly one of .*got none"):
        load_mesh({"scalars": "s"}, tmp_path)
    with pytest.raises(ConfigError, match=r"mesh\.builtin: unknown built-in scene 'teapot'; available: 'sphere'"):
        load_mesh({"builtin": "teapot"}, tmp_path)


def test_tet_mesh_direct_errors():
    with pytest.raises(MeshError, match=r"m: tet index out of range: tets\[0\]\[2\] = -1"):
        TetMesh(UNIT_TET, [[0, 1, -1, 3]], np.zeros(4), name="m")
    with pytest.raises(MeshError, match=r"m: empty mesh"):
        TetMesh(UNIT_TET, np.empty((0, 4), int), np.zeros(4), name="m")


# -- conformity of the splits ------------------------------------------------------------------------
def test_six_tet_split_conforms():
    dims = (4, 5, 6)
    xs, ys, zs = np.cumsum(np.r_[0, 0.3, 0.5, 0.2]), np.linspace(0, 1, 5), np.linspace(-1, 0, 6) ** 3
    zz, yy, xx = np.meshgrid(zs, ys, xs, indexing="ij")
    pts = np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])
    m = TetMesh(pts, structured_to_tets(dims), pts[:, 0], strict=True)
    adj = m.adjacency
    interior = adj >= 0
    assert len(m.boundary_faces) == analytic_boundary(dims)
    assert interior.sum() == 4 * m.n_tets - analytic_boundary(dims)  # each interior face seen twice
    c, f = np.nonzero(interior)
    assert (adj[adj[c, f]] == c[:, None]).any(axis=1).all()  # symmetric
    assert signed_volumes(m.points, m.tets).sum() / 6 == pytest.approx(1.0)


def test_five_tet_split_conforms_only_with_alternating_parity():
    dims = (5, 4, 3)
    x = np.linspace(0, 1, 5)
    zz, yy, xx = np.meshgrid(x[:3], x[:4], x, indexing="ij")
    pts = np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])
    tets = structured_to_tets5(dims)
    assert len(tets) == 5 * 4 * 3 * 2
    m = TetMesh(pts, tets, pts[:, 2], strict=True)
    assert len(m.boundary_faces) == analytic_boundary(dims)
    assert signed_volumes(m.points, m.tets).sum() / 6 == pytest.approx(1.0 * 0.75 * 0.5)
    bad = TetMesh(pts, structured_to_tets5(dims, alternate=False), pts[:, 2])
    assert len(bad.boundary_faces) > analytic_boundary(dims)  # mismatched diagonals leave cracks


# -- built-in scenes ---------------------------------------------------------------------------------
def _voxel_boundary(mask: np.ndarray) -> int:
    padded = np.pad(mask, 1).astype(np.int8)
    return 2 * sum(int(np.abs(np.diff(padded, axis=a)).sum()) for a in range(3))


@pytest.mark.parametrize("name", list(BUILTIN_SCENES))
def test_builtin_validates(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = builtin_scene(name)
    m = s.mesh
    assert isinstance(s, Scene) and s.name == name and s.source is None
    assert m.n_dropped == 0 and (signed_volumes(m.points, m.tets) > 0).all()
    assert isinstance(s.transfer, TransferFunction) and isinstance(s.camera, Camera)
    assert (s.camera.width_px, s.camera.height_px) == (128, 128)
    expected_boundary = {
        "sphere": analytic_boundary((9, 9, 9)),
        "box": analytic_boundary((5, 5, 5)),
        "linear_box": analytic_boundary((5, 5, 5)),
        "stiff": analytic_boundary((5, 5, 17)),
    }
    if name == "concave":
        ci, cj = np.meshgrid(np.arange(12), np.arange(8), indexing="ij")
        u = (ci <= 7) & ((ci <= 1) | (ci >= 6) | (cj <= 1))
        block = (ci >= 10) & (cj >= 2) & (cj <= 5)
        expected_boundary[name] = _voxel_boundary(np.repeat((u | block)[:, :, None], 4, axis=2))
    assert len(m.boundary_faces) == expected_boundary[name]
    lo, hi = s.transfer.srange
    assert lo <= m.scalar_range[0] + 1e-12 and m.scalar_range[1] <= hi + 1e-12  # TF covers the data


def test_builtin_sizes_and_fields():
    sph = builtin_mesh("sphere")
    assert (sph.n_points, sph.n_tets) == (729, 2560)
    np.testing.assert_allclose(sph.scalars, np.linalg.norm(sph.points, axis=1))
    assert builtin_scene("sphere").transfer.emission == "emission_density"
    box = builtin_scene("box")
    assert box.mesh.n_tets == 384 and np.all(box.mesh.scalars == 1.0)
    assert box.camera.projection == "orthographic"
    np.testing.assert_allclose(box.camera.forward, [0, 0, -1])
    np.testing.assert_allclose(box.transfer.evaluate([0.0, 1.0, 2.0])[:, 3], 1.5)
    lin = builtin_scene("linear_box")
    np.testing.assert_array_equal(lin.mesh.scalars, lin.mesh.points[:, 2])
    # rho(z) = 1.25 + 0.75 z, so the optical depth through the box is 2.5
    z = np.linspace(-1, 1, 2001)
    tau = np.trapezoid(lin.transfer.evaluate(z)[:, 3], z)
    assert tau == pytest.approx(2.5, rel=1e-9)


def test_box_convex_concave_not():
    assert builtin_mesh("box").is_convex
    assert builtin_mesh("sphere").is_convex
    assert not builtin_mesh("concave").is_convex


def test_concave_is_disconnected_and_rays_cross_boundary_often():
    s = builtin_scene("concave")
    m = s.mesh
    # connected components over face adjacency
    lab = np.arange(m.n_tets)
    c, f = np.nonzero(m.adjacency >= 0)
    nb = m.adjacency[c, f]
    while True:
        new = lab.copy()
        np.minimum.at(new, c, lab[nb])
        if (new == lab).all():
            break
        lab = new
    assert len(np.unique(lab)) == 2
    # count boundary crossings along a few rays of the default camera (Moller-Trumbore)
    tri = m.points[m.boundary_triangles()]
    o, d = s.with_camera(width_px=16, height_px=16).camera.rays()
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    best = 0
    for oo, dd in zip(o.reshape(-1, 3), d.reshape(-1, 3)):
        p = np.cross(dd, e2)
        det = (e1 * p).sum(1)
        ok = np.abs(det) > 1e-12
        inv = 1.0 / np.where(ok, det, 1.0)
        tv = oo - tri[:, 0]
        u = (tv * p).sum(1) * inv
        qv = np.cross(tv, e1)
        v = (dd * qv).sum(1) * inv
        t = (e2 * qv).sum(1) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        best = max(best, len(np.unique(np.round(t[hit], 9))))
    assert best >= 6  # enters and leaves at least three times


def test_stiff_edge_ratio():
    m = builtin_mesh("stiff")
    assert m.edge_ratio >= 1e4
    assert m.edge_lengths.min() == pytest.approx(2e-5, rel=1e-6)
    lo, hi = m.bounds
    np.testing.assert_allclose([lo, hi], [[-1, -1, -1], [1, 1, 1]])


def test_builtin_unknown_name():
    with pytest.raises(ConfigError, match=r"unknown built-in scene 'cube'; available: 'sphere', 'box'"):
        builtin_scene("cube")


def test_with_camera_override():
    s = builtin_scene("sphere")
    t = s.with_camera(width_px=32, height_px=16, fov_y_deg=50.0)
    assert (t.camera.width_px, t.camera.height_px, t.camera.fov_y_deg) == (32, 16, 50.0)
    assert (s.camera.width_px, s.camera.fov_y_deg) == (128, 28.0)  # original untouched
    assert t.mesh is s.mesh and t.transfer is s.transfer
    with pytest.raises(ConfigError, match=r"width_px: 0 is outside"):
        s.with_camera(width_px=0)


# -- scene files -------------------------------------------------------------------------------------
GOOD_TF = "[transfer]\npoints = [[0.0, 0, 0, 0, 0.0], [3.0, 1, 0.5, 0.2, 2.0]]\n"
GOOD_CAM = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nwidth_px = 8\nheight_px = 8\n"


def test_scene_builtin_defaults_and_camera_replacement(tmp_path):
    s = load_scene(write_scene(tmp_path, '[mesh]\nbuiltin = "box"\n', "mybox.toml"))
    assert s.name == "mybox" and s.mesh.n_tets == 384
    assert s.camera.projection == "orthographic" and s.transfer.srange == (0.0, 2.0)
    s2 = load_scene(write_scene(tmp_path, '[mesh]\nbuiltin = "box"\n[camera]\neye = [0, 0, 7]\n'))
    # the given [camera] replaces the default entirely: Camera defaults, not the built-in's
    assert s2.camera.projection == "perspective" and s2.camera.width_px == 512
    assert s2.camera.eye.tolist() == [0, 0, 7]
    s3 = scene_from_config({"mesh": {"builtin": "sphere"}, "name": "ball"}, ".")
    assert s3.name == "ball" and s3.transfer.emission == "emission_density"


def test_scene_with_vtu(tmp_path):
    write_vtu(tmp_path / "m.vtu", UNIT_TET, [[0, 1, 2, 3]], point_data={"density": [0.0, 1, 2, 3]})
    sub = tmp_path / "scenes"
    sub.mkdir()
    p = write_scene(sub, '[mesh]\npath = "../m.vtu"\nscalars = "density"\n' + GOOD_TF + GOOD_CAM)
    s = load_scene(p)
    assert s.mesh.n_tets == 1 and s.source == p and s.name == "scene"
    assert s.transfer.srange == (0.0, 3.0) and s.camera.width_px == 8


def test_scene_file_errors(tmp_path):
    with pytest.raises(ConfigError, match=r"scene file not found: .*missing\.toml"):
        load_scene(tmp_path / "missing.toml")
    p = write_scene(tmp_path, '[mesh]\nbuiltin = "box\n', "broken.toml")
    with pytest.raises(ConfigError, match=r"broken\.toml: TOML syntax error"):
        load_scene(p)
    p = write_scene(tmp_path, '[mesh]\nbuiltin = "box"\n[lights]\nsun = 1\n', "extra.toml")
    with pytest.raises(ConfigError, match=r"extra\.toml: unknown key\(s\) 'lights'"):
        load_scene(p)
    p = write_scene(tmp_path, '[mesh]\nbuiltin = "box"\ncolour = 1\n', "meshkey.toml")
    with pytest.raises(ConfigError, match=r"meshkey\.toml: mesh: unknown key\(s\) 'colour'"):
        load_scene(p)
    p = write_scene(tmp_path, '[mesh]\npath = "gone.vtu"\nscalars = "s"\n' + GOOD_TF + GOOD_CAM, "gone.toml")
    with pytest.raises(ConfigError, match=r"gone\.toml: mesh\.path: file not found: .*gone\.vtu"):
        load_scene(p)
    p = write_scene(tmp_path, "[transfer]\n" + GOOD_TF.split("\n", 1)[1], "nomesh.toml")
    with pytest.raises(ConfigError, match=r"nomesh\.toml: missing \[mesh\]"):
        load_scene(p)


TF_CASES = [
    ("points = [[0.0, 0, 0, 0, 1], [1.0, 1, 1, 1, 1], [1.0, 1, 1, 1, 1]]",
     r"transfer\.points: s must be strictly ascending; points\[1\]\.s = (np\.float64\()?1\.0"),
    ("points = [[0.0, 0, 0, 0, 1], [1.0, 1, 1, 1, -0.5]]", r"transfer\.points\[1\]: extinction (np\.float64\()?-0\.5\)? is negative"),
    ("points = [[0.0, 0, 0, 0, 1], [1.0, 1, 1, 1, inf]]", r"transfer\.points\[1\]: non-finite value"),
    ("points = [[0.0, 0, 0, 0, nan], [1.0, 1, 1, 1, 1]]", r"transfer\.points\[0\]: non-finite value"),
    ("points = [[0.0, 0, 0, 0, 1]]", r"transfer\.points: need at least 2 control points, got 1"),
    ('emission = "glow"\npoints = [[0.0, 0, 0, 0, 1], [1.0, 1, 1, 1, 1]]',
     r"transfer\.emission: unknown value 'glow'; allowed: 'color_extinction'"),
    ("points = [[0.0, 0, 0, 0, 1], [1.0, 1, 1, 1, 1]]\nsmooth = true", r"transfer: unknown key\(s\) 'smooth'"),
]


@pytest.mark.parametrize("body,match", TF_CASES)
def test_scene_transfer_errors(tmp_path, body, match):
    p = write_scene(tmp_path, '[mesh]\nbuiltin = "box"\n[transfer]\n' + body + "\n", "tf.toml")
    with pytest.raises(ConfigError, match=r"tf\.toml: " + match):
        load_scene(p)


CAMERA_CASES = [
    ("eye = [1, 2, 3]\ntarget = [1, 2, 3]", r"camera\.eye: equals .*camera\.target \(\[1\.0, 2\.0, 3\.0\]\)"),
    ("eye = [0, 5, 0]\ntarget = [0, 0, 0]\nup = [0, 1, 0]", r"camera\.up: \[0\.0, 1\.0, 0\.0\] is parallel"),
    ("fov_y_deg = 0", r"camera\.fov_y_deg: 0 is outside the allowed range \(0, 180\)"),
    ("fov_y_deg = 180.0", r"camera\.fov_y_deg: 180\.0 is outside the allowed range \(0, 180\)"),
    ("fov_y_deg = -10", r"camera\.fov_y_deg: -10 is outside"),
    ("width_px = 0", r"camera\.width_px: 0 is outside the allowed range \[1, inf\]"),
    ("height_px = -4", r"camera\.height_px: -4 is outside"),
    ("height = 0.0", r"camera\.height: 0\.0 is outside"),
    ('projection = "fisheye"', r"camera\.projection: unknown value 'fisheye'; allowed: 'perspective'"),
    ("fov = 30", r"camera: unknown key\(s\) 'fov'"),
]


@pytest.mark.parametrize("body,match", CAMERA_CASES)
def test_scene_camera_errors(tmp_path, body, match):
    p = write_scene(tmp_path, '[mesh]\nbuiltin = "box"\n[camera]\n' + body + "\n", "cam.toml")
    with pytest.raises(ConfigError, match=r"cam\.toml: " + match):
        load_scene(p)


def test_scene_strict_zero_volume(tmp_path):
    pts = np.vstack([UNIT_TET, [[5, 0, 0], [6, 0, 0], [5, 1, 0], [6, 1, 0]]])
    write_vtu(tmp_path / "z.vtu", pts, [[0, 1, 2, 3], [4, 5, 6, 7]], point_data={"s": np.arange(8.0)})
    p = write_scene(tmp_path, '[mesh]\npath = "z.vtu"\nscalars = "s"\n' + GOOD_TF + GOOD_CAM)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_scene(p).mesh
    assert m.n_tets == 1 and m.load_notes == {"zero_volume_cells_dropped": 1}
    with pytest.raises(MeshError, match="zero-volume.*strict"):
        load_scene(p, strict=True)
