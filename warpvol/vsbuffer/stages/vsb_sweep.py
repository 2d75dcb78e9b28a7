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

from warpvol.errors import ConfigError
from warpvol.progress import detail
from warpvol.reference.pixels import redo_mesh_properties, redo_pixels_float64
from warpvol.shared.entry_bins import ENTRY_MESH_PROPERTIES
from warpvol.shared.thin_cells import _shape, edge_on_pixels, silhouette_pixels, unresolved_pixels
from warpvol.shared.visible import skipping
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
                                         -- traced again in float64, ``thin_rays_redone``; so are
                                         pixel centres within 1/64 px of a silhouette or of a face seen
                                         edge-on, ``silhouette_rays_redone``; both: ``float64_rays``)
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
        """``img`` with the pixels whose rays may cross a piece a float32 walk cannot resolve
        (:func:`warpvol.shared.thin_cells.unresolved_pixels`), and those whose centre lies within 1/64 pixel
        of a silhouette of the front boundary or of a face seen edge-on (in a sweep plane), where the ID
        buffers' snapped coverage does not decide the cell the ray crosses
        (:func:`~warpvol.shared.thin_cells.silhouette_pixels`,
        :func:`~warpvol.shared.thin_cells.edge_on_pixels`), traced again in float64."""
        import numpy as np


        sc = ctx.scene
        tets = getattr(sc.mesh, "pieces", sc.mesh)  # a ConvexCellMesh's tets
        pieces = ctx.buffers["vsb_cells"].pieces
        cache = ctx.persistent.setdefault("vsb_thin_cells", {})  # per mesh, kept: set-up, not frame time
        if cache.get("mesh") is not pieces:
            with ctx.setup_work("thin-piece shapes"):
                _shape(pieces, cache)
        ctx.mesh_setup(tets, *ENTRY_MESH_PROPERTIES)  # silhouette_pixels' entry faces
        pix, n_thin = unresolved_pixels(pieces, sc.transfer, sc.camera, cache=cache)
        edge = np.union1d(silhouette_pixels(tets, sc.camera), edge_on_pixels(tets, sc.camera))
        ctx.stats["vsbuffer"].update(thin_pieces=n_thin, thin_rays_redone=int(len(pix)),
                                     silhouette_rays_redone=int(len(np.setdiff1d(edge, pix))))
        pix = np.union1d(pix, edge)
        ctx.stats["vsbuffer"]["float64_rays"] = int(len(pix))  # the float64 redo's one name, as in the others
        if len(pix):
            h, w = sc.camera.height_px, sc.camera.width_px
            out = np.array(img, dtype=np.float32).reshape(h * w, 4)
            ctx.mesh_setup(tets, *redo_mesh_properties(sc.camera))
            out[pix] = redo_pixels_float64(tets, sc.transfer, sc.camera, pix, visible=skipping(ctx)[0])
            img = out.reshape(h, w, 4)
            ctx.progress(f"{self.name}: {len(pix)} rays that may cross pieces thinner than float32 resolves, or "
                         "graze a silhouette or a face seen edge-on, were redone in float64")
        return img
