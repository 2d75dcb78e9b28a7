"""Cylindrical 2D planes of the 3D table (Roettger & Ertl 2002 §4).

All fragments of one projected tetrahedron lie on a plane through the front diagonal
(``sf = sb, l = 0``). In sheared cylinder coordinates ``(alpha, s, t)`` every such plane has constant
``alpha``; the 3D table is resampled into ``P`` square planes (``alpha_p = p / (P - 1)``, 0°..180°,
the 3D table's scalar resolution, same node convention) with eq. 9:

==================  ==================================
alpha               (sf, sb, l)
==================  ==================================
[0, .25]            (t + s, t, 4 alpha s)
[.25, .5]           (t + 4 (.5 - alpha) s, t, s)
[.5, .75]           (t - 4 (alpha - .5) s, t, s)
[.75, 1]            (t - s, t, 4 (1 - alpha) s)
==================  ==================================

Points of a plane outside the unit cube (e.g. ``sf = t + s > 1``) are never looked up by a
tetrahedron and take the clamped (edge) value. The inverse (eq. 10, per vertex, one division) is
:func:`to_cylinder`; the front diagonal ``d = l = 0`` maps to ``(0, 0, sb)`` (the silhouette rule)
instead of dividing 0 by 0. Reconstruction blends the two nearest planes linearly in ``alpha``
(two-pass multi-texturing), each plane sampled bilinearly, with the weight held as the 8-bit colour
value the combiner interpolates with (``PLANE_WEIGHTS``); the SGI path of the paper's Fig. 8 draws one
texture instead, the nearest plane with nearest-texel filtering (``PLANE_PATHS``).

The planes resample a given 3D table (``table=``: the software or hardware table a 3D preset uses,
so both paths draw from the same numbers; trilinear in fp32 on the host, then stored in the planes'
format) or, without one, an exact fp32 table built here (an analysis set-up). ``P = 4N`` reconstructs the 3D table to
within interpolation error; ``2N`` and ``N`` trade accuracy for memory. The planes are also tiled
into one atlas texture (``extra["atlas"]``, tile ``p`` at row ``p // cols``, column ``p % cols``,
row 0 = GL bottom, so ``alpha = 0`` is the bottom-left tile as in the paper's Fig. 10).

The same tiling is uploaded to the emulated texture unit on first use: :func:`plane_texture` returns
a :class:`warpvol.gpu.texture.TextureAtlas` (linear or nearest filtering, 8-bit filter weights, texel
format of the stored table, :data:`TEXEL_FORMAT`), kept in ``extra["texture"]`` (uploaded lazily: a
large plane set is not held twice unless it is sampled), or a fresh one for another device / filter /
weight precision / format. :func:`reconstruct` has two paths:

* ``via="texture"`` (default): what the 2002 hardware computed; each plane is sampled by the
  texture unit (its filter-weight quantisation, texel-centre and clamp conventions).
* ``via="float"``: fp32 bilinear filtering of the decoded planes, i.e. the interpolation error of
  the mapping alone (an analysis path, no texture unit).

Both share the inverse mapping and the plane choice; the float path blends the two planes in fp32,
the texture path with the weight ``plane_weight`` (fp32 by default; ``unorm8`` as the renderer).
"""

from __future__ import annotations

import math

import numpy as np

from warpvol.gpu.texture import TextureAtlas
from warpvol.tables.base import TABLE_FORMATS, Axis, Table
from warpvol.tables.common import (
    check_choice,
    check_lmax,
    check_res,
    check_tf,
    farr,
    finish,
    kernels,
    launch_bands,
    linear_index_map,
    model_id,
    table_key,
    tf_arrays,
    tf_pieces,
    timed,
)
from warpvol.tables.exact import build_exact3d

PLANE_FACTORS = {"4x": 4, "2x": 2, "1x": 1}

# stored table format -> texel format of the emulated texture unit holding the planes. HILO16 has two
# channels per texture, so four 16-bit channels are rgba16; al16 (Guthe's A/L byte pairs, not a
# 2002 cylindrical format) keeps its decoded values exactly in rgba32f texels.
TEXEL_FORMAT = {"rgba8": "rgba8", "hilo16": "rgba16", "fp16": "rgba16f", "fp32": "rgba32f",
                "snorm8": "rgba8s", "al16": "rgba32f"}
RECONSTRUCT_VIA = ("texture", "float")
# the weight between the two planes: the combiner's 8-bit colour value (primary colour alpha, set per
# tetrahedron with its vertices) or an fp32 analysis weight
PLANE_WEIGHTS = {"unorm8": 8, "fp32": 0}
# "multitexture": two planes in two texture units, bilinear, blended (PC cards of Fig. 8);
# "sgi": one 2D texture, the nearest plane, nearest-texel filtering (SGI platforms of Fig. 8)
PLANE_PATHS = ("multitexture", "sgi")


def to_cylinder(sf, sb, l) -> np.ndarray:
    """Eq. 10 in NumPy (float64): ``(alpha, s, t)`` of normalised ``(sf, sb, l)``; shape (..., 3)."""
    sf, sb, l = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (sf, sb, l)))
    d = sf - sb
    a = np.zeros_like(d)
    s = np.zeros_like(d)
    with np.errstate(divide="ignore", invalid="ignore"):
        c1 = (d >= 0) & (l <= d) & (d > 0)
        c2 = (d >= 0) & (l > d)
        c3 = (d < 0) & (l >= -d)
        c4 = (d < 0) & (l < -d)
        a = np.where(c1, l / (4 * d), a)
        s = np.where(c1, d, s)
        a = np.where(c2 | c3, 0.5 - d / (4 * l), a)
        s = np.where(c2 | c3, l, s)
        a = np.where(c4, 1 + l / (4 * d), a)
        s = np.where(c4, -d, s)
    return np.stack([a, s, sb], axis=-1)


def from_cylinder(alpha, s, t) -> np.ndarray:
    """Eq. 9 in NumPy: ``(sf, sb, l)`` of ``(alpha, s, t)``; shape (..., 3)."""
    a, s, t = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (alpha, s, t)))
    sf = np.select([a <= .25, a <= .5, a <= .75], [t + s, t + 4 * (.5 - a) * s, t - 4 * (a - .5) * s], t - s)
    l = np.select([a <= .25, a <= .75], [4 * a * s, s], 4 * (1 - a) * s)
    return np.stack([sf, t, l], axis=-1)


def build_cylindrical(tf, *, n_s: int = 64, n_l: int | None = None, lmax: float = 1.0, planes: str = "4x",
                      source: str = "table", table: Table | None = None, format: str = "fp32",
                      device: str = "cpu") -> Table:
    """Cylindrical planes (and their atlas) of a 3D table.

    Parameters
    ----------
    tf : TransferFunction
    n_s : int
        Scalar resolution of the 3D table; each plane is ``n_s x n_s``.
    n_l : int, optional
        Thickness resolution of the 3D table (default ``n_s``).
    lmax : float
    planes : str
        ``"4x"``, ``"2x"`` or ``"1x"``: number of planes relative to ``n_s``.
    source : str
        ``"table"``: trilinear resampling of a 3D table, as the paper does (``table``, else an exact
        fp32 table built here); ``"exact"``: exact integrals at the mapped points (no resampling error).
    table : Table, optional
        The 3D table to resample (linear axes): the one the 3D path draws from (software
        ``build_roettger_sw`` or hardware ``build_roettger_hw``, decoded from its stored format);
        ``n_s``, ``n_l`` and ``lmax`` are then the table's. Built with :func:`build_exact3d` when omitted.
    format, device : str
    """
    check_tf(tf)
    check_choice("planes", planes, tuple(PLANE_FACTORS))
    check_choice("source", source, ("table", "exact"))
    check_choice("format", format, TABLE_FORMATS)
    if table is not None:
        if source != "table":
            raise ValueError(f"source: a given table is resampled (source = 'table'), got {source!r}")
        if table.data.ndim != 4 or table.axes[0].kind == "log2":
            raise ValueError("table: expected a 3D table with linear axes (centred or endpoint)")
        n_l, n_s, lmax = table.data.shape[0], table.data.shape[2], float(table.axes[0].scale)
        src_key = table.key
    else:
        n_s = check_res("n_s", n_s, 2)
        n_l = n_s if n_l is None else check_res("n_l", n_l, 1)
        lmax = check_lmax(lmax)
        src_key = None
    import warp as wp

    k = kernels()
    P = PLANE_FACTORS[planes] * n_s
    key = table_key("cylindrical", tf.hash, n_s=n_s, n_l=n_l, lmax=lmax, planes=planes, source=source,
                    table=src_key, format=format)
    meta = {"builder": "cylindrical", "emission": tf.emission, "lmax": lmax, "planes": P, "source": source}
    kind = table.axes[2].kind if table is not None else "centred"
    ax_p = Axis("alpha", P, "endpoint")
    ax_t = Axis("t", n_s, kind)
    ax_s = Axis("s", n_s, kind)
    out = wp.zeros((P, n_s, n_s), dtype=wp.vec4, device=device)
    alphas = farr(ax_p.nodes, device)
    xs = farr(ax_s.nodes, device)
    if source == "table":
        if table is None:
            table = build_exact3d(tf, n_s=n_s, n_l=n_l, lmax=lmax, device=device)
        meta["source_build_s"] = table.meta.get("build_s")
        meta["source_table"] = table.name
        meta["source_key"] = table.key
        src = table.to_warp(device)
        fa, fb = linear_index_map(table.axes[2])
        ba, bb = linear_index_map(table.axes[1])
        la, lb = linear_index_map(table.axes[0])
        with timed(meta, device=device):
            wp.launch(k.cylindrical_resample, dim=(P, n_s, n_s), device=device,
                      inputs=[src, alphas, xs, xs, fa, fb, ba, bb, la, lb, out])
    else:
        tf_s, tf_v = tf_arrays(tf, device)
        lo, hi = tf.srange
        with timed(meta, device=device):
            launch_bands(k.cylindrical_exact, P, n_s, n_s, device, lambda p0, np_, j0, nj: [
                alphas[p0:p0 + np_], xs, xs[j0:j0 + nj], lmax, lo, hi - lo, tf_s, tf_v, model_id(tf),
                out[p0:p0 + np_, j0:j0 + nj]], pieces=tf_pieces(tf), what=f"cylindrical planes {P}x{n_s}x{n_s}")
    t = finish("cylindrical", out.numpy(), (ax_p, ax_t, ax_s), ("r", "g", "b", "a"), format, key, meta)
    t.extra["atlas"] = atlas(t.data)
    return t


def _make_texture(planes: Table, device: str, weight_bits: int | None, filter: str = "linear"):
    return TextureAtlas(planes.data, fmt=TEXEL_FORMAT[planes.format], filter=filter, device=device,
                        weight_bits=weight_bits)


def plane_texture(planes: Table, device: str = "cpu", weight_bits: int | None = 8, filter: str = "linear"):
    """The planes as an emulated :class:`~warpvol.gpu.texture.TextureAtlas` (tile ``p`` = plane ``p``).

    Returns ``planes.extra["texture"]`` when it matches (device, texel format of ``planes.format``,
    ``filter``, ``weight_bits``), else uploads a new atlas; the first one uploaded is kept there.
    ``weight_bits=None`` gives fp32 filter weights (the texture unit's analysis mode); ``filter`` is
    ``"linear"`` (bilinear) or ``"nearest"`` (the SGI path).
    """
    if planes.name != "cylindrical" or planes.data.ndim != 4:
        raise ValueError("planes: expected a table from build_cylindrical")
    check_choice("filter", filter, ("linear", "nearest"))
    tex = planes.extra.get("texture")
    fmt = TEXEL_FORMAT[planes.format]
    if (tex is not None and tex.device == device and tex.texture.fmt == fmt and tex.texture.filter == filter
            and tex.texture.weight_bits == weight_bits and tex.ntiles == planes.data.shape[0]):
        return tex
    tex = _make_texture(planes, device, weight_bits, filter)
    planes.extra.setdefault("texture", tex)
    return tex


def atlas(planes: np.ndarray) -> np.ndarray:
    """Tile ``planes[P, N, N, C]`` into one ``(rows N, cols N, C)`` texture, ``cols = ceil(sqrt(P))``."""
    P, N, M, C = planes.shape
    cols = math.ceil(math.sqrt(P))
    rows = math.ceil(P / cols)
    out = np.zeros((rows * N, cols * M, C), dtype=planes.dtype)
    for p in range(P):
        r, c = divmod(p, cols)
        out[r * N:(r + 1) * N, c * M:(c + 1) * M] = planes[p]
    return out


def reconstruct(planes: Table, sf, sb, l, device: str = "cpu", via: str = "texture",
                weight_bits: int | None = 8, plane_weight: str = "fp32", path: str = "multitexture") -> np.ndarray:
    """Colour and opacity at normalised ``(sf, sb, l)`` from the planes: inverse mapping (eq. 10),
    bilinear in each of the two nearest planes, linear between them. Returns float32 (..., 4).

    via : str
        ``"texture"`` (default): the planes are sampled by the emulated texture unit
        (:func:`plane_texture`, 8-bit filter weights unless ``weight_bits`` says otherwise), i.e. what
        the 2002 hardware computed. ``"float"``: fp32 bilinear filtering of the decoded planes and an
        fp32 plane weight, the interpolation error of the mapping alone (``weight_bits``,
        ``plane_weight`` and ``path`` unused).
    plane_weight : str
        Texture path: the weight between the planes, ``"fp32"`` (default here, so that this path
        differs from the float path by the texture unit alone) or ``"unorm8"`` (the combiner's 8-bit
        colour value, what stage ``pt_cylindrical`` draws with by default).
    path : str
        Texture path: ``"multitexture"`` (two planes, bilinear) or ``"sgi"`` (one texture: the
        nearest plane, nearest texel).
    """
    import warp as wp

    via = check_choice("via", via, RECONSTRUCT_VIA)
    check_choice("plane_weight", plane_weight, tuple(PLANE_WEIGHTS))
    check_choice("path", path, PLANE_PATHS)
    k = kernels()
    sf, sb, l = np.broadcast_arrays(*(np.asarray(v, dtype=np.float32) for v in (sf, sb, l)))
    shape = sf.shape
    n = int(sf.size)
    out = wp.zeros(n, dtype=wp.vec4, device=device)
    if n == 0:
        return out.numpy().reshape(shape + (4,))
    sa, sb_ = linear_index_map(planes.axes[2])
    ta, tb = linear_index_map(planes.axes[1])
    coords = [farr(sf.ravel(), device), farr(sb.ravel(), device), farr(l.ravel(), device)]
    if via == "float":
        wp.launch(k.cylindrical_lookup, dim=n, device=device,
                  inputs=[planes.to_warp(device), *coords, sa, sb_, ta, tb, out])
    else:
        sgi = path == "sgi"
        tex = plane_texture(planes, device, weight_bits, "nearest" if sgi else "linear")
        ns, nt = planes.axes[2].n, planes.axes[1].n
        # continuous texel index a x + b  ->  in-tile texture coordinate (a x + b + 0.5) / n
        wp.launch(k.cylindrical_lookup_tex, dim=n, device=device,
                  inputs=[tex.struct, *coords, sa / ns, (sb_ + 0.5) / ns, ta / nt, (tb + 0.5) / nt,
                          PLANE_WEIGHTS[plane_weight], int(sgi), out])
        tex.texture.count(n if sgi else 2 * n)  # one plane (SGI) or two (two-pass multi-texturing)
    return out.numpy().reshape(shape + (4,))
