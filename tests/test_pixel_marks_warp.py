"""``near_segment_pixels_warp`` (one Warp kernel, pt_best's per-frame marks beside the edges of rough tets)
against the NumPy ``near_segment_pixels``: the same (pixel, segment) pairs."""

import numpy as np
import pytest

from warpvol.shared.pixel_marks import near_segment_pixels, near_segment_pixels_warp


@pytest.mark.parametrize("case", ["random", "on_centres", "non_finite", "vertical", "points", "wide"])
def test_near_segment_pixels_warp_gives_the_numpy_pairs(case):
    """Random segments in and around a 97 x 61 window; segments with ends on pixel centres (distances 0 and
    exact ties), non-finite and huge coordinates, vertical segments, zero-length ones, and a wide band whose
    pairs outnumber the kernel's first output buffer."""
    rng = np.random.default_rng(["random", "on_centres", "non_finite", "vertical", "points", "wide"].index(case))
    w, h, n = 97, 61, 5000
    ax, ay = rng.uniform(-20, 120, n), rng.uniform(-20, 80, n)
    bx, by = ax + rng.normal(0, 15, n), ay + rng.normal(0, 15, n)
    delta = 0.3 if case == "wide" else 2 / 256
    if case == "on_centres":
        ax, ay, bx, by = (np.round(v) + 0.5 for v in (ax, ay, bx, by))
    elif case == "non_finite":
        ax[::7], by[::5], bx[::11], ay[::13] = np.inf, np.nan, 1e300, -1e250
    elif case == "vertical":
        bx = ax.copy()
    elif case == "points":
        bx, by = ax.copy(), ay.copy()
    with np.errstate(invalid="ignore"):
        want = near_segment_pixels(ax, ay, bx, by, w, h, delta)
    got = near_segment_pixels_warp(ax, ay, bx, by, w, h, delta)
    assert len(want[0]) > 0 or case == "points"
    if case == "wide":
        assert len(want[0]) > 4 * n + 1024  # the kernel ran again with room for them all
    assert sorted(zip(*(a.tolist() for a in want))) == sorted(zip(*(a.tolist() for a in got)))


@pytest.mark.parametrize("case", ["random", "ties", "one_point", "integers", "long"])
def test_segment_samples_all_rows_at_once_as_row_by_row(case):
    """``_segment_samples`` (every projected face's points at once) gives the row-by-row ``np.linspace``
    points bit for bit: equal longest pairs, a degenerate face, integer corners, segments past the 1e5 cap."""
    from warpvol.shared.pixel_marks import _segment_samples, _segment_samples_rows

    rng = np.random.default_rng(["random", "ties", "one_point", "integers", "long"].index(case))
    col, row = rng.uniform(-50, 600, (200, 3)), rng.uniform(-50, 600, (200, 3))
    if case == "ties":
        col[:, 1], row[:, 1] = col[:, 0], row[:, 0]
    elif case == "one_point":
        col[:], row[:] = 3.5, 7.25
    elif case == "integers":
        col, row = np.round(col), np.round(row)
    elif case == "long":
        col, row = col[:5] * 2e4, row[:5] * 1e4
    for a, b in zip(_segment_samples(col, row), _segment_samples_rows(col, row)):
        assert a.dtype == b.dtype and np.array_equal(a, b)
