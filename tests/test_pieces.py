"""A mesh in pieces on Dask (warpvol.pieces): a .pvtu of pieces interleaved along the rays, each piece's exact
reference rendered into segments on a worker and merged by depth, equals the reference of the whole mesh; a
killed worker's piece is done again; a missing or unreadable piece is an error naming it, nothing written."""

import os
import signal
import subprocess
import sys

import numpy as np
import pytest

import warpvol
from tests.test_segments import slab_pieces
from warpvol.deep import read_deep
from warpvol.errors import ConfigError
from warpvol.io import read_exr
from warpvol.pieces import partition_mesh, pvtu_pieces, read_piece, render_pieces, scene_pieces
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.interop import mesh_to_pyvista

W, H = 24, 20


def write_pieces(folder, meshes, name="mesh"):
    """``meshes`` as piece files and the .pvtu naming them (scalars ``s``)."""
    for k, m in enumerate(meshes):
        mesh_to_pyvista(m, "s").save(folder / f"p{k}.vtu")
    src = "".join(f'<Piece Source="p{k}.vtu"/>' for k in range(len(meshes)))
    (folder / f"{name}.pvtu").write_text(
        '<?xml version="1.0"?><VTKFile type="PUnstructuredGrid" version="0.1" byte_order="LittleEndian">'
        '<PUnstructuredGrid GhostLevel="0"><PPointData Scalars="s"><PDataArray type="Float64" Name="s"/></PPointData>'
        f'<PPoints><PDataArray type="Float64" NumberOfComponents="3"/></PPoints>{src}</PUnstructuredGrid></VTKFile>')
    return folder / f"{name}.pvtu"


def scene_file(folder, pvtu, s):
    c = s.camera
    tf = "\n".join(f"  [{', '.join(repr(float(v)) for v in row)}]," for row in s.transfer.points)
    (folder / "scene.toml").write_text(f'''[mesh]
path = "{pvtu.name}"
scalars = "s"
[transfer]
emission = "{s.transfer.emission}"
points = [
{tf}
]
[camera]
projection = "perspective"
eye = {list(map(float, c.eye))}
target = {list(map(float, c.target))}
up = {list(map(float, c.up))}
fov_y_deg = {float(c.fov_y_deg)}
width_px = {W}
height_px = {H}
''')
    return folder / "scene.toml"


@pytest.fixture(scope="module")
def pieces(tmp_path_factory):
    d = tmp_path_factory.mktemp("pieces")
    s = warpvol.builtin_scene("concave").with_camera(width_px=W, height_px=H)
    pvtu = write_pieces(d, slab_pieces(s.mesh, 2, slabs=7))
    return s, scene_file(d, pvtu, s), render_reference(s.mesh, s.transfer, s.camera)


def test_distributed_equals_single(pieces):
    from dask.distributed import Client, LocalCluster

    s, scene, ref = pieces
    info = scene_pieces(scene)
    assert len(info["pieces"]) == 2 and info["scalars"] == "s"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cl, \
            Client(cl) as client:
        segs, rep = render_pieces(info["pieces"], "s", info["transfer"], info["camera"], client)
        res = warpvol.render_in_pieces(scene, "reference", client, reference=True)  # the Python API
    assert res["report"]["error"]["max_abs"] == 0 and len(res["report"]["pieces"]) == 2
    np.testing.assert_allclose(res["image"], ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(segs.flatten(), ref, rtol=0, atol=1e-12)
    assert [p["piece"] for p in rep["pieces"]] == ["p0.vtu", "p1.vtu"] and rep["workers"] == 2
    assert sum(p["cells"] for p in rep["pieces"]) == s.mesh.n_tets
    assert all(p["peak_bytes"] > 0 and p["seconds"] > 0 and p["piece_bytes"] >= 0 for p in rep["pieces"])
    assert rep["compositing_s"] >= 0


def test_killed_worker_and_cli_deep(pieces, tmp_path):
    s, scene, ref = pieces
    info = scene_pieces(scene)
    killed = []

    def kill_one(k, client):
        if not killed:
            pid = sorted(client.run(os.getpid).values())[0]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    # four pieces on two worker processes: the first result kills a worker, its pieces are done again
    four = pvtu_pieces(write_pieces(tmp_path, slab_pieces(s.mesh, 4, slabs=9), name="four"))
    segs, _ = render_pieces(four, "s", info["transfer"], info["camera"], "local", workers=2, on_piece=kill_one)
    assert killed
    np.testing.assert_allclose(segs.flatten(), ref, rtol=0, atol=1e-12)
    # the CLI: image and deep file; the deep file flattens to the image
    out, deep = tmp_path / "ref.exr", tmp_path / "deep.exr"
    r = subprocess.run([sys.executable, "-m", "warpvol.cli", "reference", str(scene), "--scheduler", "local",
                        "--workers", "2", "-o", str(out), "--deep", str(deep)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "2 pieces" in r.stdout
    np.testing.assert_allclose(read_exr(out), ref, rtol=0, atol=1e-6)
    np.testing.assert_allclose(read_deep(deep, s.camera).flatten(), ref, rtol=0, atol=2e-6)


def test_missing_or_unreadable_piece_names_it(pieces, tmp_path):
    s, _, _ = pieces
    pvtu = write_pieces(tmp_path, slab_pieces(s.mesh, 2, slabs=3))
    scene = scene_file(tmp_path, pvtu, s)
    (tmp_path / "p1.vtu").write_bytes(b"<VTKFile broken")
    with pytest.raises(ConfigError, match="p1.vtu"):
        read_piece(tmp_path / "p1.vtu", "s")
    (tmp_path / "p1.vtu").unlink()
    with pytest.raises(ConfigError, match=r"piece 1 \(p1.vtu\) not found"):
        pvtu_pieces(pvtu)
    out = tmp_path / "img.exr"
    r = subprocess.run([sys.executable, "-m", "warpvol.cli", "reference", str(scene), "--scheduler", "local", "-o",
                        str(out)], capture_output=True, text=True)
    assert r.returncode == 2 and "p1.vtu" in r.stderr and "Traceback" not in r.stderr and not out.exists()
    # a preset that cannot emit segments refuses a piece-by-piece render in words
    (tmp_path / "p1.vtu").write_bytes((tmp_path / "p0.vtu").read_bytes())
    r = subprocess.run([sys.executable, "-m", "warpvol.cli", "render", str(scene), "--pipeline", "pt_best",
                        "--scheduler", "local", "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 2 and "piece by piece" in r.stderr and not out.exists()
    assert "presets that do: raycast, harc_best" in r.stderr
    # a local worker's memory limit: only for pieces on a local cluster, a size
    for scene_arg, sched, mem, why in ((str(scene), "local", "lots", "expected a size"),
                                       ("builtin:box", None, "1GB", "only used with --scheduler local")):
        r = subprocess.run([sys.executable, "-m", "warpvol.cli", "reference", scene_arg, "-o", str(out),
                            "--worker-memory", mem] + (["--scheduler", sched] if sched else []),
                           capture_output=True, text=True)
        assert r.returncode == 2 and why in r.stderr and not out.exists()


def test_partition_cuts_into_a_pvtu(tmp_path):
    s = warpvol.builtin_scene("concave").with_camera(width_px=W, height_px=H)
    mesh_to_pyvista(s.mesh, "s").save(tmp_path / "whole.vtu")
    pvtu = partition_mesh(tmp_path / "whole.vtu", 3, tmp_path / "pieces")
    files = pvtu_pieces(pvtu)
    meshes = [read_piece(f, "s") for f in files]
    assert len(files) == 3 and sum(m.n_tets for m in meshes) == s.mesh.n_tets
    assert max(m.n_tets for m in meshes) - min(m.n_tets for m in meshes) <= 1
    from warpvol.reference.segments import reference_segments
    from warpvol.segments import merge

    img = merge([reference_segments(m, s.transfer, s.camera) for m in meshes]).flatten()
    np.testing.assert_allclose(img, render_reference(s.mesh, s.transfer, s.camera), rtol=0, atol=1e-12)


def test_raycast_pieces_equal_the_single_render(pieces, tmp_path):
    """raycast into segments: the whole mesh flattens to the preset's image, the pieces merged too (within the
    preset's float32 row), and the CLI renders the pieces with the reference's error in the report."""
    import json

    from tests.tolerances import TOLERANCES, preset_tolerance
    from warpvol.conditioning.conditioning import shared_frame
    from warpvol.pipeline import Pipeline
    from warpvol.raycast_segments import raycast_segments
    from warpvol.scene.scene import Scene
    from warpvol.segments import merge

    s, scene, ref = pieces
    img = Pipeline.load("raycast").render(s, quiet=True).image
    tol, close = preset_tolerance("raycast"), TOLERANCES["pieces/raycast"]
    whole = raycast_segments(s).flatten()
    frame = shared_frame(s.transfer, *s.mesh.bounds, s.mesh.scalar_range)
    own, parts = (merge([raycast_segments(Scene(mesh=p, transfer=s.transfer, camera=s.camera, name="p"), frame=f)
                         for p in slab_pieces(s.mesh, 2, slabs=7)]).flatten() for f in (None, frame))
    for got in (whole, own, parts):
        d = got - img
        assert np.sqrt((d ** 2).mean()) <= close["rmse"] and abs(d).max() <= close["max_abs"]
        assert np.sqrt(((got - ref) ** 2).mean()) <= tol["rmse"] and abs(got - ref).max() <= tol["max_abs"]
    # the pieces in the whole mesh's frame meet in the same float32 points: closer to the single render
    assert np.sqrt(((parts - img) ** 2).mean()) < np.sqrt(((own - img) ** 2).mean())
    out, rep = tmp_path / "img.exr", tmp_path / "rep.json"
    r = subprocess.run([sys.executable, "-m", "warpvol.cli", "render", str(scene), "--pipeline", "raycast",
                        "--scheduler", "local", "--workers", "2", "--compute-reference", "-o", str(out), "--report",
                        str(rep)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    report = json.loads(rep.read_text())
    assert len(report["pieces"]) == 2 and report["workers"] == 2 and report["compositing_s"] >= 0
    assert report["error"]["max_abs"] <= tol["max_abs"] and report["error"]["rmse"] <= tol["rmse"]
    assert report["frame"]["h"] > 0  # the first pass's shared frame
    np.testing.assert_allclose(read_exr(out), parts, rtol=0, atol=1e-6)


def test_piece_points_taken_in_global_order(tmp_path):
    """A piece whose points carry global ids in another order is read with its points in global order, as the
    whole mesh holds them (rays through shared edges and vertices then tie-break as for the whole)."""
    from warpvol.pieces import _points_in_order

    m = slab_pieces(warpvol.builtin_scene("concave").mesh, 2, slabs=5)[0]
    g = mesh_to_pyvista(m, "s")
    g.point_data["GlobalPointIds"] = np.arange(g.n_points) * 3
    perm = np.random.default_rng(5).permutation(g.n_points)
    _points_in_order(g, perm).save(tmp_path / "shuffled.vtu")
    back = read_piece(tmp_path / "shuffled.vtu", "s")
    assert back.load_notes["points_in_global_order"] == g.n_points
    np.testing.assert_array_equal(back.points, m.points)
    np.testing.assert_array_equal(back.scalars, m.scalars)
    np.testing.assert_array_equal(np.sort(back.tets, axis=1), np.sort(m.tets, axis=1))


@pytest.mark.parametrize("tets", [False, True])
def test_solver_pieces_with_ghost_layers(tmp_path, tets):
    """A .pvtu as a solver writes it (slab pieces of hexahedra or tets, each with a ghost layer from its
    neighbour): every worker drops its piece's ghost cells, and the pieces merged give the whole grid's
    reference (hexahedra split alike on both sides of a piece boundary)."""
    from warpvol.pieces import render_pieces
    from warpvol.scene.camera import Camera
    from warpvol.scene.mesh import TetMesh
    from warpvol.tools.stress_files import ghost_grid, write_pvtu

    g = ghost_grid((7, 6, 5), tets)
    path, ghosts = write_pvtu(tmp_path, g, 3, 1, 0)
    tf = warpvol.builtin_scene("concave").transfer
    cam = Camera(eye=(2.5, 1.6, 2.2), target=(0.5, 0.5, 0.5), width_px=20, height_px=16, fov_y_deg=35.0)
    ref = render_reference(TetMesh.from_pyvista(g, "s"), tf, cam)
    from dask.distributed import Client, LocalCluster

    from tests.tolerances import TOLERANCES

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cl, \
            Client(cl) as client:
        segs, rep = render_pieces(pvtu_pieces(path), "s", tf, cam, client)
    assert sum(p.get("ghost_cells_dropped", 0) for p in rep["pieces"]) == ghosts > 0
    np.testing.assert_allclose(segs.flatten(), ref, rtol=0, atol=TOLERANCES["pieces/reference"]["max_abs"])


def test_harc_best_pieces_equal_the_single_render(pieces):
    """harc_best into segments: the whole mesh flattens to the preset's image, and the pieces (in the whole
    mesh's frame, on a local Dask cluster) merged by depth too, within pieces/harc_best."""
    from dask.distributed import Client, LocalCluster

    from tests.tolerances import TOLERANCES, preset_tolerance
    from warpvol.pipeline import Pipeline
    from warpvol.raycast_segments import harc_segments

    s, scene, ref = pieces
    img = Pipeline.load("harc_best").render(s, quiet=True).image
    tol, close = preset_tolerance("harc_best"), TOLERANCES["pieces/harc_best"]
    st: dict = {}
    whole = harc_segments(s, stats=st).flatten()
    assert st["passes"] >= 2  # the depth-peel passes re-entered the concave mesh
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cl, \
            Client(cl) as client:
        res = warpvol.render_in_pieces(scene, "harc_best", client)
    assert len(res["report"]["pieces"]) == 2 and res["report"]["frame"]["h"] > 0
    for got in (whole, res["image"]):
        d = got - img
        assert np.sqrt((d ** 2).mean()) <= close["rmse"] and abs(d).max() <= close["max_abs"]
        assert np.sqrt(((got - ref) ** 2).mean()) <= tol["rmse"] and abs(got - ref).max() <= tol["max_abs"]
