"""Segments (one per entry of a ray into a piece of the mesh) merged by depth compose exactly: the exact
reference of a mesh cut into pieces interleaved along the rays, piece by piece, merged and flattened, is the
reference of the whole mesh; the deep OpenEXR file of the segments flattens to the image."""

import numpy as np
import pytest

import warpvol
from warpvol.reference.numpy_render import render_reference
from warpvol.reference.segments import reference_segments
from warpvol.scene.mesh import TetMesh
from warpvol.segments import Segments, merge


def piece_of(mesh, keep, name):
    """The tets ``keep`` of ``mesh`` with their points, in the whole mesh's point order (ties break alike)."""
    tets = mesh.tets[keep]
    used = np.unique(tets)
    local = np.searchsorted(used, tets)
    return TetMesh(mesh.points[used], local, mesh.scalars[used], name=name)


def slab_pieces(mesh, n_pieces=2, slabs=6, axis=0):
    """Pieces of ``mesh`` made of alternate slabs across ``axis``: interleaved along rays, non-convex."""
    c = mesh.points[mesh.tets].mean(axis=1)[:, axis]
    k = np.floor((c - c.min()) / (np.ptp(c) + 1e-12) * slabs).astype(int) % n_pieces
    return [piece_of(mesh, k == i, f"piece{i}") for i in range(n_pieces)]


def test_two_slabs_compose_closed_form():
    # a ray through slab A (tau a, colour ca) then B: RGB = ca + e^-a cb, A = 1 - e^-(a+b)
    a, b = 0.7, 1.3
    ca, cb = np.array([0.2, 0.1, 0.0]), np.array([0.0, 0.3, 0.4])
    sa = Segments.from_unsorted([0, 0], [1.0, 3.0], [2.0, 4.0], [ca, ca], [a, a], (1, 2))
    sb = Segments.from_unsorted([0], [2.0], [3.0], [cb], [b], (1, 2))
    img = merge([sb, sa]).flatten()[0]
    np.testing.assert_allclose(img[0, :3], ca + np.exp(-a) * cb + np.exp(-a - b) * ca, rtol=1e-15)
    assert img[0, 3] == pytest.approx(1 - np.exp(-2 * a - b), rel=1e-15)
    assert (img[1] == 0).all()
    # entries: cells that follow each other join into one segment (front of one = back of the other)
    e = Segments.entries([0, 0, 0], [2.0, 1.0, 5.0], [3.0, 2.0, 6.0], [cb, ca, ca], [b, a, a], (1, 1))
    assert e.counts().tolist() == [2] and e.front.tolist() == [1.0, 5.0] and e.back.tolist() == [3.0, 6.0]
    np.testing.assert_allclose(e.rgb[0], ca + np.exp(-a) * cb, rtol=1e-15)
    cells = Segments.from_unsorted([0, 0, 0], [2.0, 1.0, 5.0], [3.0, 2.0, 6.0], [cb, ca, ca], [b, a, a], (1, 1))
    np.testing.assert_allclose(e.flatten(), cells.flatten(), rtol=1e-15)


@pytest.mark.parametrize("name", ["concave", "sphere"])
def test_reference_segments_flatten_to_the_reference(name):
    s = warpvol.builtin_scene(name).with_camera(width_px=24, height_px=20)
    stats = {}
    segs = reference_segments(s.mesh, s.transfer, s.camera, stats=stats)
    ref = render_reference(s.mesh, s.transfer, s.camera, method="numpy")
    np.testing.assert_allclose(segs.flatten(), ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(segs.flatten(), render_reference(s.mesh, s.transfer, s.camera), rtol=0, atol=1e-12)
    assert stats["n_segments"] < stats["n_cell_segments"]  # one per entry, not one per cell
    if name == "concave":
        assert segs.counts().max() >= 2  # rays leave and re-enter the mesh
    # rows of the image are the rows of the whole
    part = reference_segments(s.mesh, s.transfer, s.camera, rows=(5, 11))
    np.testing.assert_array_equal(part.flatten(), segs.rows(5, 11).flatten())


def test_interleaved_pieces_merge_to_the_whole():
    s = warpvol.builtin_scene("concave").with_camera(width_px=24, height_px=20)
    pieces = slab_pieces(s.mesh, 2, slabs=7)
    assert sum(p.n_tets for p in pieces) == s.mesh.n_tets
    parts = [reference_segments(p, s.transfer, s.camera) for p in pieces]
    whole = reference_segments(s.mesh, s.transfer, s.camera)
    merged = merge(parts)
    assert len(merged) > len(whole)  # the pieces' entries alternate along the rays
    np.testing.assert_allclose(merged.flatten(), whole.flatten(), rtol=0, atol=1e-12)


def test_deep_exr_round_trip(tmp_path):
    import OpenImageIO as oiio

    from warpvol.deep import read_deep, write_deep

    s = warpvol.builtin_scene("concave").with_camera(width_px=16, height_px=12)
    segs = merge([reference_segments(p, s.transfer, s.camera) for p in slab_pieces(s.mesh, 2, slabs=5)])
    img = segs.flatten()
    stats = {}
    write_deep(tmp_path / "deep.exr", segs, s.camera, stats=stats)
    assert stats["samples"] == len(segs) and [p.name for p in tmp_path.iterdir()] == ["deep.exr"]
    back = read_deep(tmp_path / "deep.exr", s.camera)
    assert back.counts().tolist() == segs.counts().tolist()
    np.testing.assert_allclose(back.front, segs.front, rtol=1e-6)
    np.testing.assert_allclose(back.flatten(), img, rtol=0, atol=2e-6)
    # a compositor's flatten (OpenImageIO's) of the file gives the image too
    flat = oiio.ImageBufAlgo.flatten(oiio.ImageBuf(str(tmp_path / "deep.exr")))
    np.testing.assert_allclose(flat.get_pixels(oiio.FLOAT)[..., :4], img, rtol=0, atol=2e-6)
