"""Host step ``cell_setup``: per-mesh cell data for ray propagation, kept across renders.

Layout (float32 / int32, 32 bytes per tet plus 16 per point): per point ``(x, y, z, s)``, the
position relative to ``cells["origin"]`` (the centre of the mesh's bounding box; float64 shift before
the float32 cast, so rounding scales with the mesh's size, not with its distance from the world
origin) and the scalar; per tet the 4 vertex indices and per local face ``4 * neighbour + (the face's local index
in the neighbour)`` (``-1`` on the boundary). The walk (:mod:`warpvol.kernels.raycast`) needs no
face planes or gradients: Plücker edge tests on the shared points decide faces, barycentric weights
give depth and scalar. The transfer function is uploaded per render.

The mesh arrays are built once per (mesh, device) and kept in the pipeline's persistent state
(``ctx.persistent["cells"]``), so re-rendering (new camera, TF edit) skips them; a different mesh
object rebuilds them.
"""

from __future__ import annotations

import weakref

import numpy as np

from warpvol.shared.visible import skipping, sub_mesh
from warpvol.stage import Context, Stage, register_stage


def neighbour_faces(adjacency: np.ndarray) -> np.ndarray:
    """``(M, 4)`` int32: ``4 * n + j`` for the neighbour ``n`` across each local face and the local
    index ``j`` of the same face in ``n``; ``-1`` on the boundary."""
    adj = np.asarray(adjacency)
    out = np.full(adj.shape, -1, dtype=np.int32)
    for i in range(adj.shape[1] if adj.ndim == 2 else 0):  # a face at a time: small temporaries
        c = np.flatnonzero(adj[:, i] >= 0)
        n = adj[c, i].astype(np.int64)
        j = np.argmax(adj[n] == c[:, None], axis=1)
        out[c, i] = 4 * n + j
    return out


def neighbour_vertices(nbr: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """``(M, 4)`` int32: the global index of the neighbour's vertex opposite each local face (the
    vertex a ray walking through that face meets next), ``-1`` on the boundary. With it a walker
    fetches the next vertex in parallel with the next cell's record instead of after it."""
    nb = np.asarray(nbr, dtype=np.int64)
    ok = nb >= 0
    out = np.full(nb.shape, -1, dtype=np.int32)
    out[ok] = np.asarray(tets)[nb[ok] >> 2, nb[ok] & 3]
    return out


def scalar_check_needed(tf_s, tf_v, model: int, s_span: float, radius: float) -> int:
    """Whether a walk needs its per-step bound on the crossings' scalar errors
    (:func:`warpvol.kernels.walk.scalar_step`, 6 square roots and a division per cell step): 0 where that
    bound provably stays below :data:`~warpvol.kernels.walk.STEEP_ERR` for every ray, else 1.

    ``tf_s``, ``tf_v``: the transfer function as the kernel reads it (float32 control points; numpy or Warp
    arrays), ``model``: 0 ``color_extinction``, 1 ``emission_density``; ``s_span``: the mesh's scalar range
    (largest minus smallest point scalar, as uploaded); ``radius``: the mesh's bounding radius about the cells'
    origin. The inequality: every piece's :func:`~warpvol.kernels.walk.density_slope` is at most
    ``G = max_k (|extinction_k - extinction_(k-1)| + model max_channel |colour_k - colour_(k-1)|) / (s_k - s_(k-1))``
    (0 outside the control points), and ``scalar_step`` adds per segment at most ``tr length G (ds_in + ds_out)``
    (within a piece ``length g / 2`` per unit of an end's scalar with ``g <= G``; across control points its
    term is capped at ``length`` times the steepest slope crossed); every crossing's scalar error is at most its
    face's scalar spread (:func:`~warpvol.kernels.walk.spread_error`), at most ``s_span``; the transmittance
    ``tr`` is at most 1; and a pass's segments lie on the ray inside the bounding sphere, whose chord is at most
    ``2 radius`` (taken as ``2.1 radius``). So a walk's sum is at most ``G 2 s_span 2.1 radius``; where that is
    at most ``STEEP_ERR / 2`` (the factor 2: room for the float32 rounding of the sum over up to millions of
    steps) the check cannot fire and is skipped, the image and the rays redone in float64 the same. A transfer
    function of constant extinction under ``color_extinction`` (an opaque one) has ``G = 0``."""
    from warpvol.kernels.walk import STEEP_ERR

    s = np.asarray(tf_s.numpy() if hasattr(tf_s, "numpy") else tf_s, np.float64)
    v = np.asarray(tf_v.numpy() if hasattr(tf_v, "numpy") else tf_v, np.float64).reshape(len(s), 4)
    if len(s) < 2:
        return 0
    dv = np.abs(np.diff(v, axis=0))
    dd = dv[:, 3] + (dv[:, :3].max(axis=1) if model == 1 else 0.0)
    ds = np.diff(s)
    if not np.all(np.isfinite(dd)) or not np.all(ds > 0):
        return 1
    g = float(np.max(np.where(dd > 0, dd / ds, 0.0)))
    return int(not (g * 2.0 * float(s_span) * 2.1 * float(radius) <= 0.5 * float(STEEP_ERR)))


def mesh_arrays(mesh, device: str, frame: dict | None = None) -> dict:
    """Device arrays of the per-mesh cell layout (plain function for tests and other walkers); ``frame``: a
    piece of a larger mesh takes the whole mesh's ``cells_origin`` and ``cells_radius``
    (:func:`warpvol.conditioning.conditioning.shared_frame`)."""
    import warp as wp

    lo, hi = mesh.bounds
    origin = 0.5 * (lo + hi) if frame is None else np.asarray(frame["cells_origin"], dtype=np.float64)
    rel = mesh.points - origin
    tets = np.ascontiguousarray(mesh.tets, dtype=np.int32)
    nbr = neighbour_faces(mesh.adjacency)
    return {
        "origin": origin,
        "radius": float(np.sqrt((rel * rel).sum(axis=1).max())) if frame is None else float(frame["cells_radius"]),
        "diameter": float(np.linalg.norm(hi - lo)),
        "s_span": float(np.ptp(np.asarray(mesh.scalars, np.float32))) if len(mesh.scalars) else 0.0,
        "verts": wp.array(np.ascontiguousarray(np.c_[rel, mesh.scalars], dtype=np.float32), dtype=wp.vec4,
                          device=device),
        "tets": wp.array(tets, dtype=wp.vec4i, device=device),
        "nbr": wp.array(nbr, dtype=wp.vec4i, device=device),
        "nbr_host": nbr,
        "nbr_vertex": wp.array(neighbour_vertices(nbr, tets), dtype=wp.vec4i, device=device),
    }


def cell_arrays(mesh, tf, device: str, cache: dict | None = None, frame: dict | None = None) -> dict:
    """Mesh arrays (from ``cache`` when it holds them for this mesh and device) plus the TF; ``frame``: see
    :func:`mesh_arrays` (not cached)."""
    if frame is not None:
        cache = None
    key = str(device)
    hit = None if cache is None else cache.get(key)
    if hit is not None and hit["mesh"]() is mesh:
        cells = dict(hit["arrays"])
        cells["cached"] = True
    else:
        arrays = mesh_arrays(mesh, device, frame)
        if cache is not None:
            cache[key] = {"mesh": weakref.ref(mesh), "arrays": arrays}
        cells = dict(arrays)
        cells["cached"] = False
    tf_s, tf_v = tf.to_warp(device)
    model = 0 if tf.emission == "color_extinction" else 1
    cells.update(tf_s=tf_s, tf_v=tf_v, model=model,
                 scalar_check=scalar_check_needed(tf_s, tf_v, model, cells["s_span"], cells["radius"]))
    return cells


def confine_to_visible(ctx: Context, cells: dict) -> int:
    """Empty-space skipping (:mod:`warpvol.shared.visible`): with a ``visible_cells`` mask that leaves
    cells out, the walk's neighbour records ``cells["nbr"]`` end at invisible neighbours and
    ``cells["entry_faces"]`` lists the visible sub-mesh's boundary faces (the faces ``entry_bins`` and
    ``harc_raster`` start rays from); both kept per (mesh, mask, device). ``cells["confined"]`` says
    whether it did, the one value the later stages read (:func:`warpvol.shared.visible.confined`). Returns the
    cells left out."""
    import warp as wp


    vis, n_out = skipping(ctx)
    cells["confined"] = vis is not None
    if vis is None:
        return 0
    cache = ctx.persistent.setdefault("sub_mesh", {}).setdefault(str(ctx.device), {})
    sm = sub_mesh(ctx.scene.mesh, vis, cells["nbr_host"], cache)
    if "nbr_device" not in sm:
        sm["nbr_device"] = wp.array(sm["nbr"], dtype=wp.vec4i, device=ctx.device)
    cells["nbr"] = sm["nbr_device"]
    cells["entry_faces"] = sm["faces"]
    cells["cells_not_walked"] = n_out
    return n_out


@register_stage
class CellSetup(Stage):
    """Per-mesh cell data (points, scalars, tets, neighbour faces; cached per mesh) and the TF.

    With a ``visibility`` stage before it (and skipping on), the walk is confined to the cells the
    transfer function makes visible (:func:`confine_to_visible`): rays start and re-enter at the visible
    sub-mesh's boundary, and no ray walks an invisible cell.

    ==========  =====  =========  ===========================
    parameter   type   default    meaning
    ==========  =====  =========  ===========================
    (none)
    ==========  =====  =========  ===========================
    """

    name = "cell_setup"
    summary = "upload points, scalars, tets, neighbour faces (cached per mesh) and the TF"
    needs = ()
    provides = ("cells",)
    setup = True

    def run(self, ctx: Context) -> None:
        cache = ctx.persistent.setdefault("cells", {})
        cells = cell_arrays(ctx.scene.mesh, ctx.scene.transfer, ctx.device, cache, ctx.buffers.get("frame"))
        n_out = confine_to_visible(ctx, cells)
        ctx.buffers["cells"] = cells
        ctx.stats["cell_setup"] = {"cached": cells["cached"]}
        if n_out:
            ctx.stats["cell_setup"].update(cells_not_walked=n_out, entry_faces=int(len(cells["entry_faces"])))
