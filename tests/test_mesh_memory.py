"""The per-tet topology and geometry a first ray-cast render builds (adjacency, face planes, neighbour records,
thin-cell shapes) hold their temporaries to a bounded size per tet, and give what a direct construction gives."""

import tracemalloc

import numpy as np
import pytest

import warpvol
import warpvol.scene.mesh as mesh_module
import warpvol.shared.thin_cells as thin_cells
from tests.helpers import box_mesh
from warpvol.errors import MeshError
from warpvol.raycasting.stages.cell_setup import neighbour_faces
from warpvol.scene.mesh import FACE_VERTS, TetMesh


def direct_adjacency(tets):
    """Adjacency by a dictionary of sorted face triples."""
    seen, adj = {}, np.full((len(tets), 4), -1, dtype=np.int32)
    for c, t in enumerate(tets):
        for f in range(4):
            key = tuple(sorted(t[FACE_VERTS[f]]))
            if key in seen:
                d, g = seen.pop(key)
                adj[c, f], adj[d, g] = d, c
            else:
                seen[key] = (c, f)
    return adj


@pytest.mark.parametrize("name", ["concave", "sphere"])
def test_adjacency_and_neighbour_records_match_a_direct_construction(name):
    m = warpvol.builtin_scene(name).mesh
    rng = np.random.default_rng(3)
    m = TetMesh(m.points, m.tets[rng.permutation(m.n_tets)], m.scalars)
    adj = direct_adjacency(m.tets)
    assert np.array_equal(m.adjacency, adj) and m.adjacency.dtype == np.int32
    nbr = neighbour_faces(m.adjacency)
    c, f = np.nonzero(nbr >= 0)
    assert np.array_equal(nbr[c, f] >> 2, adj[c, f]) and (adj[nbr[c, f] >> 2, nbr[c, f] & 3] == c).all()
    assert (nbr[adj < 0] == -1).all()
    with pytest.raises(MeshError, match=r"face \[0, 1, 2\] is shared by 3 tets \(\[0, 1, 2\]\)"):
        pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [1, 1, 1.0]])
        TetMesh(pts, [[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 5]], np.zeros(6)).adjacency


def test_first_render_topology_peak_per_tet(monkeypatch):
    # chunks smaller than the mesh, as a mesh of millions of tets meets them
    monkeypatch.setattr(mesh_module, "_CHUNK_TETS", 2048)
    monkeypatch.setattr(thin_cells, "_CHUNK", 2048)
    m = box_mesh(dims=(17, 17, 17))  # 24,576 tets
    whole = TetMesh(m.points, m.tets, m.scalars)
    planes = np.concatenate([mesh_module._face_planes(m.points, m.tets[a:a + 5000]) for a in range(0, m.n_tets, 5000)])
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        _ = whole.adjacency, whole.face_planes, neighbour_faces(whole.adjacency), thin_cells._shape(whole)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    # held: face planes 128 B/tet, adjacency and neighbour records 16 each, altitude 8; the builds' temporaries
    # were 3-7 times that (a (4M, 3, 3) table of face points, np.unique's copies)
    assert peak / m.n_tets < 400
    assert np.array_equal(whole.face_planes, planes)  # chunks change no bit
