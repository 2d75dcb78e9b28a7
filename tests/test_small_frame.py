"""A small frame's fixed costs: the ray casters (``raycast``, ``harc_best``) launch only the rays whose entry
search has a face to test, and a frame that leaves that out is bit for bit the frame that launches every ray
(image, counters, stats)."""

import json

import numpy as np
import pytest

from helpers import box_mesh, scene
from warpvol.pipeline import Pipeline
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction

CASTERS = ["raycast", "harc_best"]


def corner_scene(size=48, eye=(9.0, 5.0, 12.0), fov=20.0, target=(0.4, 0.3, 0.0)):
    """A box seen from far off, small in the image (a few screen tiles hold its faces); a shell TF leaves
    some cells out, so the walk re-enters the visible part. ``eye``, ``fov``: another view of it."""
    mesh = box_mesh(dims=(5, 5, 5), scalar=lambda p: np.linalg.norm(p, axis=1))
    tf = TransferFunction([[0.0, 0.2, 0.5, 0.9, 0.0], [0.9, 0.2, 0.5, 0.9, 0.0], [1.2, 0.9, 0.6, 0.2, 3.0],
                           [1.5, 0.2, 0.5, 0.9, 0.0], [2.0, 0.2, 0.5, 0.9, 0.0]])
    cam = Camera(projection="perspective", eye=list(eye), target=list(target), fov_y_deg=fov,
                 width_px=size, height_px=size)
    return scene(mesh, tf, cam, name="corner")


def launched(monkeypatch, preset, sc):
    """Render ``sc`` with ``preset``; ``(result, rays launched by its march kernels)``: a launch's threads, or for
    the lane march (several rays per thread) its ``count`` argument."""
    import warp

    seen = []
    orig = warp.launch

    def spy(kernel, *a, **k):
        if "march" in getattr(kernel, "key", ""):
            labels = [x.label for x in kernel.adj.args]
            if "count" in labels:
                seen.append(int(k["inputs"][labels.index("count")]))
            else:
                seen.append(int(k.get("dim", a[0] if a else 0)))
        return orig(kernel, *a, **k)

    monkeypatch.setattr(warp, "launch", spy)
    res = Pipeline.load(preset).render(sc, quiet=True)
    monkeypatch.setattr(warp, "launch", orig)
    return res, sum(seen)


def facts(res):
    stats = {k: {kk: vv for kk, vv in v.items() if kk not in ("pass_s", "float64_s", "cached")}
             if isinstance(v, dict) else v for k, v in res.report.get("stats", {}).items()}
    return json.dumps(res.report["counters"], sort_keys=True, default=str), json.dumps(stats, sort_keys=True, default=str)


@pytest.mark.parametrize("preset", CASTERS)
@pytest.mark.parametrize("near", [False, True])
def test_rays_without_a_face_are_not_launched(monkeypatch, preset, near):
    from warpvol.raycasting import harc
    from warpvol.raycasting.stages import raycast as rs

    # near: the eye within 1.42 radii of the box's bounding sphere, above its top face and turned towards a
    # corner: the rays beside the box that start inside the sphere are launched (the kernel hands them to the
    # float64 redo), those that surely start outside it or miss it are not
    sc = corner_scene(eye=(0.5, 0.5, 2.2), fov=50.0, target=(1.2, 1.2, 0.0)) if near else corner_scene()
    res, n = launched(monkeypatch, preset, sc)
    w, h = sc.camera.width_px, sc.camera.height_px
    assert 0 < n < w * h * (0.9 if near else 0.5)  # the first pass launches the rays with a face, not all
    monkeypatch.setattr(rs, "tile_reach", lambda ctx: None)
    monkeypatch.setattr(harc, "face_reach", lambda ctx, entry, setup="robust": None)
    full, n_full = launched(monkeypatch, preset, sc)
    assert n_full >= w * h
    assert np.array_equal(res.image, full.image)
    assert facts(res) == facts(full)
    assert res.image[..., 3].max() > 0.1  # the view shows the data


def test_per_pixel_maps_in_the_listed_box_match_the_whole_window():
    """HARC's re-entry bound and the pixels with a face around are computed in the box of the listed pixels:
    the same values as over the whole window."""
    from warpvol.raycasting import harc
    from warpvol.shared.thin_cells import surface_neighbours
    from warpvol.shared.visible import face_triangles

    sc = corner_scene(40)
    mesh, cam = sc.mesh, sc.camera
    e = harc.entry_fragments(mesh, cam)
    w, h = cam.width_px, cam.height_px
    y0, y1, x0, x1 = e["box"]
    assert (y1 - y0) * (x1 - x0) < w * h // 2  # a small view: the box is part of the window
    front = harc.entry_face_mask(mesh, cam, None)
    tris = face_triangles(mesh.tets, mesh.boundary_faces[front])
    nbr = surface_neighbours(tris).reshape(-1, 3)
    start, edge_start = e["frag_start_host"], e["edge_start_host"]
    frag_bf = e["frag_bf"].numpy()[:e["fragments"]]
    edge_bf = e["edge_bf"].numpy()[:e["edge_pairs"]]
    whole = harc.reentry_bound(mesh, cam, tris, nbr, start, frag_bf, edge_start, edge_bf, (0, h, 0, w))
    assert np.array_equal(e["far"].numpy(), whole)
    assert np.isfinite(whole).any() and not np.isfinite(whole).all()
    listed = (np.diff(start) > 0).reshape(h, w)
    pad = np.pad(listed, 1)
    around = np.zeros((h, w), bool)
    for dy in range(3):
        for dx in range(3):
            around |= pad[dy:dy + h, dx:dx + w]
    around |= (np.diff(edge_start) > 0).reshape(h, w)
    ctx = type("Ctx", (), {})()
    ctx.device, ctx.scene, ctx.buffers = "cpu", sc, {"cells": {"origin": np.zeros(3), "radius": 1.8}}
    assert np.array_equal(harc.face_reach(ctx, dict(e)).reshape(h, w), around)
    assert np.array_equal(np.isfinite(whole).reshape(h, w), around)


def test_a_later_pass_looks_at_the_last_pass_rays_only():
    from warpvol.raycasting.stages.raycast import pass_rays

    status = np.array([1, 1, 0, 5, 2, 1, 1, 0], np.int32)  # 5 = active with a re-entry count (raycast: & 3)
    reach = np.array([1, 1, 1, 1, 1, 0, 1, 1], bool)
    first = pass_rays(status.copy(), 1, 0, None, None, 3)
    assert first.tolist() == [0, 1, 3, 5, 6]
    st = status.copy()
    first = pass_rays(st, 1, 0, reach, None, 3)
    assert first.tolist() == [0, 1, 3, 6] and st[5] == 0  # outside reach: done without a launch
    st[[0, 6]] = 0  # the pass ended these
    st[7] = 1  # (a pixel no pass launched is never active again; a candidate list does not look at it)
    assert pass_rays(st, 1, 0, reach, first, 3).tolist() == [1, 3]


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_rays_said_to_start_outside_the_sphere_do_so_in_the_kernels_set_up(projection):
    """``starts_outside`` against the kernel's ray set-up written out in float64 (``ray_setup``: ``t_clip > 0``
    and no miss is a ray that may start inside the mesh's bounding sphere): never a ray that does, and most of
    those that do not, on views from inside, beside and far from the sphere."""
    from warpvol.raycasting.harc import starts_outside

    rng = np.random.default_rng(3)
    radius, origin = 1.3, np.array([0.2, -0.1, 0.3])
    for dist in (0.5, 1.2, 1.45, 3.0, 20.0):
        for k in range(4):
            v = rng.normal(size=3)
            eye = origin + dist * radius * v / np.linalg.norm(v)
            target = origin + rng.normal(size=3) * 0.7
            if k == 3:  # looking away from the sphere: rays whose line meets it behind the eye (tc < 0)
                target = eye + (eye - origin) + rng.normal(size=3) * 0.3 * dist
            cam = Camera(projection=projection, eye=list(eye), target=list(target), fov_y_deg=50.0,
                         ortho_height=3.0, width_px=23, height_px=17)
            e = eye - origin
            h, w = cam.height_px, cam.width_px
            qx = 2.0 * (np.arange(w) + 0.5) / w - 1.0
            qy = 1.0 - 2.0 * (np.arange(h) + 0.5) / h
            hh = np.tan(np.radians(cam.fov_y_deg) / 2.0) if projection == "perspective" else cam.ortho_height / 2.0
            sx, sy = np.meshgrid(qx * hh * cam.aspect, qy * hh)
            f, r, u = (np.asarray(a, np.float64) for a in (cam.forward, cam.right, cam.true_up))
            if projection == "perspective":
                d = f + sx[..., None] * r + sy[..., None] * u
                d /= np.linalg.norm(d, axis=-1, keepdims=True)
                o = np.broadcast_to(e, d.shape)
            else:
                d = np.broadcast_to(f, sx.shape + (3,))
                o = e + sx[..., None] * r + sy[..., None] * u
            tc = -(o * d).sum(-1)
            t_clip = np.maximum(0.0, -(tc - 1.001 * radius))
            miss = ((o + d * tc[..., None]) ** 2).sum(-1) > radius * radius
            inside = (t_clip > 0) & ~miss
            out = starts_outside(cam, origin, radius)
            out = np.ones((h, w), bool) if out is None else out.reshape(h, w)
            assert not (out & inside).any()
            assert (out | inside).mean() > 0.99


def test_march_image_from_the_written_pixels_is_the_kernels():
    """``MarchState.image`` reads the pixels a pass or the redo wrote; the rest keep radiance 0 and
    transmittance 1 (RGBA 0): the same image as the kernel over every pixel."""
    from warpvol.raycasting.stages.raycast import MarchState

    st = MarchState(6 * 5, "cpu")
    rng = np.random.default_rng(0)
    idx = np.array([0, 7, 8, 29])
    st.rgb.numpy()[idx] = rng.random((4, 3)).astype(np.float32)
    st.trans.numpy()[idx] = rng.random(4).astype(np.float32)
    st.touch(idx[:2])
    st.touch(idx[2:])
    mine = st.image(5, 6)
    st.touched = None  # the kernel's image
    assert np.array_equal(mine, st.image(5, 6)) and mine.dtype == np.float32 and mine[..., 3].max() > 0
