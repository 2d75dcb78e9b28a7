"""VSBUFFER sweep-plane renderer (Westermann & Ertl 1997) on the emulated rasteriser: plain functions.

Per image row (scanline) one **sweep plane** holds that row's rays. All geometry is taken into *ray
space* ``(a, b, c)``: ``a`` the pixel column, ``b`` the pixel row, ``c`` the depth coordinate (eye
distance for an orthographic view; ``-1/z`` for a perspective one, i.e. NDC depth: the paper's
"rotation of 90 degrees after the perspective distortion", under which the sweep planes of a
perspective view, inclined per scanline, become the planes ``b = j + 1/2``). Looking at the plane
along ``+b``, the cells' boundary triangles are drawn twice into 24-bit ID buffers of ``width x
depth_res`` pixels (x: column, y: depth) with the cell ID as flat colour
(:meth:`warpvol.gpu.raster.Rasterizer.draw_ids`): back faces (outward normal along ``+b``) with depth
test LESS and everything in front of the plane clipped, front faces with GREATER and everything behind
it clipped. Clipping is the paper's near/far trick: window depth is ``(b - b_j) / range`` (pass 1)
or ``1 + (b - b_j) / range`` (pass 2) with ``range`` the largest cell extent along ``b``, and the
rasteriser drops fragments outside [0, 1]. Where both buffers hold the same ID the plane cuts that
cell: the **VSBUFFER** (:func:`warpvol.kernels.vsbuffer.vsb_compare`); its columns are walked front to
back (:func:`warpvol.kernels.vsbuffer.column_walk`).

Culling: a regular octree over the mesh's bounding box holds every cell at the deepest node whose box
contains the cell's box; a plane visits the nodes whose boxes it cuts and, of the cells stored there,
draws those whose own bounding box it cuts (``cell_test``, the paper's "the cells at each node that
have an intersection with the scanline are drawn"; without it, every cell of a cut node). The
paper's "drawn tetra" counts the drawn cells (``drawn_cells``). A cell the plane does not cut survives
the near/far clipping in one pass at most, so it never enters the VSBUFFER; the selection saves work
and the depth-precision gaps such cells leave where they win a pass's depth test against a cut cell.
Faces are classified front/back once per frame (all planes share the direction ``+b`` in ray space).

Emulation detail: several planes are drawn in one rasteriser call, stacked along y with a gap (every
drawn triangle lies within its plane's ``depth_res`` rows, so planes cannot touch each other and the
per-pixel primitive order is that of a plane drawn alone).

Example
-------
>>> import warpvol
>>> s = warpvol.builtin_scene("linear_box").with_camera(width_px=24, height_px=24)
>>> img, st = render_vsbuffer(ConvexCellMesh.from_tetmesh(s.mesh), s.transfer, s.camera, integration="exact")
>>> img.shape, st["counters"]["lost_segments"]
((24, 24, 4), 0)
"""

from __future__ import annotations

import time
from contextlib import contextmanager

import numpy as np

from warpvol.conditioning.visibility import per_cell
from warpvol.errors import ConfigError
from warpvol.gpu.raster import Rasterizer
from warpvol.parallel import blocks, cpu_threads, launch_blocks
from warpvol.shared.integration import integ_setup
from warpvol.vsbuffer.cells import ConvexCellMesh
from warpvol.vsbuffer.octree import Octree, _expand, box_corners_yz, build_octree, plane_box_cut, plane_node_hits  # noqa: F401 (re-exported)

__all__ = ["ConvexCellMesh", "Octree", "build_octree", "ray_space", "render_vsbuffer", "walk_column",
           "INTEGRATIONS", "ADJACENCY_MODES"]

INTEGRATIONS = ("trapezoid", "exact", "table")
ADJACENCY_MODES = ("count", "recover")
ID_LIMIT = 2 ** 24  # cell IDs are drawn as RGB8 colours
#: ID-buffer pixels per plane batch at most (fewer planes per batch for wide images): each batch's
#: launches run uninterrupted, so this bounds how long Ctrl-C waits (~0.2 s at 256^2 on 2 CPU cores)
BATCH_PIXELS = 1 << 18
#: pixels by which the audit widens a cell's ray-space range (rays in its boundary faces stay checked)
AUDIT_SLACK = 1e-3
#: the per-cell selection also draws a cell whose vertices lie within this fraction of the clipping
#: range (the largest cell extent along the sweep direction), or within AUDIT_SLACK pixels, of its
#: plane though its box misses it: float32 window depths can round such a cell into both clipped
#: passes, and the audit checks it
CUT_SLACK = 2.0 ** -16


# ------------------------------------------------------------------------------------------------
# ray space
# ------------------------------------------------------------------------------------------------


def ray_space(points: np.ndarray, camera, used: np.ndarray | None = None) -> np.ndarray:
    """(N, 3) float64 ray-space coordinates ``(a, b, c)`` of world points (module docstring). With
    ``used`` (bool per point, :attr:`warpvol.scene.mesh.TetMesh.point_used`) only the used points are
    mapped and checked; the others take the first used point's coordinates (inside every range).

    Examples
    --------
    >>> from warpvol.scene.camera import Camera
    >>> cam = Camera(projection="orthographic", eye=(0, 0, 5), target=(0, 0, 0), ortho_height=2.0, width_px=4, height_px=4)
    >>> ray_space(np.array([[0.0, 0.0, 0.0], [-1.0, 1.0, 1.0]]), cam).tolist()   # centre; top-left corner
    [[2.0, 2.0, 5.0], [0.0, 0.0, 4.0]]
    """
    if used is not None:
        out = np.empty((len(used), 3))
        out[used] = ray_space(np.asarray(points)[used], camera)
        out[~used] = out[int(np.argmax(used))]
        return out
    q = np.asarray(points, dtype=np.float64) - camera.eye
    x, y, z = q @ camera.right, q @ camera.true_up, q @ camera.forward
    w, h = camera.width_px, camera.height_px
    if camera.projection == "orthographic":
        hh = camera.ortho_height / 2.0
        return np.stack([(x / (hh * camera.aspect) + 1.0) * w / 2.0, (1.0 - y / hh) * h / 2.0, z], axis=1)
    th = np.tan(np.radians(camera.fov_y_deg) / 2.0)
    zmin = float(z.min()) if len(z) else 1.0
    if not zmin > 1e-9 * float(np.abs(q).max()):  # relative to the mesh's distances: any unit of length
        raise ConfigError("vsbuffer: a perspective view needs the whole mesh in front of the eye "
                          f"(nearest point at eye depth {zmin:g}); move the eye out of the mesh or use 'raycast'")
    return np.stack([(x / (z * th * camera.aspect) + 1.0) * w / 2.0, (1.0 - y / (z * th)) * h / 2.0, -1.0 / z], axis=1)


def ray_used(cells) -> np.ndarray:
    """The points of ``cells`` its tets use."""
    used = cells.pieces.point_used
    return cells.points if used is None else cells.points[used]


# ------------------------------------------------------------------------------------------------
# the renderer
# ------------------------------------------------------------------------------------------------


@contextmanager
def _unit_counters():
    """The hardware counters the emulated units add on this thread, as a dict (empty where the
    units do not count)."""
    try:
        from warpvol.gpu.counters import Counters
    except ImportError:  # units without hardware counters
        yield {}
        return
    out: dict[str, int] = {}
    with Counters() as c:
        yield out
    out.update(c.as_dict())


def _device_cells(cm: ConvexCellMesh, origin: np.ndarray, device: str, camera=None, visible=None):
    """The cells on the device; ``visible`` (per cell, optional): faces towards a cell left out are
    boundary faces to the walk (no adjacency into it), so the walk meets the cells left out as empty
    space."""
    import warp as wp

    from warpvol.kernels import vsbuffer as kv

    tm = cm.pieces
    fp = tm.face_planes.copy()
    # a ray lying in a face plane: with the camera given (the rewalking walk of vsbuffer_best), inside
    # that face's piece as in the reference (moved by an infinitesimal step along the camera's right,
    # then up, it falls on the inner side); without, inside every piece it bounds (the paper's walk)
    tie = np.ones(fp.shape[:2], np.int32)
    if camera is not None:
        nr, nu = fp[..., :3] @ camera.right, fp[..., :3] @ camera.true_up
        tie = np.where(np.abs(nr) > 1e-12, nr < 0.0, nu < 0.0).astype(np.int32)
    fp[..., 3] += np.einsum("mfk,k->mf", fp[..., :3], origin)
    c = kv.VsbCells()
    c.points = wp.array((tm.points - origin).astype(np.float32), dtype=wp.vec3, device=device)
    c.scalars = wp.array(tm.scalars.astype(np.float32), dtype=wp.float32, device=device)
    c.tets = wp.array(tm.tets.astype(np.int32), dtype=wp.vec4i, device=device)
    c.planes = wp.array(fp.reshape(-1, 4).astype(np.float32), dtype=wp.vec4, device=device)
    adj = tm.adjacency
    if visible is not None:
        adj = np.where((adj >= 0) & ~visible[cm.piece_cell[np.maximum(adj, 0)]], -1, adj)
    c.adj = wp.array(adj.reshape(-1).astype(np.int32), dtype=wp.int32, device=device)
    g0 = tm.offsets + tm.gradients @ origin
    c.grad = wp.array(np.column_stack([tm.gradients, g0]).astype(np.float32), dtype=wp.vec4, device=device)
    c.piece_cell = wp.array(cm.piece_cell.astype(np.int32), dtype=wp.int32, device=device)
    c.cell_start = wp.array(cm.cell_start.astype(np.int32), dtype=wp.int32, device=device)
    c.tie = wp.array(tie.reshape(-1), dtype=wp.int32, device=device)
    return c


def _face_sides(cm: ConvexCellMesh, abc: np.ndarray) -> np.ndarray:
    """Per boundary triangle: +1 back face (outward normal along +b in ray space), -1 front, 0 edge-on."""
    tris = cm.boundary
    p = abc[tris]
    nb = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 1]
    # the ray-space map may reverse orientation: take it from the face's own piece
    q = abc[cm.pieces.tets[cm.face_piece[:, 0]]]
    vol = np.einsum("fk,fk->f", np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]), q[:, 3] - q[:, 0])
    return np.sign(nb) * np.sign(vol)


#: what the sweep reports as hardware work (:mod:`warpvol.gpu.counters` names, so the throughput model of
#: :mod:`warpvol.model` can time it): the units' own counts (fragments, primitives, ID writes), plus
#: these, plus ``host_cell_steps`` (cells intersected and integrated on the host) and ``drawn_cells``
#: (the paper's "drawn tetra", informational: ``vertices`` carry its cost)
WORK_COUNTERS = ("passes", "vertices", "readbacks", "bytes_down", "clears", "clear_pixels", "drawn_cells")
UNIT_COUNTERS = ("fragments", "fragments_passed", "primitives", "primitives_culled")


def work_counters(c: dict) -> dict:
    """The hardware-work subset of :func:`render_vsbuffer`'s counters (what the stage passes to
    ``ctx.count``); every other count is a detail of the walk, reported under ``stats``.

    Examples
    --------
    >>> work_counters({"passes": 2, "cells_integrated": 5, "lost_segments": 1, "writes_rgb8": 9})
    {'passes': 2, 'writes_rgb8': 9, 'host_cell_steps': 5}
    """
    out = {k: v for k, v in c.items() if k in WORK_COUNTERS or k in UNIT_COUNTERS or k.startswith("writes_")}
    out["host_cell_steps"] = int(c.get("cells_integrated", 0))
    return out


def _nothing_drawn(H: int, W: int, R: int, cells, nonconvex: int, audit: bool, note: str, counters: dict):
    """:func:`render_vsbuffer`'s result where no plane draws anything: a transparent image, why in ``note``."""
    return np.zeros((H, W, 4), np.float32), {
        "counters": counters, "id_s": 0.0, "walk_s": 0.0, "setup_s": 0.0, "depth_res": R, "range": 0.0,
        "lists": None, "vsbuffers": None, "drawn": None, "missed_length": 0.0,
        "missed_per_ray": np.zeros((H, W), np.int32) if audit else None, "octree_nodes": 0,
        "cells": cells.n_cells, "tets": cells.n_tets, "nonconvex_cells": nonconvex, "note": note}


def _zero_counts(planes: int) -> dict:
    from warpvol.kernels import vsbuffer as kv

    cnt = {k: 0 for k in kv.COUNTERS}
    cnt.update(planes=planes, drawn_cells=0, tree_nodes_tested=0, cell_boxes_tested=0, id_triangles_back=0, id_triangles_front=0,
               id_pixels_read=0, vsb_pixels_compared=0, audit_pairs=0, missed_cells=0, rays_rewalked=0,
               rewalk_candidates=0, passes=0, readbacks=0, bytes_down=0, clears=0, clear_pixels=0, vertices=0)
    return cnt


#: the walk's float32 frame: points, planes, gradients and ray origins shifted (in float64) to the cells'
#: centre and the origins moved along their rays to the sphere around the mesh; ``False``: the mesh's own
#: frame and rays from the eye (float64 values rounded to float32 once)
ORIGIN_SHIFT = True


def _walk_inputs(cells: ConvexCellMesh, transfer, camera, device: str, rows: int, cmin: float, cspan: float,
                 integration: str, steps: int, neighbour_check: bool, adjacency: str, t_min: float, max_list: int,
                 table=None, weight_bits: int | None = 8, texture_cache: dict | None = None, ties: bool = False,
                 visible=None):
    """``(Walk, VsbCells, ray origins, ray directions, tf_s, tf_v, textures)`` on ``device`` for one
    frame; ``textures``: the 3D table's texture (``"table"``; kept alive, its fetches counted) or none."""
    import warp as wp

    from warpvol.kernels import vsbuffer as kv

    origin = 0.5 * (cells.bounds[0] + cells.bounds[1]) if ORIGIN_SHIFT else np.zeros(3)
    dc = _device_cells(cells, origin, device, camera if ties else None, visible)
    o_np, d_np = camera.rays(normalise=True)
    # origins moved along their rays (float64) to the sphere around the mesh: ray parameters then stay
    # of the mesh's size in float32 however far the eye is (lengths, not positions, are integrated)
    radius = 0.5 * float(np.linalg.norm(cells.bounds[1] - cells.bounds[0]))
    if ORIGIN_SHIFT:
        t0 = np.maximum(np.einsum("hwk,hwk->hw", origin - o_np, d_np) - 1.01 * radius, 0.0)
        o_np = o_np + t0[..., None] * d_np
    ray_o = wp.array((o_np - origin).reshape(-1, 3).astype(np.float32), dtype=wp.vec3, device=device)
    ray_d = wp.array(d_np.reshape(-1, 3).astype(np.float32), dtype=wp.vec3, device=device)
    tf_s, tf_v = transfer.to_warp(device)
    w = kv.Walk()
    w.rows, w.stride, w.width, w.height = rows, rows + 2, camera.width_px, camera.height_px
    w.eye = wp.vec3(*(camera.eye - origin))
    w.fwd = wp.vec3(*camera.forward)
    w.ortho = int(camera.projection == "orthographic")
    w.cmin, w.cscale = cmin, rows / cspan
    w.integ = INTEGRATIONS.index(integration)
    w.steps, w.model = int(steps), 0 if transfer.emission == "color_extinction" else 1
    w.t_min, w.nbr, w.adjacency = float(t_min), int(bool(neighbour_check)), ADJACENCY_MODES.index(adjacency)
    w.max_list = int(max_list)
    w.eps = 1e-6 * float(np.linalg.norm(cells.bounds[1] - cells.bounds[0]))
    if integration == "table":
        if table is None:
            raise ConfigError("integration: 'table' needs a 3D pre-integration table (a table stage before the sweep)")
        # the HARC kernels' 'full' set-up: the table as an emulated 3D texture and its axis maps
        w.ig, keep = integ_setup("full", transfer, device, table=table, weight_bits=weight_bits, cache=texture_cache)
        w.l_max = float(table.axes[0].physical[-1])
        keep = [t for t in keep if t.shape != (1, 1) and t.shape != (1, 1, 1)]  # not the empty placeholders
    else:
        with _unit_counters():  # unused 1-texel placeholders: their uploads are no work of the sweep
            w.ig, keep = integ_setup("exact", transfer, device, cache=texture_cache)
        w.l_max, keep = 1.0, []
    return w, dc, ray_o, ray_d, tf_s, tf_v, keep


def walk_column(cells: ConvexCellMesh, transfer, camera, column, row: int, col: int, *, device: str = "cpu",
                integration: str = "exact", neighbour_check: bool = False, adjacency: str = "count",
                max_list: int = 256, table=None) -> tuple[np.ndarray, dict, list[int]]:
    """Walk one given VSBUFFER column for the ray of pixel ``(row, col)``: ``column`` lists the cell ID
    of each depth row front to back (-1 empty); the other columns of the plane are empty. Returns the
    pixel's premultiplied RGBA, the walk's counters and the ray's list of integrated cells, in order.

    For inspecting the walk on hand-made buffers (split runs, missing rows); the depth rows map onto
    the mesh's depth range as in :func:`render_vsbuffer`.
    """
    import warp as wp

    from warpvol.kernels import vsbuffer as kv

    ids = np.asarray(column, dtype=np.int32).reshape(-1)
    R, W = len(ids), camera.width_px
    abc = ray_space(cells.points, camera, cells.pieces.point_used)
    cmin, cmax = float(abc[:, 2].min()), float(abc[:, 2].max())
    w, dc, ray_o, ray_d, tf_s, tf_v, _ = _walk_inputs(cells, transfer, camera, device, R, cmin,
                                                      max(cmax - cmin, 1e-30), integration, 1, neighbour_check,
                                                      adjacency, 0.0, max_list, table=table)
    w.j0 = int(row)
    vsb = np.full((R + 2, W), -1, np.int32)
    vsb[:R, col] = ids
    out = wp.zeros(W * camera.height_px, dtype=wp.vec4, device=device)
    done = wp.full((W, max_list), -1, dtype=wp.int32, device=device)
    counters = wp.zeros((W, kv.NCOUNT), dtype=wp.int32, device=device)
    wp.launch(kv.column_walk, dim=(1, W), device=device,
              inputs=[dc, w, wp.array(vsb, dtype=wp.int32, device=device), ray_o, ray_d, tf_s, tf_v, done, out,
                      counters, 0])
    lst = done.numpy()[col]
    c = counters.numpy()[col]
    return out.numpy()[row * W + col], dict(zip(kv.COUNTERS, map(int, c))), lst[lst >= 0].tolist()


def render_vsbuffer(cells: ConvexCellMesh, transfer, camera, *, device: str = "cpu", depth_res: int = 0,
                    tree_depth: int = 5, integration: str = "trapezoid", steps: int = 1,
                    neighbour_check: bool = True, adjacency: str = "count", t_min: float = 0.0,
                    max_list: int = 1024, planes_per_batch: int = 16, threads: int = 0,
                    tile_size: int = 4, tree_insert: str = "centroid", cell_test: bool = True,
                    raster_rules: dict | None = None, count=None, keep_lists: bool = False,
                    keep_buffers: bool = False, audit: bool = True, rewalk: bool = False, table=None,
                    weight_bits: int = 8, texture_cache: dict | None = None,
                    on_batch=None, visible_pieces=None) -> tuple[np.ndarray, dict]:
    """Render ``cells`` with the VSBUFFER algorithm; returns ``(image (H, W, 4) premultiplied, stats)``.

    Parameters
    ----------
    cells : ConvexCellMesh
    transfer : TransferFunction
    camera : Camera
    depth_res : int
        VSBUFFER rows along the view direction (0: the image height, as in the paper).
    tree_depth : int
        Octree levels below the root (the paper: 5 for the Blunt Fin).
    tree_insert : {"centroid", "containing"}
        Where a cell is stored in the octree (:func:`build_octree`).
    cell_test : bool
        Of the cells stored at the nodes a plane cuts, draw only those whose own bounding box the
        plane cuts (the same world-space 8-corner test as the nodes', :func:`plane_box_cut`; cells
        whose vertices lie within :data:`CUT_SLACK` of it are drawn too); false: every cell of a cut
        node. A cell the plane does not cut never enters the VSBUFFER (it survives the near/far
        clipping in one pass at most), but drawn it can win that pass's depth test where its face
        meets a cut cell's face within float32 depth resolution and leave a gap there: the VSBUFFER
        with ``cell_test`` equals the one without wherever that one holds a cell, and may hold a cell
        where that one has such a gap. ``drawn_cells``, triangles, vertices and fragments differ
        (``cell_boxes_tested`` counts the tests).
    integration : {"trapezoid", "exact", "table"}
        The paper's trapezoidal rule with attenuation (``steps`` equal sub-steps per piece), the
        exact segment integral (:func:`warpvol.kernels.integrate.integrate_segment`), or a lookup of
        each piece's ``(sf, sb, l)`` in the 3D pre-integration ``table`` through the emulated 3D
        texture unit (:func:`warpvol.kernels.harc.integrate_sub`, pieces longer than the table's
        thickness axis in equal parts), composited front to back.
    table, weight_bits, texture_cache
        For ``"table"``: the 3D table (``data[l, sb, sf]``, any table stage's), its texture unit's
        filter-weight bits (0: fp32) and a dict of textures by table key kept across renders.
    neighbour_check : bool
        Look at the 3x3 VSBUFFER neighbours of the exit point when leaving a cell.
    adjacency : {"count", "recover"}
        Behind an interior exit face (adjacency derived from the pieces), a cell the VSBUFFER missed
        leaves a gap: ``count`` it (``lost_segments``) or ``recover`` it by stepping across the face.
    t_min : float
        Early ray termination below this transmittance (0: off, as in the paper).
    max_list : int
        Length of the per-ray list of integrated cells (overflow is counted).
    planes_per_batch : int
        Sweep planes drawn per rasteriser call (emulation only; results do not depend on it).
    tile_size : int
        Rasteriser bin size (emulation only).
    raster_rules : dict, optional
        ``fill_rule`` / ``snap_ties`` for the rasteriser (default: its defaults).
    audit : bool
        After each plane's walk, check every (ray, cell) pair the plane cuts: a cell the ray crosses
        for more than ``1e-6`` of the mesh diagonal but never integrated is counted in
        ``missed_cells`` (its length in ``stats["missed_length"]``, the count per ray in
        ``stats["missed_per_ray"]``): no loss goes unreported.
    rewalk : bool
        Integrate every ray the audit flagged again, from all cells its plane cuts over its column
        sorted by entry (an improvement over the paper, which does not sort; needs ``audit``). Also
        decides rays lying exactly in a face plane (pixel centres on boundary faces seen edge-on) by
        the reference's rule (:func:`warpvol.kernels.vsbuffer.piece_interval`); without it such a ray
        is inside every cell whose face it lies in.
    keep_lists : bool
        Return every ray's list of integrated cells, in order (``stats["lists"]``, (H, W, max_list),
        -1 padded; for inspection of small images).
    keep_buffers : bool
        Return every plane's VSBUFFER (``stats["vsbuffers"]``, (H, depth_res, W) cell IDs, -1 empty)
        and the drawn (plane, cell) pairs (``stats["drawn"]``, (drawn_cells, 2)); for inspection of
        small images.
    count : callable, optional
        ``count(name=int, ...)`` receives the hardware work (:func:`work_counters`; a stage passes
        ``ctx.count``).
    on_batch : callable, optional
        ``on_batch(first_row, n_rows)`` before each batch of planes: progress, and the point where an
        exception raised there (or a Ctrl-C's ``KeyboardInterrupt``) stops the sweep. A batch draws
        at most :data:`BATCH_PIXELS` ID-buffer pixels, so Ctrl-C waits for one short batch.
    visible_pieces : (T,) bool, optional
        Per piece (tet), whether the transfer function can make it visible
        (:func:`warpvol.conditioning.visibility.cell_visibility`): a cell none of whose pieces is
        visible is left out of the octree, so no plane draws, walks, audits or integrates it, and the
        walk treats a face towards it as a boundary face (empty space behind it, found again in the
        VSBUFFER as in a non-convex mesh). An invisible cell adds nothing to any ray: the image is the
        same. Counted as ``cells_culled``.

    ``stats`` holds ``counters`` (all counted work), ``id_s`` (octree query + both ID passes + read-back
    + comparison) and ``walk_s`` (column walk and integration), ``depth_res``, ``range``, ``cells``
    (as drawn) and ``nonconvex_cells``: cells of ``cells`` that are not convex within float32
    resolution (:attr:`ConvexCellMesh.nonconvex`), drawn as their pieces (:attr:`ConvexCellMesh.drawable`),
    and ``thin_pieces``: pieces too thin for float32 segment lengths at their extinction
    (:meth:`ConvexCellMesh.thin_pieces`; pixels crossing them are approximate).
    """
    import warp as wp

    from warpvol.kernels import vsbuffer as kv
    from warpvol.kernels import vsbuffer_audit as ka

    if not isinstance(cells, ConvexCellMesh):
        raise ConfigError(f"cells: expected a ConvexCellMesh, got {type(cells).__name__}")
    # cells that are not convex (non-planar faces folded in) are drawn as their pieces
    nonconvex = int(cells.nonconvex.sum())
    cells = cells.drawable
    if cells.n_cells >= ID_LIMIT:
        raise ConfigError(f"cells: {cells.n_cells} cells do not fit 24-bit IDs (at most {ID_LIMIT - 1})")
    if integration not in INTEGRATIONS:
        raise ConfigError(f"integration: {integration!r} not allowed; allowed: {', '.join(INTEGRATIONS)}")
    if adjacency not in ADJACENCY_MODES:
        raise ConfigError(f"adjacency: {adjacency!r} not allowed; allowed: {', '.join(ADJACENCY_MODES)}")
    W, H = camera.width_px, camera.height_px
    R = int(depth_res) or H
    vis_cell = None if visible_pieces is None else per_cell(visible_pieces, cells.cell_start)
    if camera.projection == "perspective" and float(((ray_used(cells) - camera.eye) @ camera.forward).max()) <= 0.0:
        # the whole mesh behind the eye: no plane cuts anything in view, the image is transparent
        culled = 0 if vis_cell is None else int(cells.n_cells - vis_cell.sum())
        return _nothing_drawn(H, W, R, cells, nonconvex, audit, "mesh behind the eye",
                              dict(_zero_counts(0), cells_culled=culled))
    if vis_cell is not None and not vis_cell.any():  # nothing the transfer function shows
        return _nothing_drawn(H, W, R, cells, nonconvex, audit, "no cell visible under the transfer function",
                              dict(_zero_counts(0), cells_culled=cells.n_cells))
    stride = R + 2
    t0 = time.perf_counter()
    abc = ray_space(cells.points, camera, cells.pieces.point_used)
    cmin, cmax = float(abc[:, 2].min()), float(abc[:, 2].max())
    cspan = max(cmax - cmin, 1e-30 * max(1.0, abs(cmax)))
    pb = abc[cells.pieces.tets][..., 1]  # (T, 4)
    cb_lo = np.minimum.reduceat(pb.min(axis=1), cells.cell_start[:-1])
    cb_hi = np.maximum.reduceat(pb.max(axis=1), cells.cell_start[:-1])
    brange = float((cb_hi - cb_lo).max()) * (1.0 + 1e-6) + 1e-9
    if cell_test:  # the cells' world bounding boxes: corners' eye-space y, z for the per-plane test
        cell_y, cell_z = box_corners_yz(*cells.cell_bounds, camera)
    pa = abc[cells.pieces.tets][..., 0]
    ca_lo = np.minimum.reduceat(pa.min(axis=1), cells.cell_start[:-1])
    ca_hi = np.maximum.reduceat(pa.max(axis=1), cells.cell_start[:-1])
    side = _face_sides(cells, abc)
    fc = cells.face_cell
    back_f, front_f = np.nonzero(side > 0)[0], np.nonzero(side < 0)[0]
    # faces per cell (CSR over cells) for each pass
    csr = {}
    for name, fl in (("back", back_f), ("front", front_f)):
        o = fl[np.argsort(fc[fl], kind="stable")]
        cnt = np.bincount(fc[o], minlength=cells.n_cells)
        csr[name] = (o, np.concatenate([[0], np.cumsum(cnt)])[:-1], cnt)
    if vis_cell is None:
        tree = build_octree(*cells.cell_bounds, tree_depth, tree_insert)
    else:  # only the visible cells enter the octree: no plane draws the others
        keep = np.nonzero(vis_cell)[0]
        tree = build_octree(*(b[keep] for b in cells.cell_bounds), tree_depth, tree_insert)
        tree.cells = keep[tree.cells]
    node_cnt = np.diff(tree.cell_start)
    w, dc, ray_o, ray_d, tf_s, tf_v, textures = _walk_inputs(
        cells, transfer, camera, device, R, cmin, cspan, integration, steps, neighbour_check, adjacency, t_min,
        max_list, table=table, weight_bits=weight_bits or None, texture_cache=texture_cache, ties=rewalk,
        visible=vis_cell)
    out = wp.zeros(W * H, dtype=wp.vec4, device=device)
    rules = dict(raster_rules or {})
    # planes of one batch are stacked in one ID buffer: keep it within the rasteriser's 65536 rows
    # and within BATCH_PIXELS, so a Ctrl-C waits for one short batch of launches
    P = max(1, min(int(planes_per_batch), H, 65536 // stride, BATCH_PIXELS // (stride * W)))
    threads = threads or cpu_threads()
    cnt = _zero_counts(H)
    cnt["cells_culled"] = 0 if vis_cell is None else int(cells.n_cells - vis_cell.sum())
    missed_length = 0.0
    ray_missed = wp.zeros(W * H, dtype=wp.int32, device=device)
    t_setup = time.perf_counter() - t0
    id_s, walk_s = 0.0, 0.0
    done = wp.full((P * W, max(1, int(max_list))), -1, dtype=wp.int32, device=device)
    counters = wp.zeros((P * W, kv.NCOUNT), dtype=wp.int32, device=device)
    lists = np.full((H, W, max(1, int(max_list))), -1, np.int32) if keep_lists else None
    vsbs = np.full((H, R, W), -1, np.int32) if keep_buffers else None
    drawn = []
    for j0 in range(0, H, P):
        if on_batch is not None:
            on_batch(j0, min(P, H - j0))
        t1 = time.perf_counter()
        rows = np.arange(j0, min(H, j0 + P))
        np_ = len(rows)
        hits = plane_node_hits(tree, camera, rows.astype(np.float64))  # (np_, N)
        par = tree.parent
        reached = np.ones_like(hits)
        reached[:, par >= 0] = hits[:, par[par >= 0]]
        cnt["tree_nodes_tested"] += int(reached.sum())
        pl, nd = np.nonzero(hits)
        own, item = _expand(tree.cell_start[nd], node_cnt[nd])
        pc_plane, pc_cell = pl[own], tree.cells[item]
        if cell_test:
            # the cells whose box the plane cuts; and those within float32 depth of the plane (vertices'
            # ray-space range): the clipped passes could keep them, as they do with the node drawn whole
            bj, eps = rows[pc_plane] + 0.5, max(CUT_SLACK * brange, AUDIT_SLACK)
            sel = (plane_box_cut(cell_y[pc_cell], cell_z[pc_cell], camera, rows[pc_plane])
                   | ((cb_lo[pc_cell] - eps <= bj) & (bj <= cb_hi[pc_cell] + eps)))
            cnt["cell_boxes_tested"] += len(pc_cell)
            pc_plane, pc_cell = pc_plane[sel], pc_cell[sel]
        cnt["drawn_cells"] += len(pc_cell)
        jobs = []
        for name, func, zoff in (("back", "less", 0.0), ("front", "greater", 1.0)):
            order, fst, fcnt = csr[name]
            own2, item2 = _expand(fst[pc_cell], fcnt[pc_cell])
            f = order[item2]
            plane = pc_plane[own2]
            v = abc[cells.boundary[f]]  # (n, 3 vertices, abc)
            pos = np.empty((len(f), 3, 4), np.float32)
            pos[..., 0] = v[..., 0]
            pos[..., 1] = (v[..., 2] - cmin) * (R / cspan) + (plane * stride)[:, None]
            pos[..., 2] = (v[..., 1] - (rows[plane] + 0.5)[:, None]) * (1.0 / brange) + zoff
            pos[..., 3] = 1.0
            cnt[f"id_triangles_{name}"] += len(f)
            jobs.append((func, pos.reshape(-1, 4), fc[f]))
        bufs, unit_counts = [None, None], [{}, {}]

        def draw(b: int, jobs=jobs, np_=np_, bufs=bufs, unit_counts=unit_counts) -> None:
            func, pos, ids = jobs[b]
            rast = Rasterizer(W, np_ * stride, device=device, depth_func=func, depth_write=True, depth_clip=True,
                              tile_size=tile_size, **rules)
            idbuf = wp.full((np_ * stride, W), -1, dtype=wp.int32, device=device)
            with _unit_counters() as uc:  # what the rasteriser counts on this thread (fragments, ...)
                rast.draw_ids(pos, np.arange(len(pos), dtype=np.int32).reshape(-1, 3), ids, id_buffer=idbuf)
            unit_counts[b] = uc
            bufs[b] = idbuf

        # the two passes are independent draws: on the CPU each runs on its own host thread
        launch_blocks(device, 2, draw, threads, modules=Rasterizer.KERNEL_MODULES)
        for uc in unit_counts:
            for k, v in uc.items():
                cnt[k] = cnt.get(k, 0) + int(v)
        cnt["id_pixels_read"] += 2 * np_ * R * W
        # in the vocabulary of the hardware counters: per plane two passes, each cleared (colour and
        # depth), drawn and read back as RGBA8 (glReadPixels(..., RGBA, BYTE) in the paper's Fig. 7)
        cnt["passes"] += 2 * np_
        cnt["readbacks"] += 2 * np_
        cnt["bytes_down"] += 4 * 2 * np_ * R * W
        cnt["clears"] += 4 * np_
        cnt["clear_pixels"] += 4 * np_ * R * W
        cnt["vertices"] += 3 * (len(jobs[0][2]) + len(jobs[1][2]))
        vsb = wp.empty((np_ * stride, W), dtype=wp.int32, device=device)
        wp.launch(kv.vsb_compare, dim=(np_ * stride, W), inputs=[bufs[0], bufs[1], vsb], device=device)
        cnt["vsb_pixels_compared"] += np_ * R * W
        if keep_buffers:
            vsbs[j0:j0 + np_] = vsb.numpy().reshape(np_, stride, W)[:, :R]
            drawn.append(np.column_stack([rows[pc_plane], pc_cell]))
        t2 = time.perf_counter()
        w.j0 = int(j0)
        counters.zero_()
        on_cpu = str(device).startswith("cpu")
        pblocks = blocks(np_, 1 if on_cpu else np_)

        def launch(b: int, pblocks=pblocks, vsb=vsb) -> None:
            p0, n = pblocks[b]
            wp.launch(kv.column_walk, dim=(n, W), device=device,
                      inputs=[dc, w, vsb, ray_o, ray_d, tf_s, tf_v, done, out, counters, p0])

        # each block writes its own rows of ``done``/``counters`` (thread id = plane-in-batch * W + column)
        launch_blocks(device, len(pblocks), launch, threads, modules=[kv])
        c = counters.numpy().sum(axis=0)
        for k, name in enumerate(kv.COUNTERS):
            cnt[name] += int(c[k])
        if audit:
            # (plane, column, cell) for cells the plane cuts whose column range holds column centres
            # (ranges widened by AUDIT_SLACK pixels: a ray exactly in a cell's boundary face, rounded
            # out of the float64 range, is still checked)
            cut = ((cb_lo[pc_cell] - AUDIT_SLACK <= rows[pc_plane] + 0.5)
                   & (rows[pc_plane] + 0.5 <= cb_hi[pc_cell] + AUDIT_SLACK))
            ap, ac = pc_plane[cut], pc_cell[cut]
            c0 = np.clip(np.ceil(ca_lo[ac] - 0.5 - AUDIT_SLACK), 0, W).astype(np.int64)
            c1 = np.clip(np.floor(ca_hi[ac] - 0.5 + AUDIT_SLACK), -1, W - 1).astype(np.int64)
            n = np.maximum(c1 - c0 + 1, 0)
            own3, col3 = _expand(c0, n)
            if len(own3):
                dev = lambda a: wp.array(a.astype(np.int32), dtype=wp.int32, device=device)  # noqa: E731
                missed = wp.zeros(len(own3), dtype=wp.int32, device=device)
                mlen = wp.zeros(len(own3), dtype=wp.float32, device=device)
                wp.launch(ka.audit_pairs, dim=len(own3), device=device,
                          inputs=[dc, w, dev(ap[own3]), dev(col3), dev(ac[own3]), ray_o, ray_d, done, out, missed,
                                  mlen, ray_missed])
                cnt["audit_pairs"] += len(own3)
                miss = missed.numpy()
                cnt["missed_cells"] += int(miss.sum())
                missed_length += float(mlen.numpy().astype(np.float64).sum())
                if rewalk and miss.any():
                    key = ap[own3] * W + col3
                    flagged = np.unique(key[miss > 0])
                    sel = np.nonzero(np.isin(key, flagged))[0]
                    sel = sel[np.argsort(key[sel], kind="stable")]
                    keys, first = np.unique(key[sel], return_index=True)
                    starts = np.append(first, len(sel))
                    counters.zero_()
                    wp.launch(ka.rewalk, dim=len(keys), device=device,
                              inputs=[dc, w, dev(keys), dev(starts), dev(ac[own3][sel]), ray_o, ray_d, tf_s, tf_v,
                                      out, counters])
                    c = counters.numpy().sum(axis=0)
                    for k, name in enumerate(kv.COUNTERS):
                        cnt[name] += int(c[k])
                    cnt["rays_rewalked"] += len(keys)
                    cnt["rewalk_candidates"] += len(sel)
        if lists is not None:
            lists[j0:j0 + np_] = done.numpy()[:np_ * W].reshape(np_, W, -1)
        done.fill_(-1)
        t3 = time.perf_counter()
        id_s += t2 - t1
        walk_s += t3 - t2
    if count is not None:
        count(**work_counters(cnt))
    for t in textures:  # the 3D table: one trilinear fetch per lookup (the unit's counters)
        t.count(cnt["table_lookups"])
    img = out.numpy().reshape(H, W, 4)
    thin = int(cells.thin_pieces(transfer).sum())
    return img, {"thin_pieces": thin, "counters": cnt, "id_s": id_s, "walk_s": walk_s, "setup_s": t_setup, "depth_res": R,
                 "range": brange, "lists": lists, "missed_length": missed_length, "vsbuffers": vsbs,
                 "drawn": np.concatenate(drawn) if keep_buffers and drawn else None,
                 "missed_per_ray": ray_missed.numpy().reshape(H, W) if audit else None, "octree_nodes": tree.n_nodes, "cells": cells.n_cells, "tets": cells.n_tets,
                 "nonconvex_cells": nonconvex}
