"""Vertex stage of the emulated GPU: model-view / projection transform, perspective division, viewport.

``k_transform`` maps object-space points ``p`` to

* eye space ``e = MV [p, 1]`` (kept: projected tetrahedra need eye-space z),
* clip space ``c = P e``,
* window coordinates ``(x, y, z, w) = (V (c / c.w)).xyz, c.w`` with the viewport matrix V
  (x right, y *down* = row index, z in [0, 1]); the clip w is kept for perspective-correct
  interpolation. Vertices with ``c.w <= 0`` (at or behind the eye) get window (0, 0, 0, c.w); the
  rasteriser discards triangles that use them (no geometric clipping).
"""

import warp as wp

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.func
def to_window(c: wp.vec4, vp: wp.mat44) -> wp.vec4:
    if not (c[3] > 0.0):
        return wp.vec4(0.0, 0.0, 0.0, c[3])
    inv = 1.0 / c[3]
    ndc = wp.vec4(c[0] * inv, c[1] * inv, c[2] * inv, 1.0)
    win = vp * ndc
    return wp.vec4(win[0], win[1], win[2], c[3])


@wp.kernel
def k_transform(points: wp.array(dtype=wp.vec3), modelview: wp.mat44, proj: wp.mat44, viewport: wp.mat44,
                eye: wp.array(dtype=wp.vec4), clip: wp.array(dtype=wp.vec4), window: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    p = points[i]
    e = modelview * wp.vec4(p[0], p[1], p[2], 1.0)
    c = proj * e
    eye[i] = e
    clip[i] = c
    window[i] = to_window(c, viewport)
