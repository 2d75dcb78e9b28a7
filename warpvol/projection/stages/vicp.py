"""Stage ``vicp``: view-independent cell projection (Weiler, Kraus, Merz & Ertl 2003) as Espinha &
Celes 2005 measured it on the GeForce 6800 GT.

Every tetrahedron, in the visibility order of stage ``sort`` (MPVO / MPVONC), is drawn as its four
faces (12 vertices, unindexed) with back-face culling, so each pixel its projection covers gets one
fragment, from the front face its ray enters through. The rasteriser interpolates the object-space
vertex positions perspective-correctly; the fragment program (:mod:`warpvol.kernels.vicp`, fp32
arithmetic) casts the view ray through the fragment's entry point, finds the exit as the smallest
ray parameter among the planes of the cell's other faces that the ray leaves through, takes
``sf``, ``sb`` from the cell's scalar gradient and ``l`` from the two points, and looks ``(C, α)``
up in the 3D pre-integration table through the texture unit (``table_exact``'s 128³ RGBA8 table,
trilinear with 8-bit filter weights); the blending unit composites back to front into the 8-bit
frame buffer. Face planes and gradients are per-cell constants computed once per mesh in fp32
(view-independent data, cached in the pipeline's persistent state).

The segment is that of the pixel's ray, so unlike projected tetrahedra with screen-linear
``(sf, sb, l)`` there is no perspective error; the losses that remain are the hardware's: the
table's 8-bit texels and its sampling, 8-bit filter weights, 8-bit blending, fp32 ray set-up and the
visibility order (MPVONC is approximate on non-convex meshes). They are stated in
``stats["vicp"]["losses"]``; fragments whose ray leaves through no other face (fp32, rays grazing an
edge; drawn with ``l = 0``) are counted and reported as a warning.

Counters: the rasteriser and blending unit count ``primitives``, ``fragments`` and ``blends_<fmt>``;
this stage counts ``vertices`` (12 per tet), ``bytes_up`` (``geometry = "upload"``: the 12 vertices'
position, the cell's four planes and gradient, fp32, sent each frame as in Espinha & Celes' VICP;
``"resident"``: kept in graphics memory, their VICP-GPU), the 3D texture fetches (one per
fragment), ``texture_lookups`` and ``combiner_ops`` (:data:`warpvol.kernels.vicp.FP_INSTRUCTIONS`
fp40 instructions per fragment).
"""

from __future__ import annotations

import weakref

import numpy as np

from warpvol.errors import ConfigError
from warpvol.gpu.blend import BlendUnit, FrameBuffer
from warpvol.gpu.raster import Rasterizer
from warpvol.gpu.texture import Texture3D
from warpvol.projection.programs import _scalar_consts
from warpvol.projection.pt import RASTER_RULES
from warpvol.projection.stages.pt_vertex_color import (
    BATCH,
    FILTER,
    TABLE3D,
    WEIGHT_BITS,
    fb_param,
    table_from,
    texel_param,
)
from warpvol.shared.integration import TEXEL_FOR_TABLE, _axis_affine
from warpvol.stage import Context, Param, Stage, register_stage

#: fp32 values sent per vertex with ``geometry = "upload"``: position (3), four face planes (16),
#: gradient and offset (4)
FLOATS_PER_VERTEX = 23

LOSSES = ("faithful to Espinha & Celes' VICP: 128^3 RGBA8 table (its l axis sampled in 128 steps up to the "
          "longest edge), trilinear lookups with 8-bit filter weights, 8-bit back-to-front blending, fp32 "
          "fragment-program ray set-up; MPVONC order (approximate on non-convex meshes)")


def cell_constants(mesh, device: str, cache: dict | None = None) -> dict:
    """Per-tet face planes ``(M, 4)`` vec4 and gradients ``(M,)`` vec4 (fp32, :func:`warpvol.kernels.vicp.k_vicp_cells`),
    the tets' culling-consistent faces ``(M, 4, 3)`` (outward, counter-clockwise seen from outside) and the
    count of degenerate tets; from ``cache`` when it holds them for this mesh and device."""
    import warp as wp

    from warpvol.kernels import vicp as kv

    key = str(device)
    hit = None if cache is None else cache.get(key)
    if hit is not None and hit["mesh"]() is mesh:
        return hit["data"]
    tets = np.ascontiguousarray(mesh.tets, dtype=np.int32)
    m = len(tets)
    pts = np.asarray(mesh.points, dtype=np.float64)
    e = pts[tets[:, 1:]] - pts[tets[:, :1]]
    neg = np.linalg.det(e) < 0  # orientation (float64: only the winding, the faces' own arithmetic is the GPU's)
    local = np.array(kv.FACES, dtype=np.int64)  # (4, 3)
    faces = tets[:, local]  # (M, 4, 3)
    faces[neg] = faces[neg][:, :, [0, 2, 1]]
    planes = wp.zeros((max(m, 1), 4), dtype=wp.vec4, device=device)
    grads = wp.zeros(max(m, 1), dtype=wp.vec4, device=device)
    degen = wp.zeros(max(m, 1), dtype=wp.int32, device=device)
    if m:
        wp.launch(kv.k_vicp_cells, dim=m,
                  inputs=[wp.array(np.asarray(mesh.points, np.float32), dtype=wp.vec3, device=device),
                          wp.array(np.asarray(mesh.scalars, np.float32), dtype=wp.float32, device=device),
                          wp.array(tets, dtype=wp.vec4i, device=device), planes, grads, degen], device=device)
    data = {"planes": planes, "grads": grads, "faces": faces.astype(np.int32),
            "points": np.ascontiguousarray(mesh.points, dtype=np.float32),
            "degenerate": int(degen.numpy()[:m].sum()) if m else 0}
    if cache is not None:
        cache[key] = {"mesh": weakref.ref(mesh), "data": data}
    return data


@register_stage
class VICP(Stage):
    """Faces rasterised with back-face culling; exit from the cell's face planes per fragment; 3D table.

    ============  =====  ========  ===============================================  ====================
    parameter     type   default   allowed                                          meaning
    ============  =====  ========  ===============================================  ====================
    table         str    table3d   ``ctx.buffers`` key                              the 3D table
    texel_format  str    auto      ``auto`` ``rgba8`` ``rgba16f`` ``rgba32f``       3D texture format
                                                                                    (auto: the table's)
    filter        str    linear    ``linear`` | ``nearest``                         texture filter
    weight_bits   int    8         [0, 16]; 0 = fp32 filter weights                 filter-weight bits
    format        str    unorm8    ``unorm8`` ``unorm12`` ``unorm16`` ``fp16``     frame-buffer format
                                   ``fp32``
    geometry      str    upload    ``upload`` | ``resident``                        cell data sent each
                                                                                    frame (VICP) or kept
                                                                                    on the card
                                                                                    (VICP-GPU)
    walk          str    pixel     ``pixel`` | ``triangle``                         rasteriser walk
                                                                                    (same fragments)
    batch_tets    int    65536     [1, 2^26]                                        tets per batch
    ============  =====  ========  ===============================================  ====================

    Example
    -------
    >>> from warpvol.pipeline import Pipeline
    >>> from warpvol.scene.builtin import builtin_scene
    >>> res = Pipeline.load("weiler2003_vicp").render(builtin_scene("box").with_camera(width_px=8, height_px=8),
    ...                                               quiet=True)
    >>> c = res.report["counters"]["vicp"]
    >>> c["texture_lookups"] == c["fragments"] > 0
    True
    """

    name = "vicp"
    summary = ("view-independent cell projection: front faces rasterised, exit from the cell's face planes in "
               "the fragment program, 3D table lookup, back-to-front blending")
    params = (
        TABLE3D, texel_param(("auto", "rgba8", "rgba16f", "rgba32f")), FILTER, WEIGHT_BITS, fb_param(),
        Param("geometry", str, "upload", "cell data sent over the bus each frame (VICP) or resident (VICP-GPU)",
              choices=("upload", "resident")),
        Param("walk", str, "pixel", "rasteriser fragment generation (same fragments)", choices=("pixel", "triangle")),
        BATCH,
    )
    needs = ("vertices", "order")
    provides = ("image",)

    def requires_caps(self) -> dict:
        from warpvol.kernels.vicp import FP_INSTRUCTIONS

        return {"tex3d": True, "fragment_program": FP_INSTRUCTIONS}

    def _texture(self, ctx: Context, table):
        """The table as a 3D texture, made resident once per table object (a redraw uploads nothing)."""

        fmt = self.config["texel_format"]
        if fmt == "auto":
            if table.format not in TEXEL_FOR_TABLE or TEXEL_FOR_TABLE[table.format] == "rgba16":
                raise ConfigError(f"{self.where}.texel_format: no texel format of this stage holds a "
                                  f"{table.format!r} table; give texel_format")
            fmt = TEXEL_FOR_TABLE[table.format]
        key = (fmt, self.config["filter"], self.config["weight_bits"], str(ctx.device))
        cache = ctx.persistent.setdefault("vicp_texture", {})
        hit = cache.get(key)
        if hit is not None and hit[0]() is table:
            return hit[1]
        tex = Texture3D(table.data, fmt=fmt, filter=self.config["filter"], device=ctx.device,
                        weight_bits=self.config["weight_bits"] or None)
        cache.clear()
        cache[key] = (weakref.ref(table), tex)
        return tex

    def run(self, ctx: Context) -> None:
        import warp as wp

        from warpvol.kernels import vicp as kv

        table = table_from(self, ctx, "table_exact")
        if table.data.ndim != 4 or table.data.shape[-1] != 4 or len(table.axes) != 3:
            raise ConfigError(f"{self.where}.table: expected a 3D RGBA table data[l, sb, sf, 4], got {table!r}")
        ax_l, _, ax_f = table.axes
        tex = self._texture(ctx, table)
        mesh, cam = ctx.scene.mesh, ctx.scene.camera
        dev = ctx.device
        cells = cell_constants(mesh, dev, ctx.persistent.setdefault("vicp_cells", {}))
        order = np.asarray(ctx.buffers["order"], dtype=np.int32)
        m = len(order)
        la, lb, llog = _axis_affine(ax_l)
        consts = [*_scalar_consts(ax_f), 1.0 / float(ax_l.scale), la, lb, llog]
        ortho = int(cam.projection == "orthographic")
        fwd = np.asarray(cam.forward, dtype=np.float64)
        view_dir = wp.vec3(*(fwd / np.linalg.norm(fwd)).astype(np.float32))
        eye = wp.vec3(*np.asarray(cam.eye, dtype=np.float32))

        fb = FrameBuffer(cam.width_px, cam.height_px, self.config["format"], device=dev)
        fb.clear((0, 0, 0, 0))
        blend = BlendUnit.over()
        rast = Rasterizer(fb.width, fb.height, device=dev, cull="back", front_face="ccw", **RASTER_RULES)
        positions = ctx.buffers["vertices"].window_array
        tris_all = cells["faces"][order].reshape(-1, 3)  # 4 faces per tet, in visibility order
        order_w = wp.array(order if m else np.zeros(1, np.int32), dtype=wp.int32, device=dev)
        unresolved = wp.zeros(1, dtype=wp.int32, device=dev)
        n_frag = 0
        bt = self.config["batch_tets"]
        for k0 in range(0, m, bt):
            k1 = min(m, k0 + bt)
            frags = rast.fragments(positions, tris_all[4 * k0:4 * k1], cells["points"], interpolation="perspective",
                                   walk=self.config["walk"])
            if frags.count == 0:
                continue
            n_frag += frags.count
            colours = wp.zeros(frags.count, dtype=wp.vec4, device=dev)
            wp.launch(kv.k_vicp_fragments, dim=frags.count,
                      inputs=[frags.attrs, frags.prim, order_w, k0, cells["planes"], cells["grads"], ortho, eye,
                              view_dir, tex.struct, *consts, colours, unresolved], device=dev)
            blend.blend_fragments(fb, frags, colours)
        ctx.image = fb.readback()
        tex.count(n_frag)
        bytes_up = 12 * 4 * FLOATS_PER_VERTEX * m if self.config["geometry"] == "upload" else 0
        ctx.count(vertices=12 * m, bytes_up=bytes_up, texture_lookups=n_frag,
                  combiner_ops=kv.FP_INSTRUCTIONS * n_frag)
        lost = int(unresolved.numpy()[0])
        st = {"fragments": n_frag, "geometry": self.config["geometry"], "degenerate_cells": cells["degenerate"],
              "exit_unresolved": lost, "losses": LOSSES}
        if lost:
            st["warning"] = (f"{lost:,} of {n_frag:,} fragments found no exit face in fp32 (rays grazing a cell's "
                             "edge) and were drawn with l = 0")
        ctx.stats["vicp"] = st
