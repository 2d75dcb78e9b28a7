"""Cells projected tetrahedra cannot draw right in float32: thin cells that carry the image, and the
pixels where the eye lies in the plane of a face.

Cell projection computes each fragment's thickness ``l`` from float32 window positions and
eye-space depths interpolated across the projected triangles (positions snapped to 1/256 pixel). A
tet whose smallest height is below :data:`THIN_ULPS` float32 units of the mesh radius has a
thickness float32 resolves only coarsely, and seen at a grazing angle its triangles are slivers the
snapping moves by more than their width; when its density times that thickness error exceeds
:data:`THIN_TAU` the pixels it covers may be visibly wrong (:func:`thin_tets`). Likewise a face whose
plane passes within float32 resolution of the perspective eye projects to a segment: the tets on
either side are classified by rounding (:func:`edge_on_faces`).

:func:`unresolved_pixels` finds both in float64 on the host, from the scene alone, and returns the
pixels they cover (their projected bounding boxes grown by one pixel); ``pt_integrate`` redoes those
pixels with the float64 ray tracer (:func:`warpvol.reference.pixels.redo_pixels_float64`)
and counts them.
"""

from __future__ import annotations

import numpy as np

from warpvol.scene.tf_ranges import density_bound, density_max, slope_max
from warpvol.shared.pixel_marks import (
    InFront,
    _mark_boxes,
    _mark_near_edges,
    _segment_samples,
    near_segment_pixels_warp,
)

#: a tet whose smallest height is below this many float32 units (2^-23) of the mesh radius is thin
THIN_ULPS = 1024.0
#: ... and matters when its largest density times its thickness error exceeds this optical depth
THIN_TAU = 2e-3  # half of pt_best's max_abs tolerance (tests/tolerances.py)
#: a face plane within this many float32 units (of the eye's distance to the mesh plus the mesh
#: radius) of the perspective eye is seen edge-on
EDGE_ON_ULPS = 64.0
EPS32 = float(np.finfo(np.float32).eps)
#: window coordinates beyond this magnitude are infinite (:func:`project_points`): a point at or behind
#: the eye plane, or so far to the side that float64 could not hold its window position
WINDOW_LIMIT = 1e300
#: pixel centres within this many pixels of a sliver face's projection (:func:`snap_edge_on_faces`) may
#: be cut on the wrong side of it: four times the rasteriser's 1/256-pixel snapping
SLIVER_PX = 4.0 / 256.0
#: a face projected narrower than this (pixels) may flip its orientation when its vertices are snapped to
#: 1/256 pixel (each moves up to 1/512): 1/256 with a factor 2 of margin
SNAP_FLIP_PX = 2.0 / 256.0
#: :func:`rough_tets` flags a tet when its bound exceeds this: the bound is far from tight (the sphere's
#: 64-point rough transfer function is flagged at 2e-3 and drawn within 1.4e-4 without a redo); at 0.05
#: the Blunt Fin (a smooth transfer function) adds 13 / 6 pixels at 128^2 / 512^2 (599 / 1,792 at 2e-3),
#: and transfer functions of 4,096 and 20,000 rough control points still flag every tet of the sphere
ROUGH_TAU = 0.05
#: :func:`rounding_bound`'s factor over one tet's rounding: pt_best's largest errors on the sphere with
#: 4,096, 10,000 and 20,000 control points of random colour and extinction (64^2) were 3.2x, 2.5x and
#: 2.5x the largest per-tet term (fragments along a ray add up; at 512 points, 8x, other errors dominate
#: and the image stays within 5e-4)
ROUNDING_FACTOR = 4.0


def _geometry(mesh, tf) -> dict:
    """View-independent part of :func:`thin_tets` (cached on the mesh per transfer function): the
    candidate tets (smallest height below :data:`THIN_ULPS` float32 units of the mesh radius), their
    volumes, longest edges and largest densities, and the mesh radius."""
    key = np.asarray(tf.points).tobytes() + tf.emission.encode()
    cache = mesh.__dict__.setdefault("_pt_thin_cache", {})
    if key in cache:
        return cache[key]
    pts = np.asarray(mesh.points, dtype=np.float64)
    tets = np.asarray(mesh.tets)
    lo, hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds)  # of the points the tets use
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    p = [pts[tets[:, k]] for k in range(4)]
    vol6 = np.abs(np.einsum("ij,ij->i", p[1] - p[0], np.cross(p[2] - p[0], p[3] - p[0])))
    area2 = np.max([np.linalg.norm(np.cross(p[b] - p[a], p[c] - p[a]), axis=1)
                    for a, b, c in ((1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2))], axis=0)
    height = vol6 / np.maximum(area2, 1e-300)  # 3 V / largest face area
    cand = np.flatnonzero(height < THIN_ULPS * EPS32 * radius)
    sc = np.asarray(mesh.scalars, dtype=np.float64)[tets[cand]]
    diam = np.max([np.linalg.norm(p[a][cand] - p[b][cand], axis=1)
                   for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))], axis=0) if len(cand) else \
        np.zeros(0)
    dens = density_max(tf, sc.min(axis=1), sc.max(axis=1)) if len(cand) else np.zeros(0)
    keep = dens > 0.0  # a tet without density cannot matter
    out = {"cand": cand[keep], "vol": vol6[cand][keep] / 6.0, "diam": diam[keep], "dens": dens[keep],
           "radius": radius}
    cache.clear()
    cache[key] = out
    return out


def project_points(mesh, camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Window columns, rows (float64, pixel centres at +0.5) and eye depths of every point of ``mesh``:
    one projection per frame, gathered by :func:`_window` for each set of tets or faces."""
    w, h = camera.width_px, camera.height_px
    rel = np.asarray(mesh.points, dtype=np.float64) - np.asarray(camera.eye, dtype=np.float64)
    x, y, d = rel @ camera.right, rel @ camera.true_up, rel @ camera.forward
    lim = WINDOW_LIMIT / (max(w, h) + 1.0)  # |ndc| up to this keeps the window coordinates below WINDOW_LIMIT
    if camera.projection == "perspective":
        th = np.tan(np.radians(camera.fov_y_deg) / 2.0)
        dd = np.maximum(d, 1e-300)
        xn, yn = _ratio(x, dd * th * camera.aspect, lim), _ratio(y, dd * th, lim)
    else:
        hh = camera.ortho_height / 2.0
        xn, yn = _ratio(x, np.full_like(x, hh * camera.aspect), lim), _ratio(y, np.full_like(y, hh), lim)
    return (xn + 1.0) * 0.5 * w, (1.0 - yn) * 0.5 * h, d



def _ratio(num: np.ndarray, den: np.ndarray, lim: float) -> np.ndarray:
    """``num / den`` (``den`` > 0), ``+-inf`` where its magnitude would exceed ``lim``: what the plain
    division and the window transform gave through float64 overflow, computed without overflowing.

    Examples
    --------
    >>> _ratio(np.array([1.0, -1e10, 0.0, 1e308]), np.array([2.0, 1e-300, 1e-300, 1e-10]), 1e200).tolist()
    [0.5, -inf, 0.0, inf]
    """
    far = np.abs(num) / lim > den
    return np.divide(num, den, out=np.copysign(np.full(num.shape, np.inf), num), where=~far)


def _window(mesh, camera, tets: np.ndarray, proj=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Window columns, rows (float64, pixel centres at +0.5) and eye depths of the vertices of
    ``tets``, each (n, 4), gathered from ``proj`` (:func:`project_points` of the mesh's points; computed
    here when not given)."""
    col, row, d = project_points(mesh, camera) if proj is None else proj
    idx = np.asarray(mesh.tets)[tets]
    return col[idx], row[idx], d[idx]


def thin_tets(mesh, tf, camera, tau: float = THIN_TAU, proj=None, drawn=None) -> np.ndarray:
    """Indices of the tets thinner than float32 resolves (smallest height below :data:`THIN_ULPS`
    float32 units of the mesh radius) whose fragments may be visibly wrong: largest density over the
    tet's scalar range times the thickness error -- float32 depth resolution (4 units of the radius)
    plus, for a tet whose projection is narrower than the rasteriser's 1/256-pixel snapping, its
    largest thickness along the view (3 V / projected area) scaled by how much the snapping moves it
    -- above ``tau`` (:data:`THIN_TAU` by default). ``drawn`` (bool per tet): only among these;
    ``proj``: :func:`project_points`, when the caller has it."""
    g = _geometry(mesh, tf)
    keep = np.ones(len(g["cand"]), bool) if drawn is None else drawn[g["cand"]]
    cand = g["cand"][keep]
    if len(cand) == 0:
        return cand
    g = {k: (v[keep] if k in ("vol", "diam", "dens") else v) for k, v in g.items()}
    col, row, depth = _window(mesh, camera, cand, proj)
    tri = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
    area_px = 0.25 * sum(np.abs((col[:, b] - col[:, a]) * (row[:, c] - row[:, a])
                                - (col[:, c] - col[:, a]) * (row[:, b] - row[:, a])) for a, b, c in tri)
    longest = np.max([np.hypot(col[:, a] - col[:, b], row[:, a] - row[:, b])
                      for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))], axis=0)
    width_px = area_px / np.maximum(longest, 1e-300)  # hull area / longest projected edge
    if camera.projection == "perspective":
        px_size = 2.0 * np.abs(depth).mean(axis=1) * np.tan(np.radians(camera.fov_y_deg) / 2.0) / camera.height_px
    else:
        px_size = np.full(len(cand), camera.ortho_height / camera.height_px)
    lmax = np.minimum(g["diam"], 3.0 * g["vol"] / np.maximum(area_px * px_size ** 2, 1e-300))
    snap = np.minimum(1.0, (1.0 / 256.0) / np.maximum(width_px, 1e-300))
    err = g["dens"] * (4.0 * EPS32 * g["radius"] + lmax * snap)
    return cand[err > tau]


def _slopes(mesh, tf) -> dict:
    """View-independent part of :func:`rough_tets` and :func:`rounding_bound` (cached on the mesh per
    transfer function): per tet its scalar range and ``rate``, the transfer function's steepest colour
    slope plus its steepest extinction slope times the tet's longest edge over that range (a value
    change per unit scalar), and ``relative_rate``, the same per unit of the scalar's size."""
    key = np.asarray(tf.points).tobytes() + tf.emission.encode()
    cache = mesh.__dict__.setdefault("_pt_slopes", {})
    if key in cache:
        return cache[key]
    tets = np.asarray(mesh.tets)
    sc = np.asarray(mesh.scalars, dtype=np.float64)[tets]
    smin, smax = sc.min(axis=1), sc.max(axis=1)
    colour, ext = slope_max(tf, smin, smax)
    rel_colour, rel_ext = slope_max(tf, smin, smax, relative=True)
    pts = np.asarray(mesh.points, dtype=np.float64)
    diam = np.sqrt(np.max([((pts[tets[:, a]] - pts[tets[:, b]]) ** 2).sum(axis=1)
                           for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))], axis=0))
    out = {"smin": smin, "smax": smax, "rate": colour + ext * diam, "relative_rate": rel_colour + rel_ext * diam}
    cache.clear()
    cache[key] = out
    return out


def rough_tets(mesh, tf, camera, tau: float = ROUGH_TAU, proj=None, drawn=None) -> np.ndarray:
    """Indices of the tets whose colour may be off by more than ``tau`` where the rasteriser's snapped
    coverage and the exact attribute planes part (within :data:`SNAP_FLIP_PX` of the projected
    edges): the transfer function's steepest rate over the tet's scalar range (:func:`_slopes`) times
    the scalar's screen gradient (range over projected width) times that distance. A smooth transfer
    function flags few; one of thousands of rough control points flags most tets. ``drawn``, ``proj``: as
    :func:`thin_tets`."""
    g = _slopes(mesh, tf)
    if "change" not in g:  # per mesh and transfer function, kept with the slopes
        g["change"] = g["rate"] * (g["smax"] - g["smin"])  # the largest value change across the tet
    change = g["change"]
    steep = g.get(("steep", tau))
    if steep is None:  # the bound below is at most the change itself
        steep = g[("steep", tau)] = np.flatnonzero(change > tau)
    cand = steep if drawn is None else steep[drawn[steep]]
    if len(cand) == 0:
        return cand
    col, row, _ = _window(mesh, camera, cand, proj)
    area_px = 0.25 * sum(np.abs((col[:, b] - col[:, a]) * (row[:, c] - row[:, a])
                                - (col[:, c] - col[:, a]) * (row[:, b] - row[:, a]))
                         for a, b, c in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)))
    longest2 = np.max([(col[:, a] - col[:, b]) ** 2 + (row[:, a] - row[:, b]) ** 2
                       for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))], axis=0)
    # change SNAP_FLIP_PX / max(width, SNAP_FLIP_PX) > tau with width = area / longest edge (change > tau
    # here): width < change SNAP_FLIP_PX / tau, squared
    return cand[area_px * area_px < longest2 * (change[cand] * (SNAP_FLIP_PX / tau)) ** 2]


def rounding_bound(mesh, tf) -> tuple[float, int]:
    """``(bound, tets)``: an estimate of the largest colour error float32 rounding of the fragments'
    ``(sf, sb)`` causes (:data:`ROUNDING_FACTOR` times the largest per tet of the transfer function's
    steepest rate times one float32 unit of the scalar where that rate holds, :func:`_slopes`), and
    how many tets reach :data:`THIN_TAU` by it. A steep transfer function (thousands of rough control
    points) is what makes it matter: there a scalar moved by one unit in the last place crosses a
    visible share of a segment."""
    g = _slopes(mesh, tf)
    if "rounding_bound" not in g:  # per mesh and transfer function, kept with the slopes
        per = ROUNDING_FACTOR * g["relative_rate"] * EPS32
        g["rounding_bound"] = (float(per.max(initial=0.0)), int((per > THIN_TAU).sum()))
    return g["rounding_bound"]


def _face_planes(mesh) -> dict:
    """Every face of the mesh once (sorted vertex triples) with the tets on either side (``owners``, -1:
    none), its unnormalised normal ``n`` and offset
    ``c = n . p0`` in float64 (cached on the mesh): the plane test of :func:`edge_on_faces` is then one
    dot product per face and frame."""
    cache = mesh.__dict__.setdefault("_pt_face_planes", {})
    if "faces" in cache:
        return cache
    pts = np.asarray(mesh.points, dtype=np.float64)
    tets = np.asarray(mesh.tets)
    faces, inv = np.unique(np.sort(tets[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3), axis=1),
                           axis=0, return_inverse=True)
    inv = inv.ravel()
    o = np.argsort(inv, kind="stable")  # the tets on either side of each face (-1: none)
    first = np.r_[True, inv[o][1:] != inv[o][:-1]]
    owners = np.full((len(faces), 2), -1, dtype=np.int64)
    owners[inv[o][first], 0], owners[inv[o][~first], 1] = o[first] // 4, o[~first] // 4
    p0, p1, p2 = pts[faces[:, 0]], pts[faces[:, 1]], pts[faces[:, 2]]
    n = np.cross(p1 - p0, p2 - p0)
    nn = np.linalg.norm(n, axis=1)
    longest = np.max([np.linalg.norm(p1 - p0, axis=1), np.linalg.norm(p2 - p0, axis=1), np.linalg.norm(p2 - p1, axis=1)],
                     axis=0)
    cache.update(faces=faces, owners=owners, n=n, c=np.einsum("ij,ij->i", n, p0), nn=nn, p0=p0,
                 height=nn / np.maximum(longest, 1e-300))
    return cache


def drawn_faces(mesh, drawn: np.ndarray | None, cached_only: bool = False):
    """``(rows, planes)``: the rows of :func:`_face_planes` with a ``drawn`` tet on either side and those
    rows of it (``rows`` ``None``: every face, when every tet is drawn), kept on the mesh for the last
    ``drawn`` set (per transfer function: set-up); ``cached_only``: ``None`` when not kept yet."""
    fp = _face_planes(mesh)
    if drawn is None or drawn.all():
        return None, fp
    key = np.packbits(drawn).tobytes()
    cache = mesh.__dict__.setdefault("_pt_drawn_faces", {})
    if key not in cache:
        if cached_only:
            return None
        rows = np.flatnonzero(np.r_[drawn, False][fp["owners"]].any(axis=1))  # owner -1: none
        cache.clear()
        cache[key] = rows, {k: fp[k][rows] for k in ("faces", "n", "c", "nn", "p0", "height")}
    return cache[key]


def edge_on_faces(mesh, camera, ids: bool = False, drawn=None) -> np.ndarray:
    """The faces ``(n, 3)`` vertex indices) whose plane passes within float32 resolution of a
    perspective eye: each projects to a segment and the tets on either side are classified by
    rounding. Empty for orthographic cameras (no eye point). ``ids``: their rows of :func:`_face_planes`;
    ``drawn`` (bool per tet): only faces of these tets (:func:`drawn_faces`)."""
    if camera.projection != "perspective":
        return np.zeros(0 if ids else (0, 3), dtype=np.int64)
    pts = np.asarray(mesh.points, dtype=np.float64)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    eye = np.asarray(camera.eye, dtype=np.float64)
    tol = EDGE_ON_ULPS * EPS32 * (float(np.linalg.norm(eye - centre)) + radius)
    rows, fp = drawn_faces(mesh, drawn)
    dist = fp["n"] @ eye  # times |n|: the eye's distance to each face's plane
    dist -= fp["c"]
    np.abs(dist, out=dist)
    hit = np.flatnonzero(dist < tol * fp["nn"])  # never where |n| = 0
    return (hit if rows is None else rows[hit]) if ids else fp["faces"][hit]


def snap_edge_on_faces(mesh, tf, camera, tau: float = THIN_TAU, ids: bool = False, proj=None,
                       drawn=None) -> np.ndarray:
    """Faces ``(n, 3)`` whose projection is narrower than the rasteriser's snapping can keep apart: snapping
    moves each vertex by up to 1/512 pixel, so a projected triangle less than 1/256 pixel high (here, with
    margin, 2/256) can lose or flip its orientation, and the tets on either side are then cut into
    triangles on the wrong side of it -- a pixel centre inside the sliver takes its front or back point
    from the wrong face, a thickness error up to the depth difference across the sliver: at most the face's
    extent along the view and at most its own height (so a needle-shaped face, narrow in every view, is
    thin in depth too). Marked when, in that regime, the largest density over the face's scalar range
    times that depth difference exceeds ``tau`` (a face seen edge-on).

    Only faces that can be that narrow are projected: the projected height of a triangle is at least its
    height in its plane times ``|cos|`` (normal against the view ray) over twice the pixel size (per-mesh
    heights). ``ids``, ``drawn``: as :func:`edge_on_faces`; ``proj``: :func:`project_points`."""
    rows, fp = drawn_faces(mesh, drawn)
    faces = fp["faces"]
    none = np.zeros(0 if ids else (0, 3), dtype=np.int64)
    dens_all = density_bound(tf)  # a bound for every face
    if len(faces) == 0 or dens_all <= 0.0:
        return none
    eye = np.asarray(camera.eye, dtype=np.float64)
    wide = SNAP_FLIP_PX
    if camera.projection == "perspective":
        # width >= h |cos| / (2 px), px = 2 tan depth / H, |cos| = |n . rel| / (|n| |rel|); inside the view
        # frustum |rel| <= corner depth: a face with h |n . rel| >= wide 4 tan corner depth^2 |n| / H is wider
        fwd = np.asarray(camera.forward, np.float64)
        rhs = fp["p0"] @ fwd  # in place from here: one pass per operation over every face
        rhs -= eye @ fwd
        rhs *= rhs
        th = np.tan(np.radians(camera.fov_y_deg) / 2.0)
        corner = np.sqrt(1.0 + th * th * (1.0 + camera.aspect * camera.aspect))
        rhs *= fp["nn"]
        rhs *= wide * 4.0 * th * corner / camera.height_px
        lhs = fp["n"] @ eye
        lhs -= fp["c"]
    else:
        px = camera.ortho_height / camera.height_px
        lhs, rhs = fp["n"] @ np.asarray(camera.forward, np.float64), wide * 2.0 * px * fp["nn"]
    np.abs(lhs, out=lhs)
    lhs *= fp["height"]
    cand = np.flatnonzero(lhs < rhs)
    cand = cand[(dens_all * fp["height"][cand] > tau) & (fp["nn"][cand] > 0)]
    if len(cand) == 0:
        return none
    col, row, depth = _window(TetMeshFaces(mesh, faces[cand]), camera, np.arange(len(cand)), proj)
    col, row, depth = col[:, :3], row[:, :3], depth[:, :3]
    area2 = np.abs((col[:, 1] - col[:, 0]) * (row[:, 2] - row[:, 0]) - (col[:, 2] - col[:, 0]) * (row[:, 1] - row[:, 0]))
    longest = np.max([np.hypot(col[:, a] - col[:, b], row[:, a] - row[:, b]) for a, b in ((0, 1), (0, 2), (1, 2))],
                     axis=0)
    width = area2 / np.maximum(longest, 1e-300)  # the triangle's projected height, pixels
    # across the sliver two points of the face differ in depth by at most its extent along the view and
    # at most its own height (a needle-shaped face is thin in every view, and thin in depth too)
    span = np.minimum(depth.max(axis=1) - depth.min(axis=1), fp["height"][cand])
    keep = (width < wide) & (dens_all * span > tau)
    cand, span = cand[keep], span[keep]
    if len(cand) == 0:
        return none
    sc = np.asarray(mesh.scalars, dtype=np.float64)[faces[cand]]
    dens = density_max(tf, sc.min(axis=1), sc.max(axis=1))
    hit = cand[dens * span > tau]
    return (hit if rows is None else rows[hit]) if ids else faces[hit]


def _boundary_edges(mesh, tf) -> dict:
    """View-independent part of :func:`silhouette_edges` (cached on the mesh per transfer function):
    each boundary edge with its two boundary triangles (outward normals) and the largest density of
    the two cells they bound."""
    key = np.asarray(tf.points).tobytes() + tf.emission.encode()
    cache = mesh.__dict__.setdefault("_pt_boundary_edges", {})
    if key in cache:
        return cache[key]
    pts = np.asarray(mesh.points, dtype=np.float64)
    tris = np.asarray(mesh.boundary_triangles(), dtype=np.int64)
    cells = np.asarray(mesh.boundary_faces)[:, 0]
    out = {"a": np.zeros(0, np.int64), "b": np.zeros(0, np.int64), "f1": np.zeros(0, np.int64),
           "f2": np.zeros(0, np.int64), "dens": np.zeros(0), "normals": np.zeros((0, 3)), "centres": np.zeros((0, 3))}
    if len(tris):
        e = np.stack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]], axis=1).reshape(-1, 2)
        fid = np.repeat(np.arange(len(tris)), 3)
        key2 = np.sort(e, axis=1)
        order = np.lexsort((key2[:, 1], key2[:, 0]))
        k = key2[order]
        same = (k[1:] == k[:-1]).all(axis=1)  # manifold boundary: each edge twice, in consecutive rows
        i = np.flatnonzero(same)
        f1, f2 = fid[order[i]], fid[order[i + 1]]
        sc = np.asarray(mesh.scalars, dtype=np.float64)[np.asarray(mesh.tets)[cells]]
        dcell = density_max(tf, sc.min(axis=1), sc.max(axis=1))
        p = pts[tris]
        out = {"a": k[i, 0], "b": k[i, 1], "f1": f1, "f2": f2, "dens": np.maximum(dcell[f1], dcell[f2]),
               "normals": np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), "centres": p.mean(axis=1)}
    cache.clear()
    cache[key] = out
    return out


def silhouette_edges(mesh, tf, camera, ids: bool = False) -> np.ndarray:
    """Boundary edges on the silhouette (one of their two boundary triangles faces the eye, the other
    faces away) where a shift of the rasteriser's 1/256-pixel snapping changes the thickness of the
    fragments beside the edge by more than :data:`THIN_TAU` of optical depth: density times the snap's
    world size times the grazing factors ``1 / |cos|`` of the two faces to the view ray. Inside the mesh a
    neighbour's fragment makes up what one cell's snapped edge loses; at the silhouette nothing does.
    Returns ``(n, 2)`` vertex indices (``ids``: their rows of :func:`_boundary_edges`)."""
    g = _boundary_edges(mesh, tf)
    if len(g["a"]) == 0:
        return np.zeros(0 if ids else (0, 2), dtype=np.int64)
    eye = np.asarray(camera.eye, dtype=np.float64)
    if "unit_normals" not in g:  # view-independent: kept with the edges
        g["unit_normals"] = g["normals"] / np.maximum(np.linalg.norm(g["normals"], axis=1, keepdims=True), 1e-300)
    nrm = g["unit_normals"]
    if camera.projection == "perspective":
        view = g["centres"] - eye
        depth = view @ camera.forward
        view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-300)
        px = 2.0 * np.abs(depth) * np.tan(np.radians(camera.fov_y_deg) / 2.0) / camera.height_px
    else:
        view = np.broadcast_to(camera.forward, nrm.shape)
        px = np.full(len(nrm), camera.ortho_height / camera.height_px)
    cos = np.einsum("ij,ij->i", nrm, view)
    f1, f2 = g["f1"], g["f2"]
    sil = (cos[f1] < 0) != (cos[f2] < 0)
    grazing = 1.0 / np.maximum(np.abs(cos[f1]), 1e-6) + 1.0 / np.maximum(np.abs(cos[f2]), 1e-6)
    err = g["dens"] * (0.5 * (px[f1] + px[f2]) / 256.0) * grazing
    hit = sil & (err > THIN_TAU)
    return np.flatnonzero(hit) if ids else np.column_stack([g["a"][hit], g["b"][hit]])


def _view_independent_parts(edge_on: bool = True, silhouettes: bool = True, rough: bool = False) -> dict:
    """The view-independent parts :func:`unresolved_pixels` reads: name -> (mesh attribute of its
    cache, whether keyed by the transfer function, function computing it)."""
    parts = {"thin geometry": ("_pt_thin_cache", True, _geometry)}
    if edge_on:
        parts["face planes"] = ("_pt_face_planes", False, lambda mesh, tf: _face_planes(mesh))
    if silhouettes:
        parts["boundary edges"] = ("_pt_boundary_edges", True, _boundary_edges)
    if rough:
        parts["slopes"] = ("_pt_slopes", True, _slopes)
    return parts


def missing_parts(mesh, tf, edge_on: bool = True, silhouettes: bool = True, rough: bool = False) -> list[str]:
    """Names of the per-mesh / per-transfer-function parts of :func:`unresolved_pixels` (with the same
    flags) the mesh does not hold yet: set-up its first call computes (:func:`prepare_parts`)."""
    key = np.asarray(tf.points).tobytes() + tf.emission.encode()
    out = []
    for name, (attr, keyed, _) in _view_independent_parts(edge_on, silhouettes, rough).items():
        cache = mesh.__dict__.get(attr, {})
        if not (key in cache if keyed else "faces" in cache):
            out.append(name)
    return out


def prepare_parts(mesh, tf, names: list[str]) -> None:
    """Compute the parts ``names`` (from :func:`missing_parts`) and keep them on the mesh."""
    parts = _view_independent_parts(True, True, True)
    for n in names:
        parts[n][2](mesh, tf)


def unresolved_pixels(mesh, tf, camera, tau: float = THIN_TAU, silhouettes: bool = True,
                      edge_on: bool = True, rough: bool = False, rank: np.ndarray | None = None,
                      term_at: np.ndarray | None = None) -> dict:
    """The thin tets (:func:`thin_tets`), the faces seen edge-on from the eye (:func:`edge_on_faces`) or
    narrower than the snapping resolves (:func:`snap_edge_on_faces`, ``sliver_faces``), the silhouette
    edges snapping makes visible (:func:`silhouette_edges`) and the pixels they may make wrong
    (``pixels``, flat indices): within one pixel of a thin tet's projected bounding box or of an edge-on
    face's or a silhouette edge's projected segment, within :data:`SLIVER_PX` of a sliver face's
    projected edges; with ``rough`` also within :data:`SNAP_FLIP_PX` of the projected edges of the tets
    :func:`rough_tets` finds (``rough_tets``).

    ``rank`` (per tet: its draw position, -1 for a tet not drawn) leaves out what no drawn tet carries (a
    face or edge counts with the front-most drawn tet beside it); ``term_at`` (:class:`InFront`) also the
    pixels that terminated before the tet's fragment came (``occluded_pixels`` counts those, pixels no
    other source marks)."""
    h, w = camera.height_px, camera.width_px
    cover = np.zeros((h, w), dtype=bool)
    proj = project_points(mesh, camera)
    drawn = None if rank is None else rank >= 0
    front = None if term_at is None or rank is None else InFront(term_at)

    def ranks(cells):  # the front-most drawn cell of each row of ``cells`` (-1: none, or outside the mesh)
        if rank is None:
            return np.zeros(len(cells), np.int64)
        return np.where(cells >= 0, rank[np.maximum(cells, 0)], -1).max(axis=1, initial=-1)

    thin = thin_tets(mesh, tf, camera, tau, proj=proj, drawn=drawn)
    if len(thin):
        col, row, _ = _window(mesh, camera, thin, proj)
        _mark_boxes(cover, col, row, front, ranks(thin[:, None]))
    fp = _face_planes(mesh) if edge_on else {"faces": np.zeros((0, 3), np.int64), "owners": np.zeros((0, 2), int)}
    fids = edge_on_faces(mesh, camera, ids=True, drawn=drawn) if edge_on else np.zeros(0, dtype=np.int64)
    sids = snap_edge_on_faces(mesh, tf, camera, tau, True, proj, drawn) if edge_on else np.zeros(0, np.int64)
    frank, srank = ranks(fp["owners"][fids]), ranks(fp["owners"][sids])
    fids, frank, sids, srank = fids[frank >= 0], frank[frank >= 0], sids[srank >= 0], srank[srank >= 0]
    if len(sids):
        col, row, _ = _window(TetMeshFaces(mesh, fp["faces"][sids]), camera, np.arange(len(sids)), proj)
        _mark_near_edges(cover, col[:, :3], row[:, :3], SLIVER_PX, front, srank)
    sil = silhouette_edges(mesh, tf, camera, ids=True) if silhouettes else np.zeros(0, dtype=np.int64)
    if len(sil):
        g, cells = _boundary_edges(mesh, tf), np.asarray(mesh.boundary_faces)[:, 0]
        erank = ranks(np.column_stack([cells[g["f1"][sil]], cells[g["f2"][sil]]]))
        sil, erank = np.column_stack([g["a"][sil], g["b"][sil]])[erank >= 0], erank[erank >= 0]
    else:
        sil, erank = np.zeros((0, 2), dtype=np.int64), np.zeros(0, np.int64)
    segs = np.concatenate([fp["faces"][fids], np.column_stack([sil, sil[:, 1]])])
    if len(segs):
        col, row, _ = _window(TetMeshFaces(mesh, segs), camera, np.arange(len(segs)), proj)
        sc, sr, src = _segment_samples(col[:, :3], row[:, :3])
        _mark_boxes(cover, sc, sr, front, np.concatenate([frank, erank])[src])
    rtets = rough_tets(mesh, tf, camera, proj=proj, drawn=drawn) if rough else np.zeros(0, dtype=np.int64)
    if len(rtets):  # every edge of the tets once, with the front-most rank of the tets it bounds
        e = np.sort(np.asarray(mesh.tets)[rtets][:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]], axis=2)
        key, inv = np.unique(e[..., 0] * np.int64(len(proj[0])) + e[..., 1], return_inverse=True)
        er = np.full(len(key), -1, np.int64)
        np.maximum.at(er, inv.ravel(), np.repeat(ranks(rtets[:, None]), 6))
        a, b = key // len(proj[0]), key % len(proj[0])
        (ca, cb), (ra, rb) = ((q[a], q[b]) for q in proj[:2])
        pix, seg = near_segment_pixels_warp(ca, ra, cb, rb, w, h, SNAP_FLIP_PX)  # the same pairs, one kernel
        cover.ravel()[pix if front is None else pix[front(pix, er[seg])]] = True
    occluded = 0 if front is None else int(np.count_nonzero(front.dropped & ~cover.ravel()))
    return {"thin_tets": int(len(thin)), "edge_on_faces": int(len(fids)), "sliver_faces": int(len(sids)),
            "silhouette_edges": int(len(sil)), "rough_tets": int(len(rtets)), "occluded_pixels": occluded,
            "pixels": np.flatnonzero(cover.ravel())}


class TetMeshFaces:
    """Faces posing as degenerate tets (fourth vertex repeated) for :func:`_window`."""

    def __init__(self, mesh, faces: np.ndarray):
        self.points = mesh.points
        self.tets = np.column_stack([faces, faces[:, 2]])


