"""Cells and points renumbered along a Morton curve (warpvol/conditioning/reorder.py, the ``condition``
stage's ``reorder``): the renumbered mesh is the same mesh (tets, orientation, adjacency, scalars), the
rule leaves coherently numbered meshes alone and renumbers incoherent ones, and the exact presets render
a shuffled mesh within their tolerance rows either way."""

import numpy as np
import pytest

from tolerances import EXACT_PRESETS, preset_tolerance
from warpvol.conditioning.reorder import (
    far_neighbour_fraction,
    morton_codes,
    morton_permutations,
    needs_reorder,
    reordered_mesh,
)
from warpvol.errors import ConfigError
from warpvol.metrics import image_error
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.builtin import builtin_mesh, builtin_scene
from warpvol.scene.mesh import TetMesh, signed_volumes
from warpvol.tools.sweep import pipeline_config


def shuffled(mesh: TetMesh, seed: int = 0) -> TetMesh:
    """``mesh`` with its cells and points in a random order (a plain, validated TetMesh)."""
    rng = np.random.default_rng(seed)
    p, c = rng.permutation(mesh.n_points), rng.permutation(mesh.n_tets)
    new = np.empty_like(p)
    new[p] = np.arange(len(p))
    return TetMesh(mesh.points[p], new[mesh.tets[c]], mesh.scalars[p], name="shuffled")


def cell_keys(mesh) -> np.ndarray:
    """Each tet as its four vertex positions in local order (rows sorted: comparable across numberings)."""
    k = mesh.points[mesh.tets].reshape(mesh.n_tets, 12)
    return k[np.lexsort(k.T[::-1])]


def test_morton_codes_interleave_x_y_z_and_follow_each_axis():
    g = np.arange(6.0)
    x = morton_codes(np.c_[g, 0 * g, 0 * g], np.zeros(3), 2**21 - 1)
    y = morton_codes(np.c_[0 * g, g, 0 * g], np.zeros(3), 2**21 - 1)
    z = morton_codes(np.c_[0 * g, 0 * g, g], np.zeros(3), 2**21 - 1)
    assert x.tolist() == [0, 1, 8, 9, 64, 65]
    assert (y == x << np.uint64(1)).all() and (z == x << np.uint64(2)).all()
    # outside the cube: clamped to its faces, not wrapped
    assert morton_codes(np.array([[-5.0, 0, 0], [1e9, 0, 0]]), np.zeros(3), 1.0).tolist() == \
        [0, int(morton_codes(np.array([[1.0, 0, 0]]), np.zeros(3), 1.0)[0])]


def test_reordered_mesh_is_the_same_mesh():
    m = shuffled(builtin_mesh("concave"))
    r = reordered_mesh(m)
    assert r.n_tets == m.n_tets and r.n_points == m.n_points
    np.testing.assert_array_equal(cell_keys(r), cell_keys(m))  # same tets, same local vertex order
    assert (signed_volumes(r.points, r.tets) > 0).all()
    np.testing.assert_array_equal(r.points, m.points[r.point_order])
    np.testing.assert_array_equal(r.scalars, m.scalars[r.point_order])
    # the renumbered adjacency equals the one a fresh mesh of the new arrays builds
    fresh = TetMesh(r.points, r.tets, r.scalars)
    np.testing.assert_array_equal(r.adjacency, fresh.adjacency)
    np.testing.assert_array_equal(r.boundary_faces, fresh.boundary_faces)
    assert r.is_convex == m.is_convex


def test_morton_order_makes_neighbours_close_and_the_rule_follows_it():
    m = shuffled(builtin_mesh("sphere"))  # 2,560 tets in a random order
    r = reordered_mesh(m)
    w = 64  # records: small enough for this mesh to have far pairs
    far_shuffled, far_morton = far_neighbour_fraction(m.adjacency, w), far_neighbour_fraction(r.adjacency, w)
    assert far_shuffled > 0.9 and far_morton < 0.35
    # the grid's own order is coherent: the rule leaves it; the default window exceeds this mesh
    assert far_neighbour_fraction(builtin_mesh("sphere").adjacency, w) < 0.5
    assert far_neighbour_fraction(m.adjacency) == 0.0 and not needs_reorder(m, "auto")
    assert needs_reorder(m, "morton") and not needs_reorder(m, "none")
    with pytest.raises(ValueError, match="reorder"):
        needs_reorder(m, "hilbert")


def test_permutations_are_permutations():
    m = builtin_mesh("stiff")
    p, c = morton_permutations(m.points, m.tets)
    assert sorted(p.tolist()) == list(range(m.n_points)) and sorted(c.tolist()) == list(range(m.n_tets))


@pytest.mark.parametrize("preset", sorted(EXACT_PRESETS))
def test_shuffled_mesh_renders_within_tolerance_renumbered_or_not(preset):
    sc = builtin_scene("concave").with_camera(width_px=40, height_px=40)
    sc.mesh = shuffled(sc.mesh, seed=3)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    tol = preset_tolerance(preset)
    images = {}
    for mode in ("none", "morton"):
        res = Pipeline.from_config(pipeline_config(preset, (("condition.reorder", mode),))).render(sc, quiet=True)
        assert res.report["stats"]["condition"]["reordered"] is (mode == "morton")
        e = image_error(res.image, ref)
        assert e["rmse"] <= tol["rmse"] and e["max_abs"] <= tol["max_abs"], (mode, e)
        images[mode] = res.image
    assert np.abs(images["none"] - images["morton"]).max() <= tol["max_abs"]


def test_condition_stage_refuses_an_unknown_reorder_naming_it():
    with pytest.raises(ConfigError, match="reorder"):
        Pipeline.from_config({"name": "x", "stages": [{"stage": "condition", "reorder": "hilbert"},
                                                      {"stage": "cell_setup"}, {"stage": "entry_bins"},
                                                      {"stage": "raycast"}]})


def test_source_cells_move_whole():
    """A mesh whose tets are grouped into the source cells they were split from (``cell_start``, 5 tets
    per cube here) keeps every group whole and consecutive, in Morton order of the groups."""
    from warpvol.scene.grids import grid_points, structured_to_tets5

    x = np.linspace(-1.0, 1.0, 7)
    pts = grid_points(x, x, x)
    tets = structured_to_tets5((7, 7, 7))
    rng = np.random.default_rng(5)
    groups = rng.permutation(len(tets) // 5)  # the cubes in a random order, each cube's 5 tets together
    order = (groups[:, None] * 5 + np.arange(5)).ravel()
    m = TetMesh(pts, tets[order], np.linalg.norm(pts, axis=1), cell_start=np.arange(0, len(tets) + 1, 5))
    r = reordered_mesh(m)
    np.testing.assert_array_equal(r.cell_start, m.cell_start)  # 5 tets per group still
    old_group = r.cell_order // 5
    assert (old_group.reshape(-1, 5) == old_group[::5, None]).all()  # each new group is one old group
    np.testing.assert_array_equal(cell_keys(r), cell_keys(m))
    np.testing.assert_array_equal(r.adjacency, TetMesh(r.points, r.tets, r.scalars).adjacency)
    assert far_neighbour_fraction(r.adjacency, 32) < far_neighbour_fraction(m.adjacency, 32)
