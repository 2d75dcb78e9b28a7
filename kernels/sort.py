"""Visibility sorting of tetrahedra on the host: topological sort of the face-adjacency graph.

``k_priority_topo`` runs Kahn's topological sort with a priority queue (a binary max-heap on a
per-cell depth key) in one thread. Edges come from the mesh adjacency and per-face directions
``dirs[c, i]`` (+1: cell ``c`` is drawn before its neighbour across local face ``i``; -1: after;
0: no constraint), plus optional extra edges in CSR form (``extra_dst[extra_off[c]:extra_off[c+1]]``
are drawn after ``c``; XMPVO's constraints between boundary faces along pixel rays). Among the cells whose predecessors are all drawn, the one with the largest key
(the farthest) goes next: for convex meshes any choice gives Williams' MPVO order; for non-convex
meshes the depth priority is the MPVONC heuristic. When the queue runs empty while cells remain, the
graph has a cycle: the farthest remaining cell (``by_key`` lists cells by decreasing key) is emitted
anyway and the break is counted in ``stats[0]``; given no ``by_key`` (fewer entries than cells) the
kernel stops there with ``stats[1] = 1`` (the host sorts the keys and runs it again: most meshes
have no cycle and never pay that sort). With ``fifo`` the ready cells leave in the order they
became ready (a queue, O(1) per cell): for an exact order (MPVO on a convex mesh, XMPVO) any
topological order draws the same image, so the depth priority is only needed by MPVONC.

``k_boundary_count``, ``k_boundary_scatter`` and ``k_ray_gaps_listed`` are the lean form of the same (``pt_best``):
the boundary faces' fragments as (face, depth) only, counted and scattered per pixel (no attributes, no sort of
the whole list; pixels with one fragment left out), each pixel's list sorted by (depth, exit before entry, face): the pairs ``k_ray_gaps`` finds.
``k_indegree`` counts each cell's incoming face edges from ``dirs``.

``k_ray_gaps`` finds XMPVO's extra edges along the pixel rays: per pixel, its boundary fragments
ordered by depth (an insertion sort in place: a pixel holds a few), and wherever the ray leaves the
mesh through one boundary face and enters again through the next, the pair of their cells.
"""

import warp as wp

from .raster import TriSetup, edge_step_i, edge_step_j, edges_at, interp_depth, row_span, screen_bary

wp.set_module_options({"enable_backward": False, "fuse_fp": False})  # same roundings on CPU and CUDA


@wp.func
def before(key: wp.array(dtype=wp.float64), a: int, b: int) -> bool:
    """Heap order: larger key first, ties by the smaller cell index (deterministic)."""
    ka = key[a]
    kb = key[b]
    return ka > kb or (ka == kb and a < b)


@wp.func
def swap_up(heap: wp.array(dtype=wp.int32), key: wp.array(dtype=wp.float64), child: int, parent: int) -> bool:
    """Swap ``child`` above ``parent`` if it must come first; returns whether it did."""
    a = heap[child]
    b = heap[parent]
    if before(key, a, b):
        heap[parent] = a
        heap[child] = b
        return True
    return False


@wp.func
def heap_push(heap: wp.array(dtype=wp.int32), size: int, key: wp.array(dtype=wp.float64), v: int) -> int:
    i = size
    heap[i] = v
    while i > 0:
        p = (i - 1) / 2
        if not swap_up(heap, key, i, p):
            break
        i = p
    return size + 1


@wp.func
def heap_pop(heap: wp.array(dtype=wp.int32), size: int, key: wp.array(dtype=wp.float64)) -> int:
    """Remove the top; returns the new size (the top was read by the caller)."""
    n = size - 1
    heap[0] = heap[n]
    i = int(0)
    while True:
        l = 2 * i + 1
        if l >= n:
            break
        c = l
        if l + 1 < n and before(key, heap[l + 1], heap[l]):
            c = l + 1
        if not swap_up(heap, key, c, i):
            break
        i = c
    return n


@wp.func
def ready_push(heap: wp.array(dtype=wp.int32), head: int, size: int, key: wp.array(dtype=wp.float64), v: int,
               fifo: int) -> int:
    """Add a ready cell: to the priority heap, or (``fifo``) to the tail of the queue ``heap[head:head+size]``."""
    if fifo != 0:
        heap[head + size] = v
        return size + 1
    return heap_push(heap, size, key, v)


@wp.kernel
def k_priority_topo(adj: wp.array2d(dtype=wp.int32), dirs: wp.array2d(dtype=wp.int32),
                    extra_off: wp.array(dtype=wp.int32), extra_dst: wp.array(dtype=wp.int32),
                    key: wp.array(dtype=wp.float64), by_key: wp.array(dtype=wp.int32),
                    indeg: wp.array(dtype=wp.int32), heap: wp.array(dtype=wp.int32),
                    done: wp.array(dtype=wp.int32), order: wp.array(dtype=wp.int32),
                    stats: wp.array(dtype=wp.int32), fifo: int):
    n = key.shape[0]
    size = int(0)
    head = int(0)  # fifo: the queue is heap[head:head+size] (each cell enters it at most once)
    for v in range(n):
        if indeg[v] == 0:
            size = ready_push(heap, head, size, key, v, fifo)
    out = int(0)
    cursor = int(0)
    cycles = int(0)
    while out < n:
        v = int(-1)
        if size > 0:
            if fifo != 0:
                v = heap[head]
                head += 1
                size -= 1
            else:
                v = heap[0]
                size = heap_pop(heap, size, key)
        else:
            if by_key.shape[0] < n:  # a cycle, and no cells by key given: report it, the host runs again
                stats[1] = 1
                return
            while done[by_key[cursor]] != 0:
                cursor += 1
            v = by_key[cursor]
            cycles += 1
        if done[v] == 0:
            done[v] = 1
            order[out] = v
            out += 1
            for f in range(4):
                if dirs[v, f] > 0:
                    b = adj[v, f]
                    indeg[b] = indeg[b] - 1
                    if indeg[b] == 0 and done[b] == 0:
                        size = ready_push(heap, head, size, key, b, fifo)
            for e in range(extra_off[v], extra_off[v + 1]):
                b = extra_dst[e]
                indeg[b] = indeg[b] - 1
                if indeg[b] == 0 and done[b] == 0:
                    size = ready_push(heap, head, size, key, b, fifo)
    stats[0] = cycles


@wp.kernel
def k_face_directions(points: wp.array(dtype=wp.vec3d), tets: wp.array2d(dtype=wp.int32),
                      adj: wp.array2d(dtype=wp.int32), face_verts: wp.array2d(dtype=wp.int32), eye: wp.vec3d,
                      fwd: wp.vec3d, persp: int, dirs: wp.array2d(dtype=wp.int32)):
    """One thread per cell ``a``: for each shared face with ``adj[a, f] = b > a`` the side of the
    face's plane the eye is on (float64, points relative to the mesh centre), written to both
    ``dirs[a, f]`` and ``-dirs[b, f']`` (each face decided once, so both sides agree)."""
    a = wp.tid()
    for f in range(4):
        b = adj[a, f]
        if b > a:
            p0 = points[tets[a, face_verts[f, 0]]]
            p1 = points[tets[a, face_verts[f, 1]]]
            p2 = points[tets[a, face_verts[f, 2]]]
            n = wp.cross(p1 - p0, p2 - p0)  # outward normal of cell a
            side = float(0.0)
            if persp != 0:
                side = float(wp.dot(n, eye - p0))
            else:
                side = -float(wp.dot(n, fwd))
            s = int(0)
            if side > 0.0:
                s = 1
            elif side < 0.0:
                s = -1
            dirs[a, f] = s
            for g in range(4):
                if adj[b, g] == a:
                    dirs[b, g] = -s


@wp.kernel
def k_ray_gaps(offsets: wp.array(dtype=wp.int32), prim: wp.array(dtype=wp.int32), depth: wp.array(dtype=wp.float32),
               front: wp.array(dtype=wp.int32), cell: wp.array(dtype=wp.int32), src: wp.array(dtype=wp.int32),
               dst: wp.array(dtype=wp.int32), p0: int):
    """Pixel ``p0 + tid``: its fragments ``offsets[p] ..`` (``prim``: boundary face, ``depth``) sorted in
    place by depth, at equal depth the exit (``front == 0``) before the entry, stably (primitive order);
    then for each consecutive exit -> entry pair the entered face's cell (``src``, drawn first: farther)
    and the left face's cell (``dst``) at the exit's slot, else -1 there. Blocks of pixels may run
    concurrently (each owns its slots)."""
    p = p0 + wp.tid()
    a = offsets[p]
    b = offsets[p + 1]
    for k in range(a + 1, b):  # insertion sort: stable, short lists
        kd = depth[k]
        kp = prim[k]
        kf = front[kp]
        m = k - 1
        while m >= a:
            md = depth[m]
            if md > kd or (md == kd and front[prim[m]] > kf):
                depth[m + 1] = md
                prim[m + 1] = prim[m]
                m -= 1
            else:
                break
        depth[m + 1] = kd
        prim[m + 1] = kp
    for k in range(a, b):
        src[k] = -1
        dst[k] = -1
        if k + 1 < b:
            if front[prim[k]] == 0 and front[prim[k + 1]] == 1:  # leave the mesh, then re-enter it
                src[k] = cell[prim[k + 1]]
                dst[k] = cell[prim[k]]


@wp.kernel
def k_indegree(dirs: wp.array2d(dtype=wp.int32), indeg: wp.array(dtype=wp.int32)):
    """Cell ``c``: how many of its faces have ``dirs < 0`` (a neighbour drawn before it)."""
    c = wp.tid()
    n = int(0)
    for f in range(4):
        if dirs[c, f] < 0:
            n += 1
    indeg[c] = n


@wp.kernel
def k_boundary_count(s: TriSetup, width: int, pixel_counts: wp.array(dtype=wp.int32)):
    """Face ``t`` (a set-up triangle): add one to ``pixel_counts`` at every pixel centre it covers (each row of
    its bounding box walked over its covered run, :func:`warpvol.kernels.raster.row_span`: the pixels the
    rasteriser's exact coverage test passes; no depth clip)."""
    t = wp.tid()
    b = s.bbox[t]
    if b[2] < b[0] or b[3] < b[1]:  # culled or off screen
        return
    e = edges_at(s, t, b[0], b[1])
    sj = edge_step_j(s, t)
    si = edge_step_i(s, t)
    for i in range(b[1], b[3] + 1):
        run = row_span(e, sj, b[2] - b[0] + 1)
        e = e + si
        for j in range(b[0] + run[0], b[0] + run[1] + 1):
            wp.atomic_add(pixel_counts, i * width + j, 1)


@wp.kernel
def k_boundary_scatter(s: TriSetup, pos: wp.array(dtype=wp.vec4), width: int, counts: wp.array(dtype=wp.int32),
                       offsets: wp.array(dtype=wp.int32), cursor: wp.array(dtype=wp.int32),
                       prim: wp.array(dtype=wp.int32), depth: wp.array(dtype=wp.float32)):
    """Face ``t``: at every pixel centre it covers (as :func:`k_boundary_count` walks them) that holds two or
    more fragments (``counts``; one alone makes no pair), its index and its depth (the fragment depth of
    :func:`warpvol.kernels.raster_draw.k_tri_fragments`) in the pixel's next free slot from ``offsets[p]``.
    Atomics: one launch on the CPU (Warp's CPU atomics are plain read-modify-writes)."""
    t = wp.tid()
    b = s.bbox[t]
    if b[2] < b[0] or b[3] < b[1]:
        return
    v = s.vidx[t]
    e = edges_at(s, t, b[0], b[1])
    sj = edge_step_j(s, t)
    si = edge_step_i(s, t)
    for i in range(b[1], b[3] + 1):
        run = row_span(e, sj, b[2] - b[0] + 1)
        e = e + si
        for j in range(b[0] + run[0], b[0] + run[1] + 1):
            p = i * width + j
            if counts[p] > 1:
                k = offsets[p] + wp.atomic_add(cursor, p, 1)
                prim[k] = t
                depth[k] = interp_depth(pos, v, screen_bary(pos, v, float(j) + 0.5, float(i) + 0.5))


@wp.kernel
def k_ray_gaps_listed(pixels: wp.array(dtype=wp.int32), offsets: wp.array(dtype=wp.int32),
                      prim: wp.array(dtype=wp.int32), depth: wp.array(dtype=wp.float32),
                      front: wp.array(dtype=wp.int32), cell: wp.array(dtype=wp.int32), n_pairs: wp.array(dtype=wp.int32),
                      src: wp.array(dtype=wp.int32), dst: wp.array(dtype=wp.int32)):
    """:func:`k_ray_gaps` for the listed pixels, their lists in any order: pixel ``pixels[tid]``'s fragments
    sorted by (depth, exit before entry, face index), the order ``k_ray_gaps`` gives a list in face order; each
    exit -> entry pair appended at ``n_pairs[0]`` (the same pairs as a set; one launch on the CPU)."""
    p = pixels[wp.tid()]
    a = offsets[p]
    b = offsets[p + 1]
    for k in range(a + 1, b):
        kd = depth[k]
        kp = prim[k]
        kf = front[kp]
        m = k - 1
        while m >= a:
            md = depth[m]
            mp = prim[m]
            mf = front[mp]
            if md > kd or (md == kd and (mf > kf or (mf == kf and mp > kp))):
                depth[m + 1] = md
                prim[m + 1] = mp
                m -= 1
            else:
                break
        depth[m + 1] = kd
        prim[m + 1] = kp
    for k in range(a, b - 1):
        if front[prim[k]] == 0 and front[prim[k + 1]] == 1:  # leave the mesh, then re-enter it
            o = wp.atomic_add(n_pairs, 0, 1)
            src[o] = cell[prim[k + 1]]
            dst[o] = cell[prim[k]]
