"""Texture-cache misses counted from the fragment stream (warpvol.reproduce.texcache)."""

import numpy as np

from warpvol.pipeline import Pipeline
from warpvol.reproduce.texcache import BLOCK, distinct_blocks, table_misses
from warpvol.scene.builtin import builtin_scene


def test_bilinear_footprint_blocks_per_triangle():
    # one triangle sweeping a row of texel centres across an 8-texel-wide texture: every block of the row once
    x = np.arange(8) + 0.5 + 0.5  # footprints k..k+1 for k = 0..7 (the last clamped): both blocks
    texel = np.stack([x, np.full(8, 1.0)], axis=1)
    assert distinct_blocks(np.zeros(8), texel, (8, 8)) == 8 // BLOCK
    # the same fetches split over two triangles: each reads its own blocks again
    assert distinct_blocks(np.repeat([0, 1], 4), texel, (8, 8)) == 1 + 2
    # a footprint straddling a block row edge touches the two rows' blocks
    assert distinct_blocks([0], [[1.0, BLOCK]], (8, 8)) == 2


def test_nearest_and_trilinear_footprints():
    # nearest: the one texel floor(x); at a block edge only the block holding it
    assert distinct_blocks([0], [[BLOCK + 0.0, 1.0]], (8, 8), filter="nearest") == 1
    # trilinear at a slice centre + 0.5: two slices, one block each
    assert distinct_blocks([0], [[1.0, 1.0, 2.0]], (4, 8, 8)) == 2
    # clamp-to-edge: coordinates past the texture read its edge blocks only
    assert distinct_blocks([0, 0], [[-5.0, 1.0], [40.0, 1.0]], (8, 8)) == 2


def test_table_misses_counts_the_drawn_fragments():
    sc = builtin_scene("sphere").with_camera(width_px=64, height_px=48)
    p3 = Pipeline.load("roettger2000_3d")
    r3 = table_misses(p3, sc)
    frags = p3.render(sc, quiet=True).report["counters"]["pt_table3d"]["fragments"]
    assert r3["fragments"] == frags > 0
    assert r3["block_bytes"] == 4 * BLOCK * BLOCK  # RGBA8 texels
    assert 0 < r3["blocks"] and r3["miss_bytes"] == r3["blocks"] * r3["block_bytes"]
    # the 2D planes of the same table: one tile per triangle and plane, fewer blocks per fragment than the
    # 3D texture, whose lookups cross its l slices (Roettger & Ertl 2002 §4's reason for the 2D speed-up)
    r2 = table_misses(Pipeline.load("roettger2002_cylindrical"), sc)
    assert r2["fragments"] == r3["fragments"]
    assert r2["blocks"] < r3["blocks"]


def test_atlas_tiles_read_at_one_coordinate():
    """Guthe et al.'s coefficient tiles are all read at the fragment's (u, v): one fetch per tile, each in
    its own tile of the atlas (a 1-texel border around every tile)."""
    from types import SimpleNamespace

    from warpvol.gpu.texture import TextureAtlas
    from warpvol.reproduce.texcache import _texel_coords

    atlas = TextureAtlas(np.zeros((3, 4, 4, 4)), fmt="rgba32f")  # 3 tiles of 4x4 in a 2-column atlas
    prog = SimpleNamespace(texture=atlas, all_tiles=True)
    tex, fetches = _texel_coords(prog, np.array([[0.5, 0.25, 0.0]]))
    assert tex is atlas.texture and len(fetches) == 3
    got = [f[0].tolist() for f in fetches]  # x = col (4 + 2) + 1 + u 4, y = row (4 + 2) + 1 + v 4
    assert got == [[3.0, 2.0], [9.0, 2.0], [3.0, 8.0]]
