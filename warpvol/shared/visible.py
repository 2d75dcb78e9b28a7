"""Empty-space skipping for the ray casters: the walk confined to the cells the transfer function makes
visible.

A cell the transfer function maps to zero over its whole scalar range (``visible_cells``, from the
``visibility`` stage) adds no colour and leaves the transmittance as it is: a ray segment through it
composites as the identity. The ray casters (``raycast``, ``harc_best``) therefore walk only the
*visible sub-mesh*: its boundary is every face of a visible cell whose neighbour is invisible or absent
(:func:`visible_boundary`), rays enter and re-enter there exactly as they enter and re-enter a
non-convex mesh at its own boundary (``entry_bins`` bins these faces, ``harc_raster`` rasterises them,
``raycast``'s threads and the ``peel`` / ``harc_peel`` passes re-enter further on), and the walk's neighbour records
(:func:`walk_neighbours`) end at an invisible neighbour as at the mesh boundary. A pixel whose ray meets
no visible cell costs only its entry search; a run of invisible cells between two visible ones costs a
re-entry search instead of one walk step per cell.

The image is the full walk's up to float32 rounding of the re-entry point (the ray parameter of a face
crossing, computed from the face instead of carried through the invisible cells). The rays the float32 walk
cannot resolve are redone in float64 through the same visible sub-mesh
(:func:`warpvol.reference.pixels.redo_pixels_float64` with the mask), bit for bit the whole walk's pixels.
"""

from __future__ import annotations

import weakref

import numpy as np

from warpvol.conditioning.visibility import cell_visibility, cut_at_invisible
from warpvol.scene.mesh import FACE_VERTS


def visible_boundary(adjacency: np.ndarray, visible: np.ndarray) -> np.ndarray:
    """``(B, 2)`` int64 rows ``(tet, local face)``: the faces of visible tets whose neighbour is invisible
    or absent (the boundary of the visible sub-mesh, each face oriented outward from its visible tet).
    With every tet visible these are the mesh's boundary faces, in the same order."""
    vis = np.asarray(visible, dtype=bool)
    return np.argwhere(vis[:, None] & (cut_at_invisible(adjacency, vis) < 0)).astype(np.int64)


def face_triangles(tets: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(B, 3)`` point indices of the faces ``(tet, local face)``, ordered as the mesh's boundary
    triangles (normal pointing out of the tet)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 2)
    return np.asarray(tets)[faces[:, 0][:, None], FACE_VERTS[faces[:, 1]]]


def walk_neighbours(nbr: np.ndarray, visible: np.ndarray) -> np.ndarray:
    """The walk's neighbour records (``4 * neighbour + face``, -1 at the boundary: see
    :func:`warpvol.raycasting.stages.cell_setup.neighbour_faces`) with every face into an invisible tet
    made a boundary face (-1), so a walk through visible tets ends there."""
    out = np.array(nbr, dtype=np.int32, copy=True)
    ok = out >= 0
    vis = np.asarray(visible, dtype=bool)
    out[ok & ~vis[np.where(ok, out >> 2, 0)]] = -1
    return out


def skipping(ctx) -> tuple[np.ndarray | None, int]:
    """``(visible, invisible)``: the ``visible_cells`` mask the ray casters walk (``None`` when skipping is
    off, there is no ``visibility`` stage, or every cell is visible) and how many cells it leaves out."""
    vis = ctx.buffers.get("visible_cells") if getattr(ctx, "skip", True) else None
    if vis is None:
        return None, 0
    n_out = int(len(vis) - np.count_nonzero(vis))
    return (vis, n_out) if n_out else (None, 0)


def sub_mesh(mesh, visible: np.ndarray, nbr: np.ndarray, cache: dict | None = None) -> dict:
    """The visible sub-mesh's walk data: ``{"faces": visible_boundary, "nbr": walk_neighbours}`` (numpy),
    kept in ``cache`` for the last (mesh, visibility mask) pair (the ``visibility`` stage keeps its mask
    while mesh and transfer function stay the same)."""
    hit = None if cache is None else cache.get("sub_mesh")
    if hit is not None and hit[0]() is mesh and hit[1] is visible:
        return hit[2]
    out = {"faces": visible_boundary(mesh.adjacency, visible), "nbr": walk_neighbours(nbr, visible)}
    if cache is not None:
        cache["sub_mesh"] = (weakref.ref(mesh), visible, out)
    return out


def confined(ctx) -> bool:
    """Whether the ray casters walk a visible sub-mesh that leaves cells out: rays may then enter and
    re-enter several times even on a convex mesh, so the re-entry passes (``peel``, ``harc_peel``) run.
    From ``cell_setup``'s ``cells["confined"]`` in a render; when planning (no buffers yet), from the transfer function
    as the ``visibility`` stage will decide, if one is planned before (``ctx.planned``)."""
    if not getattr(ctx, "skip", True):
        return False
    cells = ctx.buffers.get("cells")
    if cells is not None:
        return bool(cells.get("confined", False))
    if "visible_cells" not in ctx.planned:
        return False

    return not bool(cell_visibility(ctx.scene.mesh, ctx.scene.transfer).all())


def unfinished_to_float64(state, active_code: int, failed_code: int) -> int:
    """Mark the rays still active after the last allowed re-entry pass for the float64 redo (their walk
    is not finished: a pixel is never left with part of its ray); returns how many."""
    import warp as wp

    st = state.status.numpy()
    left = (st & 3) == active_code
    n = int(np.count_nonzero(left))
    if n:
        st[left] = failed_code
        state.status = wp.array(st, dtype=wp.int32, device=state.device)
    return n
