"""Pixel marking for :mod:`warpvol.projection.pt_thin` (and the ray casters' open-edge pixels): the pixel
centres within one pixel of boxes, within a distance of segments, the points along projected faces, and the
filter that keeps only the pixels a source's fragment reached before the pixel terminated (:class:`InFront`).
"""

from __future__ import annotations

import numpy as np


def _box_ranges(col: np.ndarray, row: np.ndarray, h: int, w: int):
    """Per row of window points ``col``, ``row`` (n, k): the pixel columns ``j0 .. j1 - 1`` and rows
    ``i0 .. i1 - 1`` (clipped to the window) whose centres lie within one pixel of their bounding box."""
    big = 4.0 * (w + h) + 4.0  # clamp before the int casts (off-screen boxes)
    j0 = np.ceil(np.clip(col.min(axis=1) - 0.5, -big, big)).astype(np.int64) - 1
    j1 = np.floor(np.clip(col.max(axis=1) - 0.5, -big, big)).astype(np.int64) + 1
    i0 = np.ceil(np.clip(row.min(axis=1) - 0.5, -big, big)).astype(np.int64) - 1
    i1 = np.floor(np.clip(row.max(axis=1) - 0.5, -big, big)).astype(np.int64) + 1
    return np.clip(j0, 0, w), np.clip(j1 + 1, 0, w), np.clip(i0, 0, h), np.clip(i1 + 1, 0, h)


#: :func:`_mark_boxes` lists at most this many (pixel, box) pairs to test each against the termination
#: (beyond: every pixel of every box is marked, as without it)
BOX_PAIRS_MAX = 1 << 22


def _mark_boxes(cover: np.ndarray, col: np.ndarray, row: np.ndarray, front=None, rank=None) -> None:
    """Mark in ``cover`` (H, W) the pixels whose centres lie within one pixel of the bounding box of
    each row of window points ``col``, ``row`` (n, k); with ``front`` (:class:`InFront`) only those where
    the box's source (draw position ``rank``, per row) was drawn."""
    h, w = cover.shape
    j0, j1, i0, i1 = _box_ranges(col, row, h, w)
    area = np.maximum(j1 - j0, 0) * np.maximum(i1 - i0, 0)
    if front is not None and 0 < area.sum() <= BOX_PAIRS_MAX:  # each (pixel, box) pair tested
        src = np.repeat(np.arange(len(area)), area)
        k = np.arange(len(src)) - np.repeat(np.cumsum(area) - area, area)
        wd = (j1 - j0)[src]
        pix = (i0[src] + k // wd) * w + j0[src] + k % wd
        cover.ravel()[pix[front(pix, rank[src])]] = True
        return
    ok = area > 0
    diff = np.zeros((h + 1, w + 1), dtype=np.int64)  # boxes summed by a 2D difference array
    np.add.at(diff, (i0[ok], j0[ok]), 1)
    np.add.at(diff, (i0[ok], j1[ok]), -1)
    np.add.at(diff, (i1[ok], j0[ok]), -1)
    np.add.at(diff, (i1[ok], j1[ok]), 1)
    cover |= diff.cumsum(axis=0).cumsum(axis=1)[:h, :w] > 0


class InFront:
    """The (pixel, source) pairs whose source was drawn at the pixel, with ``term_at`` ((H, W): the draw
    position of the cell whose fragment terminated each pixel, drawn front to back, positions falling;
    -1 where none did): the pixel did not terminate, or terminated at a position at most the source's (its
    fragment came first). ``dropped`` marks the pixels a pair was left out at."""

    def __init__(self, term_at: np.ndarray):
        self.term = np.asarray(term_at).ravel()
        self.dropped = np.zeros(self.term.size, dtype=bool)

    def __call__(self, pix: np.ndarray, rank: np.ndarray) -> np.ndarray:
        t = self.term[pix]
        keep = (t < 0) | (rank >= t)
        self.dropped[pix[~keep]] = True
        return keep


def near_segment_pixels(ax, ay, bx, by, w: int, h: int, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """``(flat pixel index, segment index)`` pairs of the pixel centres of a ``w`` x ``h`` window within
    ``delta`` (< 0.35) pixels of the window-space segments ``a b`` (non-finite segments are left out). Each
    segment is stepped along its major axis: per pixel column (row) of its span, the one row (column) whose
    centre is nearest the segment there is tested -- with ``delta`` < 0.35 no other centre can be within
    ``delta``."""
    ax, ay, bx, by = (np.asarray(v, dtype=np.float64) for v in (ax, ay, bx, by))
    ids = np.flatnonzero(np.isfinite(ax) & np.isfinite(ay) & np.isfinite(bx) & np.isfinite(by))
    p = np.column_stack([ax[ids], ay[ids]])
    d = np.column_stack([bx[ids], by[ids]]) - p
    flat = np.abs(d[:, 0]) >= np.abs(d[:, 1])  # closer to horizontal: stepped by column, the others by row
    pix, seg = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for major, sel in ((0, flat), (1, ~flat)):
        pp, dd, ss = p[sel], d[sel], ids[sel]
        if len(pp) == 0:
            continue
        lim = float(w if major == 0 else h)
        lo = np.clip(np.minimum(pp[:, major], pp[:, major] + dd[:, major]) - delta - 0.5, -1.0, lim)
        hi = np.clip(np.maximum(pp[:, major], pp[:, major] + dd[:, major]) + delta - 0.5, -1.0, lim)
        c0 = np.ceil(lo).astype(np.int64)
        cnt = np.maximum(np.floor(hi).astype(np.int64) - c0 + 1, 0)
        if cnt.sum() == 0:
            continue
        e = np.repeat(np.arange(len(pp)), cnt)
        c = c0[e] + (np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt))
        m = c + 0.5  # pixel centre along the major axis
        den = np.where(dd[e, major] == 0.0, 1.0, dd[e, major])
        u = np.clip((m - pp[e, major]) / den, 0.0, 1.0)
        other = np.rint(pp[e, 1 - major] + u * dd[e, 1 - major] - 0.5).astype(np.int64)
        o = other + 0.5
        # distance from the pixel centre to the segment
        rx = (m if major == 0 else o) - pp[e, 0]
        ry = (o if major == 0 else m) - pp[e, 1]
        ex, ey = dd[e, 0], dd[e, 1]
        with np.errstate(over="ignore", invalid="ignore"):  # a huge or non-finite segment is near no centre
            t = np.clip((rx * ex + ry * ey) / np.maximum(ex * ex + ey * ey, 1e-300), 0.0, 1.0)
            near = np.hypot(rx - t * ex, ry - t * ey) <= delta
        jj, ii = (c, other) if major == 0 else (other, c)
        near &= (jj >= 0) & (jj < w) & (ii >= 0) & (ii < h)
        pix.append(ii[near] * w + jj[near])
        seg.append(ss[e[near]])
    return np.concatenate(pix), np.concatenate(seg)


#: :func:`near_segment_pixels_warp`'s kernel keeps the centres whose distance is within this factor of
#: ``delta``; ``np.hypot`` then decides, as :func:`near_segment_pixels` does
_NEAR_SLACK = 1.0 + 1e-9


def near_segment_pixels_warp(ax, ay, bx, by, w: int, h: int, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`near_segment_pixels` by one Warp kernel on the CPU (:func:`warpvol.kernels.pixel_marks.k_near_segments`:
    the same float64 steps, one thread per segment), the pairs in another order: the same set. The
    kernel keeps the centres within :data:`_NEAR_SLACK` of ``delta`` with the distance's components, and
    ``np.hypot`` of those decides, so the pairs are the NumPy function's exactly. For many long segments
    (the edges ``pt_best`` checks every frame) it replaces a dozen NumPy passes over every pixel step of
    them."""
    import warp as wp

    from warpvol.kernels import pixel_marks as kpm

    ax, ay, bx, by = (np.asarray(v, dtype=np.float64) for v in (ax, ay, bx, by))
    ids = np.flatnonzero(np.isfinite(ax) & np.isfinite(ay) & np.isfinite(bx) & np.isfinite(by))
    if len(ids) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    dev = "cpu"
    segs = [wp.array(np.ascontiguousarray(v[ids]), dtype=wp.float64, device=dev) for v in (ax, ay, bx, by)]
    room = 4 * len(ids) + 1024  # marks are rare: centres within delta (< 0.35 px) of a segment
    for _ in range(2):
        n = wp.zeros(1, dtype=wp.int32, device=dev)
        out = [wp.empty(room, dtype=t, device=dev) for t in (wp.int64, wp.int32, wp.float64, wp.float64)]
        wp.launch(kpm.k_near_segments, dim=len(ids),
                  inputs=[*segs, int(w), int(h), float(delta), float((delta * _NEAR_SLACK) ** 2), n, *out], device=dev)
        k = int(n.numpy()[0])
        if k <= room:
            break
        room = k
    pix, seg, qx, qy = (o.numpy()[:k] for o in out)
    near = np.hypot(qx, qy) <= delta
    return pix[near], ids[seg[near]]


def _mark_near_edges(cover: np.ndarray, col: np.ndarray, row: np.ndarray, delta: float, front=None,
                     rank=None) -> None:
    """Mark in ``cover`` (H, W) the pixels whose centres lie within ``delta`` (< 0.35) pixels of an edge of
    the projected triangle of each row of window points ``col``, ``row`` (n, 3) (a sliver narrower than
    ``2 delta`` lies wholly within that band), by :func:`near_segment_pixels`; ``front``, ``rank``: as
    :func:`_mark_boxes`."""
    h, w = cover.shape
    for a, b in ((0, 1), (1, 2), (2, 0)):
        pix, seg = near_segment_pixels(col[:, a], row[:, a], col[:, b], row[:, b], w, h, delta)
        if front is not None:
            pix = pix[front(pix, rank[seg])]
        cover[pix // w, pix % w] = True


def _segment_samples(col: np.ndarray, row: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points every half pixel along each row's projected face (three collinear window points): the
    segment between its two farthest vertices, as (m, 1) columns and rows, and the row each came from.
    The points of a row are ``np.linspace(0, 1, n)``'s (``k / (n - 1)`` as ``k * step``, the last 1), for every
    row at once."""
    col, row = np.asarray(col, np.float64), np.asarray(row, np.float64)
    if len(col) == 0:
        return np.zeros((0, 1)), np.zeros((0, 1)), np.zeros(0, np.int64)
    if not (np.isfinite(col).all() and np.isfinite(row).all()):  # rare: row by row, as written first
        return _segment_samples_rows(col, row)
    pairs = np.array([(0, 1), (0, 2), (1, 2)])
    length = np.hypot(col[:, pairs[:, 0]] - col[:, pairs[:, 1]], row[:, pairs[:, 0]] - row[:, pairs[:, 1]])
    pick = pairs[np.argmax(length, axis=1)]  # the first longest, as max() over the pairs in this order
    r = np.arange(len(col))
    ca, cb, ra, rb = col[r, pick[:, 0]], col[r, pick[:, 1]], row[r, pick[:, 0]], row[r, pick[:, 1]]
    n = (np.minimum(length[r, np.argmax(length, axis=1)], 1e5) * 2.0).astype(np.int64) + 2
    src = np.repeat(r, n)
    k = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)).astype(np.float64)
    u = k * (1.0 / (n - 1).astype(np.float64))[src] + 0.0
    u[np.cumsum(n) - 1] = 1.0  # linspace's endpoint
    return (ca[src] + (cb[src] - ca[src]) * u)[:, None], (ra[src] + (rb[src] - ra[src]) * u)[:, None], src


def _segment_samples_rows(col: np.ndarray, row: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_segment_samples` one row at a time (rows with non-finite window points)."""
    cs, rs = [np.zeros(0)], [np.zeros(0)]
    for c, r in zip(col, row):
        a, b = max(((0, 1), (0, 2), (1, 2)), key=lambda e: np.hypot(c[e[0]] - c[e[1]], r[e[0]] - r[e[1]]))
        n = int(min(np.hypot(c[a] - c[b], r[a] - r[b]), 1e5) * 2.0) + 2
        u = np.linspace(0.0, 1.0, n)
        cs.append(c[a] + (c[b] - c[a]) * u)
        rs.append(r[a] + (r[b] - r[a]) * u)
    n = np.array([len(c) for c in cs[1:]], dtype=np.int64)
    return np.concatenate(cs)[:, None], np.concatenate(rs)[:, None], np.repeat(np.arange(len(n)), n)
