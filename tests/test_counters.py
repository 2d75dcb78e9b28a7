"""Hardware counters: each equals a hand count on small scenes (warpvol.gpu.counters)."""

import math

import numpy as np
import pytest

from helpers import box_mesh, scene
from test_tables_common import smooth_tf
from warpvol.gpu.blend import BlendUnit, FrameBuffer
from warpvol.gpu.counters import Counters
from warpvol.gpu.raster import Rasterizer, draw_textured_quads
from warpvol.gpu.texture import Texture1D, Texture2D, Texture3D
from warpvol.gpu.vertex import VertexStage
from warpvol.pipeline import Pipeline
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction
from warpvol.tables.pingpong import build_pingpong
from warpvol.tables.roettger_hw import build_roettger_hw
from warpvol.tables.roettger_sw import build_roettger_sw


def quad(x0, y0, x1, y1, z):
    """Two triangles covering the pixel centres of columns x0..x1-1, rows y0..y1-1."""
    pos = np.array([[x0, y0, z, 1], [x1, y0, z, 1], [x0, y1, z, 1], [x1, y1, z, 1]], np.float32)
    return pos, np.array([[0, 1, 2], [1, 3, 2]])


def test_nothing_counted_without_active_counters():
    c = Counters()
    fb = FrameBuffer(2, 2, "unorm8")
    fb.clear((0, 0, 0, 0))
    assert c.as_dict() == {}


def test_quad_of_known_coverage_fragments_and_blends():
    pos, tris = quad(2, 1, 6, 4, 0.5)  # 4 x 3 = 12 pixel centres
    fb = FrameBuffer(8, 8, "unorm8")
    with Counters() as c:
        fb.clear((0, 0, 0, 0))
        Rasterizer(8, 8).draw(pos, tris, np.full((4, 4), 0.25), fb, BlendUnit.over())
    assert c["primitives"] == 2 and c["primitives_culled"] == 0
    assert c["fragments"] == c["fragments_passed"] == 12
    assert c["blends_unorm8"] == 12
    assert (c["clears"], c["clear_pixels"]) == (1, 64)
    assert int((fb.codes()[..., 0] > 0).sum()) == 12  # the hand count is the image's


def test_depth_test_counts_generated_and_passed_fragments():
    near, tris = quad(0, 0, 4, 4, 0.2)
    far, _ = quad(0, 0, 2, 4, 0.8)  # 8 fragments, all behind the first quad
    r = Rasterizer(4, 4, depth_func="less", depth_write=True, cull="back", front_face="cw")
    depth = r._depth(None)
    with Counters() as c:
        r.fragments(near, tris, depth=depth)
        r.fragments(far, tris, depth=depth)
    assert c["fragments"] == 16 + 8 and c["fragments_passed"] == 16
    with Counters() as c:  # wound the other way: both triangles culled
        r.fragments(near, tris[:, ::-1])
    assert c["primitives_culled"] == 2 and c["fragments"] == 0


@pytest.mark.parametrize("traversal", ["tile", "pixel"])
def test_fused_draws_count_in_the_kernel(traversal):
    """draw / draw_ids count generated and passed fragments in the kernel (no extra launch)."""
    near, tris = quad(0, 0, 6, 4, 0.2)   # 24 fragments
    far, _ = quad(2, 0, 8, 2, 0.8)       # 12 fragments, 8 of them behind the first quad
    r = Rasterizer(8, 4, depth_func="less", depth_write=True, traversal=traversal)
    fb = FrameBuffer(8, 4, "unorm8")
    with Counters() as c:
        r.draw(near, tris, np.full((4, 4), 0.2), fb, BlendUnit.over())
        r.draw(far, tris, np.full((4, 4), 0.2), fb, BlendUnit.over())
    assert (c["fragments"], c["fragments_passed"], c["blends_unorm8"]) == (36, 28, 28)
    with Counters() as c:
        r.draw_ids(near, tris, [1, 2])
        r.draw(quad(0, 0, 2, 2, 1.5)[0], tris, np.full((4, 4), 0.2), fb, BlendUnit.over())  # depth-clipped
        r.fragments(quad(0, 0, 2, 2, -0.5)[0], tris)
    assert (c["fragments"], c["fragments_passed"], c["writes_rgb8"]) == (24, 24, 24)


def test_textured_quads_fetches_texels_blends():
    fb = FrameBuffer(4, 2, "unorm12")
    tex = Texture1D([[0.1, 0.1, 0.1, 0.1]] * 4, fmt="rgba8", filter="linear")
    with Counters() as c:
        draw_textured_quads(fb, BlendUnit.over(), tex, [[0, 1, 0, 1]] * 3)
        fb.readback()
    assert c["fragments"] == 24 and c["tex_1d_rgba8_linear"] == 24 and c["texels"] == 48
    assert c["blends_unorm12"] == 24 and (c["vertices"], c["primitives"]) == (12, 6)
    assert c["readbacks"] == 1 and c["bytes_down"] == 8 * 4 * 2  # 12-bit channels read as 16-bit


@pytest.mark.parametrize("cls,shape,filt,per", [(Texture2D, (2, 2), "linear", 4), (Texture3D, (2, 2, 2), "linear", 8),
                                                (Texture3D, (2, 2, 2), "nearest", 1)])
def test_texture_fetch_kinds_and_texels(cls, shape, filt, per):
    with Counters() as c:
        t = cls(np.zeros(shape + (4,)), fmt="rgba8", filter=filt)
        t.sample(np.full((5, len(shape)), 0.3))
    assert c[f"tex_{len(shape)}d_rgba8_{filt}"] == 5 and c["texels"] == 5 * per
    assert c["texture_bytes"] == c["bytes_up"] == 4 * int(np.prod(shape))


def test_vertices_and_explicit_counters():
    c = Counters()
    cam = Camera(eye=[0, 0, 5], target=[0, 0, 0], width_px=4, height_px=4, fov_y_deg=90)
    with c:
        VertexStage.from_camera(cam, 1.0, 10.0).transform(np.zeros((7, 3)))
    assert c["vertices"] == 7
    fb = FrameBuffer(2, 2, "fp16")
    mine = Counters()
    BlendUnit.over().count(fb, 9, mine)  # a kernel of one's own reports its blends explicitly
    assert mine.as_dict() == {"blends_fp16": 9}
    with Counters() as sec, sec.section("peel"):
        fb.clear((0, 0, 0, 0))
    assert sec["peel/clears"] == 1


@pytest.mark.parametrize("variant,bits,passes", [("blend", 12, "two"), ("geforce3", 8, "one")])
def test_roettger_hw_builder_counts(variant, bits, passes):
    tf = smooth_tf("emission_density", rho_max=2.0)
    n_s, n_l, steps = 6, 3, 10
    with Counters() as c:
        t = build_roettger_hw(tf, n_s=n_s, n_l=n_l, steps=steps, bits=bits, passes=passes, variant=variant)
    npass = n_l * (2 if passes == "two" else 1)
    group = 4 if variant == "geforce3" else 1
    rects = math.ceil(steps / group)
    assert c["passes"] == c["readbacks"] == c["clears"] == npass
    assert c["fragments"] == c[f"blends_unorm{bits}"] == npass * rects * n_s * n_s == t.meta["blends"]
    assert c[f"tex_1d_rgba{bits}_linear"] == npass * steps * n_s * n_s  # one fetch per step
    assert c["combiner_ops"] == (npass * rects * 3 * n_s * n_s if group == 4 else 0)  # 3 general stages


def test_pingpong_and_software_counts():
    tf = smooth_tf("color_extinction")
    with Counters() as c:
        build_pingpong(tf, n_s=4, lengths=(0.5, 1.0), m=10, per_pass=4)
    assert c["passes"] == 2 * 3 * 3 and c["readbacks"] == 6  # (slices, channels, ceil(10 / 4))
    assert c["combiner_ops"] == 6 * 10 * 16 and c["tex_1d_rgba8_linear"] == 6 * 10 * 16
    assert c["writes_unorm8"] == c["fragments"] == 18 * 16
    tf = TransferFunction.from_table(np.ones((5, 4)), (0.0, 1.0), "emission_density")
    with Counters() as c:
        build_roettger_sw(tf, n_s=4, n_l=2, m=5, oversampling=2.0)
    x = (np.arange(4) + 0.5) / 4
    hand = sum(max(1, math.ceil(2 * 5 * abs(a - b))) for a in x for b in x)
    assert c["sw_samples"] == 2 * hand


def test_every_report_has_counters_per_stage():
    tf = TransferFunction.from_table(np.full((4, 4), 0.5), (0.0, 2.0))
    cam = Camera(eye=[0, 0, 6], target=[0, 0, 0], width_px=12, height_px=10, fov_y_deg=40)
    cfg = {"stages": [{"stage": "table_roettger_hw", "n_s": 4, "n_l": 2, "steps": 3}, {"stage": "cell_setup"},
                      {"stage": "entry_bins"}, {"stage": "raycast"}, {"stage": "peel"}]}
    res = Pipeline.from_config(cfg).render(scene(box_mesh(), tf, cam), quiet=True)
    cnt = res.report["counters"]
    assert cnt["table_roettger_hw"]["passes"] == 4 and cnt["table_roettger_hw"]["blends_unorm12"] == 4 * 3 * 16
    assert cnt["raycast"]["rays"] == 120 and cnt["raycast"]["cell_steps"] > 0
