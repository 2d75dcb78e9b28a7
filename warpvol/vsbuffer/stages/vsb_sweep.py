"""Stage ``vsb_sweep``: Westermann & Ertl's VSBUFFER sweep, one plane per scanline.

Per plane: octree query, two ID passes on the emulated rasteriser (back faces LESS / front faces
GREATER, near/far clipping at the plane), buffer comparison, front-to-back column walk and
integration (:func:`warpvol.vsbuffer.vsbuffer.render_vsbuffer`). Counts the hardware work in the counters'
vocabulary (passes, vertices, fragments, ID writes, read-backs, clears; ``host_cell_steps`` for the
host's intersections and integration; the 3D table's texture fetches under ``integration = "table"``; ``drawn_cells``, the paper's "drawn tetra"), so ``--gpu
indigo2_impact`` models it; every count of the walk (runs, reused exit points, ``lost_segments``,
``missed_cells`` ...) and the time in ID-buffer generation and in integration go to
``stats["vsbuffer"]``.

With the ``visibility`` stage before it (skipping on), the cells the transfer function makes invisible
are left out of the octree: no plane draws, walks, audits or integrates them, and the walk meets them
as empty space (``left_out``: ``cells_culled``).
"""

from __future__ import annotations

from warpvol.stage import Context, Param, Stage, register_stage
from warpvol.vsbuffer.vsbuffer import ADJACENCY_MODES, INTEGRATIONS, render_vsbuffer


@register_stage
class VsbSweep(Stage):
    """VSBUFFER generation and traversal for every scanline.

    ================  =====  ==========  ==============================================================
    parameter         type   default     meaning
    ================  =====  ==========  ==============================================================
    depth_res         int    0           VSBUFFER rows along the view (0: the image height, the paper's)
    tree_depth        int    5           octree levels below the root (the paper: 5), [0, 10]
    tree_insert       str    containing  ``containing`` (the paper's: deepest node fully containing
                                         the cell's box) | ``centroid`` (leaf of the box centre,
                                         tight node boxes: fewer cells tested or drawn, same image)
    cell_test         bool   true        of the cells stored at the nodes a plane cuts, draw only
                                         those whose own bounding box it cuts (the paper's "the cells
                                         at each node that have an intersection with the scanline are
                                         drawn"); false: every cell of a cut node (the paper's "only if
                                         the scanline intersects a bounding box all polygons stored at
                                         that node are drawn" read as a node test). Fewer drawn
                                         cells, vertices and fragments; the VSBUFFER differs only
                                         where a drawn uncut cell won a pass's depth test against a
                                         cut cell within float32 depth resolution (a gap there)
    integration       str    trapezoid   ``trapezoid`` (the paper's, with attenuation) | ``exact`` |
                                         ``table`` (3D pre-integration lookup of (sf, sb, l))
    table             str    table3d     ``ctx.buffers`` key of the 3D table (``table``; then needed)
    weight_bits       int    8           table texture's filter-weight bits, [0, 16] (0: fp32 weights)
    steps             int    1           trapezoid sub-steps per cell segment, [1, 1024]
    neighbour_check   bool   true        check the 3x3 buffer neighbours when leaving a cell
    adjacency         str    count       gaps behind interior faces: ``count`` | ``recover``
    t_min             float  0.0         early ray termination below this transmittance (0: off)
    max_list          int    1024        per-ray list of integrated cells (overflow counted)
    planes_per_batch  int    16          planes per rasteriser call (emulation only)
    audit             bool   true        count ray/cell crossings the walk missed (``missed_cells``)
    rewalk            bool   false       integrate flagged rays again from their cut cells, sorted
    thin              str    warn        cells too thin for float32: ``warn`` (pixels crossing them
                                         are approximate, warned) | ``redo`` (the pixels whose rays
                                         may cross one -- too thin at its extinction, or seen edge-on
                                         -- traced again in float64, ``thin_rays_redone``)
    threads           int    0           host threads for the column walk on the CPU (0: all cores)
    max_sweep_pixels  int    2^32        refuse a sweep drawing more ID-buffer pixels than this (two
                                         passes x planes x (depth_res + 2) x width): the emulated sweep
                                         grows as the cube of the image size (1024^2: 2.1e9 pixels,
                                         3.5 min on 2 CPU cores; 4096^2: 1.4e11, hours)
    ================  =====  ==========  ==============================================================
    """

    name = "vsb_sweep"
    summary = "VSBUFFER sweep planes: two 24-bit ID passes per scanline, comparison, column walk + integration"
    needs = ("vsb_cells",)
    provides = ("image",)
    params = (
        Param("depth_res", int, 0, "VSBUFFER rows along the view (0: image height)", lo=0, hi=65536),
        Param("tree_depth", int, 5, "octree levels below the root", lo=0, hi=10),
        Param("tree_insert", str, "containing", "cell placement in the octree", choices=("containing", "centroid")),
        Param("cell_test", bool, True, "draw only the cells of a cut node whose own box the plane cuts"),
        Param("integration", str, "trapezoid", "integration rule", choices=INTEGRATIONS),
        Param("table", str, "table3d", "ctx.buffers key of the 3D table (integration = table)"),
        Param("weight_bits", int, 8, "table texture's filter-weight fraction bits (0: fp32 weights)", lo=0, hi=16),
        Param("steps", int, 1, "trapezoid sub-steps per cell segment", lo=1, hi=1024),
        Param("neighbour_check", bool, True, "check buffer neighbours when leaving a cell"),
        Param("adjacency", str, "count", "gaps behind interior faces", choices=ADJACENCY_MODES),
        Param("t_min", float, 0.0, "early ray termination below this transmittance", lo=0.0, hi=1.0),
        Param("max_list", int, 1024, "per-ray list of integrated cells", lo=1, hi=1 << 20),
        Param("planes_per_batch", int, 16, "sweep planes per rasteriser call (emulation only)", lo=1, hi=4096),
        Param("audit", bool, True, "count ray/cell crossings the walk missed (missed_cells)"),
        Param("rewalk", bool, False, "integrate rays the audit flagged again from their sorted cut cells"),
        Param("thin", str, "warn", "pixels crossing pieces too thin for float32: warned or redone in float64",
              choices=("warn", "redo")),
        Param("threads", int, 0, "host threads for the column walk (0: all cores)", lo=0, hi=256),
        Param("max_sweep_pixels", int, 1 << 32, "refuse a sweep drawing more ID-buffer pixels than this",
              lo=1, hi=1 << 50),
    )

    def validate(self) -> None:
        if self.integration == "table":  # the table stage's output must come before the sweep
            self.needs = ("vsb_cells", "{table}")
        if self.rewalk and not self.audit:
            from warpvol.errors import ConfigError

            raise ConfigError(f"{self.where}.rewalk: needs audit = true (the audit finds the rays to walk again)")

    def leaves_out(self, ctx: Context) -> str | None:
        what = []
        if self.config["t_min"] > 0:
            what.append(f"the rest of each ray once its transmittance is below t_min = {self.config['t_min']:g}")
        what.append("with the visibility stage before it: the cells the transfer function makes invisible (left "
                    "out of the octree: not drawn, walked or integrated)")
        return "; ".join(what)

    def run(self, ctx: Context) -> None:
        from warpvol.errors import ConfigError

        sc = ctx.scene
        cfg = dict(self.config)
        key = cfg.pop("table")
        limit = cfg.pop("max_sweep_pixels")
        cfg.pop("thin")
        cam = sc.camera
        rows = cfg["depth_res"] or cam.height_px
        work = 2 * cam.height_px * (rows + 2) * cam.width_px
        if work > limit:
            raise ConfigError(
                f"{self.where}: a {cam.width_px}x{cam.height_px} image with depth_res {rows} sweeps {cam.height_px} "
                f"planes of {rows + 2}x{cam.width_px} ID-buffer pixels, two passes each: {work:.3g} pixels, over "
                f"max_sweep_pixels = {limit:.3g} (the emulated sweep grows as the cube of the image size; hours "
                "on a CPU); lower the image size or depth_res, or raise max_sweep_pixels")
        table = ctx.buffers[key] if self.integration == "table" else None
        from warpvol.progress import detail

        h = cam.height_px  # the sweep's planes, one per image row: its share done goes to an open progress bar
        vis = ctx.buffers.get("visible_cells") if ctx.skip else None
        if not ctx.skip:  # all the work, for comparison: no early ray termination either
            cfg["t_min"] = 0.0
        img, st = render_vsbuffer(ctx.buffers["vsb_cells"], sc.transfer, sc.camera, device=ctx.device, visible_pieces=vis,
                                  count=ctx.count, table=table, on_batch=lambda j0, n: detail(self.name, j0 / h,
                                                                                                  f"plane {j0} of {h}"),
                                  texture_cache=ctx.persistent.setdefault("vsb_textures", {}), **cfg)
        ctx.stats["vsbuffer"] = {k: v for k, v in st.items() if k not in ("counters", "lists", "missed_per_ray", "vsbuffers", "drawn")}
        c = st["counters"]
        ctx.stats["vsbuffer"]["walk"] = c  # every count of the sweep; the hardware work is in ``counters``
        ctx.stats["vsbuffer"].update(lost_segments=c["lost_segments"], missed_cells=c["missed_cells"])
        ctx.stats["vsbuffer"]["rays_rewalked"] = c["rays_rewalked"]
        why, left = [], {}
        if vis is not None:
            why.append("cells the transfer function makes invisible (zero extinction and colour over their scalar "
                       "range): left out of the octree, never drawn into a VSBUFFER, walked or integrated")
            left["cells_culled"] = c["cells_culled"]
        if cfg["t_min"] > 0:
            import numpy as np

            why.append(f"the rest of a ray once its transmittance is below t_min = {cfg['t_min']:g}")
            left["rays_terminated"] = int(np.count_nonzero(1.0 - img[..., 3] < cfg["t_min"]))
        if why:
            ctx.left_out(why="; ".join(why), **left)
        # the paper's Table 1 column "drawn tetra": cells drawn over all sweep planes, by the selection rule
        ctx.stats["vsbuffer"].update(tree_insert=self.tree_insert, cell_test=self.cell_test,
                                     drawn_cells=c["drawn_cells"])
        if (c["lost_segments"] or c["missed_cells"]) and not self.rewalk:
            ctx.stats["vsbuffer"]["warning"] = (
                f"{c['missed_cells']} ray/cell crossings missed by the VSBUFFER "
                f"({int((st['missed_per_ray'] > 0).sum()) if st['missed_per_ray'] is not None else '?'} rays), "
                f"{c['lost_segments']} gaps behind interior faces; raise depth_res or use vsbuffer_best")
        if self.thin == "redo":
            img = self._redo_thin(ctx, img)
        elif st.get("thin_pieces"):
            thin = (f"{st['thin_pieces']} cells are thinner than float32 segment lengths resolve at their "
                    "extinction (optical-depth error over 1e-5 per crossing): pixels crossing them are approximate")
            w = ctx.stats["vsbuffer"].get("warning")
            ctx.stats["vsbuffer"]["warning"] = f"{w}; {thin}" if w else thin
        ctx.image = img

    def _redo_thin(self, ctx: Context, img):
        """``img`` with the pixels whose rays may cross an unresolved thin piece traced again in float64: a
        piece too thin for float32 at its extinction, or a thin piece whose window footprint is narrower
        than :data:`EDGE_ON_PX` (seen edge-on: a ray may run inside it) and whose optical depth along its
        diameter exceeds 1e-5 (:meth:`~warpvol.vsbuffer.cells.ConvexCellMesh.thin_pieces`)."""
        import numpy as np

        from warpvol.reference.pixels import redo_pixels_float64

        sc = ctx.scene
        cells = ctx.buffers["vsb_cells"]
        pieces = cells.points[cells.pieces.tets]
        thin = cells.thin_pieces(sc.transfer)
        diameter = np.max([np.linalg.norm(pieces[:, a] - pieces[:, b], axis=1)
                           for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))], axis=0)
        maybe = np.flatnonzero(cells.thin_pieces(sc.transfer, length=diameter) & ~thin)
        thin[maybe[window_width(pieces[maybe], sc.camera) < EDGE_ON_PX]] = True
        pix = pixels_under(pieces[thin], sc.camera)
        ctx.stats["vsbuffer"].update(thin_pieces=int(thin.sum()), thin_rays_redone=int(len(pix)))
        if len(pix):
            h, w = sc.camera.height_px, sc.camera.width_px
            out = np.array(img, dtype=np.float32).reshape(h * w, 4)
            out[pix] = redo_pixels_float64(sc.mesh, sc.transfer, sc.camera, pix)
            img = out.reshape(h, w, 4)
            ctx.progress(f"{self.name}: {len(pix)} rays that may cross pieces thinner than float32 resolves were "
                         "redone in float64")
        return img


#: a thin piece whose window footprint is narrower than this (pixels) is taken as seen edge-on
EDGE_ON_PX = 1.0 / 64.0


def window_width(pieces, camera):
    """(T,) the width in pixels of each piece's (T, 4, 3) window footprint: its projected area (half the
    summed absolute areas of its projected faces) over its longest projected edge; 0 where a point does
    not project (perspective, on the eye plane)."""
    import numpy as np

    from warpvol.raycasting.stages.entry_bins import window_xy

    if len(pieces) == 0:
        return np.zeros(0)
    wx, wy, bad, _ = window_xy(camera, np.asarray(pieces, np.float64).reshape(-1, 3))
    q = np.stack([wx, wy], axis=-1).reshape(-1, 4, 2)
    area = np.zeros(len(q))
    longest = np.zeros(len(q))
    for a, b, c in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
        u, v = q[:, b] - q[:, a], q[:, c] - q[:, a]
        area += 0.25 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])  # half of each face's |area| (2A / 2 / 2)
    for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)):
        longest = np.maximum(longest, np.linalg.norm(q[:, b] - q[:, a], axis=1))
    with np.errstate(divide="ignore", invalid="ignore"):
        width = np.where(longest > 0, area / longest, 0.0)
    return np.where(bad.reshape(-1, 4).any(axis=1) | ~np.isfinite(width), 0.0, width)


def pixels_under(pieces, camera):
    """Flat indices of the pixels whose rays may cross any of ``pieces`` (T, 4, 3): each piece's window box
    grown by one pixel (float64 projection; a piece reaching the eye plane of a perspective camera: every
    pixel)."""
    import numpy as np

    from warpvol.raycasting.stages.entry_bins import window_xy

    h, w = camera.height_px, camera.width_px
    if len(pieces) == 0:
        return np.zeros(0, np.int64)
    wx, wy, bad, z = window_xy(camera, np.asarray(pieces, np.float64).reshape(-1, 3))
    wx, wy, bad, z = (a.reshape(-1, 4) for a in (wx, wy, bad, z))
    if camera.projection == "perspective" and (bad.any() or (z <= 0).any()):
        return np.arange(h * w, dtype=np.int64)
    x0 = np.clip(np.floor(wx.min(axis=1) - 1.0), 0, w).astype(np.int64)
    x1 = np.clip(np.ceil(wx.max(axis=1) + 1.0), 0, w).astype(np.int64)
    y0 = np.clip(np.floor(wy.min(axis=1) - 1.0), 0, h).astype(np.int64)
    y1 = np.clip(np.ceil(wy.max(axis=1) + 1.0), 0, h).astype(np.int64)
    diff = np.zeros((h + 1, w + 1), np.int64)  # box corners, summed over both axes
    np.add.at(diff, (y0, x0), 1)
    np.add.at(diff, (y0, x1), -1)
    np.add.at(diff, (y1, x0), -1)
    np.add.at(diff, (y1, x1), 1)
    return np.flatnonzero(diff.cumsum(axis=0).cumsum(axis=1)[:h, :w] > 0)
