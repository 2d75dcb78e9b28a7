"""Fragment programs of projected tetrahedra (run by :func:`warpvol.projection.pt.draw` on each batch).

* :func:`vertex_color_program` over :func:`vertex_colors` (Shirley & Tuchman's averaged colour);
* :func:`table3d_program` (a 3D pre-integration table: Roettger & Ertl, Weiler, Kraus et al.),
  :func:`guthe_program` (Guthe et al.'s 2D tables), :func:`cylindrical_program` (Roettger & Ertl's
  cylindrical planes), :func:`exact_program` (the segment integrated exactly; ``pt_best``);
* :func:`perspective_attrs`: Kraus et al. 2004's per-vertex attributes for perspective-correct (sf, sb, l).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import warp as wp

from warpvol.errors import ConfigError
from warpvol.gpu.texture import Texture1D, Texture3D, TextureAtlas
from warpvol.kernels import pt as kpt
from warpvol.kernels.tf import device_points
from warpvol.projection.pt import NO_ZERO, PERSPECTIVE_MODES, PTGeometry
from warpvol.shared.integration import TEXEL_FOR_TABLE, _axis_affine
from warpvol.tables.base import model_id
from warpvol.tables.common import linear_index_map
from warpvol.tables.cylindrical import PLANE_PATHS, PLANE_WEIGHTS, plane_texture


def vertex_colors(geo: PTGeometry, tf, device: str = "cpu") -> np.ndarray:
    """Per output vertex ``(c̄r, c̄g, c̄b, τ̄, l)``: colour and extinction averaged over the front
    and back scalars (Shirley & Tuchman's averaged colour), thickness ``l``."""

    n = geo.attrs.shape[0]
    out = wp.zeros((n, 5), dtype=wp.float32, device=device)
    tf_s = wp.array(tf.points[:, 0].astype(np.float32), dtype=wp.float32, device=device)
    tf_v = wp.array(tf.points[:, 1:].astype(np.float32), dtype=wp.vec4, device=device)
    wp.launch(kpt.k_vertex_colors, dim=n, inputs=[wp.array(geo.attrs, dtype=wp.vec3, device=device), tf_s, tf_v, out],
              device=device)
    return out.numpy()


def vertex_color_program(emission_density: bool, device: str = "cpu") -> Callable:
    """Fragment program of :func:`vertex_colors` attributes: ``α = 1 - exp(-τ̄ l)`` per fragment."""

    def run(frags, tris):
        out = wp.zeros(frags.count, dtype=wp.vec4, device=device)
        wp.launch(kpt.k_frag_vertex_color, dim=frags.count, inputs=[frags.attrs, int(emission_density), out],
                  device=device)
        return out

    return run


#: fragment attribute modes: screen-linear (sf, sb, l), or Kraus et al.'s perspective-correct
#: division with the exact or the approximate thickness (:func:`warpvol.kernels.pt.fragment_sfsbl`)


def perspective_attrs(geo: PTGeometry, device: str = "cpu") -> np.ndarray:
    """Kraus et al. 2004 vertex program: per output vertex ``(sf/wf, sb/wb, 1/wf, 1/wb, xf/wf,
    yf/wf, zf/wf, zb/wb)`` (V+M, 8) from the front and back points of :func:`decompose`."""

    if geo.front is None or geo.back is None:
        raise ConfigError("pt_geometry: no front/back points (decompose() output needed)")
    n = geo.attrs.shape[0]
    out = wp.zeros((n, 8), dtype=wp.float32, device=device)
    wp.launch(kpt.k_kraus_vertices, dim=n, inputs=[wp.array(geo.attrs, dtype=wp.vec3, device=device),
                                                   wp.array(geo.front, dtype=wp.vec4, device=device),
                                                   wp.array(geo.back, dtype=wp.vec4, device=device), out],
              device=device)
    return out.numpy()


def _scalar_consts(ax) -> list:
    sa, sb, _ = _axis_affine(ax)
    return [float(ax.offset), 1.0 / float(ax.scale), sa, sb]


def guthe_program(table, *, mode: str = "off", ortho: bool = False, weight_bits: int | None = 8,
                  device: str = "cpu", z_off: float = 0.0) -> Callable:
    """Guthe et al. 2002 fragment program over a :func:`warpvol.tables.guthe2d.build_guthe2d` table:
    the ``degree + 1`` coefficient textures (tile 0: ``C~_0`` and ``rho_hat``) as 2D textures of
    an atlas, holding the table's stored (already quantised: signed 8-bit RGB and unsigned 8-bit A
    for ``snorm8``) values exactly, bilinear with ``weight_bits`` filter fractions; the decoded
    alpha1D (8-bit A or the 16-bit A/L value) as a linear 1D texture read by a dependent lookup."""

    if table.name != "guthe2d":
        raise ConfigError(f"table: expected Guthe 2D tables (stage table_guthe), got {table!r}")
    deg = table.data.shape[0] - 1
    atlas = TextureAtlas(table.data, fmt="rgba32f", filter="linear", device=device, weight_bits=weight_bits)
    a1 = np.asarray(table.extra["alpha1d"], dtype=np.float32).reshape(-1)
    alpha = Texture1D(a1, fmt="r32f", filter="linear", device=device, weight_bits=weight_bits)
    na = a1.shape[0]
    scale = wp.array(np.asarray(table.meta["coef_scale"], dtype=np.float32), dtype=wp.vec3, device=device)
    consts = [*_scalar_consts(table.axes[2]), 1.0 / float(table.meta["lmax"]), 1.0 - 1.0 / na, 0.5 / na, deg]

    def run(frags, tris):
        out = wp.zeros(frags.count, dtype=wp.vec4, device=device)
        wp.launch(kpt.k_frag_guthe, dim=frags.count,
                  inputs=[frags.attrs, PERSPECTIVE_MODES[mode], int(ortho), float(z_off), atlas.struct, alpha.struct,
                          *consts,
                          scale, out], device=device)
        return out

    return guthe_lookups(run, atlas, consts, mode=mode, ortho=ortho, z_off=z_off, device=device)


def guthe_lookups(run: Callable, atlas, consts: list, *, mode: str, ortho: bool, z_off: float, device: str) -> Callable:
    """``run`` (a Guthe et al. fragment program over ``atlas``'s coefficient tiles, ``consts`` as
    :func:`guthe_program` builds them) with ``coords``: the (sf, sb) texture coordinates each fragment
    reads every tile at (texture-cache analysis; the tiles hold signed 8-bit RGBA on the cards, 4 bytes per
    texel, whatever the emulation stores)."""

    def coords(frags, tris):
        out = wp.zeros(frags.count, dtype=wp.vec3, device=device)
        wp.launch(kpt.k_table3d_coords, dim=frags.count,
                  inputs=[frags.attrs, PERSPECTIVE_MODES[mode], int(ortho), float(z_off), *consts[:5], 1.0, 0.0, 0,
                          out], device=device)
        return out

    run.coords, run.texture, run.all_tiles, run.texel_bytes = coords, atlas, True, 4
    return run




def exact_program(tf, *, mode: str = "off", ortho: bool = False, device: str = "cpu", z_off: float = 0.0,
                  camera=None, tile: int = 0, lanes: int = 0) -> Callable:
    """Fragment program without a table: each fragment's segment integrated exactly (fp32). ``z_off``:
    the eye-space depth offset of the perspective attributes (:attr:`PTGeometry.eye_offset`).
    ``camera``: for the fused draw (``draw(walk="fused")``), whose exact thickness takes each pixel's
    :func:`~warpvol.projection.pt.ray_length_factors` (needed with ``mode="exact"`` in perspective); ``tile``: its bin size
    (:func:`~warpvol.projection.pt.fused_tile`; 0: by device); ``lanes``: its fragments per SIMD span
    (:func:`~warpvol.projection.pt.fused_lanes`; 1: one fragment at a time; 0: by device)."""

    tf_s, tf_v = tf.to_warp(device)
    flags = [PERSPECTIVE_MODES[mode], int(ortho), float(z_off)]

    def run(frags, tris):
        out = wp.zeros(frags.count, dtype=wp.vec4, device=device)
        wp.launch(kpt.k_frag_exact, dim=frags.count, inputs=[frags.attrs, *flags, tf_s, tf_v, model_id(tf), out],
                  device=device)
        return out

    run.fused = {"mode": flags[0], "ortho": flags[1], "camera": camera, "tf_s": tf_s, "tf_v": tf_v,
                 "model": model_id(tf), "tile": int(tile), "lanes": int(lanes), "zero": zero_interval(tf)}
    return run


def zero_interval(tf) -> tuple[float, float]:
    """``(lo, hi)``: the control points the device sees (:meth:`TransferFunction.to_warp`) add nothing at
    every scalar ``<= lo`` and every scalar ``>= hi`` (no extinction; with ``emission_density`` no colour
    either), so a segment whose two ends lie there integrates to exact zeros; ``-NO_ZERO`` / ``NO_ZERO``
    where no such run of control points begins or ends the function (``(NO_ZERO, -NO_ZERO)``: zero
    everywhere). The values are the device's float32 control scalars.

    >>> from warpvol.scene.transfer import TransferFunction
    >>> zero_interval(TransferFunction([[0, 1, 1, 1, 0], [0.25, 1, 1, 1, 0], [0.5, 1, 1, 1, 2], [1, 1, 1, 1, 0]]))
    (0.25, 1.0)
    """

    p = device_points(tf.points)
    v = p[:, 1:5].astype(np.float32)
    zero = (v[:, 3] == 0) if tf.emission == "color_extinction" else (v == 0).all(axis=1)
    s = p[:, 0].astype(np.float32)
    if zero.all():
        return NO_ZERO, -NO_ZERO
    first, last = int(np.argmin(zero)), len(zero) - 1 - int(np.argmin(zero[::-1]))  # first / last contributing
    return (float(s[first - 1]) if first > 0 else -NO_ZERO), (float(s[last + 1]) if last < len(s) - 1 else NO_ZERO)


def table3d_program(table, texel_format: str = "auto", filter: str = "linear", weight_bits: int | None = 8,
                    device: str = "cpu", *, mode: str = "off", ortho: bool = False,
                    z_off: float = 0.0) -> tuple[Callable, str]:
    """Fragment program looking up ``table`` (layout ``data[l, sb, sf]``, any 3D table builder) through
    an emulated 3D texture of ``texel_format`` (``auto``: the format that holds the table's stored
    values: fp32 -> rgba32f, fp16 -> rgba16f, rgba8 -> rgba8, hilo16 -> rgba16); the texture is uploaded
    once per table and format and kept in ``table.extra``. ``mode``: the
    fragments' attributes (:data:`PERSPECTIVE_MODES`; not ``off``: :func:`perspective_attrs`).
    Returns the program and the texel format used."""

    if table.data.ndim != 4 or table.data.shape[-1] != 4 or len(table.axes) != 3:
        raise ConfigError(f"table: expected a 3D RGBA table data[l, sb, sf, 4], got {table!r}")
    ax_l, ax_b, ax_f = table.axes
    if (ax_b.kind, ax_b.n, ax_b.scale, ax_b.offset) != (ax_f.kind, ax_f.n, ax_f.scale, ax_f.offset):
        raise ConfigError(f"table: the sf and sb axes differ ({ax_f.describe()} vs {ax_b.describe()})")
    if texel_format == "auto":
        if table.format not in TEXEL_FOR_TABLE:
            raise ConfigError(f"table: no 3D texel format holds a {table.format!r} table; give texel_format")
        texel_format = TEXEL_FOR_TABLE[table.format]
    # the texture stays resident between frames (kept on the table): a redraw uploads nothing
    key = ("texture3d", str(device), texel_format, filter, weight_bits)
    tex = table.extra.get(key)
    if tex is None:
        tex = table.extra[key] = Texture3D(table.data, fmt=texel_format, filter=filter, device=device,
                                           weight_bits=weight_bits)
    la, lb, llog = _axis_affine(ax_l)
    consts = [*_scalar_consts(ax_f), 1.0 / float(ax_l.scale), la, lb, llog]
    flags = [PERSPECTIVE_MODES[mode], int(ortho), float(z_off)]

    def run(frags, tris):
        out = wp.zeros(frags.count, dtype=wp.vec4, device=device)
        wp.launch(kpt.k_frag_table3d, dim=frags.count, inputs=[frags.attrs, *flags, tex.struct, *consts, out],
                  device=device)
        return out

    def coords(frags, tris):  # the (u, v, r) each fragment fetches (texture-cache analysis)
        out = wp.zeros(frags.count, dtype=wp.vec3, device=device)
        wp.launch(kpt.k_table3d_coords, dim=frags.count, inputs=[frags.attrs, *flags, *consts, out], device=device)
        return out

    run.coords, run.texture = coords, tex
    return run, texel_format


def cylindrical_program(planes, tf, geo: PTGeometry, weight_bits: int | None = 8,
                        device: str = "cpu", plane_weight: str = "unorm8",
                        path: str = "multitexture") -> tuple[np.ndarray, Callable]:
    """Per-vertex ``(α, s, t)`` attributes of ``geo`` and the plane fragment program for the
    cylindrical ``planes`` (:func:`warpvol.tables.cylindrical.build_cylindrical`, built for ``tf``):
    ``path = "multitexture"``, the two nearest planes (bilinear) blended with a ``plane_weight``
    weight (``unorm8``: the combiner's 8-bit colour; ``fp32``); ``"sgi"``, one texture, the nearest
    plane with nearest-texel filtering."""

    if getattr(planes, "name", None) != "cylindrical":
        raise ConfigError(f"planes: expected cylindrical planes (stage table_cylindrical), got {planes!r}")
    lo, hi = tf.srange
    lmax = float(planes.meta["lmax"])
    n = geo.attrs.shape[0]
    vattrs = wp.zeros((n, 3), dtype=wp.float32, device=device)
    wp.launch(kpt.k_cyl_vertices, dim=n, inputs=[wp.array(geo.attrs, dtype=wp.vec3, device=device), float(lo),
                                                 1.0 / (hi - lo), 1.0 / lmax, vattrs], device=device)
    if plane_weight not in PLANE_WEIGHTS or path not in PLANE_PATHS:
        raise ConfigError(f"plane_weight / path: expected one of {tuple(PLANE_WEIGHTS)} / {PLANE_PATHS}, got "
                          f"{plane_weight!r} / {path!r}")
    sgi = int(path == "sgi")
    tex = plane_texture(planes, device, weight_bits, "nearest" if sgi else "linear")
    sa, sb = linear_index_map(planes.axes[2])
    ta, tb = linear_index_map(planes.axes[1])
    ns, nt = planes.axes[2].n, planes.axes[1].n
    # continuous texel index a x + b  ->  in-tile texture coordinate (a x + b + 0.5) / n
    consts = [sa / ns, (sb + 0.5) / ns, ta / nt, (tb + 0.5) / nt]

    def run(frags, tris):
        out = wp.zeros(frags.count, dtype=wp.vec4, device=device)
        wp.launch(kpt.k_frag_cylindrical, dim=frags.count,
                  inputs=[frags.attrs, frags.prim, tris, vattrs, tex.struct, *consts, PLANE_WEIGHTS[plane_weight], sgi,
                          out], device=device)
        return out

    def coords(frags, tris):  # the (alpha, u, v) each fragment samples (texture-cache analysis)
        out = wp.zeros(frags.count, dtype=wp.vec3, device=device)
        wp.launch(kpt.k_cylindrical_coords, dim=frags.count, inputs=[frags.attrs, frags.prim, tris, vattrs, *consts, out],
                  device=device)
        return out

    run.coords, run.texture, run.nearest = coords, tex, bool(sgi)
    return vattrs.numpy(), run
