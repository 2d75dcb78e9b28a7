"""View-independent cell projection (Weiler, Kraus, Merz & Ertl 2003), as Espinha & Celes 2005 ran it
on the GeForce 6800 GT (fp40 fragment program, fp32 arithmetic).

Each tetrahedron is drawn as its four faces with back-face culling, in visibility order; the
rasteriser interpolates the object-space position perspective-correctly, so a fragment's position
is the view ray's entry point into the cell on the rasterised front face. The fragment program
(:func:`k_vicp_fragments`) takes the view ray through that point, intersects it with the planes of
the cell's other faces (``lambda_i = -(p . n_i + o_i) / (d . n_i)`` over the faces with
``d . n_i > 0``), takes the smallest as the exit, evaluates the scalar at entry and exit from the
cell's gradient (``s(x) = g . x + g0``), and looks the pre-integrated ``(C, alpha)`` of
``(sf, sb, l)`` up in the 3D table through the texture unit. Nothing is interpolated in screen
space but the entry point, so the segment is that of the pixel's ray (no perspective error).

:func:`k_vicp_cells` is the per-mesh set-up in fp32 (the application's float arithmetic): four face
planes with outward unit normals (face ``i`` opposite vertex ``i``) and the scalar gradient.

:data:`FP_INSTRUCTIONS` is the fragment program's length in fp40 instructions (an estimate from the
program below written as Cg would compile it; counted per fragment as ``combiner_ops``):

=============================================  ==
d = p - e; normalise (ADD, DP3, RSQ, MUL)       4
d . n_i for the 3 other faces (DP3)              3
p . n_i + o_i (DP4)                              3
reciprocals of d . n_i (RCP, scalar)             3
lambda_i = -num * rcp (MUL, vector)              1
d . n_i > 0 mask (CMP), min of 3 (MIN x 2)       3
l = max(lambda, 0) (MAX)                         1
sf = g . p + g0 (DP4); sb = sf + l (g . d)       3
table coordinates (MAD, vector)                  1
3D texture fetch (TEX)                           1
output (MOV)                                     1
=============================================  ==
"""

import warp as wp

from .harc import grad_scalar
from .pt import axis_coord
from .texture import Tex3D, tex3d

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

#: fp40 instructions per fragment of :func:`k_vicp_fragments` (module docstring)
FP_INSTRUCTIONS = 24

#: the local vertices of face ``i`` (opposite vertex ``i``), counter-clockwise seen from outside for a
#: positively oriented tet (``det(p1 - p0, p2 - p0, p3 - p0) > 0``); swap two for a negative one
FACES = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))


@wp.func
def face_plane(a: wp.vec3, b: wp.vec3, c: wp.vec3, opposite: wp.vec3) -> wp.vec4:
    """Plane ``(n, o)`` of triangle ``abc`` with ``n`` the unit normal pointing away from ``opposite``
    (``n . x + o = 0`` on the face); the zero vector for a degenerate face."""
    n = wp.cross(b - a, c - a)
    ln = wp.length(n)
    if ln == 0.0:
        return wp.vec4(0.0, 0.0, 0.0, 0.0)
    n = n / ln
    if wp.dot(n, opposite - a) > 0.0:
        n = -n
    return wp.vec4(n[0], n[1], n[2], -wp.dot(n, a))


@wp.kernel
def k_vicp_cells(points: wp.array(dtype=wp.vec3), scalars: wp.array(dtype=wp.float32),
                 tets: wp.array(dtype=wp.vec4i), planes: wp.array2d(dtype=wp.vec4), grads: wp.array(dtype=wp.vec4),
                 degenerate: wp.array(dtype=wp.int32)):
    """Per tet (fp32): ``planes[c, i]`` of the face opposite local vertex ``i`` and ``grads[c] = (g, g0)``;
    ``degenerate[c] = 1`` where the tet has no volume in fp32 (gradient 0, mean scalar)."""
    c = wp.tid()
    t = tets[c]
    p0 = points[t[0]]
    p1 = points[t[1]]
    p2 = points[t[2]]
    p3 = points[t[3]]
    planes[c, 0] = face_plane(p1, p2, p3, p0)
    planes[c, 1] = face_plane(p0, p3, p2, p1)
    planes[c, 2] = face_plane(p0, p1, p3, p2)
    planes[c, 3] = face_plane(p0, p2, p1, p3)
    s0 = scalars[t[0]]
    e1 = p1 - p0
    e2 = p2 - p0
    e3 = p3 - p0
    c23 = wp.cross(e2, e3)
    det = wp.dot(e1, c23)
    if det == 0.0:
        degenerate[c] = 1
        sm = 0.25 * (s0 + scalars[t[1]] + scalars[t[2]] + scalars[t[3]])
        grads[c] = wp.vec4(0.0, 0.0, 0.0, sm)
        return
    degenerate[c] = 0
    g = ((scalars[t[1]] - s0) * c23 + (scalars[t[2]] - s0) * wp.cross(e3, e1)
         + (scalars[t[3]] - s0) * wp.cross(e1, e2)) / det
    grads[c] = wp.vec4(g[0], g[1], g[2], s0 - wp.dot(g, p0))


@wp.kernel
def k_vicp_fragments(attrs: wp.array2d(dtype=wp.float32), prim: wp.array(dtype=wp.int32),
                     order: wp.array(dtype=wp.int32), k0: int, planes: wp.array2d(dtype=wp.vec4),
                     grads: wp.array(dtype=wp.vec4), ortho: int, eye: wp.vec3, view_dir: wp.vec3, tex: Tex3D,
                     s_off: float, s_inv: float, s_a: float, s_b: float, l_inv: float, l_a: float, l_b: float,
                     l_log2: int, out: wp.array(dtype=wp.vec4), unresolved: wp.array(dtype=wp.int32)):
    """The VICP fragment program for fragment ``f`` of triangle ``prim[f]`` (face ``prim % 4`` of the
    tet ``order[k0 + prim // 4]``): entry point ``p`` (the interpolated object-space position), ray
    direction from the eye (``view_dir`` for an orthographic view), exit on the nearest other face
    plane the ray leaves through, ``(sf, sb, l)`` normalised onto the table's axes, 3D table lookup.
    A fragment whose ray leaves through no other face (fp32, a ray grazing an edge) gets ``l = 0``
    and is counted in ``unresolved[0]``."""
    f = wp.tid()
    tri = prim[f]
    c = order[k0 + tri / 4]
    entry_face = tri - 4 * (tri / 4)
    p = wp.vec3(attrs[f, 0], attrs[f, 1], attrs[f, 2])
    d = view_dir
    if ortho == 0:
        d = wp.normalize(p - eye)
    best = float(1.0e30)
    found = int(0)
    for i in range(4):
        if i != entry_face:
            pl = planes[c, i]
            n = wp.vec3(pl[0], pl[1], pl[2])
            dn = wp.dot(d, n)
            if dn > 0.0:
                lam = -(wp.dot(p, n) + pl[3]) / dn
                found = 1
                if lam < best:
                    best = lam
    lam = float(0.0)
    if found == 1:
        lam = wp.max(best, 0.0)
    else:
        wp.atomic_add(unresolved, 0, 1)
    g = grads[c]
    sf = grad_scalar(g, p)
    sb = sf + lam * wp.dot(wp.vec3(g[0], g[1], g[2]), d)
    u = axis_coord((sf - s_off) * s_inv, s_a, s_b, 0)
    v = axis_coord((sb - s_off) * s_inv, s_a, s_b, 0)
    r = axis_coord(lam * l_inv, l_a, l_b, l_log2)
    out[f] = tex3d(tex, u, v, r)
