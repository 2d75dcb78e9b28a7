"""Exact float64 colours of a few pixels: the rays a float32 renderer could not resolve (thin layers,
ties it cannot decide), traced by the reference's watertight tracer on just the candidate (tet, pixel)
pairs of those pixels. Shared by the ray casters' and the projected tetrahedra's float64 redo.
"""

from __future__ import annotations

import numpy as np

from warpvol.reference import numpy_render as ref


def redo_mesh_properties(camera) -> tuple[str, ...]:
    """The per-mesh properties (cached on the mesh) :func:`redo_pixels_float64` reads: set-up the first
    redo on a mesh computes (``Context.mesh_setup``), not frame work."""
    return ("sorted_tets", "adjacency") + (("_gradient_and_offset",) if camera.projection == "perspective" else ())


def redo_pixels_float64(mesh, tf, camera, pixels: np.ndarray, max_pairs: int = 1_000_000,
                        method: str = "warp", visible: np.ndarray | None = None,
                        terminate: float | None = None) -> np.ndarray:
    """Exact float64 colours (n, 4) of the pixels ``pixels`` (flat indices), for rays the float32
    walk could not resolve.

    ``method = "warp"`` (default): the Warp reference's float64 walk through the adjacency on the CPU
    (:func:`warpvol.reference.warp_render.render_reference_warp` with ``pixels``; cost ~ the cells
    those rays cross plus one set-up per call), pixels whose walk fails (a mesh without a consistent
    adjacency) taken as by ``"numpy"``: the reference's watertight tracer (exact edge signs, simulation
    of simplicity) on just the candidate (tet, pixel) pairs of those pixels (cost ~ the cells whose
    screen boxes hold them), integrated and composited in float64.

    ``visible`` (bool per tet, optional: the ``visibility`` stage's ``visible_cells``): the ``"warp"`` walk
    goes through the visible tets only, entering and re-entering at the visible sub-mesh's boundary; the
    colours are those of the whole walk (a tet the transfer function maps to zero composites as the
    identity: see ``render_reference_warp``).

    ``terminate`` (optional): the ``"warp"`` walk's early ray termination, the most a channel may change by
    it (default: the reference's 1e-17); a renderer passes its own stated bound, so a redone pixel leaves
    out no more than its float32 pixels do. Pieces of one colour under ``color_extinction`` are integrated in
    closed form (``closed_form``: within 1e-12 of the reference image's pixels)."""
    pixels = np.asarray(pixels, dtype=np.int64)
    out = np.zeros((len(pixels), 4))
    if len(pixels) == 0:
        return out
    if method == "warp":
        from warpvol.reference.warp_render import render_reference_warp

        st: dict = {}
        out = np.asarray(render_reference_warp(mesh, tf, camera, device="cpu", pixels=pixels, stats=st,
                                               show_progress=False, visible=visible,
                                               terminate=terminate, closed_form=True), dtype=np.float64)
        bad = st.get("failed_at", np.zeros(0, dtype=np.int64))
        if len(bad):
            out[bad] = redo_pixels_float64(mesh, tf, camera, pixels[bad], max_pairs, method="numpy")
        return out
    if method != "numpy":
        raise ValueError(f"method: {method!r} not allowed; allowed: warp, numpy")
    fr, pc, tsorted, orient, ids, i0, i1, j0, j1 = ref._plan(mesh, camera)
    grad, offs = (mesh.gradients, mesh.offsets) if fr.persp else (None, None)
    rows, cols = np.divmod(pixels, camera.width_px)
    # candidate tets per pixel: the tets whose pixel box holds its row (found once per row), then its column
    cand: list[np.ndarray] = [None] * len(pixels)  # type: ignore[list-item]
    for r in np.unique(rows):
        in_row = np.flatnonzero((i0 <= r) & (i1 >= r))
        a, b = j0[in_row], j1[in_row]
        for k in np.flatnonzero(rows == r):
            c = cols[k]
            cand[k] = in_row[(a <= c) & (b >= c)]
    segs = []
    start = 0
    while start < len(pixels):
        stop, n = start, 0
        while stop < len(pixels) and (n == 0 or n + len(cand[stop]) <= max_pairs):
            n += len(cand[stop])
            stop += 1
        k = np.concatenate(cand[start:stop])
        who = np.repeat(np.arange(start, stop), [len(c) for c in cand[start:stop]])
        if len(k):
            ch = ref._trace_chunk(fr, pc, np.asarray(mesh.scalars, np.float64), tsorted, orient, ids[k],
                                  rows[who], rows[who], cols[who], cols[who], grad, offs)
            # the tracer reports flat pixel indices; map them back to positions in ``pixels``
            lookup = dict(zip(pixels[start:stop].tolist(), range(start, stop)))
            pos = np.array([lookup[p] for p in ch["pixel"].tolist()], dtype=np.int64)
            segs.append((pos, ch))
        start = stop
    if not segs:
        return out
    pos = np.concatenate([p for p, _ in segs])
    cat = {key: np.concatenate([c[key] for _, c in segs]) for key in ("t_in", "t_out", "s_in", "s_out")}
    rgb, tau = ref.integrate_segments(cat["s_in"], cat["s_out"], cat["t_out"] - cat["t_in"], tf)
    return ref.composite_front_to_back(pos, cat["t_in"], rgb, tau, len(pixels), cat["t_out"])
