"""Host step ``harc_mesh``: the mesh in textures for hardware ray casting (Espinha & Celes 2005 Table 1)."""

from __future__ import annotations

import weakref

from warpvol.stage import Context, Param, Stage, register_stage


@register_stage
class HarcMesh(Stage):
    """Mesh textures of the ray caster; reports bytes/tet.

    ``paper96``: four face planes ``(n, o)``, gradient ``(g, g0)`` and adjacency per tet, float32,
    six rgba32f textures (96 bytes/tet), read by the ``planes`` walk through the texture unit.
    ``compact``: the cells' layout (4 vertex indices + 4 neighbour faces per tet, ``(x, y, z, s)`` per
    point: 32 bytes/tet + 16 bytes/point, ~35 bytes/tet on the NASA meshes); planes and scalars are
    derived in the fragment program (the ``plucker`` walk). Kept across renders of the same mesh.

    ``arithmetic`` (``paper96``): ``fp32`` computes planes and gradients in float32 from the float32
    points in the mesh's own frame, as the paper's textures held them (the ``harc`` stage's
    ``ray_setup = "paper"``); ``float64`` derives them in float64 relative to the cells' origin before the
    float32 cast (``ray_setup = "robust"``).

    ==========  =====  =========  ==========================================
    parameter   type   default    meaning
    ==========  =====  =========  ==========================================
    layout      str    paper96    ``paper96`` | ``compact``
    arithmetic  str    float64    ``float64`` | ``fp32`` (``paper96`` only)
    ==========  =====  =========  ==========================================
    """

    name = "harc_mesh"
    summary = "mesh textures for hardware ray casting (paper's 96 bytes/tet, or compact); bytes/tet reported"
    needs = ("cells",)
    provides = ("harc_mesh",)
    setup = True
    params = (Param("layout", str, "paper96", "mesh layout", choices=("paper96", "compact")),
              Param("arithmetic", str, "float64", "planes and gradients: float64 then cast, or fp32 as the paper's",
                    choices=("float64", "fp32")))

    def run(self, ctx: Context) -> None:
        from warpvol.raycasting.harc import layout_bytes, mesh_textures

        mesh = ctx.scene.mesh
        sizes = layout_bytes(mesh)
        out = {"layout": self.layout, "struct": None, "textures": (), "bytes_per_tet": sizes[self.layout],
               "arithmetic": self.arithmetic if self.layout == "paper96" else None}
        if self.layout == "paper96":
            cache = ctx.persistent.setdefault("harc_mesh", {})
            key = (str(ctx.device), self.arithmetic)
            hit = cache.get(key)
            cells = ctx.buffers["cells"]
            if hit is not None and hit[0]() is mesh:
                st, texs, info = hit[1]
                cached = True
            else:
                info = {}
                st, texs = mesh_textures(mesh, cells["origin"], ctx.device, arithmetic=self.arithmetic, info=info)
                cache[key] = (weakref.ref(mesh), (st, texs, info))
                cached = False
            out.update(struct=st, textures=texs)
        else:
            cached = ctx.buffers["cells"]["cached"]
        ctx.buffers["harc_mesh"] = out
        if not cached and self.layout == "compact":  # the texture unit counts the paper96 textures itself
            ctx.count(texture_bytes=int(round(sizes[self.layout] * mesh.n_tets)))
        ctx.stats["harc_mesh"] = {"layout": self.layout, "bytes_per_tet": round(sizes[self.layout], 2),
                                  "bytes_per_tet_all": {k: round(v, 2) for k, v in sizes.items()},
                                  "cached": cached}
        bad = info.get("degenerate_tets", 0) if self.layout == "paper96" else 0
        if bad:
            ctx.stats["harc_mesh"]["degenerate_tets"] = bad
            ctx.stats["harc_mesh"]["warning"] = (
                f"{bad:,} tets degenerate in float32 (a face normal or the gradient's determinant is zero "
                "at the mesh's float32 coordinates): their texels hold zeros where the paper's held NaN; rays "
                "reaching them are lost")
