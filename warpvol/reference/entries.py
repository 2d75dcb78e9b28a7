"""Boundary entries of the float64 reference (:mod:`warpvol.reference.warp_render`, whose ``_View`` is the
``view`` here): which boundary faces can be an entry for a view, and every pixel's entries through them (the
count and write passes of :func:`warpvol.kernels.reference.boundary_entries`), grouped by pixel.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from warpvol.parallel import blocks, launch_blocks

_CULL_TOL = 1e-9


#: fewest pixels (a pixel list) or faces (entry tables) per block launched from a host thread: a block's start
#: costs a thread wake-up, more than a few pixels' walks on a loaded machine
_MIN_BLOCK = 64


def _uploader(device: str) -> Callable:
    """``arr(a, dtype)``: a NumPy array as a Warp array on ``device``."""
    import warp as wp

    return lambda a, dtype: wp.array(np.ascontiguousarray(a), dtype=dtype, device=device)


def _entry_faces(md: dict, view, first: int, last: int):
    """Boundary faces that can be an entry: ``(tet, face)`` and their pixel boxes within rows
    ``first..last``."""
    edge = md["adj"] < 0
    bt, bf = np.nonzero(edge if md["visible"] is None else edge & md["visible"][:, None])
    loc = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])[bf]
    tri = md["T"][bt[:, None], loc]
    p = md["Pc"][tri]  # (B, 3, 3)
    opp = md["Pc"][md["T"][bt, bf]]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n = np.where((np.einsum("ij,ij->i", n, opp - p[:, 0]) > 0)[:, None], -n, n)  # outward
    nn = np.linalg.norm(n, axis=1)
    if view.persp:  # entered in front of the eye only if the eye is outside the face's plane
        keep = -np.einsum("ij,ij->i", n, p[:, 0]) >= -_CULL_TOL * nn * np.linalg.norm(p[:, 0], axis=1)
    else:  # entered only if facing the camera
        keep = n[:, 2] <= _CULL_TOL * nn
    box, valid = view.boxes(p[:, :, 0], p[:, :, 1], p[:, :, 2])
    box[:, 0] = np.maximum(box[:, 0], first)
    box[:, 1] = np.minimum(box[:, 1], last)
    keep &= valid & (box[:, 0] <= box[:, 1])
    return bt[keep].astype(np.int32), bf[keep].astype(np.int32), box[keep]


def _box_area(fbox: np.ndarray) -> int:
    return int(((fbox[:, 1] - fbox[:, 0] + 1).astype(np.int64) * (fbox[:, 3] - fbox[:, 2] + 1)).sum())


def _entry_table(faces: tuple, wa: dict, view, device: str, threads: int) -> dict:
    """Every pixel's boundary entries through the faces ``(tet, face, box)`` (count pass, then write pass of
    :func:`warpvol.kernels.reference.boundary_entries`), grouped by pixel: ``ent_start`` (``W * H + 1``
    offsets; ``start`` on the host), ``ent_t``, ``ent_tet``, and ``n_ent``, ``n_box`` (pixels tested),
    ``n_exact``."""
    import warp as wp

    from warpvol.kernels import reference as K

    arr = _uploader(device)
    ftet, floc, fbox = faces
    W, H = view.W, view.H
    f64 = wp.float64
    nf = len(ftet)
    fblocks = blocks(nf, max(_MIN_BLOCK, -(-nf // (4 * threads)))) if device.startswith("cpu") else [(0, nf)]
    d_ftet, d_floc = arr(ftet, wp.int32), arr(floc, wp.int32)
    d_box = arr(fbox.reshape(-1, 4) if nf else np.zeros((0, 4), np.int32), wp.vec4i)
    count = wp.zeros(max(nf, 1), dtype=wp.int64, device=device)
    fexact = wp.zeros(max(nf, 1), dtype=wp.int64, device=device)
    offset = wp.zeros(max(nf, 1), dtype=wp.int64, device=device)
    out = [wp.zeros(1, dtype=wp.int64, device=device), wp.zeros(1, dtype=f64, device=device),
           wp.zeros(1, dtype=wp.int32, device=device)]
    geo = [wa[k] for k in ("P", "S", "T", "orient", "s_eye", "cxs", "cys")]

    def entries(write: int):
        def launch(b: int) -> None:
            f0, nb = fblocks[b]
            if nb:
                wp.launch(K.boundary_entries, dim=nb, device=device,
                          inputs=[d_ftet, d_floc, d_box, offset, f0] + geo + [int(view.persp), W, write, count,
                                                                              out[0], out[1], out[2], fexact])
        launch_blocks(device, len(fblocks), launch, threads)

    entries(0)
    cnt = count.numpy()[:nf]
    n_ent = int(cnt.sum())
    if n_ent:
        offset = arr(np.cumsum(cnt) - cnt, wp.int64)
        out = [wp.zeros(n_ent, dtype=wp.int64, device=device), wp.zeros(n_ent, dtype=f64, device=device),
               wp.zeros(n_ent, dtype=wp.int32, device=device)]
        entries(1)
        pix = out[0].numpy()
        order = np.argsort(pix, kind="stable")
        ent_t, ent_tet = arr(out[1].numpy()[order], f64), arr(out[2].numpy()[order], wp.int32)
        # start[q]: the entries of pixels below q, constant between the pixels that have one: the running
        # counts repeated over those runs (a short pixel list's few pixels: no bincount and sum over the view)
        u, c = np.unique(pix, return_counts=True)
        start = np.repeat(np.concatenate([[0], np.cumsum(c)]).astype(np.int64),
                          np.diff(np.concatenate([[0], u + 1, [W * H + 1]])))
    else:
        ent_t, ent_tet = wp.zeros(1, dtype=f64, device=device), wp.zeros(1, dtype=wp.int32, device=device)
        start = np.zeros(W * H + 1, dtype=np.int64)
    # on the CPU the device array is ``start`` itself (kept alive by it, never written), not a copy
    ent_start = wp.array(start, dtype=wp.int64, device=device, copy=not device.startswith("cpu"))
    return dict(ent_start=ent_start, ent_t=ent_t, ent_tet=ent_tet, start=start,
                n_ent=n_ent, n_box=_box_area(fbox) if nf else 0, n_exact=int(fexact.numpy()[:nf].sum()))
