"""Rasteriser: watertightness, fill rule, interpolation, depth test, culling, order, ID buffers; vertex stage."""

import numpy as np
import pytest
import warp as wp

from helpers import DEVICES
from warpvol.errors import ConfigError
from warpvol.gpu.blend import BlendUnit, FrameBuffer
from warpvol.gpu.raster import Rasterizer, rasterize
from warpvol.gpu.vertex import VertexStage, transform_vertices, viewport_matrix
from warpvol.kernels.raster import inside, row_span, vec3l
from warpvol.scene.camera import Camera


def icosphere(level: int) -> tuple[np.ndarray, np.ndarray]:
    t = (1 + 5**0.5) / 2
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
         [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6],
         [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
         [8, 6, 7], [9, 8, 1]]
    v = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(level):
        cache, nf = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = v[a] + v[b]
                v.append(m / np.linalg.norm(m))
                cache[key] = len(v) - 1
            return cache[key]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        f = nf
    return np.array(v), np.array(f)


def random_closed_mesh(seed: int, bumpy: bool = True):
    """A closed triangle mesh (randomly perturbed and rotated icosphere; convex if not ``bumpy``)."""
    rng = np.random.default_rng(seed)
    v, f = icosphere(2)
    if bumpy:
        v = v * rng.uniform(0.6, 1.0, (len(v), 1))
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return v @ q.T, f


def counts_per_pixel(frags, shape):
    return np.diff(frags.offsets.numpy()).reshape(shape)


def reference_coverage(win, faces, width, height, eps=1e-3):
    """NumPy: how many projected triangles contain each pixel centre, and where that is ambiguous
    (a centre within ``eps`` pixels of an edge line)."""
    j, i = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    p = np.stack([j.ravel(), i.ravel()], -1)
    count = np.zeros(len(p), int)
    ambiguous = np.zeros(len(p), bool)
    for tri in faces:
        a, b, c = win[tri, :2].astype(np.float64)
        e = []
        for u, v in ((a, b), (b, c), (c, a)):
            d = v - u
            e.append((d[0] * (p[:, 1] - u[1]) - d[1] * (p[:, 0] - u[0])) / max(np.hypot(*d), 1e-12))
        e = np.stack(e, -1)
        inside = np.all(e > eps, 1) | np.all(e < -eps, 1)
        count += inside
        near = np.all(e > -eps, 1) | np.all(e < eps, 1)
        ambiguous |= near & ~inside
    return count.reshape(height, width), ambiguous.reshape(height, width)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("seed,bumpy", [(0, False), (1, True), (2, True)])
def test_closed_mesh_is_watertight(device, seed, bumpy):
    verts, faces = random_closed_mesh(seed, bumpy)
    W, H = 96, 80
    cam = Camera(eye=[0.3, 0.2, 3.2], target=[0, 0, 0], width_px=W, height_px=H, fov_y_deg=45)
    out = VertexStage.from_camera(cam, near=0.5, far=10.0, device=device).transform(verts)
    win = out.window_array
    n_all = counts_per_pixel(Rasterizer(W, H, device=device, tile_size=8).fragments(win, faces), (H, W))
    n_back = counts_per_pixel(Rasterizer(W, H, device=device, cull="back").fragments(win, faces), (H, W))
    n_front = counts_per_pixel(Rasterizer(W, H, device=device, cull="front").fragments(win, faces), (H, W))
    assert (n_all > 0).sum() > 1500
    # closed mesh: at every pixel centre as many front layers as back layers, one fragment each
    np.testing.assert_array_equal(n_front, n_back)
    np.testing.assert_array_equal(n_all, n_front + n_back)
    if not bumpy:
        assert set(np.unique(n_all)) == {0, 2}
    # exactly the number of projected triangles containing the centre (where that is unambiguous),
    # and centres on shared edges (ambiguous for the reference) are still counted once per layer
    ref, amb = reference_coverage(out.window, faces, W, H)
    np.testing.assert_array_equal(n_all[~amb], ref[~amb])
    assert amb.sum() < 0.05 * W * H


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("fill_rule", ["bottom_left", "top_left"])
def test_pixel_centre_aligned_grid_mesh_covers_each_centre_once(device, fill_rule):
    """A jittered planar grid whose vertices sit on pixel centres and edges: shared edges pass through
    many pixel centres; each centre strictly inside the boundary is covered exactly once."""
    rng = np.random.default_rng(3)
    W = H = 40
    g = np.arange(4, 37, 4).astype(float)
    X, Y = np.meshgrid(g, g)
    inner = (X > 4) & (X < 36) & (Y > 4) & (Y < 36)
    X = X + inner * rng.choice([-1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5], X.shape)
    Y = Y + inner * rng.choice([-1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5], Y.shape)
    X, Y = X + 0.5, Y + 0.5  # vertices at pixel centres
    n = len(g)
    pos = np.stack([X.ravel(), Y.ravel(), np.full(n * n, 0.5), np.ones(n * n)], -1)
    idx = np.arange(n * n).reshape(n, n)
    tris = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = idx[r, c], idx[r, c + 1], idx[r + 1, c], idx[r + 1, c + 1]
            if rng.random() < 0.5:
                tris += [[a, b, e], [a, e, d]]
            else:
                tris += [[a, b, d], [b, e, d]]
    tris = np.array(tris)
    tris[::3] = tris[::3, ::-1]  # mixed windings must not matter with culling off
    cnt = counts_per_pixel(rasterize(pos, tris, W, H, device=device, tile_size=4, fill_rule=fill_rule), (H, W))
    # boundary square from 4.5 to 36.5: left boundary centres included, right excluded; the bottom
    # row as displayed (row 36, the smaller GL window y) is owned under bottom_left, the top (row 4)
    # under top_left
    expect = np.zeros((H, W), int)
    if fill_rule == "bottom_left":
        expect[5:37, 4:36] = 1
    else:
        expect[4:36, 4:36] = 1
    np.testing.assert_array_equal(cnt, expect)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("fill_rule", ["bottom_left", "top_left"])
def test_fill_rules_on_pixel_centre_edges(device, fill_rule):
    # a square with corners on pixel centres (2.5, 1.5)-(6.5, 5.5), split along its diagonal
    pos = np.array([[2.5, 1.5, 0, 1], [6.5, 1.5, 0, 1], [2.5, 5.5, 0, 1], [6.5, 5.5, 0, 1]], np.float32)
    kw = dict(device=device, fill_rule=fill_rule)
    for tris in ([[0, 1, 2], [1, 3, 2]], [[0, 1, 3], [0, 3, 2]], [[2, 1, 0], [2, 3, 1]]):
        fr = rasterize(pos, np.array(tris), 9, 8, **kw)
        cnt = counts_per_pixel(fr, (8, 9))
        expect = np.zeros((8, 9), int)
        # left column (x = 2.5) in, right out; bottom_left: the bottom row as displayed (y = 5.5, the
        # smaller GL window y) in and the top row out; top_left: the other way round
        if fill_rule == "bottom_left":
            expect[2:6, 2:6] = 1
        else:
            expect[1:5, 2:6] = 1
        np.testing.assert_array_equal(cnt, expect)
    # single triangle: which diagonal centres belong to it depends on the edge's side
    lower_left = counts_per_pixel(rasterize(pos, np.array([[0, 3, 2]]), 9, 8, **kw), (8, 9))
    upper_right = counts_per_pixel(rasterize(pos, np.array([[0, 1, 3]]), 9, 8, **kw), (8, 9))
    # (the diagonal's first centre (2.5, 1.5) lies on the top edge too, owned under top_left only)
    diag = [(1 + k, 2 + k) for k in range(0 if fill_rule == "top_left" else 1, 4)]
    # the diagonal is a left edge of the upper-right triangle (interior to its right), a right edge
    # of the lower-left one
    assert all(upper_right[r, c] == 1 for r, c in diag)
    assert all(lower_left[r, c] == 0 for r, c in diag)
    # 16 centres in the square, each once; the upper-right triangle owns the top row under top_left,
    # the lower-left one the bottom row under bottom_left
    if fill_rule == "bottom_left":
        assert lower_left.sum() == 1 + 2 + 3 + 4 and upper_right.sum() == 3 + 2 + 1
    else:
        assert lower_left.sum() == 6 and upper_right.sum() == 10
    # a horizontal edge shared by two triangles above/below it: bottom_left gives it to the triangle
    # above (its bottom edge), top_left to the one below (its top edge)
    pos2 = np.array([[0, 2.5, 0, 1], [8, 2.5, 0, 1], [4, -3, 0, 1], [4, 8, 0, 1]], np.float32)
    above = counts_per_pixel(rasterize(pos2, np.array([[0, 2, 1]]), 8, 8, **kw), (8, 8))
    below = counts_per_pixel(rasterize(pos2, np.array([[0, 1, 3]]), 8, 8, **kw), (8, 8))
    owner, other = (above, below) if fill_rule == "bottom_left" else (below, above)
    assert other[2].sum() == 0 and owner[2].sum() == 8
    assert (above + below).max() == 1


@pytest.mark.parametrize("device", DEVICES)
def test_snapping_ties(device):
    # x = 2.5 + 1/512 is half-way between the 1/256 steps 640 and 641 (2.5 + 1/256 = 641/256):
    # ties to even snap it onto the pixel centres' column (640/256 = 2.5), ties away one step right
    d = 1 / 512
    for ties, on_centre in (("even", True), ("away", False)):
        pos = np.array([[2.5 + d, 0.0, 0, 1], [2.5 + d, 8.0, 0, 1], [8.0, 0.0, 0, 1]], np.float32)
        cnt = counts_per_pixel(rasterize(pos, [[0, 1, 2]], 8, 8, device=device, snap_ties=ties), (8, 8))
        # the vertical edge is a left edge: column 2 (centre x = 2.5) is in iff the edge snapped onto it
        assert (cnt[:, 2].sum() > 0) == on_centre
        assert cnt[:, 3].sum() > 0 and cnt[:, :2].sum() == 0
    with pytest.raises(ConfigError, match="snap_ties"):
        Rasterizer(4, 4, snap_ties="up")
    with pytest.raises(ConfigError, match="fill_rule"):
        Rasterizer(4, 4, fill_rule="top_right")


def _plane_setup(device, width=64, height=48):
    cam = Camera(eye=[0.5, 0.4, 3.0], target=[0, 0, -0.5], width_px=width, height_px=height, fov_y_deg=60)
    # a large triangle strongly inclined to the view (big depth range -> visible perspective)
    P = np.array([[-2.0, -1.5, 1.0], [2.5, -1.0, -4.0], [-1.0, 2.0, -3.0]])
    near, far = 0.5, 20.0
    vs = VertexStage.from_camera(cam, near, far, device=device)
    out = vs.transform(P)
    return cam, P, out


@pytest.mark.parametrize("device", DEVICES)
def test_perspective_correct_interpolation_is_exact_at_pixel_rays(device):
    cam, P, out = _plane_setup(device)
    attrs = P  # attributes = world position (linear in the plane)
    r = Rasterizer(cam.width_px, cam.height_px, device=device)
    fr = r.fragments(out.window_array, [[0, 1, 2]], attrs, interpolation="perspective")
    assert fr.count > 500
    pix = fr.pixel_index()
    rows, cols = pix // cam.width_px, pix % cam.width_px
    o, d = cam.rays()
    o, d = o[rows, cols], d[rows, cols]
    nrm = np.cross(P[1] - P[0], P[2] - P[0])
    t = ((P[0] - o) @ nrm) / (d @ nrm)
    hit = o + t[:, None] * d
    got = fr.attrs.numpy()[: fr.count]
    np.testing.assert_allclose(got, hit, atol=2e-4 * np.abs(P).max())


@pytest.mark.parametrize("device", DEVICES)
def test_linear_interpolation_has_the_expected_screen_space_error(device):
    cam, P, out = _plane_setup(device)
    r = Rasterizer(cam.width_px, cam.height_px, device=device)
    fr = r.fragments(out.window_array, [[0, 1, 2]], P, interpolation="linear")
    pix = fr.pixel_index()
    px = pix % cam.width_px + 0.5
    py = pix // cam.width_px + 0.5
    w = out.window[:, :2].astype(np.float64)
    # screen-space barycentrics of the pixel centres: what affine (non-perspective) hardware does
    T = np.array([[w[0, 0] - w[2, 0], w[1, 0] - w[2, 0]], [w[0, 1] - w[2, 1], w[1, 1] - w[2, 1]]])
    l01 = np.linalg.solve(T, np.stack([px - w[2, 0], py - w[2, 1]]))
    lam = np.stack([l01[0], l01[1], 1 - l01[0] - l01[1]], -1)
    got = fr.attrs.numpy()[: fr.count]
    np.testing.assert_allclose(got, lam @ P, atol=2e-4 * np.abs(P).max())
    # ... which differs from the perspective-correct (exact) attribute by a visible amount
    exact = r.fragments(out.window_array, [[0, 1, 2]], P, interpolation="perspective").attrs.numpy()[: fr.count]
    assert np.abs(got - exact).max() > 0.2
    # and depth is the same either way (window z is affine in screen space)
    np.testing.assert_allclose(fr.depth.numpy()[: fr.count], lam @ out.window[:, 2], atol=1e-5)


@pytest.mark.parametrize("device", DEVICES)
def test_flat_and_mixed_interpolation_modes(device):
    pos = np.array([[0, 0, 0.5, 1], [8, 0, 0.5, 2], [0, 8, 0.5, 4]], np.float32)
    attrs = np.array([[1.0, 10.0], [2.0, 20.0], [3.0, 30.0]])
    fr = rasterize(pos, [[0, 1, 2]], 8, 8, attrs, interpolation=["flat", "linear"], device=device)
    a = fr.attrs.numpy()[: fr.count]
    assert np.all(a[:, 0] == 3.0)  # provoking vertex = last vertex
    assert a[:, 1].min() > 10.0 and a[:, 1].max() < 30.0
    with pytest.raises(ConfigError, match=r"interpolation: unknown value 'smooth'"):
        rasterize(pos, [[0, 1, 2]], 8, 8, attrs, interpolation="smooth", device=device)


@pytest.mark.parametrize("device", DEVICES)
def test_depth_tests_culling_and_primitive_order(device):
    W = H = 20
    # two overlapping full-viewport-ish quads (as 2 triangles each), near one (z=.3) drawn second
    def quad(z, x0=0.0, y0=0.0, x1=20.0, y1=20.0):
        return np.array([[x0, y0, z, 1], [x1, y0, z, 1], [x0, y1, z, 1], [x1, y1, z, 1]], np.float32)

    pos = np.concatenate([quad(0.6), quad(0.3, 5, 5, 15, 15)])
    tris = np.array([[0, 2, 1], [1, 2, 3], [4, 6, 5], [5, 6, 7]])  # CCW in GL (y up) = front facing
    cols = np.concatenate([np.tile([1.0, 0, 0, 1], (4, 1)), np.tile([0, 1.0, 0, 1], (4, 1))])

    def render(depth_func, order, **kw):
        fb = FrameBuffer(W, H, "unorm8", device)
        fb.clear((0, 0, 0, 0))
        fb.clear_depth(1.0 if depth_func in ("less", "always") else 0.0)
        r = Rasterizer(W, H, device=device, depth_func=depth_func, depth_write=True, tile_size=8, **kw)
        r.draw(pos, tris[order], cols, fb, BlendUnit.replace())
        return fb.codes()[..., :2]

    centre, corner = (10, 10), (1, 1)
    # ALWAYS: the later primitive wins, whatever its depth
    assert render("always", [0, 1, 2, 3])[centre].tolist() == [0, 255]
    assert render("always", [2, 3, 0, 1])[centre].tolist() == [255, 0]
    # LESS: the nearer wins in either order; GREATER: the farther
    for order in ([0, 1, 2, 3], [2, 3, 0, 1]):
        assert render("less", order)[centre].tolist() == [0, 255]
        assert render("greater", order)[centre].tolist() == [255, 0]
        assert render("less", order)[corner].tolist() == [255, 0]
    # culling: these faces are front facing (CCW in OpenGL's y-up window coordinates)
    assert render("always", [0, 1, 2, 3], cull="back")[centre].tolist() == [0, 255]
    assert render("always", [0, 1, 2, 3], cull="front")[centre].tolist() == [0, 0]
    assert render("always", [0, 1, 2, 3], cull="back", front_face="cw")[centre].tolist() == [0, 0]
    # depth clip: fragments beyond the far plane are dropped
    far = np.concatenate([quad(1.5), quad(0.3, 5, 5, 15, 15)])
    fb = FrameBuffer(W, H, "unorm8", device)
    Rasterizer(W, H, device=device).draw(far, tris, cols, fb, BlendUnit.replace())
    assert fb.codes()[corner].tolist() == [0, 0, 0, 0]


@pytest.mark.parametrize("device", DEVICES)
def test_fused_draw_equals_fragment_list_and_is_tile_size_independent(device):
    rng = np.random.default_rng(11)
    W, H, T = 50, 40, 300
    pos = np.concatenate([rng.uniform([-5, -5], [55, 45], (3 * T, 2)), rng.uniform(0, 1, (3 * T, 1)),
                          rng.uniform(0.5, 2, (3 * T, 1))], 1).astype(np.float32)
    tris = np.arange(3 * T).reshape(T, 3)
    cols = rng.uniform(0, 1, (3 * T, 4)).astype(np.float32)
    outs = []
    for ts, trav in ((4, "tile"), (16, "pixel"), (64, "tile"), (8, "pixel")):
        fb = FrameBuffer(W, H, "unorm8", device)
        fb.clear((0.1, 0.2, 0.3, 0.0))
        Rasterizer(W, H, device=device, tile_size=ts, traversal=trav).draw(pos, tris, cols, fb, BlendUnit.over())
        outs.append(fb.codes())
    for o in outs[1:]:
        np.testing.assert_array_equal(o, outs[0])
    # per-tile and per-pixel traversal also agree with a depth test and flat / linear shading
    for mode in ("flat", "linear"):
        res = []
        for trav in ("tile", "pixel"):
            fb = FrameBuffer(W, H, "unorm12", device)
            fb.clear((0, 0, 0, 0))
            Rasterizer(W, H, device=device, depth_func="less", depth_write=True, traversal=trav).draw(
                pos, tris, cols, fb, BlendUnit.under(), interpolation=mode)
            res.append((fb.codes(), fb.depth.numpy()))
        np.testing.assert_array_equal(res[0][0], res[1][0])
        np.testing.assert_array_equal(res[0][1], res[1][1])
        assert (res[0][1] < 1).sum() > 0.5 * W * H
    r = Rasterizer(W, H, device=device)
    fr = r.fragments(pos, tris, cols, interpolation="perspective")
    fb = FrameBuffer(W, H, "unorm8", device)
    fb.clear((0.1, 0.2, 0.3, 0.0))
    BlendUnit.over().blend_fragments(fb, fr, fr.attrs)
    np.testing.assert_array_equal(fb.codes(), outs[0])
    # primitive order per pixel: fragment prims strictly increasing within each pixel
    off, prim = fr.offsets.numpy(), fr.prim.numpy()[: fr.count]
    inc = np.diff(prim) > 0
    starts = np.zeros(fr.count, bool)
    starts[off[:-1][off[:-1] < fr.count]] = True
    assert np.all(inc | starts[1:])


@pytest.mark.parametrize("device", DEVICES)
def test_triangle_walk_gives_the_pixel_walks_fragment_list(device):
    """``fragments(walk="triangle")`` (per-triangle bounding-box walk + stable sort by pixel) = the
    emulated per-pixel walk, array for array: offsets, primitive order, depth and every interpolation
    mode / rule, with and without depth clipping; refused with a depth test."""
    rng = np.random.default_rng(13)
    W, H, T = 37, 29, 250
    pos = np.concatenate([rng.uniform([-5, -5], [42, 34], (3 * T, 2)), rng.uniform(-0.2, 1.2, (3 * T, 1)),
                          rng.uniform(0.5, 2, (3 * T, 1))], 1).astype(np.float32)
    tris = np.arange(3 * T).reshape(T, 3)
    tris[::2] = tris[::2, ::-1]
    attrs = rng.uniform(0, 1, (3 * T, 3)).astype(np.float32)
    for rule, clip in (("barycentric", False), ("barycentric", True), ("llvmpipe", False)):
        r = Rasterizer(W, H, device=device, depth_clip=clip, interp_rule=rule)
        a, b = (r.fragments(pos, tris, attrs, interpolation=["linear", "perspective", "flat"], walk=w)
                for w in ("pixel", "triangle"))
        assert a.count == b.count > 500
        for name in ("offsets", "prim", "depth", "attrs"):
            np.testing.assert_array_equal(getattr(a, name).numpy(), getattr(b, name).numpy(), err_msg=name)
    with pytest.raises(ConfigError, match="walk"):
        Rasterizer(W, H, device=device, depth_func="less").fragments(pos, tris, walk="triangle")
    with pytest.raises(ConfigError, match="walk"):
        Rasterizer(W, H, device=device).fragments(pos, tris, walk="tile")


@pytest.mark.parametrize("device", DEVICES)
def test_llvmpipe_interpolation_rule(device):
    """The llvmpipe plane-equation rule: the same fragments in the fragment list and both draw
    traversals, values within fp32 rounding of the barycentric ones (linear and perspective), and
    constant attributes exact (linear). (Code-for-code agreement with llvmpipe: tests/test_gl_conformance.py.)"""
    rng = np.random.default_rng(12)
    W, H, T = 40, 30, 120
    pos = np.concatenate([rng.uniform([0, 0], [W, H], (3 * T, 2)), rng.uniform(0, 1, (3 * T, 1)),
                          rng.uniform(0.5, 2, (3 * T, 1))], 1).astype(np.float32)
    tris = np.arange(3 * T).reshape(T, 3)
    tris[::2] = tris[::2, ::-1]  # both windings (llvmpipe reorders clockwise triangles)
    cols = rng.uniform(0, 1, (3 * T, 4)).astype(np.float32)
    cols[:, 3] = 0.75  # a constant attribute
    for mode in ("linear", "perspective"):
        fr = {rule: Rasterizer(W, H, device=device, interp_rule=rule).fragments(pos, tris, cols, interpolation=mode)
              for rule in ("barycentric", "llvmpipe")}
        a, b = fr["barycentric"], fr["llvmpipe"]
        assert a.count == b.count > 0.5 * W * H
        va, vb = a.attrs.numpy()[: a.count], b.attrs.numpy()[: b.count]
        np.testing.assert_allclose(vb, va, atol=2e-5)
        assert (vb != va).any()  # a different rule, not the same arithmetic
        if mode == "linear":  # zero gradients: exact (perspective divides a/w by 1/w, rounded)
            np.testing.assert_array_equal(vb[:, 3], 0.75)
        draws = []
        for trav in ("tile", "pixel"):
            fb = FrameBuffer(W, H, "fp32", device)
            fb.clear((0, 0, 0, 0))
            Rasterizer(W, H, device=device, interp_rule="llvmpipe", traversal=trav).draw(
                pos, tris, cols, fb, BlendUnit.replace(), interpolation=mode)
            draws.append(fb.readback())
        np.testing.assert_array_equal(draws[0], draws[1])
        last = b.offsets.numpy()
        has = np.diff(last) > 0
        np.testing.assert_array_equal(draws[0].reshape(-1, 4)[has], vb[last[1:][has] - 1])
    with pytest.raises(ConfigError, match="interp_rule"):
        Rasterizer(4, 4, interp_rule="plane")


@pytest.mark.parametrize("device", DEVICES)
def test_id_buffer_flat_24bit_ids_with_depth(device):
    pos = np.array([[0, 0, 0.7, 1], [16, 0, 0.7, 1], [0, 16, 0.7, 1],
                    [0, 0, 0.2, 1], [16, 0, 0.9, 1], [0, 16, 0.2, 1]], np.float32)
    tris = np.array([[0, 1, 2], [3, 4, 5]])
    ids = np.array([0xABCDEF, 0x123456])
    idb, depth = Rasterizer(16, 16, device=device, depth_func="less", depth_write=True).draw_ids(pos, tris, ids)
    assert idb[0, 0] == 0x123456  # second triangle nearer at x = 0
    assert idb[0, 13] == 0xABCDEF  # first nearer near x = 16
    assert idb[15, 15] == -1  # not covered: clear value
    assert np.isclose(depth[0, 0], 0.2 + 0.7 * 0.5 / 16, atol=1e-5)
    with pytest.raises(ConfigError, match=r"ids: must be 24-bit"):
        Rasterizer(16, 16, device=device).draw_ids(pos, tris, np.array([1, 2**24]))


@pytest.mark.parametrize("device", DEVICES)
def test_vertex_stage_matches_camera_rays(device):
    cam = Camera(eye=[1.0, 2.0, 4.0], target=[0, 0, 0], width_px=32, height_px=24, fov_y_deg=50)
    o, d = cam.rays()
    pts = o[[0, 5, 23], [0, 17, 31]] + 3.0 * d[[0, 5, 23], [0, 17, 31]]
    out = VertexStage.from_camera(cam, 0.1, 50.0, device=device).transform(pts)
    np.testing.assert_allclose(out.window[:, :2], [[0.5, 0.5], [17.5, 5.5], [31.5, 23.5]], atol=1e-3)
    np.testing.assert_allclose(-out.eye[:, 2], out.clip[:, 3], rtol=1e-6)  # clip w = eye distance along -z
    assert np.all((out.window[:, 2] > 0) & (out.window[:, 2] < 1))
    ortho = Camera(projection="orthographic", eye=[0, 0, 5], target=[0, 0, 0], ortho_height=2.0, width_px=4, height_px=4)
    out2 = transform_vertices([[1.0, 1.0, 0.0]], ortho.view_matrix(), ortho.projection_matrix(1, 10),
                              viewport_matrix(4, 4), device=device)
    np.testing.assert_allclose(out2.window[0], [4.0, 0.0, (5 - 1) / 9, 1.0], atol=1e-5)
    # behind the eye: w <= 0 and the rasteriser discards triangles using it
    back = VertexStage.from_camera(cam, 0.1, 50.0, device=device).transform([[0, 0, 0], [2, 4, 8], [0.5, 0, 0]])
    assert back.window[1, 3] <= 0
    assert rasterize(back.window_array, [[0, 1, 2]], 32, 24, device=device).count == 0
    with pytest.raises(ConfigError, match=r"points: expected shape \(V, 3\)"):
        VertexStage.from_camera(cam, 0.1, 50.0).transform([[0.0, 1.0]])


def test_rasterizer_validation_names_the_argument():
    with pytest.raises(ConfigError, match=r"cull: unknown value 'both'; allowed: 'none', 'back', 'front'"):
        Rasterizer(4, 4, cull="both")
    with pytest.raises(ConfigError, match=r"tile_size: 12 not allowed"):
        Rasterizer(4, 4, tile_size=12)
    with pytest.raises(ConfigError, match=r"depth_func: unknown value 'lt'"):
        Rasterizer(4, 4, depth_func="lt")
    with pytest.raises(ConfigError, match=r"width: 0 is outside the allowed range"):
        Rasterizer(0, 4)
    with pytest.raises(ConfigError, match=r"tris: vertex indices must be in \[0, 2\]"):
        rasterize(np.zeros((3, 4)), [[0, 1, 3]], 4, 4)
    with pytest.raises(ConfigError, match=r"attrs: expected shape \(3, A\)"):
        rasterize(np.zeros((3, 4)), [[0, 1, 2]], 4, 4, attrs=np.zeros((2, 1)))


def test_vertex_stage_registered_and_runs():
    from warpvol.pipeline import get_stage_class
    from warpvol.scene.builtin import builtin_scene
    from warpvol.stage import Context

    scene = builtin_scene("box").with_camera(width_px=12, height_px=10)
    ctx = Context(scene=scene, quiet=True)
    stage = get_stage_class("vertex")()
    stage.run(ctx)
    v = ctx.buffers["vertices"]
    assert v.window.shape == (scene.mesh.points.shape[0], 4)
    # every mesh point lies inside the depth range chosen from the bounds
    assert np.all((v.window[:, 2] >= 0) & (v.window[:, 2] <= 1))
    with pytest.raises(ConfigError, match=r"far: 1.0 must exceed near \(2.0\)"):
        get_stage_class("vertex")(near=2.0, far=1.0)


def test_threaded_setup_is_the_same_setup():
    """Rasterizer.setup(threads=2) (blocks of triangles set up and binned from two host threads) gives
    the arrays of the one-thread set-up, bins in submission order included."""
    rng = np.random.default_rng(5)
    n = 6000
    pos = np.concatenate([rng.uniform(-8, 72, (3 * n, 2)), np.full((3 * n, 1), 0.5), np.ones((3 * n, 1))], axis=1)
    tris = np.arange(3 * n).reshape(n, 3)
    r = Rasterizer(64, 48, tile_size=16)
    a, b = r.setup(pos.astype(np.float32), tris), r.setup(pos.astype(np.float32), tris, threads=2)
    bb = a.bbox.numpy()
    assert np.array_equal(bb, b.bbox.numpy())
    kept = (bb[:, 2] >= bb[:, 0]) & (bb[:, 3] >= bb[:, 1])  # the triangles the set-up keeps (others: bbox only)
    assert kept.sum() > n // 2
    for name in ("vidx", "sx", "sy", "bias"):
        assert np.array_equal(getattr(a, name).numpy()[kept], getattr(b, name).numpy()[kept]), name
    sa, sb = a.struct, b.struct
    for name in ("tile_start", "tile_end"):
        assert np.array_equal(getattr(sa, name).numpy(), getattr(sb, name).numpy()), name
    assert a.bin_entries == b.bin_entries > n
    assert np.array_equal(sa.tri_of.numpy()[:a.bin_entries], sb.tri_of.numpy()[:b.bin_entries])



@wp.kernel(enable_backward=False)
def _k_row_span_check(e: wp.array(dtype=vec3l), sj: wp.array(dtype=vec3l), n: wp.array(dtype=wp.int32),
                      span: wp.array(dtype=wp.vec2i), stepped: wp.array(dtype=wp.vec2i)):
    r = wp.tid()
    span[r] = row_span(e[r], sj[r], n[r])
    lo = int(n[r])
    hi = int(-1)
    ee = e[r]
    for k in range(n[r]):
        if inside(ee):
            lo = wp.min(lo, k)
            hi = wp.max(hi, k)
        ee = ee + sj[r]
    stepped[r] = wp.vec2i(lo, hi)


@pytest.mark.parametrize("device", DEVICES)
def test_row_span_is_the_run_of_covered_pixels(device):
    """``row_span`` (the covered run of a row from the three edge functions, float64 estimate corrected
    in int64) = testing every pixel with exact stepping: random rows, edges near zero, huge values."""
    rng = np.random.default_rng(21)
    m = 20000
    n = rng.integers(1, 70, m).astype(np.int32)
    sj = rng.integers(-(1 << 20), 1 << 20, (m, 3)) * rng.choice([1, 256, 1 << 14], (m, 3))
    sj[rng.random((m, 3)) < 0.1] = 0
    # starts placed so that the zero crossings fall inside the row, at its ends and just beside pixels
    k0 = rng.uniform(-5, 75, (m, 3))
    e = np.rint(-k0 * sj).astype(np.int64) + rng.integers(-2, 3, (m, 3))
    big = rng.random(m) < 0.05
    e[big] = rng.integers(-(1 << 50), 1 << 50, (int(big.sum()), 3))
    sj[big] = rng.integers(-(1 << 40), 1 << 40, (int(big.sum()), 3))
    w = lambda a, t: wp.array(a, dtype=t, device=device)  # noqa: E731
    span, stepped = wp.zeros(m, dtype=wp.vec2i, device=device), wp.zeros(m, dtype=wp.vec2i, device=device)
    wp.launch(_k_row_span_check, dim=m, inputs=[w(e, vec3l), w(sj.astype(np.int64), vec3l), w(n, wp.int32), span,
                                                 stepped], device=device)
    got, want = span.numpy(), stepped.numpy()
    empty = want[:, 0] > want[:, 1]
    assert 0.2 < empty.mean() < 0.9
    np.testing.assert_array_equal(got[~empty], want[~empty])
    assert (got[empty, 0] > got[empty, 1]).all()
