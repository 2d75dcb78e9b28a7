"""Texture units: 1D/2D/3D textures, nearest and (bi/tri)linear filtering, atlas tiles.

Texels are stored as ``vec4`` float32 holding the *decoded values of the texel format* (the host
side, :mod:`warpvol.gpu.texture`, quantises them at upload and expands the format's channels to
RGBA, e.g. LA8 -> (L, L, L, A), HILO16 -> (HI, LO, 1, 1)).

Conventions (OpenGL): normalised coordinate ``u`` in [0, 1]; texel ``k`` has its centre at
``(k + 0.5) / n``. Nearest: ``k = floor(u n)``. Linear: ``t = u n - 0.5``, ``k0 = floor(t)``,
``f = t - k0``, result ``(1 - f) T[k0] + f T[k0 + 1]``. Wrap mode is clamp-to-edge: texel indices
are clamped to ``[0, n - 1]``. (Coordinates are clamped to ``[-1, n + 1]`` texels first, which
changes no result, so float->int casts stay in range; NaN coordinates read texel 0.)

Filter weights: with ``frac_scale = 2^b > 0`` the fraction is truncated to ``b`` bits,
``f = floor(f 2^b) / 2^b``, as the fixed-point texture address units of NV2x-NV4x did (8 bits of
sub-texel precision); ``frac_scale = 0`` keeps the fp32 fraction. The weighted sum is evaluated in
fp32 and not re-quantised.

A texture reaches a kernel as a :class:`Tex1D` / :class:`Tex2D` / :class:`Tex3D` struct (``.struct``
of the host objects); call :func:`tex1d`, :func:`tex2d`, :func:`tex3d` (normalised coordinates) or
the ``*_texel`` variants (coordinates in texel units, ``u n``) from any kernel. Dependent lookups are
plain nesting: ``tex1d(b, tex2d(a, u, v)[3])``.
"""

import warp as wp

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

FILTER_NEAREST = wp.constant(0)
FILTER_LINEAR = wp.constant(1)


@wp.struct
class Tex1D:
    data: wp.array(dtype=wp.vec4)
    width: int
    filter: int
    frac_scale: float


@wp.struct
class Tex2D:
    data: wp.array2d(dtype=wp.vec4)  # [row = v index, column = u index]
    width: int
    height: int
    filter: int
    frac_scale: float


@wp.struct
class Tex3D:
    data: wp.array3d(dtype=wp.vec4)  # [r index, v index, u index]
    width: int
    height: int
    depth: int
    filter: int
    frac_scale: float


@wp.struct
class Atlas:
    """2D tiles of ``tile_w x tile_h`` texels packed with a 1-texel replicated border each."""

    tex: Tex2D
    cols: int
    tile_w: int
    tile_h: int
    ntiles: int


@wp.func
def _safe(t: float, n: int) -> float:
    if wp.isnan(t):
        return 0.0
    return wp.clamp(t, -1.0, float(n) + 1.0)


@wp.func
def axis_nearest(x: float, n: int) -> int:
    """Texel index for texel-space coordinate ``x = u n`` (nearest, clamp-to-edge)."""
    return wp.clamp(int(wp.floor(_safe(x, n))), 0, n - 1)


@wp.func
def axis_linear(x: float, n: int, frac_scale: float):
    """``(k0, k1, f)`` for texel-space coordinate ``x = u n`` (linear, clamp-to-edge)."""
    t = _safe(x, n) - 0.5
    k = wp.floor(t)
    f = t - k
    if frac_scale > 0.0:
        f = wp.floor(f * frac_scale) / frac_scale
    k0 = int(k)
    return wp.clamp(k0, 0, n - 1), wp.clamp(k0 + 1, 0, n - 1), f


@wp.func
def lerp4(a: wp.vec4, b: wp.vec4, f: float) -> wp.vec4:
    return (1.0 - f) * a + f * b


@wp.func
def tex1d_texel(t: Tex1D, x: float) -> wp.vec4:
    if t.filter == 0:
        return t.data[axis_nearest(x, t.width)]
    i0, i1, f = axis_linear(x, t.width, t.frac_scale)
    return lerp4(t.data[i0], t.data[i1], f)


@wp.func
def tex1d(t: Tex1D, u: float) -> wp.vec4:
    """Sample a 1D texture at normalised coordinate ``u``."""
    return tex1d_texel(t, u * float(t.width))


@wp.func
def tex2d_texel(t: Tex2D, x: float, y: float) -> wp.vec4:
    if t.filter == 0:
        return t.data[axis_nearest(y, t.height), axis_nearest(x, t.width)]
    i0, i1, fx = axis_linear(x, t.width, t.frac_scale)
    j0, j1, fy = axis_linear(y, t.height, t.frac_scale)
    a = lerp4(t.data[j0, i0], t.data[j0, i1], fx)
    b = lerp4(t.data[j1, i0], t.data[j1, i1], fx)
    return lerp4(a, b, fy)


@wp.func
def tex2d(t: Tex2D, u: float, v: float) -> wp.vec4:
    """Sample a 2D texture at normalised ``(u, v)`` (``v`` indexes rows)."""
    return tex2d_texel(t, u * float(t.width), v * float(t.height))


@wp.func
def tex3d_texel(t: Tex3D, x: float, y: float, z: float) -> wp.vec4:
    if t.filter == 0:
        return t.data[axis_nearest(z, t.depth), axis_nearest(y, t.height), axis_nearest(x, t.width)]
    i0, i1, fx = axis_linear(x, t.width, t.frac_scale)
    j0, j1, fy = axis_linear(y, t.height, t.frac_scale)
    k0, k1, fz = axis_linear(z, t.depth, t.frac_scale)
    a0 = lerp4(t.data[k0, j0, i0], t.data[k0, j0, i1], fx)
    b0 = lerp4(t.data[k0, j1, i0], t.data[k0, j1, i1], fx)
    a1 = lerp4(t.data[k1, j0, i0], t.data[k1, j0, i1], fx)
    b1 = lerp4(t.data[k1, j1, i0], t.data[k1, j1, i1], fx)
    return lerp4(lerp4(a0, b0, fy), lerp4(a1, b1, fy), fz)


@wp.func
def tex3d(t: Tex3D, u: float, v: float, r: float) -> wp.vec4:
    """Sample a 3D texture at normalised ``(u, v, r)``."""
    return tex3d_texel(t, u * float(t.width), v * float(t.height), r * float(t.depth))


@wp.func
def atlas_sample(a: Atlas, tile: int, u: float, v: float) -> wp.vec4:
    """Sample tile ``tile`` of an atlas at normalised in-tile ``(u, v)`` (clamp-to-edge inside the tile).

    The tile's replicated border makes the atlas's plain bilinear filter behave exactly like a
    separate clamp-to-edge texture; ``u, v`` are clamped to [0, 1] first.
    """
    k = wp.clamp(tile, 0, a.ntiles - 1)
    col = k % a.cols
    row = k / a.cols
    uc = wp.clamp(u, 0.0, 1.0)
    vc = wp.clamp(v, 0.0, 1.0)
    if wp.isnan(u):
        uc = 0.0
    if wp.isnan(v):
        vc = 0.0
    x = float(col * (a.tile_w + 2) + 1) + uc * float(a.tile_w)
    y = float(row * (a.tile_h + 2) + 1) + vc * float(a.tile_h)
    return tex2d_texel(a.tex, x, y)


# ------------------------------------------------------------------------------------------------
# array kernels: evaluate lookups for many coordinates (host-side .sample(), tests)
# ------------------------------------------------------------------------------------------------


@wp.kernel
def k_sample1d(t: Tex1D, uv: wp.array(dtype=wp.float32), out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    out[i] = tex1d(t, uv[i])


@wp.kernel
def k_sample2d(t: Tex2D, uv: wp.array(dtype=wp.vec2), out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    out[i] = tex2d(t, uv[i][0], uv[i][1])


@wp.kernel
def k_sample3d(t: Tex3D, uv: wp.array(dtype=wp.vec3), out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    out[i] = tex3d(t, uv[i][0], uv[i][1], uv[i][2])


@wp.kernel
def k_sample_atlas(a: Atlas, tiles: wp.array(dtype=wp.int32), uv: wp.array(dtype=wp.vec2),
                   out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    out[i] = atlas_sample(a, tiles[i], uv[i][0], uv[i][1])


@wp.kernel
def k_dependent_2d_1d(a: Tex2D, b: Tex1D, channel: int, uv: wp.array(dtype=wp.vec2),
                      out: wp.array(dtype=wp.vec4)):
    """Dependent lookup: ``b`` sampled at channel ``channel`` of ``a(u, v)``."""
    i = wp.tid()
    s = tex2d(a, uv[i][0], uv[i][1])
    out[i] = tex1d(b, s[channel])


@wp.kernel
def k_dependent_1d_1d(a: Tex1D, b: Tex1D, channel: int, uv: wp.array(dtype=wp.float32),
                      out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    s = tex1d(a, uv[i])
    out[i] = tex1d(b, s[channel])
