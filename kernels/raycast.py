"""Ray propagation through cell adjacency (HARC-style ray caster, float32).

One thread per pixel. A pass finds the ray's next entry into the mesh among the boundary faces
binned to the pixel's screen tile (nearest front-facing hit beyond the ray's current parameter),
then walks cell to cell: the exit face is the smallest ``lambda_i = -(e.n_i + o_i)/(d.n_i)`` over
faces with ``d.n_i > 0``; the next cell is the neighbour across it. Each segment is integrated
exactly for the piecewise-linear transfer function (:mod:`warpvol.kernels.integrate`) and composited
front to back. The pass ends where the ray leaves through a boundary face; for non-convex meshes
further passes (depth peeling of the boundary) continue from there.

Per-pixel state (radiance, transmittance, ray parameter, active flag) lives in device arrays so the
passes can be separate launches. A launch covers a block of rows (``row0``); the host may run
several blocks concurrently (CPU launches are serial, so the stage uses a thread pool). Statistics go
to ``counters[chunk]`` (entries, steps, unfinished rays) with int32 atomics, one row per block so
concurrent CPU launches never touch the same counter.
"""

import warp as wp

from .integrate import integrate_segment

wp.set_module_options({"enable_backward": False})

STATUS_ACTIVE = wp.constant(1)
STATUS_DONE = wp.constant(0)


@wp.func
def ndc_xy(px: int, py: int, width: int, height: int) -> wp.vec2:
    """NDC coordinates of the centre of pixel (row py, column px), Contract 2."""
    return wp.vec2(2.0 * (float(px) + 0.5) / float(width) - 1.0, 1.0 - 2.0 * (float(py) + 0.5) / float(height))


@wp.func
def ray_origin(q: wp.vec2, eye: wp.vec3, right: wp.vec3, up: wp.vec3, ortho: int, half_h: float,
               aspect: float) -> wp.vec3:
    if ortho == 1:
        return eye + right * (q[0] * half_h * aspect) + up * (q[1] * half_h)
    return eye


@wp.func
def ray_dir(q: wp.vec2, fwd: wp.vec3, right: wp.vec3, up: wp.vec3, ortho: int, half_h: float,
            aspect: float) -> wp.vec3:
    """Unit direction (so ray parameters are world lengths)."""
    if ortho == 1:
        return fwd
    return wp.normalize(fwd + right * (q[0] * half_h * aspect) + up * (q[1] * half_h))


@wp.func
def plane_dist(p: wp.vec4, x: wp.vec3) -> float:
    return p[0] * x[0] + p[1] * x[1] + p[2] * x[2] + p[3]


@wp.func
def plane_dot(p: wp.vec4, d: wp.vec3) -> float:
    return p[0] * d[0] + p[1] * d[1] + p[2] * d[2]


@wp.kernel
def march(
    width: int,
    height: int,
    eye: wp.vec3,
    fwd: wp.vec3,
    right: wp.vec3,
    up: wp.vec3,
    ortho: int,
    half_h: float,
    aspect: float,
    planes: wp.array2d(dtype=wp.vec4),
    grad: wp.array(dtype=wp.vec4),
    adj: wp.array2d(dtype=wp.int32),
    bface_tet: wp.array(dtype=wp.int32),
    bface_local: wp.array(dtype=wp.int32),
    tile_start: wp.array(dtype=wp.int32),
    tile_items: wp.array(dtype=wp.int32),
    tile: int,
    tiles_x: int,
    tf_s: wp.array(dtype=float),
    tf_v: wp.array(dtype=wp.vec4),
    model: int,
    max_steps: int,
    t_eps: float,
    strict_tol: float,
    inside_tol: float,
    t_min: float,
    start_cell: int,
    row0: int,
    rgb: wp.array(dtype=wp.vec3),
    trans: wp.array(dtype=float),
    tcur: wp.array(dtype=float),
    status: wp.array(dtype=wp.int32),
    counters: wp.array2d(dtype=wp.int32),
    chunk: int,
):
    tid = wp.tid()
    idx = row0 * width + tid
    if status[idx] != STATUS_ACTIVE:
        return
    py = idx // width
    px = idx - py * width
    q = ndc_xy(px, py, width, height)
    e = ray_origin(q, eye, right, up, ortho, half_h, aspect)
    d = ray_dir(q, fwd, right, up, ortho, half_h, aspect)
    t_start = tcur[idx]

    # ---- next entry: nearest front-facing boundary face hit beyond t_start in this tile ----
    # Two tiers: a hit inside its triangle up to float32 rounding (strict_tol) wins over one that
    # needs the looser tolerance; the loose tier only catches rays through shared edges/vertices
    # that rounding pushes just outside every face. Without the tiers a grazing ray could enter a
    # cell it misses by more than rounding, and walk a bogus segment.
    best_t = float(1.0e30)
    cell = int(-1)
    face_in = int(-1)
    if start_cell >= 0:
        # the perspective eye lies inside the mesh: every ray starts in that cell at t = 0
        best_t = t_start
        cell = start_cell
    else:
        tile_id = (py // tile) * tiles_x + (px // tile)
        loose_t = float(1.0e30)
        loose_cell = int(-1)
        loose_face = int(-1)
        for it in range(tile_start[tile_id], tile_start[tile_id + 1]):
            bf = tile_items[it]
            c = int(bface_tet[bf])
            f = int(bface_local[bf])
            pl = planes[c, f]
            den = plane_dot(pl, d)
            if den < 0.0:
                t = -plane_dist(pl, e) / den
                if t > t_start + t_eps and (t < best_t or t < loose_t):
                    x = e + d * t
                    worst = float(-1.0e30)
                    for k in range(4):
                        if k != f:
                            worst = wp.max(worst, plane_dist(planes[c, k], x))
                    if worst <= strict_tol:
                        if t < best_t:
                            best_t = t
                            cell = c
                            face_in = f
                    elif worst <= inside_tol:
                        if t < loose_t:
                            loose_t = t
                            loose_cell = c
                            loose_face = f
        if cell < 0:
            best_t = loose_t
            cell = loose_cell
            face_in = loose_face
    if cell < 0:
        status[idx] = STATUS_DONE
        return
    wp.atomic_add(counters, chunk, 0, 1)  # entries made in this pass

    # ---- walk through the cell adjacency ----
    acc = rgb[idx]
    tr = trans[idx]
    t_in = best_t
    g = grad[cell]
    x_in = e + d * t_in
    s_in = g[0] * x_in[0] + g[1] * x_in[1] + g[2] * x_in[2] + g[3]
    steps = int(0)
    exited = int(0)
    while steps < max_steps:
        steps += 1
        t_out = float(1.0e30)
        f_out = int(-1)
        for k in range(4):
            if k != face_in:
                pl = planes[cell, k]
                den = plane_dot(pl, d)
                if den > 0.0:
                    lam = -plane_dist(pl, e) / den
                    if lam < t_out:
                        t_out = lam
                        f_out = k
        if f_out < 0:
            break  # degenerate: no exit face (cannot happen for a valid tet and a finite ray)
        t_out = wp.max(t_out, t_in)
        g = grad[cell]
        x_out = e + d * t_out
        s_out = g[0] * x_out[0] + g[1] * x_out[1] + g[2] * x_out[2] + g[3]
        seg = integrate_segment(s_in, s_out, t_out - t_in, tf_s, tf_v, model)
        acc += tr * wp.vec3(seg[0], seg[1], seg[2])
        tr = tr * wp.exp(-seg[3])
        nxt = int(adj[cell, f_out])
        t_in = t_out
        s_in = s_out
        if tr < t_min:
            break
        if nxt < 0:
            exited = 1
            break
        # local index of the shared face in the neighbour
        fi = int(-1)
        for k in range(4):
            if int(adj[nxt, k]) == cell:
                fi = k
        cell = nxt
        face_in = fi
    wp.atomic_add(counters, chunk, 1, steps)
    rgb[idx] = acc
    trans[idx] = tr
    tcur[idx] = t_in
    if exited == 0:
        status[idx] = STATUS_DONE
        if tr >= t_min:
            wp.atomic_add(counters, chunk, 2, 1)  # rays stopped by max_steps / degeneracy


@wp.kernel
def init_state(rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float), tcur: wp.array(dtype=float),
               status: wp.array(dtype=wp.int32), t0: float):
    i = wp.tid()
    rgb[i] = wp.vec3(0.0, 0.0, 0.0)
    trans[i] = 1.0
    tcur[i] = t0
    status[i] = STATUS_ACTIVE


@wp.kernel
def finish(rgb: wp.array(dtype=wp.vec3), trans: wp.array(dtype=float), out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    c = rgb[i]
    out[i] = wp.vec4(c[0], c[1], c[2], 1.0 - trans[i])
