"""Hardware ray casting (Weiler et al. 2003; Espinha & Celes 2005) on the emulated GPU: host side.

Plain functions the ``harc*`` stages are thin over (tests call them directly):

* :func:`mesh_textures` -- the paper's Table 1 (96 bytes/tet: four face planes, gradient + offset,
  adjacency; float32) as rgba32f 2D textures of the texture unit, and :func:`layout_bytes`, which
  also sizes the compact layout the consistent walk reads (4 vertex indices + 4 neighbour faces per
  tet, ``(x, y, z, s)`` per point: 32 bytes/tet + 16 bytes/point);
* :func:`entry_fragments` -- ray start: the front-facing boundary faces rasterised by the rasteriser
  unit into per-pixel fragment lists (entry tet, local face) sorted by window depth; pass ``k`` of
  the kernel takes the first fragment beyond the ray's last exit (depth peeling);
* the kernel's integration set-up (exact, full table, or partial with psi and iso tables) is
  :func:`warpvol.shared.integration.integ_setup`, shared with the sweep;
* :func:`march_pass`, :func:`resolve_failed`, :func:`lost_rays` -- one propagation pass over all
  active rays, the float64 redo of rays the float32 walk could not resolve (robust set-up), and the
  count of rays lost under the paper's set-up.
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError
from warpvol.gpu.formats import get_format
from warpvol.gpu.raster import GUARD_PX, Rasterizer, depth_order, guard_band_overflow
from warpvol.gpu.texture import Texture2D
from warpvol.gpu.vertex import VertexStage
from warpvol.parallel import launch_blocks
from warpvol.raycasting.stages.cell_setup import neighbour_faces
from warpvol.raycasting.stages.raycast import (
    camera_struct,
    cell_mesh_struct,
    host_view,
    march_lanes,
    on_host,
    pass_rays,
    ray_blocks,
    segments_struct,
    walk_opts,
    write_back,
)
from warpvol.reference.pixels import redo_mesh_properties, redo_pixels_float64
from warpvol.scene.mesh import FACE_VERTS
from warpvol.shared.entry_bins import entry_face_mask, face_depths
from warpvol.shared.thin_cells import edge_pixels, surface_neighbours
from warpvol.shared.visible import face_triangles, skipping

TEX_ROW = 4096  # texels per row of the mesh textures (GeForce 6800: 4096 x 4096 max)
WALKS = {"planes": 0, "plucker": 1}
SETUPS = {"robust": 0, "paper": 1}
ARITHMETIC = ("float64", "fp32")


def layout_bytes(mesh) -> dict:
    """Bytes per tet of the two mesh layouts: ``paper96`` (Table 1) and ``compact`` (points shared)."""
    m, v = mesh.n_tets, mesh.n_points
    return {"paper96": 96.0, "compact": (32.0 * m + 16.0 * v) / max(m, 1)}


def planes_fp32(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Face planes ``(M, 4, 4)`` and gradients ``(M, 4)`` (``g, g0``) computed in float32 from the
    float32 points and scalars in the mesh's own frame, as a host program filling the paper's float32
    textures computes them: ``n = (b - a) x (c - a)`` normalised, ``o = -n . a``, oriented so the
    opposite vertex lies on the negative side; ``g`` by Cramer's rule on the edge vectors from vertex
    0, ``g0 = s_0 - g . p_0``. Every operation rounds to float32 (returned as float32)."""

    with np.errstate(all="ignore"):  # a degenerate tet gives Inf / NaN, as in the paper's C float code
        f = np.float32
        p = mesh.points.astype(f)[mesh.tets]  # (M, 4, 3)
        s = np.asarray(mesh.scalars).astype(f)[mesh.tets]  # (M, 4)
        tri = p[:, FACE_VERTS]  # (M, 4, 3, 3)
        n = np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0]).astype(f)
        nl = np.sqrt((n * n).sum(axis=-1, dtype=f)).astype(f)
        n = (n / nl[..., None]).astype(f)
        o = -(n * tri[:, :, 0]).sum(axis=-1, dtype=f)
        side = (n * p).sum(axis=-1, dtype=f) + o
        flip = side > 0
        n[flip] *= -1
        o[flip] *= -1
        planes = np.concatenate([n, o[..., None]], axis=-1).astype(f)
        a = p[:, 1:] - p[:, :1]  # (M, 3, 3) edge vectors, rows
        b = s[:, 1:] - s[:, :1]  # (M, 3)
        c12, c20, c01 = (np.cross(a[:, i], a[:, j]).astype(f) for i, j in ((1, 2), (2, 0), (0, 1)))
        det = (a[:, 0] * c12).sum(axis=-1, dtype=f)
        g = ((b[:, 0, None] * c12 + b[:, 1, None] * c20 + b[:, 2, None] * c01) / det[:, None]).astype(f)
        g0 = (s[:, 0] - (g * p[:, 0]).sum(axis=-1, dtype=f)).astype(f)
    return planes, np.c_[g, g0].astype(f)


def mesh_textures(mesh, origin: np.ndarray, device: str = "cpu", arithmetic: str = "float64",
                  info: dict | None = None):
    """Table 1 of the paper as six rgba32f textures ``(n0, n1, n2, n3, grad, adj)``.

    ``arithmetic = "float64"``: planes and gradients derived in float64, positions relative to
    ``origin`` (float64 shift before the float32 cast, as the cells' points); ``"fp32"``: computed in
    float32 in the mesh's own frame (:func:`planes_fp32`; ``origin`` unused), the paper's textures.
    A tet degenerate in float32 (a zero normal or determinant: non-finite plane or gradient) gets
    zero texels there: a face with ``n = 0`` never has ``d . n > 0``, so a ray reaching it is lost,
    as with the NaN the division left in the paper's texture; ``info["degenerate_tets"]`` counts them.

    Returns ``(struct, textures)``: the kernel's :class:`warpvol.kernels.harc.MeshTex` and the
    :class:`~warpvol.gpu.texture.Texture2D` objects (they own the device arrays).

    Example
    -------
    >>> from warpvol.scene.builtin import builtin_scene
    >>> m = builtin_scene("box").mesh
    >>> st, tex = mesh_textures(m, m.points.mean(axis=0))
    >>> len(tex), tex[0].fmt, st.width == min(m.n_tets, TEX_ROW)
    (6, 'rgba32f', True)
    """
    from warpvol.kernels import harc as kh

    if arithmetic not in ARITHMETIC:
        raise ConfigError(f"arithmetic: {arithmetic!r} not allowed; allowed: {', '.join(ARITHMETIC)}")
    m = mesh.n_tets
    width = max(1, min(m, TEX_ROW))
    rows = -(-m // width)
    bad = 0
    if arithmetic == "fp32":
        planes, grad = planes_fp32(mesh)
        ok = np.isfinite(planes).all(axis=(1, 2)) & np.isfinite(grad).all(axis=1)
        bad = int((~ok).sum())
        planes[~np.isfinite(planes).all(axis=2)] = 0.0
        grad[~np.isfinite(grad).all(axis=1)] = 0.0
    else:
        origin = np.asarray(origin, np.float64)
        planes = mesh.face_planes.copy()  # (M, 4, 4) unit outward normals
        planes[..., 3] += planes[..., :3] @ origin
        grad = np.c_[mesh.gradients, mesh.offsets + mesh.gradients @ origin]
    adj = neighbour_faces(mesh.adjacency).astype(np.float64)
    if 4 * m >= 2 ** 24:
        raise ConfigError(f"mesh: {m} tets do not fit the float32 adjacency texture (4 M < 2^24)")

    def tex(a):
        buf = np.zeros((rows * width, 4), np.float64)
        buf[:m] = a
        return Texture2D(buf.reshape(rows, width, 4), fmt="rgba32f", filter="nearest", device=device)

    if info is not None:
        info["degenerate_tets"] = bad
    texs = [tex(planes[:, i]) for i in range(4)] + [tex(grad), tex(adj)]
    st = kh.MeshTex()
    st.n0, st.n1, st.n2, st.n3, st.grad, st.adj = (t.struct for t in texs)
    st.width = width
    return st, texs


def empty_mesh_tex(device: str = "cpu"):
    """A :class:`warpvol.kernels.harc.MeshTex` of 1x1 textures for walks that do not read Table 1."""
    from warpvol.kernels import harc as kh

    t = Texture2D(np.zeros((1, 1, 4)), fmt="rgba32f", filter="nearest", device=device)
    st = kh.MeshTex()
    st.n0 = st.n1 = st.n2 = st.n3 = st.grad = st.adj = t.struct
    st.width = 1
    return st, t


def entry_fragments(mesh, camera, device: str = "cpu", faces: np.ndarray | None = None) -> dict:
    """Rasterise the front-facing boundary faces (the rasteriser unit, window coordinates from the
    vertex stage) into per-pixel fragment lists sorted by depth. ``faces``: ``(B, 2)`` rows ``(tet,
    local face)`` to rasterise instead of the mesh's boundary (the visible sub-mesh's boundary,
    :func:`warpvol.shared.visible.visible_boundary`).

    Returns ``dict(frag_start (H*W+1), frag_bf, bf_tet, bf_face, bf_nbr, far, bf_depth, edge_start, edge_bf,
    edge_pairs, fragments, faces, max_layers)``: per fragment the index of its face in the front-face list; per
    front face its tet, local face, the three front faces sharing its edges (-1: none; the consistent walk
    searches them when the rasteriser's snapped coverage and its edge test disagree near an edge) and its
    depth bounds (:func:`~warpvol.shared.entry_bins.face_depths`: the re-entry search leaves the faces
    wholly before its start untested);
    ``max_layers`` is the most fragments any pixel has (the boundary layers depth peeling goes
    through).
    """
    import warp as wp


    front = entry_face_mask(mesh, camera, faces)
    bf = (mesh.boundary_faces if faces is None else np.asarray(faces, dtype=np.int64).reshape(-1, 2))[front]
    tris = face_triangles(mesh.tets, bf)
    w, h = camera.width_px, camera.height_px
    npx = w * h
    count = 0
    # a mesh wholly behind the eye plane (camera looking away) has nothing to rasterise: no ray starts
    used = mesh.points if mesh.point_used is None else mesh.points[mesh.point_used]
    in_front = bool((((used - camera.eye) @ camera.forward) > 0).any())
    if len(bf) and in_front:
        near, far = camera.depth_range(*mesh.bounds)
        vs = VertexStage.from_camera(camera, near, far, device=device).transform(mesh.points)
        n_over, extent = guard_band_overflow(vs.window, tris, w, h)
        if n_over:  # the rasteriser would drop these ray starts: rays lost, never silently
            raise ConfigError(f"ray start by rasterisation: {n_over:,} front boundary faces reach {extent:.3g} px "
                              f"from the image, beyond the rasteriser's guard band of {GUARD_PX:.0f} px (fixed-point "
                              "window coordinates, no geometric clipping); use raycast (its rays start without "
                              "the rasteriser), or a view that shows more of the mesh")
        rast = Rasterizer(w, h, device=device, depth_clip=False)
        fr = rast.fragments(vs.window_array, tris.astype(np.int32), walk="triangle")  # the pixel walk's list, faster
        count = fr.count
    listed = np.zeros(0, np.int64)  # the pixels with fragments
    if count:
        start = fr.offsets.numpy()  # (int32, H*W + 1: the kernels read the rasteriser's array itself)
        per_px = np.diff(start)
        listed = np.flatnonzero(per_px)
        pix = np.repeat(listed, per_px[listed])  # (Fragments.pixel_index, from the listed pixels only)
        prim = fr.prim.numpy()[:count]
        depth = fr.depth.numpy()[:count]
        order = depth_order(pix, depth)
        frag_bf = prim[order]
        layers = int(per_px[listed].max())
    else:
        start = np.zeros(npx + 1, np.int32)
        frag_bf = np.zeros(0, np.int64)
        layers = 0

    on_cpu = on_host(device)

    def arr(a, dtype=wp.int32):
        a = np.ascontiguousarray(a, dtype=np.int32)
        if len(a) == 0:
            a = np.zeros((1,) + a.shape[1:], np.int32)
        # on the CPU the device array is the host array itself (kept alive by it; none of these is written
        # after this), not a copy
        return wp.array(a, dtype=dtype, device=device, copy=not on_cpu)

    nbr = surface_neighbours(tris).reshape(-1, 3)
    edge_start, edge_bf = edge_pixels(mesh, camera, tris, nbr) if len(bf) and in_front else (
        np.zeros(npx + 1, np.int64), np.zeros(0, np.int64))
    # the pixels with a fragment or an open-edge face lie in this box (per-pixel maps are computed there)
    box = listed_box(w, h, np.r_[listed, np.searchsorted(edge_start, np.arange(len(edge_bf)), side="right") - 1])
    far = reentry_bound(mesh, camera, tris, nbr, start, frag_bf, edge_start, edge_bf, box)
    depth = face_depths(mesh, camera, tris)
    return {"frag_start": fr.offsets if count else arr(start), "frag_bf": arr(frag_bf), "bf_tet": arr(bf[:, 0]), "bf_face": arr(bf[:, 1]),
            "bf_nbr": arr(nbr, wp.vec3i), "far": wp.array(far, dtype=wp.float32, device=device, copy=not on_cpu),
            "bf_depth": wp.array(depth if len(depth) else np.zeros((1, 2), np.float32), dtype=wp.vec2, device=device),
            "edge_start": arr(edge_start), "edge_bf": arr(edge_bf), "edge_pairs": int(len(edge_bf)),
            "frag_start_host": start, "edge_start_host": edge_start, "box": box,
            "fragments": int(count), "faces": int(len(bf)), "max_layers": layers}


def listed_box(w: int, h: int, pixels: np.ndarray):
    """The window rows and columns ``(y0, y1, x0, x1)`` (half-open) holding the flat pixel indices ``pixels``
    (the pixels with a fragment or an open-edge face listed), grown by one pixel each way and clipped to the
    window: outside it no pixel has one listed within its 3 x 3 neighbourhood. ``None``: nothing listed.
    Per-pixel maps of a small frame are computed in the box, not over the window."""
    pixels = np.asarray(pixels)
    if len(pixels) == 0:
        return None
    rows, cols = np.divmod(pixels, w)
    return (max(int(rows.min()) - 1, 0), min(int(rows.max()) + 2, h), max(int(cols.min()) - 1, 0),
            min(int(cols.max()) + 2, w))


def csr_rows(start: np.ndarray) -> np.ndarray:
    """The rows of the CSR ``start`` that list something."""
    return np.flatnonzero(np.diff(start) > 0)


def reentry_bound(mesh, camera, tris: np.ndarray, nbr: np.ndarray, start: np.ndarray, frag_bf: np.ndarray,
                  edge_start: np.ndarray | None = None, edge_bf: np.ndarray | None = None,
                  box: tuple | None = None) -> np.ndarray:
    """Per pixel (H*W, float32), a bound past which a ray leaving the mesh cannot re-enter it: the largest
    depth ``g`` (distance from the eye, perspective; depth along the view direction, orthographic) of any
    vertex of a front face the HARC entry search of that pixel can reach -- the faces listed at the pixel
    and its 8 neighbours and, through :func:`ring_search <warpvol.kernels.harc_walk.ring_search>`, the two
    rings of surface neighbours around each, and the pixel's open-edge faces (:func:`~warpvol.shared.thin_cells.edge_pixels`,
    ``edge_start`` / ``edge_bf``) -- plus a rounding margin of 1e-4 of the scene's extent.
    ``g`` is largest at a vertex (a distance is convex, a depth linear), so a crossing of any of those
    faces has ``t + t0 <= bound`` (``t0`` the ray origin's shift); ``-inf`` where no face is listed
    around the pixel. Computed in ``box``, the :func:`listed_box` of the pixels with a fragment or an open-edge
    face (``-inf`` outside it; found from ``start`` and ``edge_start`` when not given)."""
    w, h = camera.width_px, camera.height_px
    out = np.full(h * w, -np.inf, dtype=np.float32)
    n_edge = 0 if edge_bf is None else len(edge_bf)
    if box is None:
        box = listed_box(w, h, np.r_[csr_rows(start), csr_rows(edge_start) if n_edge else []].astype(np.int64))
    if (len(frag_bf) or n_edge) and len(tris) and box is not None:
        y0, y1, x0, x1 = box
        rel = np.asarray(mesh.points, np.float64) - np.asarray(camera.eye, np.float64)
        if camera.projection == "perspective":
            g = np.linalg.norm(rel, axis=1)
        else:
            g = rel @ np.asarray(camera.forward, np.float64)
        k = k0 = g[tris].max(axis=1)
        for _ in range(2):  # the two rings ring_search visits
            kn = np.where(nbr >= 0, k[np.maximum(nbr, 0)], -np.inf)
            k = np.maximum(k, kn.max(axis=1))
        # the pixels of the box: their lists' largest key (the CSR rows of the box's pixels)
        pix = (np.arange(y0, y1)[:, None] * w + np.arange(x0, x1)[None, :]).ravel()
        near = _list_max(np.full(len(pix), -np.inf), start[pix], start[pix + 1], frag_bf, k).reshape(y1 - y0, x1 - x0)
        if len(frag_bf):  # the 3 x 3 maximum, as a row pass and a column pass (-inf beyond the box: nothing listed)
            img = np.pad(near, 1, constant_values=-np.inf)
            row = np.maximum(np.maximum(img[:, :-2], img[:, 1:-1]), img[:, 2:])
            near = np.maximum(np.maximum(row[:-2], row[1:-1]), row[2:])
        if n_edge:  # few pixels have open-edge faces: their items, each to its pixel
            epix = np.searchsorted(edge_start, np.arange(n_edge), side="right") - 1
            ey, ex = np.divmod(epix, w)
            np.maximum.at(near, (ey - y0, ex - x0), k0[edge_bf])
        ext = float(np.abs(rel).max()) + float((mesh.bounds[1] - mesh.bounds[0]).max())
        out.reshape(h, w)[y0:y1, x0:x1] = (near + 1e-4 * ext).astype(np.float32)
    return out


def _list_max(empty: np.ndarray, first: np.ndarray, stop: np.ndarray, items: np.ndarray, key: np.ndarray) -> np.ndarray:
    """Per list ``items[first[i]:stop[i]]``, the largest ``key[item]`` (``empty``'s values where a list is empty);
    the lists lie one after the other in ``items``."""
    out = empty.copy()
    listed = np.flatnonzero(stop > first)
    if len(listed):
        out[listed] = np.maximum.reduceat(key[items], first[listed])
    return out


class HarcState:
    """Per-pixel ray state on the device: accumulated RGBA, ray parameter, status, last cell."""

    def __init__(self, n: int, device: str):
        import warp as wp

        from warpvol.kernels import harc as kh

        self.n, self.device = n, device
        self.rgba = (wp.array(np.zeros((n, 4), np.float32), dtype=wp.vec4, device=device, copy=False)  # (calloc'd)
                     if on_host(device) else wp.empty(n, dtype=wp.vec4, device=device))
        self.tcur = (wp.array(np.zeros(n, np.float32), dtype=wp.float32, device=device, copy=False)  # (calloc'd)
                     if on_host(device) else wp.empty(n, dtype=wp.float32, device=device))
        self.status = wp.empty(n, dtype=wp.int32, device=device)
        self.last = wp.empty(n, dtype=wp.int32, device=device)
        self.candidates = None  # the pixels a further pass looks at (the last pass's launched rays; None: all)
        #: per pixel, the last pass's loop work: (cells visited, fragment-program steps; zeroed by each pass). On the
        #: CPU over calloc'd host memory: its pages are zeroed as a pass first writes them, not all up front
        self.px_work = (wp.array(np.zeros((n, 2), np.int32), dtype=wp.vec2i, device=device, copy=False)
                        if on_host(device) else wp.zeros(n, dtype=wp.vec2i, device=device))
        self.work_clean = True  # px_work all zero (no pass has written it yet)
        if on_host(device):  # the host fills its views: a few memsets, no kernel over every pixel
            host_view(self.status).fill(int(kh.STATUS_ACTIVE))
            host_view(self.last).fill(-1)
        else:
            wp.launch(kh.init_state, dim=n, inputs=[self.rgba, self.tcur, self.status, self.last], device=device)

    def image(self, height: int, width: int) -> np.ndarray:
        """The accumulated RGBA as an ``(height, width, 4)`` float32 image: on the CPU a view of the state's
        buffer (it keeps the buffer alive; the state is the frame's own), elsewhere a copy."""
        return self.rgba.numpy().reshape(height, width, 4)


N_COUNTERS = 13
#: the peel test "beyond the last exit" accepts a boundary face from ``PEEL_TOL`` times the mesh radius
#: before the last exit on (in every set-up; the paper's depth test compared depths plainly)
PEEL_TOL = 1e-6
COUNTER_NAMES = ("entries", "steps", "cells", "failed", "step_bound", "iso_missed", "texture_fetches",
                 "entry_searches", "thin_layer_rays", "backward_rays", "edge_entries",
                 "terminated_early", "eye_inside_rays")


def starts_outside(camera, origin: np.ndarray, radius: float) -> np.ndarray | None:
    """Per pixel (bool, flat), whether the kernel's float64 ray set-up (:func:`warpvol.kernels.walk.ray_setup`:
    the eye relative to the cells' ``origin``, the bounding sphere of ``radius``) surely gives the ray
    ``t_clip = 0`` (its true start lies before the sphere: the closest approach to the centre at least 1.001
    radii along the ray) or a miss of the sphere (the closest approach farther than the radius) -- decided here
    in float64 from the same camera frame by a margin of 1e-9 of the scene's scale, far above the rounding of
    either computation. With the camera frame orthonormal, the direction ``fwd + sx right + sy up`` has
    ``tc = -(e.fwd + sx e.right + sy e.up) / sqrt(1 + sx^2 + sy^2)`` (perspective) and the closest distance
    squared ``|e|^2 - tc^2``; an orthographic ray from ``e + sx right + sy up`` along ``fwd`` has
    ``tc = -e.fwd`` and the closest distance squared ``(e.right + sx)^2 + (e.up + sy)^2``. A handful of
    array operations over the window (no square root); None (every ray) where the eye lies beyond 1.42 radii
    and every ray points to the centre's side (perspective: a ray whose line meets the sphere then has
    ``tc >= sqrt(|e|^2 - r^2) > 1.001 r``) or the eye plane lies beyond 1.001 radii before the centre
    (orthographic)."""
    w, h = camera.width_px, camera.height_px
    e = np.asarray(camera.eye, np.float64) - np.asarray(origin, np.float64)
    fwd, right, up = (np.asarray(v, np.float64) for v in (camera.forward, camera.right, camera.true_up))
    ef, er, eu = float(e @ fwd), float(e @ right), float(e @ up)
    if camera.projection == "perspective":
        half_h = float(np.tan(np.radians(camera.fov_y_deg) / 2.0))
    else:
        half_h = camera.ortho_height / 2.0
    sx = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * half_h * camera.aspect
    sy = (1.0 - 2.0 * (np.arange(h) + 0.5) / h) * half_h
    tol = 1e-9 * (float(np.linalg.norm(e)) + radius + abs(sx).max(initial=0.0) + abs(sy).max(initial=0.0))
    clip0 = 1.001 * radius + tol  # tc beyond it: t_clip = 0
    miss2 = radius * radius + 4.0 * tol * max(radius, tol)  # closest distance squared beyond it: a miss
    if camera.projection == "perspective" and float(e @ e) > (1.42 * radius) ** 2 + miss2 and \
            min(-(ef + er * x + eu * y) for x in (sx[0], sx[-1]) for y in (sy[0], sy[-1])) > tol:
        # every ray points towards the centre's side (tc > 0: the least of a linear function of (sx, sy) over
        # the image lies at a corner), so one meeting the sphere has tc >= sqrt(|e|^2 - r^2) > 1.001 r
        return None
    if camera.projection != "perspective" and -ef > clip0:
        return None  # every ray's closest approach lies beyond 1.001 r along it
    if camera.projection != "perspective":
        out = (er + sx[None, :]) ** 2 + (eu + sy[:, None]) ** 2 > miss2
        return (out | (-ef > clip0)).ravel()
    # tc = -a / sqrt(n2) with a = e.fwd + sx e.right + sy e.up, n2 = 1 + sx^2 + sy^2, compared squared (no root):
    # tc > clip0  <=>  a < 0 and a^2 > clip0^2 n2;  |e|^2 - tc^2 > miss2  <=>  a^2 < k n2 with k = |e|^2 - miss2.
    # In float32 over the window (a sixth of float64's time): with m >= |a| and n >= n2 over the window, a^2 is
    # off by under 6e-7 m^2 and c n2 by under 4e-7 |c| n, so each test is cleared only by a margin of 1e-5 of
    # those; a ray in that band is launched, as any ray the tests do not clear
    f32 = np.float32
    m = abs(ef) + abs(eu) * float(np.abs(sy).max()) + abs(er) * float(np.abs(sx).max())
    n = 1.0 + float((sx * sx).max()) + float((sy * sy).max())
    k = float(e @ e) - miss2
    a2 = np.add((ef + eu * sy).astype(f32)[:, None], (er * sx).astype(f32)[None, :])
    neg = a2 < 0.0
    np.multiply(a2, a2, out=a2)
    n2 = np.add((1.0 + sy * sy).astype(f32)[:, None], (sx * sx).astype(f32)[None, :])
    out = np.greater(a2, n2 * f32(clip0 * clip0) + f32(1e-5 * (m * m + clip0 * clip0 * n)))
    out &= neg
    if k > 0.0:
        np.multiply(n2, f32(k), out=n2)
        n2 -= f32(1e-5 * (m * m + k * n))
        out |= np.less(a2, n2)
    return out.ravel()


def face_reach(ctx, entry: dict, setup: str = "robust") -> np.ndarray | None:
    """Per pixel (bool, flat), whether the pass must launch the ray: a front face is listed at the pixel, at one
    of its 8 neighbours or among its open-edge faces (``entry``: :func:`entry_fragments`), or (robust set-up)
    the ray may start inside the mesh's bounding sphere (not :func:`starts_outside`). Elsewhere the kernel's
    entry search has no face to test and it sets the ray done (:func:`warpvol.kernels.harc.no_face_around`;
    a ray starting inside the sphere it hands to the float64 redo); the paper's set-up starts every ray at the
    eye. Per frame, kept in ``entry``; None off the CPU."""
    if not on_host(ctx.device):
        return None
    if "reach" not in entry:
        cam = ctx.scene.camera
        h, w = cam.height_px, cam.width_px
        start, edge_start = entry["frag_start_host"], entry["edge_start_host"]
        reach = np.zeros((h, w), dtype=bool)
        box = entry["box"]
        if box is not None:  # (nothing outside the box is listed: no pixel there has a face around)
            y0, y1, x0, x1 = box
            pix = (np.arange(y0, y1)[:, None] * w + np.arange(x0, x1)[None, :])
            pad = np.pad(start[pix + 1] > start[pix], 1)
            row = pad[:, :-2] | pad[:, 1:-1] | pad[:, 2:]
            reach[y0:y1, x0:x1] = row[:-2] | row[1:-1] | row[2:] | (edge_start[pix + 1] > edge_start[pix])
        reach = reach.ravel()
        if setup != "paper":
            cells = ctx.buffers["cells"]
            clear = starts_outside(cam, cells["origin"], max(float(cells["radius"]), 1e-30))
            if clear is not None:
                reach |= ~clear
        entry["reach"] = reach
    return entry["reach"]


def march_pass(ctx, state: HarcState, *, walk: str, mesh_tex, entry: dict, ig, fb_format: str, t_stop: float,
               max_steps: int, threads: int, scalar_check: int = 1, rows_per_block: int = 16,
               setup: str = "robust", segments=None) -> dict:
    """One propagation pass over all active rays (the kernel of this walk, set-up and integration:
    :func:`warpvol.kernels.harc.march_kernel`, one thread per active ray:
    :func:`warpvol.raycasting.stages.raycast.ray_blocks`); returns the summed counters by name (all zero,
    nothing launched, when no ray is active). ``setup``:
    ``robust`` (float64 ray set-up from the mesh, :func:`warpvol.kernels.walk.pixel_ray`) or
    ``paper`` (the ray from the eye in fp32, in the frame of ``fp32`` mesh textures). ``scalar_check``: the
    exact walk's bound on the crossings' scalar errors on (1) or off where it provably cannot fire (0: the
    frame's :func:`~warpvol.raycasting.stages.cell_setup.scalar_check_needed`). ``segments``
    (:func:`~warpvol.raycasting.stages.raycast.segments_struct`, the consistent walk with exact segments): each
    entry's segment is kept there (front and back ray parameter, its own colour and transmittance)."""
    import warp as wp

    from warpvol.kernels import harc as kh

    cells = ctx.buffers["cells"]
    if not state.work_clean:
        if state.candidates is None or not on_host(ctx.device):
            state.px_work.zero_()
        else:  # only the last pass's launched rays have work written
            host_view(state.px_work)[state.candidates] = 0
    state.work_clean = False
    status = state.status.numpy()
    active = pass_rays(status, int(kh.STATUS_ACTIVE), int(kh.STATUS_DONE), face_reach(ctx, entry, setup),
                       state.candidates)
    state.candidates = active if len(active) < state.n else None  # the next pass looks at these only
    ids, parts = ray_blocks(ctx, active, threads, rows_per_block)
    if not parts:
        return dict.fromkeys(COUNTER_NAMES, 0)
    counters = wp.zeros((len(parts), N_COUNTERS), dtype=wp.int32, device=ctx.device)
    # the kernel's inputs that stay the same through a frame's passes: built by its first pass, kept on the state
    # the consistent walk with exact segments (harc_best) marches in SIMD lanes on the CPU (raycast's lane count:
    # :func:`~warpvol.raycasting.stages.raycast.march_lanes`); the same bits as one ray per thread
    lanes = march_lanes(ctx.device) if (walk, setup, int(ig.mode)) == ("plucker", "robust", int(kh.INTEG_EXACT)) else 1
    key = (walk, setup, fb_format, float(t_stop), int(max_steps), int(scalar_check), id(mesh_tex), id(entry), id(ig),
           id(segments), lanes)
    kept = getattr(state, "pass_inputs", None)
    if kept is not None and kept[0] == key:
        common, segments, kernel, fm = kept[1:]
    else:
        eye_w = wp.vec3(*np.asarray(ctx.scene.camera.eye, np.float64).astype(np.float32))
        lists = kh.FragLists()
        for name in ("frag_start", "frag_bf", "bf_tet", "bf_face", "bf_nbr", "far", "bf_depth", "edge_start",
                     "edge_bf"):
            setattr(lists, name, entry[name])
        common = [camera_struct(ctx), eye_w, mesh_tex, cell_mesh_struct(cells), lists, ig,
                  get_format(fb_format).kernel_params(),
                  walk_opts(t_stop, max_steps, scalar_check, PEEL_TOL * cells["radius"])]
        if segments is None:
            segments = segments_struct(0, 0, ctx.device)
        fm = None
        if lanes > 1:
            from warpvol.kernels import lanes as kl
            from warpvol.kernels.lanes_march import march_lanes_kernel

            kernel = march_lanes_kernel(lanes, segments.cap > 0, harc=True)
            fm = kl.flat_mesh(common[3], ig.tf_v)
        else:
            kernel = kh.march_kernel(WALKS[walk], SETUPS[setup], ig.mode, segments.cap > 0)  # this configuration's
        state.pass_inputs = (key, common, segments, kernel, fm)

    if lanes > 1:
        from warpvol.kernels import lanes as kl

        size = kl.lane_scratch(max(f + c for f, c in parts), len(parts), lanes)
        scratch = getattr(state, "lane_scratch", None)
        if scratch is None or scratch.shape[0] < size:  # (kept through the frame's passes)
            scratch = state.lane_scratch = wp.empty(size, dtype=kl.LaneState, device=ctx.device)
        cam, _, _, mesh, lists, _, fb, opts = common

        def launch(b: int) -> None:
            first, count = parts[b]
            wp.launch(kernel, dim=kl.lane_threads(count, lanes), device=ctx.device,
                      inputs=[cam, mesh, lists, ig, opts, first, ids, state.rgba, state.px_work, state.tcur,
                              state.status, state.last, fb, counters, b, segments, count, scratch, fm])
    else:
        def launch(b: int) -> None:
            first, count = parts[b]
            wp.launch(kernel, dim=count, device=ctx.device,
                      inputs=common + [first, ids, state.rgba, state.tcur, state.status, state.last, counters, b,
                                       state.px_work, segments])

    launch_blocks(ctx.device, len(parts), launch, threads, modules=[kernel])
    return dict(zip(COUNTER_NAMES, (int(x) for x in counters.numpy().sum(axis=0))))


def resolve_failed(ctx, state: HarcState, terminate: float = 0.0) -> int:
    """Redo the rays marked failed in float64 on the host (whole ray, the reference's watertight
    tracer: :func:`warpvol.reference.pixels.redo_pixels_float64`; with skipping on, through the visible
    cells only, as the float32 walk); returns how many. ``terminate`` > 0: the redo stops a ray once no
    channel can change by more than that (the walk's stated early-termination bound)."""
    import warp as wp

    from warpvol.kernels import raycast as kr

    status = state.status.numpy()
    failed = np.flatnonzero(status == int(kr.STATUS_FAILED))
    if len(failed) == 0:
        return 0
    sc = ctx.scene
    ctx.mesh_setup(sc.mesh, *redo_mesh_properties(sc.camera))
    val = redo_pixels_float64(sc.mesh, sc.transfer, sc.camera, failed, visible=skipping(ctx)[0],
                              terminate=terminate or None)
    rgba = state.rgba.numpy()
    rgba[failed] = val
    status[failed] = int(kr.STATUS_DONE)
    state.rgba = write_back(state.rgba, rgba, wp.vec4)
    state.status = write_back(state.status, status, wp.int32)
    return int(len(failed))


def lost_rays(state: HarcState) -> int:
    """How many rays the paper's set-up lost (status :data:`warpvol.kernels.harc.STATUS_LOST`)."""
    from warpvol.kernels import harc as kh

    return int((state.status.numpy() == int(kh.STATUS_LOST)).sum())


def lost_warning(lost: int, n: int, backward: int = 0) -> str:
    """Report text for ``lost`` of ``n`` rays lost under the paper's set-up, and ``backward`` rays
    whose walk took a step with ``lambda' < lambda`` (suspect)."""
    parts = []
    if lost:
        parts.append(f"{lost:,} of {n:,} rays lost: the paper's fp32 walk (ray from the eye, float32 face planes) "
                     "found no entry or exit face, made no progress or reached the step bound; those pixels show "
                     "what the ray had composited until then")
    if backward:
        parts.append(f"{backward:,} rays took a step backwards (lambda' < lambda: float32 rounding chose the exit "
                     "face), their pixels may be wrong")
    return "; ".join(parts) + " (harc_best resolves them)"
