"""Texture-cache misses of table lookups, counted from the fragments a render draws (throughput model).

Roettger & Ertl 2002 (§4) give the reason the 3D-texture path of projected tetrahedra rasterises more
slowly than 2D textures: "additional texture memory accesses and a reduced texture cache coherency". The
emulated texture unit fetches the right texels but keeps no cache, so this module counts what a cache
would have to read from memory, from the texture coordinates each fragment of a redraw looks up
(``program.coords`` of :func:`warpvol.projection.programs.table3d_program`,
:func:`~warpvol.projection.programs.cylindrical_program` and Guthe et al.'s programs,
:func:`~warpvol.projection.programs.guthe_lookups`):

- a fetch touches its filter footprint: ``2 x 2`` texels (bilinear) of a 2D texture, ``2 x 2`` in each of
  two slices (trilinear) of a 3D texture, one texel (nearest), with the texture unit's clamp-to-edge
  (:func:`warpvol.kernels.texture.axis_linear`); an atlas tile's texels sit in the atlas' big texture;
- memory holds textures in blocks of :data:`BLOCK` x :data:`BLOCK` texels; a 3D texture is a stack of
  such blocked 2D slices;
- the cache holds the blocks of one triangle: each block a triangle's fragments touch is read once per
  triangle, and nothing is kept from one triangle to the next.

The block size and the per-triangle working set are estimates (no vendor documents the texture caches of
these cards; 4 x 4 is the block the cards' texture compression formats use, S3TC / DXT); the counted
blocks x block bytes are ``tex_miss_bytes``, priced at the profile's ``memory_bandwidth``
(:mod:`warpvol.model`). Used by :mod:`warpvol.reproduce.model_rows` for the configurations it names.

>>> import numpy as np
>>> prim = np.array([0, 0, 1])                          # two fragments of triangle 0, one of triangle 1
>>> texel = np.array([[1.0, 1.0], [2.0, 1.0], [1.0, 1.0]])  # texel-space (x, y)
>>> distinct_blocks(prim, texel, (8, 8))  # bilinear: texel columns 0-1 and 1-2, all in block column 0
2
>>> distinct_blocks(prim, texel + [3.0, 0.0], (8, 8))  # columns 3-4 straddle blocks 0 and 1
4
"""

from __future__ import annotations

import contextlib

import numpy as np

import warpvol.projection.pt as pt

#: texels per block edge (memory blocks of BLOCK x BLOCK texels; estimate, see the module docstring)
BLOCK = 4


def distinct_blocks(prim: np.ndarray, texel: np.ndarray, shape: tuple, filter: str = "linear",
                    block: int = BLOCK) -> int:
    """Distinct ``(triangle, block)`` pairs that fetches at texel-space coordinates ``texel`` (n, d),
    ``d`` = 2 (x, y) or 3 (x, y, slice), of a texture of ``shape`` (rows, columns) or (slices, rows,
    columns) touch, ``prim`` (n,) naming each fetch's triangle. Texel space as the texture unit's: ``x =
    u * width``; ``linear`` covers texels ``floor(x - 0.5)`` and the next one on each axis, ``nearest``
    ``floor(x)``, clamped to the texture."""
    prim = np.asarray(prim, dtype=np.int64)
    t = np.asarray(texel, dtype=np.float64)
    if len(prim) == 0:
        return 0
    d = t.shape[1]
    ext = [int(shape[-1]), int(shape[-2])] + ([int(shape[0])] if d == 3 else [])  # per axis: x, y, slice
    axes = []
    for a in range(d):
        x = np.nan_to_num(np.clip(t[:, a], -1.0, ext[a] + 1.0))
        k = np.floor(x - 0.5).astype(np.int64) if filter == "linear" else np.floor(x).astype(np.int64)
        ks = (k, k + 1) if filter == "linear" else (k,)
        axes.append([np.clip(kk, 0, ext[a] - 1) for kk in ks])
    nbx, nby = -(-ext[0] // block), -(-ext[1] // block)
    nsl = ext[2] if d == 3 else 1
    keys = []
    for kx in axes[0]:
        for ky in axes[1]:
            for kz in (axes[2] if d == 3 else [np.zeros_like(prim)]):
                keys.append(((prim * nsl + kz) * nby + ky // block) * nbx + kx // block)
    return int(len(np.unique(np.concatenate(keys))))


def _texel_coords(program, c: np.ndarray) -> tuple:
    """Texel-space coordinates of a batch's lookups ``c`` (``program.coords``): ``(texture, [per fetch
    (n, d) texel coordinates])`` -- a 3D table's ``(u, v, r)``; an atlas of planes' ``(alpha, u, v)``;
    or, with ``program.all_tiles``, an atlas whose every tile is read at ``(u, v)``."""
    tex = program.texture
    if not hasattr(tex, "ntiles"):  # 3D table: (u, v, r)
        sl, h, w = tex.shape
        return tex, [np.stack([c[:, 0] * w, c[:, 1] * h, c[:, 2] * sl], axis=1)]
    n, th, tw, cols = tex.ntiles, tex.tile_h, tex.tile_w, tex.cols
    if getattr(program, "all_tiles", False):  # Guthe et al.'s coefficients: every tile at (u, v) = c[:, :2]
        planes = [np.full(len(c), k, dtype=np.int64) for k in range(n)]
        c = np.stack([np.zeros(len(c)), c[:, 0], c[:, 1]], axis=1)
    elif getattr(program, "nearest", False):  # planes (alpha, u, v): the nearest plane (SGI path)
        planes = [np.clip(np.floor(np.clip(c[:, 0], 0.0, 1.0) * (n - 1) + 0.5), 0, n - 1).astype(np.int64)]
    else:  # planes: the two next to alpha
        p0 = np.minimum(np.floor(np.clip(c[:, 0], 0.0, 1.0) * (n - 1)).astype(np.int64), max(n - 2, 0))
        planes = [p0, np.minimum(p0 + 1, n - 1)]
    out = []
    for p in planes:
        row, col = np.divmod(p, cols)
        x = col * (tw + 2) + 1 + np.clip(c[:, 1], 0.0, 1.0) * tw
        y = row * (th + 2) + 1 + np.clip(c[:, 2], 0.0, 1.0) * th
        out.append(np.stack([x, y], axis=1))
    return tex.texture, out


@contextlib.contextmanager
def observe_draws(seen: list):
    """While active, every :func:`warpvol.projection.pt.draw` batch whose program has ``coords`` adds
    ``(program, prim, coords)`` to ``seen``."""

    draw = pt.draw

    def observed(geo, vertex_attrs, program, fb, blend, **kw):
        if not hasattr(program, "coords"):
            return draw(geo, vertex_attrs, program, fb, blend, **kw)

        def run(frags, tris):
            n = frags.count
            seen.append((program, frags.prim.numpy()[:n].copy(), program.coords(frags, tris).numpy()[:n]))
            return program(frags, tris)

        return draw(geo, vertex_attrs, run, fb, blend, **kw)

    pt.draw = observed
    try:
        yield
    finally:
        pt.draw = draw


#: other block edges counted beside BLOCK, to show what an agreement resting on BLOCK depends on
SENSITIVITY_BLOCKS = (BLOCK // 2, BLOCK * 2)


def table_misses(pipeline, scene, warm: bool = False) -> dict:
    """Texture-cache misses of ``pipeline``'s table lookups in a redraw of ``scene`` (a first render builds
    tables and compiles kernels, unless ``warm``: the caller rendered the scene with this pipeline
    already): :func:`misses` of the redraw's draws."""
    import warnings

    seen: list = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if not warm:
            pipeline.render(scene, quiet=True)
        with observe_draws(seen):
            pipeline.render(scene, quiet=True)
    return misses(seen)


def misses(seen: list) -> dict:
    """The misses of the draws :func:`observe_draws` saw: ``fragments``, ``blocks`` (distinct per triangle,
    summed over the draw's batches and the fetch's textures), ``block_bytes`` (the texture's bytes per texel
    x BLOCK^2) and ``miss_bytes``; ``miss_bytes_by_block``: the same count for block edges
    :data:`SENSITIVITY_BLOCKS` and BLOCK."""
    frags = 0
    nbytes = 0
    edges = sorted({BLOCK, *SENSITIVITY_BLOCKS})
    blocks = dict.fromkeys(edges, 0)
    for program, prim, c in seen:
        frags += len(prim)
        tex, texels = _texel_coords(program, c)
        nbytes = getattr(program, "texel_bytes", None) or tex.nbytes // int(np.prod(tex.shape))
        for t in texels:
            for b in edges:
                blocks[b] += distinct_blocks(prim, t, tex.shape, tex.effective_filter, block=b)
    bb = nbytes * BLOCK * BLOCK
    return {"fragments": int(frags), "blocks": int(blocks[BLOCK]), "block_bytes": int(bb),
            "miss_bytes": int(blocks[BLOCK] * bb),
            "miss_bytes_by_block": {str(b): int(n * nbytes * b * b) for b, n in blocks.items()}}
