"""Host step ``cell_setup``: upload per-tet data for ray propagation (HARC layout, 96 bytes/tet).

Per tet: 4 face planes ``(n, o)`` with unit outward normals, the scalar gradient and offset
``(g, g0)`` (both relative to ``cells["origin"]``, the mesh's bounding-box centre) and 4 neighbour
indices — float32 / int32, as Weiler's HARC stored them in textures.
Also uploads the transfer function. Buffers: ``ctx.buffers["cells"]``.
"""

from __future__ import annotations

import numpy as np

from ..pipeline import Context, Stage, register_stage


def cell_arrays(mesh, tf, device: str) -> dict:
    """Device arrays of the HARC cell layout for ``mesh`` and ``tf`` (plain function for tests)."""
    import warp as wp

    # Cell data are stored relative to the centre of the mesh's bounding box (float64 shift before
    # the float32 cast): float32 rounding then scales with the mesh's size, not with its distance
    # from the world origin (the combustor sits at z ~ 30).
    origin = 0.5 * (mesh.bounds[0] + mesh.bounds[1])
    fp = mesh.face_planes.copy()
    fp[..., 3] += np.einsum("mfk,k->mf", fp[..., :3], origin)
    planes = np.ascontiguousarray(fp, dtype=np.float32)  # (M,4,4)
    offsets = mesh.offsets + mesh.gradients @ origin
    grad = np.concatenate([mesh.gradients, offsets[:, None]], axis=1).astype(np.float32)
    tf_s, tf_v = tf.to_warp(device)
    return {
        "origin": origin,
        "planes": wp.array(planes, dtype=wp.vec4, device=device),
        "grad": wp.array(grad, dtype=wp.vec4, device=device),
        "adj": wp.array(np.ascontiguousarray(mesh.adjacency, dtype=np.int32), dtype=wp.int32, device=device),
        "tf_s": tf_s,
        "tf_v": tf_v,
        "model": 0 if tf.emission == "color_extinction" else 1,
    }


@register_stage
class CellSetup(Stage):
    """Upload cell planes, gradients, adjacency and the transfer function.

    ==========  =====  =========  ===========================
    parameter   type   default    meaning
    ==========  =====  =========  ===========================
    (none)
    ==========  =====  =========  ===========================
    """

    name = "cell_setup"
    summary = "upload face planes, scalar gradients, adjacency and the TF (HARC cell layout)"
    needs = ()
    provides = ("cells",)

    def run(self, ctx: Context) -> None:
        ctx.buffers["cells"] = cell_arrays(ctx.scene.mesh, ctx.scene.transfer, ctx.device)
