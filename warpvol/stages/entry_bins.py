"""Host step ``entry_bins``: bin the front-facing boundary faces into screen tiles.

Rays start on the mesh boundary. Instead of testing every pixel against every boundary face, each
front-facing boundary face (the eye on its outer side; for orthographic views ``d . n < 0``) is
projected with the camera's model-view / projection / viewport matrices, its pixel bounding box
(grown by one pixel) is mapped to ``tile x tile`` screen tiles, and the (tile, face) pairs are sorted
into a CSR list. A ray then only tests the faces of its tile. Faces with a vertex behind the eye
cover every tile (conservative).
"""

from __future__ import annotations

import numpy as np

from ..pipeline import Context, Param, Stage, register_stage


def bin_boundary_faces(mesh, camera, tile: int) -> dict:
    """CSR bins of front-facing boundary faces over screen tiles (plain NumPy, for tests).

    Returns ``dict(bface_tet, bface_local, tile_start, tile_items, tiles_x, tiles_y, tile)``.
    """
    bf = mesh.boundary_faces
    planes = mesh.face_planes[bf[:, 0], bf[:, 1]]  # (B,4)
    if camera.projection == "perspective":
        front = planes[:, :3] @ camera.eye + planes[:, 3] > 0.0
    else:
        front = planes[:, :3] @ camera.forward < 0.0
    bf = bf[front]
    tris = mesh.boundary_triangles()[front]
    w, h = camera.width_px, camera.height_px
    tiles_x, tiles_y = -(-w // tile), -(-h // tile)
    n_tiles = tiles_x * tiles_y
    if len(bf) == 0:
        return dict(bface_tet=np.zeros(0, np.int32), bface_local=np.zeros(0, np.int32),
                    tile_start=np.zeros(n_tiles + 1, np.int32), tile_items=np.zeros(0, np.int32),
                    tiles_x=tiles_x, tiles_y=tiles_y, tile=tile)
    near, far = camera.depth_range(*mesh.bounds)
    mvp = camera.viewport_matrix() @ camera.projection_matrix(max(near * 0.5, 1e-9), far * 2.0) @ camera.view_matrix()
    p = mesh.points[tris.reshape(-1)]
    hp = np.c_[p, np.ones(len(p))] @ mvp.T
    wv = hp[:, 3]
    behind = (wv <= 1e-12).reshape(-1, 3).any(axis=1)
    win = hp[:, :2] / np.where(wv > 1e-12, wv, 1.0)[:, None]
    win = win.reshape(-1, 3, 2)
    lo = np.floor(win.min(axis=1) - 1.0)
    hi = np.ceil(win.max(axis=1) + 1.0)
    lo[behind] = 0
    hi[behind] = [w, h]
    # pixel index ranges -> tile ranges (clipped to the screen)
    tx0 = np.clip(lo[:, 0] // tile, 0, tiles_x - 1).astype(np.int64)
    tx1 = np.clip(hi[:, 0] // tile, 0, tiles_x - 1).astype(np.int64)
    ty0 = np.clip(lo[:, 1] // tile, 0, tiles_y - 1).astype(np.int64)
    ty1 = np.clip(hi[:, 1] // tile, 0, tiles_y - 1).astype(np.int64)
    offscreen = (hi[:, 0] < 0) | (hi[:, 1] < 0) | (lo[:, 0] > w) | (lo[:, 1] > h)
    nx = np.where(offscreen, 0, tx1 - tx0 + 1)
    ny = np.where(offscreen, 0, ty1 - ty0 + 1)
    cnt = nx * ny
    face = np.repeat(np.arange(len(bf)), cnt)
    k = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    tx = tx0[face] + k % nx[face]
    ty = ty0[face] + k // nx[face]
    tid = ty * tiles_x + tx
    order = np.argsort(tid, kind="stable")
    start = np.zeros(n_tiles + 1, np.int64)
    np.cumsum(np.bincount(tid, minlength=n_tiles), out=start[1:])
    return dict(bface_tet=bf[:, 0].astype(np.int32), bface_local=bf[:, 1].astype(np.int32),
                tile_start=start.astype(np.int32), tile_items=face[order].astype(np.int32),
                tiles_x=tiles_x, tiles_y=tiles_y, tile=tile)


@register_stage
class EntryBins(Stage):
    """Bin front-facing boundary faces into screen tiles (ray start / re-entry search).

    ==========  =====  =======  ======================================
    parameter   type   default  meaning
    ==========  =====  =======  ======================================
    tile        int    8        tile edge in pixels (1 .. 256)
    ==========  =====  =======  ======================================
    """

    name = "entry_bins"
    summary = "bin front-facing boundary faces into screen tiles for ray entry"
    needs = ()
    provides = ("entry_bins",)
    params = (Param("tile", int, 8, "tile edge in pixels", lo=1, hi=256),)

    def run(self, ctx: Context) -> None:
        import warp as wp

        b = bin_boundary_faces(ctx.scene.mesh, ctx.scene.camera, self.tile)
        ctx.stats["entry_faces"] = int(len(b["bface_tet"]))
        ctx.stats["entry_bin_items"] = int(len(b["tile_items"]))
        ctx.buffers["entry_bins"] = {
            k: (wp.array(v, dtype=wp.int32, device=ctx.device) if isinstance(v, np.ndarray) else v)
            for k, v in b.items()
        }
