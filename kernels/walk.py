"""The consistent float32 cell walk shared by the ray casters (through :mod:`warpvol.kernels.cellwalk`, which
``raycast``'s :func:`~warpvol.kernels.raycast.march_kernel` and HARC's :func:`~warpvol.kernels.harc.march_kernel`
call): ray set-up, Plücker edge tests, face crossings, one step through a tet, and the thin-layer check of
integrated segments (``@wp.func`` only).

* :func:`ray_setup` -- the pixel's ray in **float64**: unit direction, origin moved along the ray to
  just before the mesh's bounding sphere (so float32 rounding of points on the ray scales with the
  mesh, not with the eye distance), the clip parameter ``t_clip`` where the true ray starts (> 0
  when the eye / orthographic eye plane lies inside the sphere: the walk starts before it and
  segments are clipped at ``t_clip``), and whether the ray meets the sphere at all beyond its start.
* :class:`Ray` / :func:`make_ray` / :func:`pixel_ray` -- the float32 ray and its tie-breaking perturbation.
* :func:`edge_side` -- Plücker side of the ray against a mesh edge, ``(b - a) . (d x (a - o))`` with
  ``a, b`` in ascending global vertex order (rounding error ~ the edge's length, not its distance),
  so every cell sharing the edge gets the *same* float32 value; exact zeros are replaced by the sign of
  the reference's ray perturbation (scaled by :data:`TIE`), also a property of the edge alone.
* :func:`oriented_side` -- that value for the directed edge ``i -> j`` (negated when ``i > j``).
* :func:`face_cross` -- ray through a triangle given its three directed edge values: whether it
  crosses (all values >= 0, sum > 0), and the crossing's ``t`` and scalar from the barycentric
  weights (convex combinations of the vertices' ``(p - o) . d`` and scalars: bounded, and the same
  from both cells sharing the face).
* :class:`Face`, :func:`make_face`, :func:`boundary_face` -- a face the ray crosses, with its
  vertices' frames and its three edge values, oriented outward for the cell the ray leaves.
* :func:`next_face` -- one step: the ray entered a tet through a :class:`Face`; only the three
  edges from the tet's new vertex are evaluated (the entry face's values are reused), and the exit
  is the first other face whose three outward-ordered edge values are all >= 0. A shared face is
  decided by the same three numbers from both sides, so the walk is watertight (no skipped cells, no
  double counting); the scalar on a face depends only on the face's vertices, so no cell's
  (possibly huge) gradient leaks into its neighbour.
* :func:`monotone_exit` -- a step that does not advance in ``t`` is clamped and counted; past
  :data:`STALL_STEPS` such steps the walker gives the ray up (redone in float64).
* :func:`thin_step`, :class:`ThinPrev` -- a segment too short for float32 to know its length beside a
  density contrast that makes the difference visible (a thin layer carrying the image,
  :func:`thin_unresolved`): the walker gives the ray up (redone in float64), never a silently wrong pixel.
* :func:`scalar_error`, :func:`scalar_step` -- a crossing's scalar is known only as well as float32 knows
  the point (about ``EPS32`` times its distance from the ray origin: a sizeable fraction of a small cell
  far from it); a transfer function steep on that scale (a narrow peak) makes the pixel uncertain. The
  walk sums a bound on that error over its segments; past :data:`STEEP_ERR` the ray is redone in float64.
  :func:`scalar_error_if` leaves the bound out (0) where the host has shown it cannot pass
  :data:`STEEP_ERR` for the transfer function and mesh (:func:`density_slope`, and
  :func:`warpvol.raycasting.stages.cell_setup.scalar_check_needed`: an opaque, constant-extinction TF).
"""

import warp as wp

wp.set_module_options({"enable_backward": False, "fuse_fp": False})

#: scale of the perturbation term that breaks exact zeros of :func:`edge_side`
TIE = wp.constant(1.0e-30)
#: consecutive steps without progress in ``t`` after which a ray counts as unresolved
STALL_STEPS = wp.constant(4096)
NO_FACE = wp.constant(-1)
#: float32 resolution of the ray parameter: a face crossing's ``t`` is trusted to about
#: ``T_ULPS * EPS32 * (|t| + radius)`` (points relative to the mesh centre, origin moved to the mesh)
EPS32 = wp.constant(1.1920929e-07)
T_ULPS = wp.constant(4.0)
#: a segment shorter than ``THIN_ULPS`` such units has a length float32 cannot be trusted with
THIN_ULPS = wp.constant(1024.0)
#: estimated pixel error (transmittance x density contrast x crossing uncertainty) above which a ray
#: with such a segment is unresolved (redone in float64)
THIN_ERR = wp.constant(2.0e-5)
#: a boundary crossing whose estimated ``t`` error exceeds this many float32 units of ``t`` is grazing (a face
#: seen nearly edge-on); oblique faces stay below it
GRAZE_ULPS = wp.constant(32.0)
#: bound on a walk's pixel error from its crossings' scalar errors (:func:`scalar_step`) above which the ray
#: is unresolved (redone in float64)
STEEP_ERR = wp.constant(1.0e-4)


@wp.func
def ndc_xy(px: int, py: int, width: int, height: int) -> wp.vec2d:
    """NDC coordinates (float64) of the centre of pixel (row py, column px), Contract 2."""
    return wp.vec2d(wp.float64(2.0) * (wp.float64(px) + wp.float64(0.5)) / wp.float64(width) - wp.float64(1.0),
                    wp.float64(1.0) - wp.float64(2.0) * (wp.float64(py) + wp.float64(0.5)) / wp.float64(height))


@wp.func
def ray_setup(q: wp.vec2d, eye: wp.vec3d, fwd: wp.vec3d, right: wp.vec3d, up: wp.vec3d, ortho: int,
              half_h: wp.float64, aspect: wp.float64, radius: wp.float64):
    """Float64 ray set-up for NDC point ``q``; ``eye`` is relative to the mesh centre (the cells'
    origin), ``radius`` bounds the mesh around it.

    Returns ``(o, d, t0, t_clip, t_end)`` in float32: origin ``eye + t0 d`` relative to the mesh
    centre, placed ``radius`` before the ray's closest approach to it, unit direction, the shift
    ``t0``, the true start ``t_clip = max(0, -t0)`` and the end of the bounding-sphere chord
    ``t_end`` (``t_end < t_clip``: the ray cannot meet the mesh)."""
    sx = q[0] * half_h * aspect
    sy = q[1] * half_h
    o = eye
    d = fwd
    if ortho == 1:
        o = eye + right * sx + up * sy
    else:
        d = wp.normalize(fwd + right * sx + up * sy)
    tc = -wp.dot(o, d)  # closest approach to the centre
    t0 = tc - radius * wp.float64(1.001)
    o0 = o + d * t0
    t_clip = -t0
    if t_clip < wp.float64(0.0):
        t_clip = wp.float64(0.0)
    t_end = t_clip  # relative to o0: end of the chord beyond which nothing is hit
    miss = wp.length_sq(o + d * tc) > radius * radius
    if not miss:
        t_end = wp.float64(2.002) * radius
    if miss:
        t_end = wp.float64(-1.0)
    return wp.vec3(float(o0[0]), float(o0[1]), float(o0[2])), wp.vec3(float(d[0]), float(d[1]), float(d[2])), \
        float(t0), float(t_clip), float(t_end)


@wp.struct
class Ray:
    """A ray in the cells' frame: origin ``o`` near the mesh, unit direction ``d``; ``tie_x``,
    ``tie_y`` (camera right, up) and ``back = o - eye`` define the perturbation that breaks exact
    zeros of :func:`edge_side` (the reference's: orthographic origin ``+ eps right + eps^2 up``,
    perspective direction ``+ eps right + eps^2 up``)."""

    o: wp.vec3
    d: wp.vec3
    tie_x: wp.vec3
    tie_y: wp.vec3
    back: wp.vec3
    ortho: int


@wp.func
def make_ray(o: wp.vec3, d: wp.vec3, right: wp.vec3, up: wp.vec3, t0: float, ortho: int) -> Ray:
    r = Ray()
    r.o = o
    r.d = d
    r.tie_x = right
    r.tie_y = up
    r.back = d * t0
    r.ortho = ortho
    return r


@wp.func
def pixel_ray(px: int, py: int, width: int, height: int, eye: wp.vec3d, fwd: wp.vec3d, right: wp.vec3d,
              up: wp.vec3d, ortho: int, half_h: wp.float64, aspect: wp.float64, radius: wp.float64):
    """The :class:`Ray` through the centre of pixel (row py, column px) (:func:`ray_setup` of its NDC
    point, :func:`make_ray` with the camera's right and up as tie-breakers), with ``t_clip`` and
    ``t_end`` (``t_end < t_clip``: the ray misses the mesh's bounding sphere). Shared by the ray
    casters' march kernels (``raycast``, HARC)."""
    o, d, t0, t_clip, t_end = ray_setup(ndc_xy(px, py, width, height), eye, fwd, right, up, ortho, half_h,
                                        aspect, radius)
    r = make_ray(o, d, wp.vec3(float(right[0]), float(right[1]), float(right[2])),
                 wp.vec3(float(up[0]), float(up[1]), float(up[2])), t0, ortho)
    return r, t_clip, t_end


@wp.func
def vertex_frame(v: wp.vec4, r: Ray):
    """Vertex record ``(x, y, z, s)`` -> ``(p, h, m)``: position, ``h = q . d`` (its ray parameter's
    share: a crossing's ``t`` is the barycentric mean of its face's ``h``) and ``m = d x q``, with
    ``q = p - o``."""
    p = wp.vec3(v[0], v[1], v[2])
    q = p - r.o
    return p, wp.dot(q, r.d), wp.cross(r.d, q)


@wp.func
def edge_side(pa: wp.vec3, ma: wp.vec3, e: wp.vec3, r: Ray) -> float:
    """Plücker side of ray ``r`` and edge ``a -> b`` (``a`` the lower global vertex index), from
    ``pa``, ``ma = d x qa`` (``qa = pa - o``) and the edge vector ``e = b - a`` taken from the stored points:
    ``d . (qa x e) = e . ma``. Every cell sharing the edge computes the same float32 value, and its
    rounding error scales with ``|qa| |e|`` (the edge's length, not its distance from the origin).

    ``> 0``: the ray passes the edge counter-clockwise seen along ``d``. An exact zero becomes
    ``TIE`` times the first (then second) order term of the ray perturbation, also a property of the
    edge alone; it stays 0 only for an edge parallel to an orthographic ray (or on a line through a
    perspective eye)."""
    v = wp.dot(e, ma)
    if v == 0.0:
        if r.ortho == 1:
            v = TIE * wp.dot(r.tie_x, wp.cross(r.d, e))
            if v == 0.0:
                v = TIE * wp.dot(r.tie_y, wp.cross(r.d, e))
        else:
            ae = wp.cross(pa - r.o + r.back, e)
            v = TIE * wp.dot(r.tie_x, ae)
            if v == 0.0:
                v = TIE * wp.dot(r.tie_y, ae)
    return v


@wp.func
def oriented_side(gi: int, gj: int, pi: wp.vec3, mi: wp.vec3, pj: wp.vec3, mj: wp.vec3, r: Ray) -> float:
    """:func:`edge_side` of the directed edge ``i -> j`` (global indices ``gi``, ``gj``; points
    ``p``, ``m = d x (p - o)``)."""
    if gi < gj:
        return edge_side(pi, mi, pj - pi, r)
    return -edge_side(pj, mj, pi - pj, r)


@wp.func
def face_cross(ha: float, hb: float, hc: float, sa: float, sb: float, sc: float, wab: float, wbc: float,
               wca: float):
    """Crossing of the ray with triangle ``(a, b, c)`` given its vertices' ``h = (p - o) . d`` and its
    directed edge values ``wab``, ``wbc``, ``wca``: crossed when all are >= 0 with a positive sum.
    Returns ``(crossed, t, s)``: ray parameter and scalar at the crossing from the barycentric weights
    ``(wbc, wca, wab) / sum`` -- convex combinations of the vertices' ``h`` and scalars (the scalar
    taken relative to the face's smallest, so a constant face gives its value exactly), bounded, and
    the same from both cells sharing the face."""
    ssum = wab + wbc + wca
    if wab < 0.0 or wbc < 0.0 or wca < 0.0 or not (ssum > 0.0):
        return False, 0.0, 0.0
    inv = 1.0 / ssum
    # the scalar relative to the face's smallest: exact on a face of constant scalar, where a transfer
    # function steep at that value would turn the rounding of a plain barycentric sum into a visible error
    s0 = wp.min(sa, wp.min(sb, sc))
    s = s0 + ((sa - s0) * wbc + (sb - s0) * wca + (sc - s0) * wab) * inv
    return True, (ha * wbc + hb * wca + hc * wab) * inv, s


@wp.struct
class Face:
    """A face the ray crosses, as vertices ``A, B, C`` in the outward order of the cell the ray
    leaves: global indices ``g``, positions ``p*``, ``h = ((pA, pB, pC) - o) . d``, ``m* = d x (p* - o)``,
    scalars ``s`` and the directed edge values ``w = (A->B, B->C, C->A)`` (all >= 0: the ray crosses it)."""

    g: wp.vec3i
    pa: wp.vec3
    pb: wp.vec3
    pc: wp.vec3
    h: wp.vec3
    ma: wp.vec3
    mb: wp.vec3
    mc: wp.vec3
    s: wp.vec3
    w: wp.vec3


@wp.func
def boundary_face(tv: wp.vec4i, f: int, verts: wp.array(dtype=wp.vec4), r: Ray) -> Face:
    """Boundary face ``f`` of tet ``tv`` as the :class:`Face` through which the ray enters the tet
    (its outward order reversed: ``(a, c, b)``): :func:`face_hit` tells whether it does."""
    ia = 1
    ib = 2
    ic = 3
    if f == 1:
        ia = 0
        ib = 3
        ic = 2
    elif f == 2:
        ia = 0
        ib = 1
        ic = 3
    elif f == 3:
        ia = 0
        ib = 2
        ic = 1
    return make_face(tv[ia], tv[ic], tv[ib], verts, r)


@wp.func
def make_face(ga: int, gb: int, gc: int, verts: wp.array(dtype=wp.vec4), r: Ray) -> Face:
    """:class:`Face` ``(A, B, C)`` from its global vertex indices."""
    va = verts[ga]
    vb = verts[gb]
    vc = verts[gc]
    pa, ha, ma = vertex_frame(va, r)
    pb, hb, mb = vertex_frame(vb, r)
    pc, hc, mc = vertex_frame(vc, r)
    w = wp.vec3(oriented_side(ga, gb, pa, ma, pb, mb, r), oriented_side(gb, gc, pb, mb, pc, mc, r),
                oriented_side(gc, ga, pc, mc, pa, ma, r))
    return fan_face(wp.vec3i(ga, gb, gc), pa, ma, pb, mb, pc, mc, wp.vec3(ha, hb, hc), wp.vec3(va[3], vb[3], vc[3]),
                    w)


@wp.func
def monotone_exit(t_in: float, t_out: float, stall: int):
    """Keep a walk's exit parameter at or beyond its entry: ``(t_out, stall)``, where a step that does not
    advance (flat cell, rounding) is clamped to ``t_in`` and counted in ``stall`` (reset by a step that
    advances); the raycast and HARC walks give up past ``STALL_STEPS`` such steps in a row."""
    t = t_in
    st = stall + 1
    if t_out > t_in:  # (a NaN t_out does not advance either)
        t = t_out
        st = int(0)
    return t, st


@wp.func
def fan_face(g: wp.vec3i, pa: wp.vec3, ma: wp.vec3, pb: wp.vec3, mb: wp.vec3, pc: wp.vec3, mc: wp.vec3, h: wp.vec3,
             sv: wp.vec3, w: wp.vec3) -> Face:
    """:class:`Face` from already evaluated vertex frames, scalars and edge values."""
    fc = Face()
    fc.g = g
    fc.pa = pa
    fc.ma = ma
    fc.pb = pb
    fc.mb = mb
    fc.pc = pc
    fc.mc = mc
    fc.h = h
    fc.s = sv
    fc.w = w
    return fc


@wp.func
def face_hit(fc: Face):
    """:func:`face_cross` of a :class:`Face`: ``(crossed, t, s)``."""
    return face_cross(fc.h[0], fc.h[1], fc.h[2], fc.s[0], fc.s[1], fc.s[2], fc.w[0], fc.w[1], fc.w[2])


@wp.func
def next_face(tv: wp.vec4i, j: int, fc: Face, verts: wp.array(dtype=wp.vec4), r: Ray):
    """One step of the walk: the ray entered tet ``tv`` through ``fc`` (its local face ``j``).

    Only the three edges from the new vertex ``N = tv[j]`` are evaluated; the entry face's edge
    values are reused (they are the same numbers the neighbour computed). The exit is the first of
    ``(N, A, B)``, ``(N, B, C)``, ``(N, C, A)`` whose edge values are all >= 0. Returns
    ``(exit face, local index of the exit face in tv (-1: none qualifies), t, s)``."""
    return next_face_from(tv, tv[j], fc, verts, r)


@wp.func
def next_face_from(tv: wp.vec4i, gn: int, fc: Face, verts: wp.array(dtype=wp.vec4), r: Ray):
    """:func:`next_face` given the new vertex's global index ``gn = tv[j]`` (a walker that has it
    from the neighbour record loads its vertex without waiting for ``tv``)."""
    vn = verts[gn]
    pn, hn, mn = vertex_frame(vn, r)
    na = oriented_side(gn, fc.g[0], pn, mn, fc.pa, fc.ma, r)
    nb = oriented_side(gn, fc.g[1], pn, mn, fc.pb, fc.mb, r)
    nc = oriented_side(gn, fc.g[2], pn, mn, fc.pc, fc.mc, r)
    # candidates (N, A, B), (N, B, C), (N, C, A), each from the face record's vertices in place (no copies)
    ok, t, s = face_cross(hn, fc.h[0], fc.h[1], vn[3], fc.s[0], fc.s[1], na, fc.w[0], -nb)
    if ok:
        return fan_face(wp.vec3i(gn, fc.g[0], fc.g[1]), pn, mn, fc.pa, fc.ma, fc.pb, fc.mb, wp.vec3(hn, fc.h[0], fc.h[1]),
                        wp.vec3(vn[3], fc.s[0], fc.s[1]), wp.vec3(na, fc.w[0], -nb)), local_index(tv, fc.g[2]), t, s
    ok, t, s = face_cross(hn, fc.h[1], fc.h[2], vn[3], fc.s[1], fc.s[2], nb, fc.w[1], -nc)
    if ok:
        return fan_face(wp.vec3i(gn, fc.g[1], fc.g[2]), pn, mn, fc.pb, fc.mb, fc.pc, fc.mc, wp.vec3(hn, fc.h[1], fc.h[2]),
                        wp.vec3(vn[3], fc.s[1], fc.s[2]), wp.vec3(nb, fc.w[1], -nc)), local_index(tv, fc.g[0]), t, s
    ok, t, s = face_cross(hn, fc.h[2], fc.h[0], vn[3], fc.s[2], fc.s[0], nc, fc.w[2], -na)
    if ok:
        return fan_face(wp.vec3i(gn, fc.g[2], fc.g[0]), pn, mn, fc.pc, fc.mc, fc.pa, fc.ma, wp.vec3(hn, fc.h[2], fc.h[0]),
                        wp.vec3(vn[3], fc.s[2], fc.s[0]), wp.vec3(nc, fc.w[2], -na)), local_index(tv, fc.g[1]), t, s
    return Face(), int(-1), float(0.0), float(0.0)


@wp.func
def local_index(tv: wp.vec4i, g: int) -> int:
    """Local index (0..3) of global vertex ``g`` in tet ``tv`` (the face opposite it); -1: not a vertex."""
    local = int(-1)
    for k in range(4):
        if tv[k] == g:
            local = k
    return local


@wp.func
def density(v: wp.vec4, model: int) -> float:
    """What a segment's length error multiplies in TF value ``v``: the extinction, plus the largest
    colour channel for the emission-density model (radiance per unit length)."""
    if model == 1:
        return v[3] + wp.max(v[0], wp.max(v[1], v[2]))
    return v[3]


@wp.func
def density_max(v_a: wp.vec4, v_b: wp.vec4, k_a: int, k_b: int, tf_v: wp.array(dtype=wp.vec4),
                model: int) -> float:
    """Largest :func:`density` over a segment whose ends have TF values ``v_a``, ``v_b`` and
    :func:`~warpvol.kernels.tf.tf_upper` indices ``k_a``, ``k_b`` (the control points it crosses are
    those between)."""
    m = wp.max(density(v_a, model), density(v_b, model))
    for k in range(wp.min(k_a, k_b), wp.max(k_a, k_b)):
        m = wp.max(m, density(tf_v[k], model))
    return m


@wp.func
def t_unit(t: float, scale: float) -> float:
    """Float32 resolution of ray parameter ``t`` (origin moved to the mesh, ``scale`` its radius)."""
    return EPS32 * (wp.abs(t) + scale)


@wp.func
def weight_error(fc: Face, r: Ray) -> float:
    """Relative error of the float32 barycentric weights of the crossing of face ``fc``: each edge value
    ``w`` rounds by about ``EPS32 |e| |q|`` (edge length times the vertex's distance from the ray
    origin), over the sum of the ``w`` (the face's projected size); 1e30 where that sum is not positive.
    A few ``EPS32`` for a face the ray crosses head-on or obliquely, far more for one seen nearly edge-on."""
    qa = fc.pa - r.o
    qb = fc.pb - r.o
    qc = fc.pc - r.o
    werr = EPS32 * (wp.length(fc.pb - fc.pa) * wp.length(qa) + wp.length(fc.pc - fc.pb) * wp.length(qb)
                    + wp.length(fc.pa - fc.pc) * wp.length(qc))
    ssum = fc.w[0] + fc.w[1] + fc.w[2]
    if not (ssum > 0.0):
        return 1.0e30
    return werr / ssum


@wp.func
def spread_error(a: wp.vec3, rel: float) -> float:
    """A barycentric mean of ``a`` off by up to the spread of ``a`` times the weights' relative error
    ``rel`` (at most the spread)."""
    spread = wp.max(a[0], wp.max(a[1], a[2])) - wp.min(a[0], wp.min(a[1], a[2]))
    return wp.min(spread, spread * rel)


@wp.func
def crossing_error(fc: Face, r: Ray) -> float:
    """How far off in ``t`` the float32 crossing of face ``fc`` can be: ``t`` is the weighted mean of the
    vertices' ``h``, so it moves by the spread of ``h`` times :func:`weight_error`. A few :func:`t_unit`
    for a face the ray crosses head-on or obliquely; far more for a face seen nearly edge-on (``h``
    spread wide, the weights small), where a ray enters or leaves the mesh at a grazing angle."""
    return spread_error(fc.h, weight_error(fc, r))


@wp.func
def grazing_unresolved(tr: float, v: wp.vec4, model: int, fc: Face, r: Ray, t: float, scale: float) -> bool:
    """A ray entering or leaving the mesh (or the visible cells) at ``t`` through face ``fc``, where its
    TF value is ``v``: unresolved when the face is seen so nearly edge-on that its
    :func:`crossing_error` exceeds :data:`GRAZE_ULPS` :func:`t_unit` (the resolution every crossing is
    trusted to) and the transmittance there x :func:`density` x that error exceeds :data:`THIN_ERR`:
    the chord's float32 length is off by more than the image can take."""
    err = crossing_error(fc, r)
    return err > GRAZE_ULPS * t_unit(t, scale) and tr * density(v, model) * err > THIN_ERR


@wp.func
def scalar_error(fc: Face, r: Ray) -> float:
    """How far off the float32 scalar at the crossing of face ``fc`` can be: the spread of the face's
    scalars times :func:`weight_error` (float32 resolves a point on the ray only to about ``EPS32`` times
    its distance from the ray's origin, a large fraction of a small cell far from it)."""
    return spread_error(fc.s, weight_error(fc, r))


@wp.func
def scalar_error_if(check: int, fc: Face, r: Ray) -> float:
    """:func:`scalar_error` where ``check`` is 1; 0 where the walk's bound on the crossings' scalar errors is
    off (it provably cannot fire: :func:`warpvol.raycasting.stages.cell_setup.scalar_check_needed`), so that
    :func:`scalar_step` adds nothing. (A function rather than an ``if`` block in the walk loop: Warp turns
    every variable an ``if`` block with a ``break`` in a loop assigns, the walk's :class:`Face` among them,
    into a select after it.)"""
    if check == 0:
        return 0.0
    return scalar_error(fc, r)


@wp.func
def scalar_step(err: float, tr: float, ln: float, tau: float, s_in: float, s_out: float, v_in: wp.vec4,
                v_out: wp.vec4, k_in: int, k_out: int, ds_in: float, ds_out: float,
                tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int) -> float:
    """The walk's bound ``err`` on its pixel's error from its crossings' scalar errors, plus this
    segment's: the segment (length ``ln``, optical depth ``tau``, behind transmittance ``tr``) has its end
    scalars off by up to ``ds_in``, ``ds_out`` (:func:`scalar_error`); its integrated :func:`density`
    ``D`` moves by ``dD/ds_end`` times that. Within one linear transfer function piece (slope ``g``)
    ``dD/ds_end = ln g / 2``; across control points ``|ln density(v_end) - D| / |s_out - s_in|`` (a narrow
    peak inside the segment moves along it), at most ``ln`` times the steepest :func:`density_slope` of the
    pieces crossed (its exact value is; the cap keeps the float32 rounding of the difference, divided by a
    small ``|s_out - s_in|``, from counting as an error). Past :data:`STEEP_ERR` the ray is unresolved (redone
    in float64): a transfer function steep on the scale of float32's resolution of a point there. Nothing to
    add where both ends' scalars are exact (``ds_in = ds_out = 0``)."""
    if ds_in == 0.0 and ds_out == 0.0:
        return err
    if k_in == k_out:
        if k_in <= 0 or k_in >= tf_s.shape[0]:
            return err
        g = wp.abs(density(tf_v[k_in], model) - density(tf_v[k_in - 1], model)) / (tf_s[k_in] - tf_s[k_in - 1])
        return err + tr * ln * 0.5 * g * (ds_in + ds_out)
    dd = density(v_in, model) + density(v_out, model) - v_in[3] - v_out[3]
    big_d = tau + 0.5 * ln * dd
    cap = float(0.0)  # ln x the steepest density slope of the pieces crossed (pieces 1 .. K - 1; flat outside)
    for k in range(wp.max(wp.min(k_in, k_out), 1), wp.min(wp.max(k_in, k_out), tf_s.shape[0] - 1) + 1):
        cap = wp.max(cap, density_slope(k, tf_s, tf_v, model))
    cap = cap * ln
    ds = wp.abs(s_out - s_in)
    return err + tr * (wp.min(wp.abs(ln * density(v_in, model) - big_d) / ds, cap) * ds_in
                       + wp.min(wp.abs(ln * density(v_out, model) - big_d) / ds, cap) * ds_out)


@wp.func
def density_slope(k: int, tf_s: wp.array(dtype=float), tf_v: wp.array(dtype=wp.vec4), model: int) -> float:
    """A bound on the slope of :func:`density` in the scalar on transfer function piece ``k`` (control points
    ``k - 1`` to ``k``): the extinction's slope plus, for ``emission_density``, the steepest colour channel's
    (the largest channel can switch inside the piece). The host's per-TF maximum of it is
    :func:`warpvol.raycasting.stages.cell_setup.scalar_check_needed`'s ``G``."""
    a = tf_v[k - 1]
    b = tf_v[k]
    d = wp.abs(b[3] - a[3])
    if model == 1:
        d = d + wp.max(wp.abs(b[0] - a[0]), wp.max(wp.abs(b[1] - a[1]), wp.abs(b[2] - a[2])))
    return d / (tf_s[k] - tf_s[k - 1])


@wp.func
def thin_unresolved(tr: float, dmax: float, d_other: float, u: float) -> bool:
    """A segment shorter than ``THIN_ULPS * u`` (its float32 length untrustworthy) beside a segment of
    mean density ``d_other``: unresolved when the error its face crossings can make -- transmittance
    in front ``tr`` x density contrast x ``T_ULPS * u`` -- exceeds :data:`THIN_ERR` (a thin layer
    that carries the image)."""
    return tr * wp.abs(dmax - d_other) * (T_ULPS * u) > THIN_ERR


@wp.struct
class ThinPrev:
    """What the thin-layer check keeps of the previous integrated segment: its mean density ``d`` (0:
    outside the mesh), whether it was short (``is_short``) and then its largest density ``dmax``, the
    transmittance ``tr`` in front of it and its ray-parameter resolution ``u``."""

    d: float
    is_short: int
    dmax: float
    tr: float
    u: float


@wp.func
def thin_start() -> ThinPrev:
    """:class:`ThinPrev` at the ray's entry: nothing before it (density 0, full transmittance)."""
    p = ThinPrev()
    p.d = 0.0
    p.is_short = 0
    p.dmax = 0.0
    p.tr = 1.0
    p.u = 0.0
    return p


@wp.func
def thin_step(prev: ThinPrev, ln: float, tau: float, t_out: float, scale: float, tr: float, v_in: wp.vec4,
              v_out: wp.vec4, k_in: int, k_out: int, tf_v: wp.array(dtype=wp.vec4), model: int):
    """The thin-layer check of one integrated segment (length ``ln``, optical depth ``tau``, exit
    ``t_out``, transmittance ``tr`` in front of it), shared by the raycast and HARC walks: ``(thin,
    next)`` -- ``thin`` when this segment is shorter than float32 resolves and :func:`thin_unresolved`
    beside the previous segment's mean density, or when the previous segment was short and is unresolved
    beside this one's; ``next`` is what the check keeps of this segment."""
    u = t_unit(t_out, scale)
    d_mean = 0.5 * (density(v_in, model) + density(v_out, model))
    if k_in != k_out and ln > 0.0:
        d_mean = tau / ln + (d_mean - 0.5 * (v_in[3] + v_out[3]))
    nxt = ThinPrev()
    nxt.d = d_mean
    nxt.is_short = 0
    nxt.dmax = 0.0
    nxt.tr = tr
    nxt.u = u
    thin = int(0)
    if ln < THIN_ULPS * u:
        nxt.is_short = 1
        nxt.dmax = density_max(v_in, v_out, k_in, k_out, tf_v, model)
        if thin_unresolved(tr, nxt.dmax, prev.d, u):
            thin = 1
    if prev.is_short == 1:
        if thin_unresolved(prev.tr, prev.dmax, d_mean, prev.u):
            thin = 1
    return thin, nxt


@wp.func
def thin_at_exit(prev: ThinPrev) -> bool:
    """The ray leaves the mesh after a short segment: unresolved beside the outside's zero density."""
    return prev.is_short == 1 and thin_unresolved(prev.tr, prev.dmax, 0.0, prev.u)
