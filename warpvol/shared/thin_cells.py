"""Rays a float32 walk or a rasterised coverage cannot resolve, found on the host in float64.

* Cells too thin for a float32 walk: a tet thinner than ``2^-12`` of the mesh radius whose extinction
  makes that visible -- a segment through it whose length float32 knows only to ``2^-20`` of the radius
  (a sheet seen face-on), or a ray running inside it (a slab seen edge-on, its window footprint narrower
  than :data:`EDGE_ON_PX`; a needle along the rays). :func:`unresolved_pixels` gives the pixels whose
  rays may cross such a tet -- each tet's window box grown by a pixel -- which the exact presets trace
  again in float64 (:func:`warpvol.reference.pixels.redo_pixels_float64`).
* Pixel centres near an open edge of the front boundary (:func:`edge_pixels`, within :data:`EDGE_PX`):
  where a coverage snapped to 1/256 pixel can leave out the face a ray crosses with nothing of its layer
  listed instead. HARC's ray start tests those faces exactly; for the VSBUFFER sweep, whose ID buffers are
  rasterised, :func:`silhouette_pixels` and :func:`edge_on_pixels` (faces seen edge-on, in a sweep plane)
  give the pixels it traces again in float64.
"""

from __future__ import annotations

import numpy as np

from warpvol.scene.mesh import FACE_VERTS
from warpvol.shared.entry_bins import entry_face_mask, window_xy
from warpvol.shared.pixel_marks import near_segment_pixels

#: a tet thinner than this fraction of the mesh radius may be unresolved in float32
THIN = 2.0 ** -12
#: a thin tet whose window footprint is narrower than this (pixels) is taken as seen edge-on
EDGE_ON_PX = 1.0 / 64.0
#: a tet seen edge-on is unresolved when thinner than this fraction of the mesh radius (a ray inside it
#: cannot be told from one beside it; a thicker one seen edge-on is walked as any other)
EDGE_ON_THIN = 2.0 ** -16
#: a thin tet whose footprint is under NEEDLE_PX pixels every way and which reaches NEEDLE_RATIO times that
#: along the view is a needle along the rays: a ray inside it leaves through a face it nearly runs along
NEEDLE_PX, NEEDLE_RATIO = 1.0 / 16.0, 64.0
_EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


def thin_tets(mesh, transfer, length=None) -> np.ndarray:
    """(T,) bool: tets thinner than float32 resolves for their extinction. A float32 segment length is
    known to about ``2^-20`` of the mesh radius; where the transfer function's largest extinction over a
    tet's scalar range times that exceeds ``1e-5`` (an optical-depth error beyond the exact presets'
    tolerance) and the tet is thinner than :data:`THIN` of the radius (so not simply opaque), the pixels
    crossing it cannot be integrated exactly in float32. ``length`` (scalar or (T,)) replaces ``2^-20`` of
    the radius: e.g. each tet's diameter, for a ray that may run inside a tet seen edge-on."""
    thin, ext, radius, _ = _thin_geometry(mesh, transfer)
    return thin & (ext * (2.0 ** -20 * radius if length is None else length) > 1e-5)


#: tets per chunk of the shape measures
_CHUNK = 1 << 16


def _shape(mesh, cache: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per tet, its smallest altitude (the distance from a vertex to the plane of its opposite face, from
    ``mesh.face_planes``) and the indices of the needles: tets narrow across two directions, their largest
    face's area over their longest edge under 1 / :data:`NEEDLE_RATIO` of that edge (a plate, thin across
    one direction only, is not one); kept in ``cache`` for the next call with the same mesh."""
    if cache is not None and cache.get("mesh") is mesh:
        return cache["altitude"], cache["slender"]
    planes = mesh.face_planes  # face i is opposite vertex i
    pts, tets = np.asarray(mesh.points, np.float64), mesh.tets
    m = len(tets)
    altitude = np.empty(m, dtype=np.float64)
    slender = []
    for s in range(0, m, _CHUNK):  # in chunks: the per-vertex temporaries stay small
        p = pts[tets[s:s + _CHUNK]]
        pl = planes[s:s + _CHUNK]
        alt = np.abs(np.einsum("mfk,mfk->mf", pl[..., :3], p) + pl[..., 3]).min(axis=1)
        altitude[s:s + _CHUNK] = alt
        edge2 = np.max([((p[:, a] - p[:, b]) ** 2).sum(axis=1) for a, b in _EDGES], axis=0)
        # the largest face area from the altitudes: 3 V = h_i A_i, so A_max = 3 V / h_min
        a, b, c = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
        vol6 = np.abs(np.einsum("tk,tk->t", np.cross(a, b), c))
        with np.errstate(divide="ignore", invalid="ignore"):
            area_max = vol6 / (2.0 * alt)
        slender.append(s + np.flatnonzero(area_max * NEEDLE_RATIO < edge2))  # A_max / D < D / NEEDLE_RATIO
    slender = np.concatenate(slender) if slender else np.zeros(0, dtype=np.int64)
    if cache is not None:
        cache.update(mesh=mesh, altitude=altitude, slender=slender)
    return altitude, slender


def _extinction(mesh, transfer, k: np.ndarray) -> np.ndarray:
    """The TF's largest extinction over the scalar range of each tet ``k``."""
    sv = np.asarray(mesh.scalars)[np.asarray(mesh.tets)[k]]
    smin, smax = sv.min(axis=1), sv.max(axis=1)
    ts, te = transfer.s, transfer.extinction
    e = np.maximum(np.interp(smin, ts, te), np.interp(smax, ts, te))
    for i in range(len(ts)):
        e = np.where((smin <= ts[i]) & (ts[i] <= smax), np.maximum(e, te[i]), e)
    return e


def _thin_geometry(mesh, transfer, cache: dict | None = None) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """``(thin, extinction, radius, altitude)``: tets thinner than :data:`THIN` of the mesh radius, the TF's
    largest extinction over each tet's scalar range (0 where not thin), the radius, and each tet's smallest
    altitude (:func:`_shape`)."""
    lo, hi = mesh.bounds
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-300)
    altitude, _ = _shape(mesh, cache)
    thin = altitude < THIN * radius
    ext = np.zeros(len(thin))
    k = np.flatnonzero(thin)
    if len(k):
        ext[k] = _extinction(mesh, transfer, k)
    return thin, ext, radius, altitude


def footprint(pieces: np.ndarray, camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per tet of ``pieces`` (T, 4, 3): ``(width, longest, along)``: the width in pixels of its window footprint
    (projected area -- half the summed absolute areas of its projected faces -- over its longest projected
    edge; 0 where a point does not project), that longest edge in pixels, and its extent along the view
    direction over the footprint's longest extent in scene units (large: a needle along the rays)."""

    if len(pieces) == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    pieces = np.asarray(pieces, np.float64)
    wx, wy, bad, z = window_xy(camera, pieces.reshape(-1, 3))
    q = np.stack([wx, wy], axis=-1).reshape(-1, 4, 2)
    area = np.zeros(len(q))
    for a, b, c in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
        u, v = q[:, b] - q[:, a], q[:, c] - q[:, a]
        area += 0.25 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])  # half of each face's area
    longest = np.max([np.linalg.norm(q[:, b] - q[:, a], axis=1) for a, b in _EDGES], axis=0)
    bad = bad.reshape(-1, 4).any(axis=1)
    if camera.projection == "perspective":  # scene units per pixel at each tet's depth
        unit = 2.0 * np.tan(np.radians(camera.fov_y_deg) / 2.0) * np.abs(z.reshape(-1, 4)).mean(axis=1) / camera.height_px
    else:
        unit = np.full(len(q), camera.ortho_height / camera.height_px)
    depth = pieces @ np.asarray(camera.forward, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        width = np.where(longest > 0, area / longest, 0.0)
        along = (depth.max(axis=1) - depth.min(axis=1)) / (longest * unit)
    width = np.where(bad | ~np.isfinite(width), 0.0, width)
    return width, np.where(bad, np.inf, longest), np.where(bad | ~np.isfinite(along), np.inf, along)


def pixels_under(pieces: np.ndarray, camera) -> np.ndarray:
    """Flat indices of the pixels whose rays may cross any of the tets ``pieces`` (T, 4, 3): each tet's window
    box grown by one pixel (float64 projection; a tet reaching the eye plane of a perspective camera: every
    pixel)."""

    h, w = camera.height_px, camera.width_px
    if len(pieces) == 0:
        return np.zeros(0, np.int64)
    wx, wy, bad, z = (a.reshape(-1, 4) for a in window_xy(camera, np.asarray(pieces, np.float64).reshape(-1, 3)))
    if camera.projection == "perspective" and (bad.any() or (z <= 0).any()):
        return np.arange(h * w, dtype=np.int64)
    x0 = np.clip(np.floor(wx.min(axis=1) - 1.0), 0, w).astype(np.int64)
    x1 = np.clip(np.ceil(wx.max(axis=1) + 1.0), 0, w).astype(np.int64)
    y0 = np.clip(np.floor(wy.min(axis=1) - 1.0), 0, h).astype(np.int64)
    y1 = np.clip(np.ceil(wy.max(axis=1) + 1.0), 0, h).astype(np.int64)
    diff = np.zeros((h + 1, w + 1), np.int64)  # +1 / -1 at the box corners, summed over both axes
    np.add.at(diff, (y0, x0), 1)
    np.add.at(diff, (y0, x1), -1)
    np.add.at(diff, (y1, x0), -1)
    np.add.at(diff, (y1, x1), 1)
    return np.flatnonzero(diff.cumsum(axis=0).cumsum(axis=1)[:h, :w] > 0)


def _view_free_part(mesh, transfer, face_on: bool, cache: dict | None = None):
    """What :func:`unresolved_pixels` finds without the camera: ``(thin, thin_pieces, maybe, pieces, thin_maybe)``
    -- the tets unresolved whatever the view (indices, their corners (T, 4, 3)), the candidates the view decides on (seen edge-on or
    needles, of optical depth over 1e-5 along their diameter: indices, their corners (M, 4, 3), and whether
    each is thinner than :data:`EDGE_ON_THIN`). Per mesh and transfer function: kept in ``cache`` for the next
    frame with both unchanged (the transfer function compared by value)."""
    kept = _kept_view_free(mesh, transfer, face_on, cache)
    if kept is not None:
        return kept
    geom, ext, radius, altitude = _thin_geometry(mesh, transfer, cache)
    thin = geom & (ext * 2.0 ** -20 * radius > 1e-5) & face_on
    # seen edge-on: thinner than EDGE_ON_THIN; a needle along the rays: any slender tet
    maybe = np.union1d(np.flatnonzero(altitude < EDGE_ON_THIN * radius), _shape(mesh, cache)[1])
    maybe = maybe[~thin[maybe]]
    ext_m = _extinction(mesh, transfer, maybe) if len(maybe) else np.zeros(0)
    maybe, ext_m = maybe[ext_m > 0], ext_m[ext_m > 0]
    pieces = np.asarray(mesh.points, np.float64)[np.asarray(mesh.tets)[maybe]]
    diameter = np.max([np.linalg.norm(pieces[:, a] - pieces[:, b], axis=1) for a, b in _EDGES], axis=0) \
        if len(maybe) else np.zeros(0)
    deep = ext_m * diameter > 1e-5
    k = np.flatnonzero(thin)
    part = (k, np.asarray(mesh.points, np.float64)[np.asarray(mesh.tets)[k]], maybe[deep], pieces[deep],
            altitude[maybe[deep]] < EDGE_ON_THIN * radius)
    if cache is not None:
        cache["view_free"] = (mesh, _view_free_key(transfer, face_on), part)
    return part


def _view_free_key(transfer, face_on: bool) -> tuple:
    return (transfer.hash, bool(face_on))


def _kept_view_free(mesh, transfer, face_on: bool, cache: dict | None):
    """:func:`_view_free_part`'s result kept in ``cache`` for this mesh and transfer function, else None."""
    kept = cache.get("view_free") if cache is not None else None
    if kept is not None and kept[0] is mesh and kept[1] == _view_free_key(transfer, face_on):
        return kept[2]
    return None


def unresolved_pixels(mesh, transfer, camera, face_on: bool = True, cache: dict | None = None) -> tuple[np.ndarray, int]:
    """``(pixels, tets)``: the flat indices of the pixels whose rays may cross a tet a float32 walk cannot
    resolve -- too thin at its extinction (:func:`thin_tets`), or of optical depth over 1e-5 along its
    diameter and either thinner than :data:`EDGE_ON_THIN` of the radius and seen edge-on (window footprint
    under :data:`EDGE_ON_PX`) or a slender needle along the rays (:data:`NEEDLE_PX`, :data:`NEEDLE_RATIO`) --
    and how many such tets. ``face_on = False``: the tets seen edge-on only (for walks whose own
    thin-layer check resolves segments too short for float32). ``cache``: a dict kept between calls (the
    tets' altitudes, per mesh; what the view does not change, per mesh and transfer function)."""
    thin, thin_pieces, maybe, pieces, thin_maybe = _view_free_part(mesh, transfer, face_on, cache)
    width, longest, along = footprint(pieces, camera)
    keep = (thin_maybe & (width < EDGE_ON_PX)) | ((longest < NEEDLE_PX) & (along > NEEDLE_RATIO))
    # the candidates are not among the view-free thin tets: the two lists add up
    return pixels_under(np.concatenate([thin_pieces, pieces[keep]]), camera), int(len(thin) + keep.sum())


def mark_unresolved(ctx, status, failed: int) -> tuple[int, int]:
    """Set ``status`` (a per-pixel Warp int32 array) to ``failed`` at the pixels of the tets seen edge-on that a
    float32 walk cannot resolve (:func:`unresolved_pixels` with ``face_on = False``: the walk's own thin-layer
    check handles segments too short), so the march skips those rays and the float64 redo traces them;
    returns ``(rays, tets)``."""
    import warp as wp

    sc = ctx.scene
    cache = ctx.persistent.setdefault("thin_cells", {})
    if cache.get("mesh") is not sc.mesh:  # per mesh, kept: set-up, not frame time
        with ctx.setup_work("thin-cell shapes"):
            _shape(sc.mesh, cache)
    if _kept_view_free(sc.mesh, sc.transfer, False, cache) is None:  # per mesh and TF, kept: set-up
        with ctx.setup_work("thin-cell candidates"):
            _view_free_part(sc.mesh, sc.transfer, False, cache)
    pix, n_thin = unresolved_pixels(sc.mesh, sc.transfer, sc.camera, face_on=False, cache=cache)
    if len(pix):
        st = status.numpy()
        st[pix] = failed
        if not str(status.device).startswith("cpu"):  # (on the CPU ``st`` is a view of ``status``)
            wp.copy(status, wp.array(st, dtype=wp.int32, device=status.device))
    return int(len(pix)), n_thin


def surface_neighbours(tris: np.ndarray) -> np.ndarray:
    """``(B, 3)`` int32: for each triangle of ``tris`` (B, 3 point indices) the triangle sharing its
    edge ``k`` (opposite vertex ``k``), -1 where none of ``tris`` does."""
    b = len(tris)
    out = np.full((b, 3), -1, np.int64)
    if b == 0:
        return out.astype(np.int32)
    e = np.stack([tris[:, [1, 2]], tris[:, [2, 0]], tris[:, [0, 1]]], axis=1).reshape(-1, 2)
    e.sort(axis=1)
    key = e[:, 0].astype(np.int64) * (int(tris.max()) + 1) + e[:, 1]
    order = np.argsort(key, kind="stable")
    ks = key[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    a, c = order[same], order[same + 1]
    out.reshape(-1)[a] = c // 3
    out.reshape(-1)[c] = a // 3
    return out.astype(np.int32)


#: pixel centres within this distance (pixels) of a front face's open edge get the face tested exactly at the
#: ray start: about 6x the rasteriser's snapping error (1/512 px per coordinate), so a face whose snapped
#: coverage leaves out a centre it contains is always among them
EDGE_PX = 1.0 / 64.0


def edge_pixels(mesh, camera, tris: np.ndarray, nbr: np.ndarray, delta: float = EDGE_PX,
                chunk: int = 1 << 20) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel, the front faces with an *open* edge passing within ``delta`` pixels of its centre, as CSR
    ``(start (H*W+1), face)`` (float64 window coordinates of :func:`window_xy
    <warpvol.shared.entry_bins.window_xy>`, edges clipped to the eye's front half-space).

    An edge is open where the front faces on its two sides do not both cover a band of the window along it:
    no front face beyond it (a silhouette, the outline of a part) or a face on either side narrower than
    ``delta`` in the window (seen edge-on, thinner than the snapping, a cell smaller than a pixel); within
    ``delta`` of an open edge's end, every front face at that vertex. Only
    there can the rasteriser's snapped coverage leave out a face at a centre it contains with nothing of
    its layer listed instead (a deeper layer, or no face at all); elsewhere the face across the edge is
    listed, and the entry search's consistent edge test rejects it and searches its surface rings. The
    kernel tests these faces exactly at every ray start and takes the nearest crossing."""

    w, h = camera.width_px, camera.height_px
    wx, wy, bad, _ = window_xy(camera, np.asarray(mesh.points, np.float64)[tris.reshape(-1)])
    win = np.stack([wx, wy], axis=-1).reshape(-1, 3, 2)
    e1, e2 = win[:, 1] - win[:, 0], win[:, 2] - win[:, 0]
    longest = np.sqrt(np.max([(e * e).sum(axis=1) for e in (e1, e2, win[:, 2] - win[:, 1])], axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        height = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / longest  # the triangle's least width
    wide = (height >= delta) & ~bad.reshape(-1, 3).any(axis=1)  # NaN (a point on the eye plane): narrow
    b, k = np.nonzero((nbr < 0) | ~wide[:, None] | ~wide[np.maximum(nbr, 0)])  # open edge k of face b
    a3 = mesh.points[tris[b, (k + 1) % 3]].astype(np.float64)  # its vertices k + 1, k + 2
    b3 = mesh.points[tris[b, (k + 2) % 3]].astype(np.float64)
    fwd = np.asarray(camera.forward, np.float64)
    if camera.projection == "perspective":  # keep the part in front of the eye (a ray meets nothing behind it)
        za, zb = (a3 - camera.eye) @ fwd, (b3 - camera.eye) @ fwd
        lo, hi = mesh.bounds  # of the points the tets use
        ext = float((hi - lo).max()) + float(np.abs(np.stack([lo, hi]) - camera.eye).max())
        zmin = 1e-9 * ext
        keep = (za > zmin) | (zb > zmin)
        b, k, a3, b3, za, zb = b[keep], k[keep], a3[keep], b3[keep], za[keep], zb[keep]
        with np.errstate(divide="ignore", invalid="ignore"):
            c = a3 + np.clip((zmin - za) / (zb - za), 0.0, 1.0)[:, None] * (b3 - a3)  # the point at z = zmin
        a3 = np.where((za < zmin)[:, None], c, a3)
        b3 = np.where((zb < zmin)[:, None], c, b3)
    ax, ay, _, _ = window_xy(camera, a3)
    bx, by, _, _ = window_xy(camera, b3)
    pix, face = [], []
    for lo in range(0, len(b), chunk):
        sl = slice(lo, lo + chunk)
        p, f = _near_segments(ax[sl], ay[sl], bx[sl], by[sl], b[sl], w, h, delta)
        pix.append(p)
        face.append(f)
    # around an open edge's ends every front face at the vertex: the one a ray past the vertex crosses may have
    # no open edge of its own (a fan cut by the silhouette at that vertex)
    ends = np.unique(np.r_[tris[b, (k + 1) % 3], tris[b, (k + 2) % 3]]) if len(b) else np.zeros(0, np.int64)
    if len(ends):
        vx, vy, _, vz = window_xy(camera, np.asarray(mesh.points, np.float64)[ends])
        if camera.projection == "perspective":
            vx = np.where(vz > 0, vx, np.nan)
        vp, vi = _near_segments(vx, vy, vx, vy, np.arange(len(ends)), w, h, delta)
        inc_t = np.repeat(np.arange(len(tris)), 3)  # front faces by vertex (CSR over ends)
        inc_v = np.searchsorted(ends, tris.reshape(-1))
        hit = (inc_v < len(ends)) & (ends[np.minimum(inc_v, len(ends) - 1)] == tris.reshape(-1))
        order = np.argsort(inc_v[hit], kind="stable")
        inc_t, inc_v = inc_t[hit][order], inc_v[hit][order]
        vstart = np.searchsorted(inc_v, np.arange(len(ends) + 1))
        cnt = vstart[vi + 1] - vstart[vi]
        at = np.repeat(vstart[vi], cnt) + np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        pix.append(np.repeat(vp, cnt))
        face.append(inc_t[at])
    pix = np.concatenate(pix) if pix else np.zeros(0, np.int64)
    face = np.concatenate(face) if face else np.zeros(0, np.int64)
    key = np.unique(pix * (len(tris) + 1) + face)  # one pair per (pixel, face), grouped by pixel
    pix, face = key // (len(tris) + 1), key % (len(tris) + 1)
    # the CSR starts from the few listed pixels (sorted): start[q] = pairs of pixels below q, constant between
    # listed pixels, so one repeat of the running counts (no bincount and sum over the window)
    u, c = np.unique(pix, return_counts=True)
    runs = np.diff(np.concatenate([[0], u + 1, [w * h + 1]]))
    dtype = np.int32 if len(pix) < 2 ** 31 else np.int64  # (int32: what the kernels read, no conversion)
    start = np.repeat(np.concatenate([[0], np.cumsum(c)]).astype(dtype), runs)
    return start, face


def _near_segments(ax, ay, bx, by, ids, w: int, h: int, delta: float):
    """``(pixel, id)`` pairs: pixel centres within ``delta`` of the window-space segments ``a b``
    (:func:`warpvol.shared.pixel_marks.near_segment_pixels`), each with its segment's entry of ``ids``."""

    pix, k = near_segment_pixels(ax, ay, bx, by, w, h, delta)
    return pix, np.asarray(ids)[k]


def silhouette_pixels(mesh, camera) -> np.ndarray:
    """Flat indices of the pixels whose centre lies within :data:`EDGE_PX` of an open
    edge of the front boundary (:func:`edge_pixels`): where a rasterised coverage
    snapped to 1/256 pixel can leave out the cell a ray crosses."""

    tris = mesh.boundary_triangles()[entry_face_mask(mesh, camera)]
    if len(tris) == 0:
        return np.zeros(0, np.int64)
    start, _ = edge_pixels(mesh, camera, tris, surface_neighbours(tris))
    return np.flatnonzero(np.diff(start) > 0)


def edge_on_pixels(mesh, camera, delta: float | None = None) -> np.ndarray:
    """Flat indices of the pixels whose centre lies within ``delta`` (default
    :data:`EDGE_PX`) of a face of the mesh seen edge-on (window footprint narrower
    than ``delta``): a face in a VSBUFFER sweep plane, or a ray inside it, where rasterised coverage does
    not decide which cell the ray crosses."""

    delta = EDGE_PX if delta is None else delta
    w, h = camera.width_px, camera.height_px
    wx, wy, bad, _ = window_xy(camera, np.asarray(mesh.points, np.float64))
    tri = np.asarray(mesh.tets)[:, FACE_VERTS].reshape(-1, 3)  # every tet's faces (shared ones twice)
    x, y = wx[tri], wy[tri]
    e = [(x[:, b] - x[:, a], y[:, b] - y[:, a]) for a, b in ((0, 1), (0, 2), (1, 2))]
    longest = np.sqrt(np.max([dx * dx + dy * dy for dx, dy in e], axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        width = np.abs(e[0][0] * e[1][1] - e[0][1] * e[1][0]) / longest
    on = np.flatnonzero((width < delta) & ~bad[tri].any(axis=1))
    if len(on) == 0:
        return np.zeros(0, np.int64)
    pix = [_near_segments(x[on, a], y[on, a], x[on, b], y[on, b], on, w, h, delta)[0]
           for a, b in ((0, 1), (0, 2), (1, 2))]
    return np.unique(np.concatenate(pix))
