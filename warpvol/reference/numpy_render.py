"""Exact float64 reference renderer (Contract 3: ``warpvol reference``).

Pure NumPy, deliberately independent of the Warp kernels it is used to judge. The image is the
ray integral of Contract 2 evaluated per pixel centre to ~1e-9 relative accuracy (optical depth
exactly, up to rounding):

1. **Cell projection.** Every tetrahedron is projected with the camera and the pixel centres inside
   the bounding box of its projection become candidate ``(tet, pixel)`` pairs (a tet straddling the
   eye plane of a perspective camera gets an unbounded, clipped box).
2. **Watertight ray/tet intersection.** For each pair the side of the ray against each of the six
   tet edges is a Plücker product (perspective: ``d . (A x B)`` with ``A, B`` the edge's endpoints
   relative to the eye) or a 2D orientation (orthographic), evaluated with the endpoints in
   ascending global vertex order, so neighbouring tets see the same value on a shared edge. Its
   *sign is exact* for the float inputs: a floating-point filter, and where that is inconclusive an
   exact evaluation with error-free transformations (two-product / two-sum expansions). Exact zeros
   (rays through edges, vertices or inside face planes, common with structured grids and
   axis-aligned cameras) are broken by an infinitesimal perturbation of the ray (simulation of
   simplicity). So the classification is a genuine, consistent configuration: every ray is counted
   by exactly one tet at every depth -- no double counting on shared faces, no gaps. The ray pierces
   a face when the signs of its three edges agree; entry or exit follows from the face's
   orientation. Depth and scalar at the crossing come from the barycentric weights on that face;
   a shared face therefore yields bit-identical exit/entry depth and scalar on both sides.
3. **Segment integration** (:func:`integrate_segments`). Along a segment the scalar is linear, so
   with a piecewise-linear transfer function colour and extinction are piecewise linear in depth.
   Each segment is split at every control point it crosses; on each piece the optical depth is
   integrated exactly and the radiance with Gauss-Legendre quadrature on sub-intervals of optical
   depth at most :data:`SUB_DEPTH`, stopping after :data:`MAX_DEPTH` (transmittance < 1e-18) with a
   single tail interval, so stiff extinction costs a bounded number of sub-intervals.
4. **Compositing** (:func:`composite_front_to_back`). Segments are sorted by ``(pixel, depth)`` and
   composited with segmented cumulative sums of optical depth (no cancellation: every partial sum
   is a sum of non-negative terms within its own pixel).

Memory is bounded by processing the image in bands of rows and the tets in chunks.

Conventions
-----------
Rays start at the eye (perspective) or on the eye plane (orthographic) and only ``t >= 0`` counts;
``t`` is world length along the unit direction of Contract 2. A perspective eye inside the mesh is
supported, also exactly on a face, edge or vertex (the segment then starts at ``t = 0`` with the
scalar at the eye). Geometry is judged in camera coordinates (``(p - eye)`` projected on right, up,
forward), computed once per mesh point in float64.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from warpvol.errors import ConfigError, check_choice
from warpvol.reference.exact import _FILTER, _STATS, _certify, _exact_sum_of_products, _sign_det2  # noqa: F401
from warpvol.reference.integrate import (  # noqa: F401
    GL_NODES,
    MAX_DEPTH,
    SUB_DEPTH,
    composite_front_to_back,
    integrate_segments,
    segmented_exclusive_cumsum,
)
from warpvol.reference.scalars import normal_scalars
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import EMISSION_MODELS, TransferFunction

#: the files the reference image depends on (the bench's reference cache hashes them)
REFERENCE_SOURCES = ("numpy_render.py", "exact.py", "integrate.py", "warp_render.py", "entries.py")
#: ways to compute the reference (:func:`render_reference`)
REFERENCE_METHODS = ("warp", "numpy")

__all__ = [
    "render_reference",
    "trace_segments",
    "integrate_segments",
    "composite_front_to_back",
    "segmented_exclusive_cumsum",
    "GL_NODES",
    "SUB_DEPTH",
    "MAX_DEPTH",
]

# Local vertex pairs (ascending) of the six edges of a tet whose vertices are sorted by global index.
_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)
# Faces (opposite vertex 0..3) as ascending local triples (a, b, c) ...
_FACE_LOCAL = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]], dtype=np.int64)
# ... and the edge numbers of (a, b), (b, c), (a, c) for each of them.
_FACE_EDGES = np.array([[3, 5, 4], [1, 5, 2], [0, 4, 2], [0, 3, 1]], dtype=np.int64)

_DEFAULT_CHUNK_PAIRS = 1_000_000  # candidate (tet, pixel) pairs per chunk
_DEFAULT_BAND_PAIRS = 24_000_000  # candidate pairs per band of image rows


# ------------------------------------------------------------------------------------------------
# ray / mesh traversal
# ------------------------------------------------------------------------------------------------
class _Frame:
    """Camera in its own coordinates: x = right, y = up, z = forward (distance in front of eye)."""

    def __init__(self, camera: Camera):
        self.persp = camera.projection == "perspective"
        self.W, self.H = int(camera.width_px), int(camera.height_px)
        self.eye = np.asarray(camera.eye, dtype=np.float64)
        self.basis = np.stack([camera.right, camera.true_up, camera.forward])
        if self.persp:
            th = np.tan(np.radians(camera.fov_y_deg) / 2.0)
            self.sx, self.sy = th * camera.aspect, th
        else:
            hh = camera.ortho_height / 2.0
            self.sx, self.sy = hh * camera.aspect, hh
        # per column / row: image-plane coordinate (direction slope or orthographic offset)
        self.cx = (2.0 * (np.arange(self.W) + 0.5) / self.W - 1.0) * self.sx
        self.cy = (1.0 - 2.0 * (np.arange(self.H) + 0.5) / self.H) * self.sy

    def to_camera(self, p: np.ndarray) -> np.ndarray:
        d = p - self.eye
        b = self.basis
        return np.stack([d[:, 0] * b[k, 0] + d[:, 1] * b[k, 1] + d[:, 2] * b[k, 2] for k in range(3)], axis=1)

    def pixel_ranges(self, Pc: np.ndarray, tets: np.ndarray):
        """Inclusive pixel index ranges ``(i0, i1, j0, j1)`` of each tet's projection and a validity
        mask (tets entirely behind the eye / eye plane, or off-screen, are invalid)."""
        x, y, z = Pc[tets, 0], Pc[tets, 1], Pc[tets, 2]
        valid = (z > 0).any(axis=1)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.persp:
                front = z > 0
                zs = np.where(front, z, 1.0)
                X, Y = x / zs, y / zs
                xlo = np.where(front, X, np.inf).min(axis=1)
                xhi = np.where(front, X, -np.inf).max(axis=1)
                ylo = np.where(front, Y, np.inf).min(axis=1)
                yhi = np.where(front, Y, -np.inf).max(axis=1)
                # edges crossing the eye plane: the projection extends to infinity in the direction
                # of the crossing point
                for a, b in _EDGES:
                    fa, fb = front[:, a], front[:, b]
                    cr = fa != fb
                    if not cr.any():
                        continue
                    pa = np.where(fa, a, b)
                    qb = np.where(fa, b, a)
                    r = np.arange(len(tets))
                    zp, zq = z[r, pa], z[r, qb]
                    lam = np.where(cr, zp / np.where(cr, zp - zq, 1.0), 0.0)
                    cx = x[r, pa] + lam * (x[r, qb] - x[r, pa])
                    cy = y[r, pa] + lam * (y[r, qb] - y[r, pa])
                    through_eye = cr & (cx == 0) & (cy == 0)
                    xlo = np.where((cr & (cx < 0)) | through_eye, -np.inf, xlo)
                    xhi = np.where((cr & (cx > 0)) | through_eye, np.inf, xhi)
                    ylo = np.where((cr & (cy < 0)) | through_eye, -np.inf, ylo)
                    yhi = np.where((cr & (cy > 0)) | through_eye, np.inf, yhi)
            else:
                xlo, xhi = x.min(axis=1), x.max(axis=1)
                ylo, yhi = y.min(axis=1), y.max(axis=1)
            big = 1e15
            jlo = np.clip((xlo / self.sx + 1.0) * self.W / 2.0 - 0.5, -big, big)
            jhi = np.clip((xhi / self.sx + 1.0) * self.W / 2.0 - 0.5, -big, big)
            ilo = np.clip((1.0 - yhi / self.sy) * self.H / 2.0 - 0.5, -big, big)
            ihi = np.clip((1.0 - ylo / self.sy) * self.H / 2.0 - 0.5, -big, big)
        # conservative margin: the exact test decides, the box only has to contain every hit
        jlo = np.ceil(jlo - 1e-6 * (1.0 + np.abs(jlo)))
        jhi = np.floor(jhi + 1e-6 * (1.0 + np.abs(jhi)))
        ilo = np.ceil(ilo - 1e-6 * (1.0 + np.abs(ilo)))
        ihi = np.floor(ihi + 1e-6 * (1.0 + np.abs(ihi)))
        valid &= (jhi >= jlo) & (jhi >= 0) & (jlo <= self.W - 1)
        valid &= (ihi >= ilo) & (ihi >= 0) & (ilo <= self.H - 1)
        j0 = np.clip(jlo, 0, self.W - 1).astype(np.int64)
        j1 = np.clip(jhi, 0, self.W - 1).astype(np.int64)
        i0 = np.clip(ilo, 0, self.H - 1).astype(np.int64)
        i1 = np.clip(ihi, 0, self.H - 1).astype(np.int64)
        return i0, i1, j0, j1, valid


def _trace_chunk(fr: _Frame, Pc: np.ndarray, scal: np.ndarray, tsorted: np.ndarray, orient: np.ndarray,
                 tet_ids: np.ndarray, i0: np.ndarray, i1: np.ndarray, j0: np.ndarray, j1: np.ndarray,
                 grad: np.ndarray | None, offs: np.ndarray | None) -> dict:
    """All ray segments of the candidate pairs of one chunk of tets (see module docstring).

    ``orient[c] = +1/-1``: orientation of the sorted tet ``tsorted[c]`` in camera coordinates.
    """
    V = tsorted[tet_ids]
    nj = j1 - j0 + 1
    cnt = (i1 - i0 + 1) * nj
    total = int(cnt.sum())
    rep = np.repeat(np.arange(len(tet_ids)), cnt)
    k = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    njr = nj[rep]
    row = i0[rep] + k // njr
    col = j0[rep] + k % njr
    del k, njr
    Pt = Pc[V]  # (mc, 4, 3) camera coordinates of the sorted vertices
    A = Pt[:, _EDGES[:, 0]]  # (mc, 6, 3): edges (a, b) with a < b in global index
    B = Pt[:, _EDGES[:, 1]]
    if fr.persp:
        # Plücker side of the line through the eye with direction d = (dx, dy, 1):  d . (A x B)
        ax, ay, az = A[..., 0], A[..., 1], A[..., 2]
        bx, by, bz = B[..., 0], B[..., 1], B[..., 2]
        p1, p2, p3, p4, p5, p6 = ay * bz, az * by, az * bx, ax * bz, ax * by, ay * bx
        cx, cy, cz = p1 - p2, p3 - p4, p5 - p6
        px, py, pz = np.abs(p1) + np.abs(p2), np.abs(p3) + np.abs(p4), np.abs(p5) + np.abs(p6)
        # exact signs of the cross product (perturbation terms; zero vector: edge line through the eye)
        scx = _sign_det2(ay, bz, az, by)
        scy = _sign_det2(az, bx, ax, bz)
        scz = _sign_det2(ax, by, ay, bx)
        dx = fr.cx[col][:, None]
        dy = fr.cy[row][:, None]
        w = cx[rep] * dx + cy[rep] * dy + cz[rep]
        # an edge whose line passes through the eye has A x B = 0 exactly, and so w = 0 exactly
        zero_edge = (scx == 0) & (scy == 0) & (scz == 0)
        bound = np.where(zero_edge[rep], 0.0,
                         _FILTER * (np.abs(dx) * px[rep] + np.abs(dy) * py[rep] + pz[rep]))

        def exact(ix):
            pr, e = np.divmod(ix, 6)
            c = rep[pr]
            a_, b_ = A[c, e], B[c, e]
            dxf, dyf = dx[pr, 0], dy[pr, 0]
            return _exact_sum_of_products([(dxf, a_[:, 1], b_[:, 2]), (-dxf, a_[:, 2], b_[:, 1]),
                                           (dyf, a_[:, 2], b_[:, 0]), (-dyf, a_[:, 0], b_[:, 2]),
                                           (a_[:, 0], b_[:, 1]), (-a_[:, 1], b_[:, 0])])

        sg = _certify(w, bound, exact)
        deg = zero_edge.any(axis=1)
        # ties: perturb d by (eps, eps^2, 0) -> sign of (A x B)_x, then (A x B)_y
        z = sg == 0
        if z.any():
            tx, ty = scx[rep][z], scy[rep][z]
            sg[z] = np.where(tx != 0, tx, ty)
    else:
        # 2D orientation of the pixel position q against the projected edge:
        # w = (A - q) x (B - A); an edge parallel to the view (B - A = 0 exactly) gives w = 0 exactly
        qx = fr.cx[col][:, None]
        qy = fr.cy[row][:, None]
        ex = B[..., 0] - A[..., 0]  # (mc, 6), exact sign
        ey = B[..., 1] - A[..., 1]
        left = (A[..., 0][rep] - qx) * ey[rep]
        right = (A[..., 1][rep] - qy) * ex[rep]
        w = left - right
        bound = _FILTER * (np.abs(left) + np.abs(right))
        del left, right

        def exact(ix):
            pr, e = np.divmod(ix, 6)
            c = rep[pr]
            a_, b_ = A[c, e], B[c, e]
            x_, y_ = qx[pr, 0], qy[pr, 0]
            # (ax - x)(by - y) - (ay - y)(bx - x); the x*y terms cancel exactly
            return _exact_sum_of_products([(a_[:, 0], b_[:, 1]), (-a_[:, 0], y_), (-x_, b_[:, 1]),
                                           (-a_[:, 1], b_[:, 0]), (a_[:, 1], x_), (y_, b_[:, 0])])

        sg = _certify(w, bound, exact)
        del bound
        # ties: perturb q by (eps, eps^2): w + (bx - ax) eps^2 - (by - ay) eps  (float signs are exact)
        z = sg == 0
        if z.any():
            zi = np.nonzero(z)
            t1 = -np.sign(ey[rep[zi[0]], zi[1]])
            t2 = np.sign(ex[rep[zi[0]], zi[1]])
            sg[z] = np.where(t1 != 0, t1, t2)
    # faces pierced by the (perturbed) line: the three edge sides agree; entry or exit by orientation
    hit = np.empty((total, 4), dtype=bool)
    sig = np.empty((total, 4), dtype=np.int8)
    for f in range(4):
        eab, ebc, eac = _FACE_EDGES[f]
        s_ab, s_bc, s_ca = sg[:, eab], sg[:, ebc], -sg[:, eac]
        hit[:, f] = (s_ab == s_bc) & (s_bc == s_ca) & (s_ab != 0)
        sig[:, f] = s_ab
    nhit = hit.sum(axis=1)
    keep = np.flatnonzero(nhit >= 1)
    hit, sig, w, rk = hit[keep], sig[keep], w[keep], rep[keep]
    row, col = row[keep], col[keep]
    m = len(keep)
    # exit through face f iff sigma * orient * (-1)^f > 0 (ascending face f is outward iff the sorted
    # tet is positively oriented and f is even, or negatively oriented and f is odd)
    exit_ = hit & ((sig * orient[tet_ids][rk][:, None] * np.array([1, -1, 1, -1])[None, :]) > 0)
    entry = hit & ~exit_
    ne, nx = entry.sum(axis=1), exit_.sum(axis=1)
    Zt = Pt[:, :, 2][rk]  # (m, 4)
    St = scal[V][rk]
    dn = np.sqrt(fr.cx[col] ** 2 + fr.cy[row] ** 2 + 1.0) if fr.persp else None
    t_f = np.zeros((m, 4))
    s_f = np.zeros((m, 4))
    for f in range(4):
        sel = np.flatnonzero(hit[:, f])
        if not len(sel):
            continue
        a, b, c = _FACE_LOCAL[f]
        eab, ebc, eac = _FACE_EDGES[f]
        sgn = sig[sel, f].astype(np.float64)
        # barycentric weights of the crossing point, clamped to the face (consistent on both sides)
        wa = np.maximum(sgn * w[sel, ebc], 0.0)
        wb = np.maximum(-sgn * w[sel, eac], 0.0)
        wc = np.maximum(sgn * w[sel, eab], 0.0)
        tot = wa + wb + wc
        good = tot > 0
        tots = np.where(good, tot, 3.0)
        al = np.where(good, wa, 1.0) / tots
        be = np.where(good, wb, 1.0) / tots
        ga = np.where(good, wc, 1.0) / tots
        zz = al * Zt[sel, a] + be * Zt[sel, b] + ga * Zt[sel, c]
        ss = al * St[sel, a] + be * St[sel, b] + ga * St[sel, c]
        if fr.persp:
            zz = zz * dn[sel]
            if not good.all():  # line in a face plane through the eye: it meets the face at the eye
                bad = np.flatnonzero(~good)
                tid = tet_ids[rk[sel[bad]]]
                zz[bad] = 0.0
                ss[bad] = grad[tid] @ fr.eye + offs[tid]
        t_f[sel, f] = zz
        s_f[sel, f] = ss
    r = np.arange(m)
    kin = np.argmax(entry, axis=1)
    kout = np.argmax(exit_, axis=1)
    t_in, t_out = t_f[r, kin], t_f[r, kout]
    s_in, s_out = s_f[r, kin], s_f[r, kout]
    ok = (nx == 1) & (ne == 1)
    if fr.persp:
        # the eye on an edge / vertex of the tet: its entry face passes through the eye and is never
        # pierced; the segment starts at the eye
        start = (nx == 1) & (ne == 0) & deg[rk]
        if start.any():
            tid = tet_ids[rk[start]]
            t_in[start] = 0.0
            s_in[start] = grad[tid] @ fr.eye + offs[tid]
        ok |= start
    ok &= t_out > 0
    # clip at the ray origin (eye inside the mesh / geometry behind the orthographic eye plane)
    neg = ok & (t_in < 0)
    if neg.any():
        span = t_out[neg] - t_in[neg]
        s_in[neg] = s_in[neg] + (s_out[neg] - s_in[neg]) * (-t_in[neg] / span)
        t_in[neg] = 0.0
    ok &= t_out > t_in
    sel = np.flatnonzero(ok)
    return {
        "pixel": row[sel] * fr.W + col[sel],
        "t_in": t_in[sel],
        "t_out": t_out[sel],
        "s_in": s_in[sel],
        "s_out": s_out[sel],
        "tet": tet_ids[rk[sel]],
        "n_pairs": total,
    }


def _plan(mesh: TetMesh, camera: Camera):
    fr = _Frame(camera)
    Pc = fr.to_camera(mesh.points)
    # mesh tets are positively oriented in world space; the sort permutes them, the camera frame
    # (right, up, forward) may be left-handed
    tsorted, parity, _ = mesh.sorted_tets
    hand = 1 if np.linalg.det(fr.basis) > 0 else -1
    orient = (parity * hand).astype(np.int8)
    i0, i1, j0, j1, valid = fr.pixel_ranges(Pc, tsorted)
    ids = np.flatnonzero(valid)
    return fr, Pc, tsorted, orient, ids, i0[ids], i1[ids], j0[ids], j1[ids]


def _iter_chunks(mesh: TetMesh, camera: Camera, *, chunk_tets: int, chunk_pairs: int, band_pairs: int,
                 progress: Callable[[float], None] | None, rows: tuple[int, int] | None = None):
    """Yield ``(band_rows, chunk_dict_or_None)``; ``None`` marks the end of a band. ``rows``: the
    first and last image row to trace (default: all); a pixel's segments do not depend on it."""
    fr, Pc, tsorted, orient, ids, i0, i1, j0, j1 = _plan(mesh, camera)
    scal = np.asarray(mesh.scalars, dtype=np.float64)
    grad, offs = (mesh.gradients, mesh.offsets) if fr.persp else (None, None)
    H = fr.H
    first, last = (0, H - 1) if rows is None else rows
    nj = j1 - j0 + 1
    per_row = (np.bincount(i0, weights=nj, minlength=H + 1)
               - np.bincount(i1 + 1, weights=nj, minlength=H + 1))[:H].cumsum()
    per_row[:first] = 0
    per_row[last + 1:] = 0
    grand = float(per_row.sum())
    done = 0.0
    # bands of rows with a bounded number of candidate pairs
    cum = np.cumsum(per_row)
    r0 = first
    while r0 <= last:
        base = cum[r0] - per_row[r0]
        r1 = int(np.searchsorted(cum, base + band_pairs, side="right")) - 1
        r1 = min(max(r1, r0), last)
        sel = np.flatnonzero((i0 <= r1) & (i1 >= r0))
        bi0 = np.maximum(i0[sel], r0)
        bi1 = np.minimum(i1[sel], r1)
        cnt = (bi1 - bi0 + 1) * nj[sel]
        cs = np.cumsum(cnt)
        a = 0
        while a < len(sel):
            start = cs[a] - cnt[a]
            b = int(np.searchsorted(cs, start + chunk_pairs, side="right"))
            b = min(max(b, a + 1), a + chunk_tets, len(sel))
            s = sel[a:b]
            yield (r0, r1), _trace_chunk(fr, Pc, scal, tsorted, orient, ids[s], bi0[a:b], bi1[a:b], j0[s],
                                         j1[s], grad, offs)
            done += float(cnt[a:b].sum())
            if progress is not None:
                progress(min(done / grand, 1.0) if grand > 0 else 1.0)
            a = b
        yield (r0, r1), None
        r0 = r1 + 1
    if progress is not None and grand == 0:
        progress(1.0)


def trace_segments(mesh: TetMesh, camera: Camera, *, chunk_tets: int = 65536,
                   progress: Callable[[float], None] | None = None) -> dict:
    """All segments of the pixel-centre rays (Contract 2) inside the tets of ``mesh``.

    Parameters
    ----------
    mesh : TetMesh
    camera : Camera
    chunk_tets : int
        Largest number of tets handled at once (memory bound, together with an internal budget of
        candidate pairs per chunk).
    progress : callable, optional
        Called with the fraction of work done after each chunk.

    Returns
    -------
    dict of arrays, one entry per segment, unsorted
        ``pixel`` (int64 flat index ``row * W + col``), ``t_in``, ``t_out`` (world distance along the
        unit ray from its origin, ``0 <= t_in < t_out``), ``s_in``, ``s_out`` (scalar at entry and
        exit), ``tet`` (index into ``mesh.tets``); plus ``n_pairs``, the number of candidate
        (tet, pixel) pairs tested.

    Notes
    -----
    Watertight: along a ray inside a closed mesh the segments tile the chord exactly (the exit depth
    of one tet is bit-identical to the entry depth of the next), also for rays lying in shared faces
    or running along edges.
    """
    parts = []
    n_pairs = 0
    for _, ch in _iter_chunks(mesh, camera, chunk_tets=chunk_tets, chunk_pairs=_DEFAULT_CHUNK_PAIRS,
                              band_pairs=np.iinfo(np.int64).max // 4, progress=progress):
        if ch is not None:
            n_pairs += ch.pop("n_pairs")
            parts.append(ch)
    keys = ("pixel", "t_in", "t_out", "s_in", "s_out", "tet")
    if not parts:
        out = {k: np.zeros(0, dtype=np.int64 if k in ("pixel", "tet") else np.float64) for k in keys}
    else:
        out = {k: np.concatenate([p[k] for p in parts]) for k in keys}
    out["n_pairs"] = n_pairs
    return out


def render_reference(mesh: TetMesh, tf: TransferFunction, camera: Camera, *, chunk_tets: int = 65536,
                     progress: Callable[[float], None] | None = None, stats: dict | None = None,
                     band_pairs: int = _DEFAULT_BAND_PAIRS, rows: tuple[int, int] | None = None,
                     method: str = "warp", device: str | None = None) -> np.ndarray:
    """Exact float64 reference image of ``mesh`` under ``tf`` seen by ``camera``.

    ``method="warp"`` (default) computes it with the float64 Warp kernels of
    :mod:`warpvol.reference.warp_render` (an adjacency walk per pixel, on ``device``: default Warp's
    preferred device); ``method="numpy"`` with the pure NumPy cell projection described in this
    module, the oracle the Warp kernels are tested against (``chunk_tets`` and ``band_pairs`` apply
    to it). The two agree to ~1e-15.

    Parameters
    ----------
    mesh : TetMesh
        Tetrahedral mesh with point scalars (need not be convex or connected).
    tf : TransferFunction
        Piecewise-linear transfer function and emission model.
    camera : Camera
        Perspective or orthographic camera; one ray per pixel centre (Contract 2).
    chunk_tets : int
        Largest number of tets processed at once (memory bound).
    progress : callable, optional
        ``progress(done_fraction)`` called after each chunk.
    stats : dict, optional
        Filled with ``n_pairs`` (candidate tet/pixel pairs), ``n_segments``, ``n_bands`` and
        ``n_exact`` (edge predicates the float filter could not decide, evaluated exactly).
    band_pairs : int
        Candidate pairs per band of image rows; a band's segments are held in memory at once.
    rows : (int, int), optional
        First and last image row (inclusive) to render: the image's rows ``first..last``, bit-identical
        to the same rows of the whole image (:mod:`warpvol.bands` spreads bands over a cluster).

    Returns
    -------
    (H, W, 4) float64
        Premultiplied RGBA composited front to back over transparent black, row 0 = top:
        RGB is the radiance, A = 1 - total transmittance. With ``rows``: ``(last - first + 1, W, 4)``.

    Examples
    --------
    >>> from warpvol.scene.mesh import TetMesh
    >>> m = TetMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]], [0, 1, 2, 3])
    >>> tf = TransferFunction([[0, 1, 1, 1, 1.0], [3, 1, 1, 1, 1.0]])
    >>> cam = Camera(eye=[0.2, 0.2, 5], target=[0.2, 0.2, 0], width_px=8, height_px=8, fov_y_deg=20)
    >>> render_reference(m, tf, cam).shape
    (8, 8, 4)
    """
    check_choice("tf.emission", tf.emission, EMISSION_MODELS)
    check_choice("render_reference: method", method, REFERENCE_METHODS)
    if int(chunk_tets) < 1:
        raise ConfigError(f"render_reference: chunk_tets must be >= 1, got {chunk_tets}")
    W, H = int(camera.width_px), int(camera.height_px)
    first, last = check_rows(rows, H)
    if hasattr(mesh, "check_overlap"):  # parts overlapping in space: no one reading of the image (cached)
        mesh.check_overlap()
    mesh, tf = normal_scalars(mesh, tf)  # scalars scaled into float64's normal range (exact)
    if method == "warp":
        from warpvol.reference.warp_render import render_reference_warp

        return render_reference_warp(mesh, tf, camera, device=device, progress=progress, stats=stats,
                                     rows=(first, last))
    img = np.zeros(((last - first + 1) * W, 4), dtype=np.float64)
    n_pairs = n_seg = n_bands = 0
    n_exact0 = _STATS["exact"]
    band: list[tuple] = []
    for (r0, r1), ch in _iter_chunks(mesh, camera, chunk_tets=int(chunk_tets), chunk_pairs=_DEFAULT_CHUNK_PAIRS,
                                     band_pairs=int(band_pairs), progress=progress, rows=(first, last)):
        if ch is not None:
            n_pairs += ch["n_pairs"]
            n_seg += len(ch["pixel"])
            rgb, tau = integrate_segments(ch["s_in"], ch["s_out"], ch["t_out"] - ch["t_in"], tf)
            band.append((ch["pixel"] - r0 * W, ch["t_in"], ch["t_out"], rgb, tau))
            continue
        n_bands += 1
        if band:
            pix = np.concatenate([b[0] for b in band])
            dep = np.concatenate([b[1] for b in band])
            dep2 = np.concatenate([b[2] for b in band])
            rgb = np.concatenate([b[3] for b in band])
            tau = np.concatenate([b[4] for b in band])
            band = []
            img[(r0 - first) * W:(r1 + 1 - first) * W] = composite_front_to_back(pix, dep, rgb, tau, (r1 - r0 + 1) * W,
                                                                                 dep2)
    if stats is not None:
        stats.update(n_pairs=int(n_pairs), n_segments=int(n_seg), n_bands=int(n_bands),
                     n_exact=int(_STATS["exact"] - n_exact0))
    return img.reshape(last - first + 1, W, 4)


def check_rows(rows, height: int) -> tuple[int, int]:
    """``(first, last)`` image rows of a band (inclusive), checked against the image height.

    Examples
    --------
    >>> check_rows(None, 8), check_rows((2, 5), 8)
    ((0, 7), (2, 5))
    >>> check_rows((5, 2), 8)
    Traceback (most recent call last):
    ...
    warpvol.errors.ConfigError: rows: expected (first, last) with 0 <= first <= last < 8, got (5, 2)
    """
    if rows is None:
        return 0, int(height) - 1
    try:
        first, last = (int(r) for r in rows)
        ok = 0 <= first <= last < height and all(float(r) == int(r) for r in rows)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ConfigError(f"rows: expected (first, last) with 0 <= first <= last < {height}, got {rows!r}")
    return first, last
