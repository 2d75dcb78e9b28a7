"""Entry bins (the ``entry_bins`` stage's host code): the front-facing boundary faces binned into screen tiles.

Rays start on the mesh boundary. Instead of testing every pixel against every boundary face, each
boundary face a ray may enter through (:func:`entry_face_mask`) is projected along the camera's rays
(no near/far planes, so a camera looking away from the mesh is fine), its pixel bounding box (grown
by one pixel) is mapped to ``tile x tile`` screen tiles, and the (tile, face) pairs are sorted into a
CSR list. A ray then only tests the faces of its tile. Faces straddling the eye plane cover every
tile (conservative).

Within a tile the faces are sorted by their nearest depth along the view direction, and each item
carries its face's depth range and the farthest depth of the tile's faces from it on
(:func:`item_depths`): a search skips the faces that lie wholly behind its start and stops at the first
face whose nearest depth lies beyond the best crossing found (no face after it can be nearer), which
gives the same entry as testing every face of the tile.
"""

from __future__ import annotations

import numpy as np

from warpvol.shared.visible import face_triangles

#: the per-mesh properties (cached on the mesh) :func:`entry_face_mask` reads: set-up on first use
ENTRY_MESH_PROPERTIES = ("boundary_faces", "face_planes", "bounds", "bounding_radius")


def entry_face_mask(mesh, camera, faces: np.ndarray | None = None) -> np.ndarray:
    """Boundary faces a ray may enter through (conservative: the kernel's Plücker test decides).
    ``faces``: ``(B, 2)`` rows ``(tet, local face)`` to choose from (the visible sub-mesh's boundary,
    :func:`warpvol.shared.visible.visible_boundary`); ``None``: the mesh's boundary faces.

    Orthographic: faces with ``n . f < tol`` (edge-on faces included). Perspective: faces with the
    eye on (or within ``tol`` of) their outer side; all faces when the eye lies in the mesh's
    bounding sphere, because rays then start walking behind the eye (``t_clip``) and enter through
    faces there."""
    bf = mesh.boundary_faces if faces is None else np.asarray(faces, dtype=np.int64).reshape(-1, 2)
    planes = mesh.face_planes[bf[:, 0], bf[:, 1]]  # (B,4)
    lo, hi = mesh.bounds
    diam = float(np.linalg.norm(hi - lo))
    if camera.projection == "perspective":
        if np.linalg.norm(camera.eye - 0.5 * (lo + hi)) <= 1.001 * mesh.bounding_radius:
            return np.ones(len(bf), dtype=bool)
        return planes[:, :3] @ camera.eye + planes[:, 3] > -1e-9 * diam
    return planes[:, :3] @ camera.forward < 1e-9


def window_xy(camera, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(wx, wy, bad, z)``: window coordinates (x right in pixels, y down in rows) of points ``p``
    (n, 3), a mask of points too close to the eye plane to project (perspective) and their depth
    along the view direction. A point behind the eye projects to the pixel whose ray *line* passes
    through it."""
    rel = p - camera.eye
    x, y, z = rel @ camera.right, rel @ camera.true_up, rel @ camera.forward
    if camera.projection == "perspective":
        th = np.tan(np.radians(camera.fov_y_deg) / 2.0)
        sx, sy = th * camera.aspect, th
        scale = np.sqrt(x * x + y * y + z * z)
        bad = np.abs(z) <= 1e-9 * np.maximum(scale, 1e-300)
        zs = np.where(bad, 1.0, z)
        x, y = x / zs, y / zs
    else:
        sx, sy = camera.ortho_height / 2.0 * camera.aspect, camera.ortho_height / 2.0
        bad = np.zeros(len(p), dtype=bool)
    wx = (x / sx + 1.0) * camera.width_px / 2.0
    wy = (1.0 - y / sy) * camera.height_px / 2.0
    return wx, wy, bad, z


#: relative float32 padding of the stored depths (outward), on top of the search's own margin
DEPTH_PAD = 1e-6


#: pixels by which a face's projected box is grown before the pixel centres in it are listed (on top of the
#: float32 ray's uncertainty, :data:`RAY_REL`)
BOX_MARGIN_PX = 0.05
#: how far (relative to the mesh's half diagonal) a float32 ray and its crossings may stray from the float64 ray
#: through the pixel centre: about 1e-7 of the mesh's size (the origin is moved to the mesh); taken 100 times
RAY_REL = 1e-5


def box_margin_px(mesh, camera, z: np.ndarray) -> np.ndarray:
    """Per triangle (vertex depths ``z`` (F, 3) from the eye), the margin in pixels by which its projected box is
    grown: :data:`BOX_MARGIN_PX` plus :data:`RAY_REL` times the mesh's half diagonal over the size of a pixel at
    the triangle's nearest vertex (perspective; the orthographic pixel size is the same at every depth), so a
    float32 ray that may cross the face keeps it among its pixel's candidates; the consistent edge test
    decides."""
    lo, hi = mesh.bounds
    half = 0.5 * float(np.linalg.norm(np.asarray(hi, np.float64) - np.asarray(lo, np.float64)))
    if camera.projection == "perspective":
        pix = 2.0 * np.abs(z).min(axis=1) * np.tan(np.radians(camera.fov_y_deg) / 2.0) / camera.height_px
    else:
        pix = np.full(len(z), camera.ortho_height / camera.height_px)
    return BOX_MARGIN_PX + RAY_REL * half / pix


def depth_pad(lo: np.ndarray, hi: np.ndarray, span: float) -> np.ndarray:
    """The outward padding of stored depth bounds ``lo`` / ``hi`` (float64) before their float32 cast: relative
    :data:`DEPTH_PAD` of their magnitudes and of ``span`` (the depth range they belong to)."""
    return DEPTH_PAD * (np.abs(lo) + np.abs(hi) + span)


def face_depths(mesh, camera, tris: np.ndarray) -> np.ndarray:
    """``(F, 2)`` float32: per triangle (point indices ``tris``) the nearest and farthest depth of its vertices
    along the view direction, from the eye, rounded outward (a ray's crossing with the triangle lies between)."""
    if len(tris) == 0:
        return np.zeros((0, 2), np.float32)
    z = (np.asarray(mesh.points, np.float64)[tris] - np.asarray(camera.eye, np.float64)) @ camera.forward
    lo, hi = z.min(axis=1), z.max(axis=1)
    pad = depth_pad(lo, hi, float(hi.max() - lo.min()) + 1.0)
    return np.ascontiguousarray(np.stack([lo - pad, hi + pad], axis=1).astype(np.float32))


def item_depths(tid: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Depth bounds of the (tile, face) items of the bins: ``tid`` the tile of each item (items grouped by tile),
    ``lo`` / ``hi`` (float64) the nearest and farthest vertex depth of its face. Returns per item ``(nearest,
    farthest, farthest of this and every later item of its tile)``, float32 rounded outward. A ray's crossing
    with a face lies between its vertices' depths (depth is linear over a triangle and grows along every ray),
    so a search over a tile's items in the order of nearest depth may stop at the first whose nearest depth is
    beyond the best crossing found; the third column bounds the crossings of the items it leaves untested."""
    if len(tid) == 0:
        return np.zeros((0, 3), np.float32)
    # suffix maximum of ``hi`` within each tile: a running maximum over the reversed items, each tile lifted
    # above every tile before it in that order so that no maximum leaks across tiles
    span = float(hi.max() - hi.min()) + 1.0
    t = tid[::-1]
    rev_rank = np.cumsum(np.r_[0, t[1:] != t[:-1]])
    lifted = hi[::-1] - hi.min() + rev_rank * (2.0 * span)
    far = (np.maximum.accumulate(lifted) - rev_rank * (2.0 * span) + hi.min())[::-1]
    far = np.maximum(far, hi)  # (rounding of the lift)
    pad = depth_pad(lo, hi, span)
    return np.ascontiguousarray(np.stack([lo - pad, hi + pad, far + pad], axis=1).astype(np.float32))


def bin_boundary_faces(mesh, camera, tile: int, faces: np.ndarray | None = None) -> dict:
    """CSR bins of the boundary faces rays may enter through, over screen tiles (plain NumPy); ``faces``
    as :func:`entry_face_mask` (``None``: the mesh's boundary).

    Returns ``dict(bface_tet, bface_local, bface_box, tile_start, tile_items, item_depth, tiles_x, tiles_y,
    tile)``; ``bface_box`` (int32, 4 per face: first column, first row, last column, last row) bounds the
    pixels whose rays may cross the face (centres in its projected box grown by :func:`box_margin_px`; a face
    between the pixel centres is listed nowhere); a tile's items are in the order of :func:`item_depths`, ``item_depth`` (float32, 3 per item) its depth bounds.
    """

    front = entry_face_mask(mesh, camera, faces)
    bf = (mesh.boundary_faces if faces is None else np.asarray(faces, dtype=np.int64).reshape(-1, 2))[front]
    tris = face_triangles(mesh.tets, bf)
    w, h = camera.width_px, camera.height_px
    tiles_x, tiles_y = -(-w // tile), -(-h // tile)
    n_tiles = tiles_x * tiles_y
    if len(bf) == 0:
        return dict(bface_tet=np.zeros(0, np.int32), bface_local=np.zeros(0, np.int32),
                    bface_box=np.zeros(0, np.int32),
                    tile_start=np.zeros(n_tiles + 1, np.int32), tile_items=np.zeros(0, np.int32),
                    item_depth=np.zeros((0, 3), np.float32), tiles_x=tiles_x, tiles_y=tiles_y, tile=tile)
    wx, wy, bad, z = window_xy(camera, mesh.points[tris.reshape(-1)])
    win = np.stack([wx, wy], axis=-1).reshape(-1, 3, 2)
    # a triangle whose vertices are not all on one side of the eye plane has an unbounded projection
    zt = z.reshape(-1, 3)
    straddle = bad.reshape(-1, 3).any(axis=1) | ((zt > 0).any(axis=1) & (zt < 0).any(axis=1))
    # the pixels whose centres lie within the projected triangle's box grown by box_margin_px (columns lo[:, 0] ..
    # hi[:, 0], rows lo[:, 1] .. hi[:, 1]; none where lo > hi)
    with np.errstate(invalid="ignore", divide="ignore"):
        m = box_margin_px(mesh, camera, zt)[:, None]
        lo = np.ceil(win.min(axis=1) - 0.5 - m)
        hi = np.floor(win.max(axis=1) - 0.5 + m)
    whole = straddle | ~(np.isfinite(lo).all(axis=1) & np.isfinite(hi).all(axis=1))
    lo[whole] = 0
    hi[whole] = [w - 1, h - 1]
    lo = np.clip(lo, -1.0, float(max(w, h)) + 1.0)
    hi = np.clip(hi, -1.0, float(max(w, h)) + 1.0)
    # pixel index ranges -> tile ranges (clipped to the screen)
    tx0 = np.clip(lo[:, 0] // tile, 0, tiles_x - 1).astype(np.int64)
    tx1 = np.clip(hi[:, 0] // tile, 0, tiles_x - 1).astype(np.int64)
    ty0 = np.clip(lo[:, 1] // tile, 0, tiles_y - 1).astype(np.int64)
    ty1 = np.clip(hi[:, 1] // tile, 0, tiles_y - 1).astype(np.int64)
    offscreen = (hi[:, 0] < 0) | (hi[:, 1] < 0) | (lo[:, 0] > w - 1) | (lo[:, 1] > h - 1) | (lo[:, 0] > hi[:, 0]) | \
        (lo[:, 1] > hi[:, 1])
    nx = np.where(offscreen, 0, tx1 - tx0 + 1)
    ny = np.where(offscreen, 0, ty1 - ty0 + 1)
    cnt = nx * ny
    # the items face by face in the order of the faces' nearest depth, then sorted (stably) by tile: within a
    # tile by nearest depth
    z_lo, z_hi = zt.min(axis=1), zt.max(axis=1)
    by_depth = np.argsort(z_lo, kind="stable")
    cnt_d = cnt[by_depth]
    face = np.repeat(by_depth, cnt_d)
    k = np.arange(cnt_d.sum()) - np.repeat(np.cumsum(cnt_d) - cnt_d, cnt_d)
    tx = tx0[face] + k % nx[face]
    ty = ty0[face] + k // nx[face]
    tid = ty * tiles_x + tx
    order = np.argsort(tid, kind="stable")
    depth = item_depths(tid[order], z_lo[face[order]], z_hi[face[order]])
    start = np.zeros(n_tiles + 1, np.int64)
    np.cumsum(np.bincount(tid, minlength=n_tiles), out=start[1:])
    # per face, the pixel columns / rows whose centres its grown box may contain: the kernel skips a face's ray
    # test outside it, as the binning does per tile
    box = np.stack([lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1]], axis=1)
    return dict(bface_tet=bf[:, 0].astype(np.int32), bface_local=bf[:, 1].astype(np.int32),
                bface_box=np.ascontiguousarray(box, dtype=np.int32).reshape(-1),
                tile_start=start.astype(np.int32), tile_items=face[order].astype(np.int32), item_depth=depth,
                tiles_x=tiles_x, tiles_y=tiles_y, tile=tile)
