"""The ray casters' entry search (``raycast``'s ``tile_entry`` over the faces binned by ``entry_bins``): faces
sorted by depth within a tile, skipped when wholly before the search's start, the search stopped at the first
face beyond the best crossing -- the same entries, bit for bit, as testing every face of the tile."""

import numpy as np
import pytest
import warp as wp

from helpers import noisy_shell
from tolerances import preset_tolerance
from warpvol.kernels import harc as kh
from warpvol.pipeline import Pipeline
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction
from warpvol.shared import entry_bins


def test_bins_list_each_tile_by_nearest_depth_with_its_depth_bounds():
    from helpers import noisy_shell
    from warpvol.shared.visible import face_triangles

    sc = noisy_shell(0, 48)
    b = entry_bins.bin_boundary_faces(sc.mesh, sc.camera, 8)
    tris = face_triangles(sc.mesh.tets, np.c_[b["bface_tet"], b["bface_local"]])
    z = (sc.mesh.points[tris] - sc.camera.eye) @ sc.camera.forward  # (faces, 3) vertex depths
    start, items, depth = b["tile_start"], b["tile_items"], b["item_depth"].astype(np.float64)
    assert len(items) > 3 * (len(start) - 1)  # several faces per tile
    for k in range(len(start) - 1):
        sel = slice(start[k], start[k + 1])
        lo, hi = z[items[sel]].min(axis=1), z[items[sel]].max(axis=1)
        assert np.all(np.diff(lo) >= 0)  # nearest depth ascending within the tile
        assert np.all(depth[sel, 0] <= lo) and np.all(depth[sel, 1] >= hi)  # rounded outward
        # the farthest depth from each item on, over this tile only
        far = np.maximum.accumulate(hi[::-1])[::-1]
        assert np.all(depth[sel, 2] >= far) and np.allclose(depth[sel, 2], far, rtol=1e-5)
    assert entry_bins.item_depths(np.zeros(0, np.int64), np.zeros(0), np.zeros(0)).shape == (0, 3)


def every_face(tid, lo, hi):
    """Depth bounds that leave no face of a tile untested (the full search)."""
    return np.tile(np.array([-np.inf, np.inf, np.inf], np.float32), (len(tid), 1))


def eye_between_shells():
    sc = builtin_scene("sphere")
    sc.camera = Camera(eye=[0.3, 0.45, 0.2], target=[0.9, 0.1, -0.4], fov_y_deg=70, width_px=32, height_px=28)
    return sc


SCENES = {
    "perspective": lambda: noisy_shell(0, 48),
    "orthographic": lambda: noisy_shell(4, 48, projection="orthographic", ortho_height=3.0),
    "eye_inside": eye_between_shells,
}


def render_raycast(sc, tile):
    p = Pipeline.load("raycast")
    cfg = {"name": "t", "stages": [dict(st.config, stage=st.name) for st in p.stages]}
    for st in cfg["stages"]:
        if st["stage"] == "entry_bins":
            st["tile"] = tile
    return Pipeline.from_config(cfg).render(sc, quiet=True)


def counts(report):
    return {k: (v.get("entries"), v.get("cell_steps")) for k, v in report["counters"].items()}, \
        {k: report["stats"][k]["float64_rays"] for k in ("raycast", "peel") if k in report["stats"]}


@pytest.mark.parametrize("tile", [4, 32])
@pytest.mark.parametrize("name", list(SCENES))
def test_depth_ordered_search_finds_the_entries_of_the_full_search(name, tile, monkeypatch):
    sc = SCENES[name]()
    got = render_raycast(sc, tile)
    with monkeypatch.context() as mp:
        mp.setattr(entry_bins, "item_depths", every_face)
        want = render_raycast(sc, tile)
    assert want.report["stats"]["peel"]["reentries"] > 0 or name == "eye_inside"
    assert np.array_equal(got.image, want.image)
    assert counts(got.report) == counts(want.report)


def configured(preset_stages: dict, **by_stage):
    """The ``raycast`` preset with ``by_stage[stage]`` merged into that stage's parameters."""
    p = Pipeline.load("raycast")
    cfg = {"name": "t", "stages": [dict(st.config, stage=st.name) for st in p.stages]}
    for st in cfg["stages"]:
        st.update(by_stage.get(st["stage"], {}))
    return Pipeline.from_config(cfg)


def totals(report):
    """Entries (first and re-entries), cell steps and float64 rays over all of raycast's passes."""
    cnt, st = report["counters"], report["stats"]
    return {"entries": sum(int(c.get("entries", 0)) for c in cnt.values()),
            "cell_steps": sum(int(c.get("cell_steps", 0)) for c in cnt.values()),
            "first_entries": st["raycast"]["entries"], "reentries": st["peel"]["reentries"],
            "float64_rays": st["raycast"]["float64_rays"] + st["peel"]["float64_rays"],
            "terminated_early": st["raycast"]["terminated_early"] + st["peel"]["terminated_early"]}


@pytest.mark.parametrize("name", list(SCENES))
def test_reentries_in_the_thread_walk_as_pass_by_pass(name):
    """A ray re-entering in its own thread (``reentries``) gives the pixel of one entry per pass, bit for
    bit, with the same entries, steps and float64 rays; the passes it saves are not run."""
    sc = SCENES[name]()
    per_pass = configured({}, raycast={"reentries": 0}, peel={"reentries": 0}).render(sc, quiet=True)
    bounded = configured({}, raycast={"reentries": 2}, peel={"reentries": 2}).render(sc, quiet=True)
    in_thread = configured({}).render(sc, quiet=True)
    want = totals(per_pass.report)
    assert want["reentries"] > 0
    for res in (bounded, in_thread):
        assert np.array_equal(res.image, per_pass.image)
        assert totals(res.report) == want
    passes = [r.report["stats"]["peel"]["passes"] for r in (per_pass, bounded, in_thread)]
    assert passes[0] > passes[1] > 0 and passes[2] == 0, passes
    assert in_thread.report["stats"]["raycast"]["reentries"] == want["reentries"]
    assert per_pass.report["stats"]["raycast"]["reentries"] == 0


def banded_slab(layers=17):
    """Box [-1, 1]^2 x [-1, 1], ``layers - 1`` cell layers in z, scalar z, and a TF visible only in every
    other layer (a peak inside each even layer, zero around every odd one); returns the mesh, the TF and the
    number of visible layers a ray down z enters one after the other."""
    from helpers import box_mesh

    m = box_mesh(dims=(3, 3, layers), scalar=lambda p: p[:, 2].copy())
    z = np.linspace(-1, 1, layers)
    gap = 0.1 * (z[1] - z[0])  # zero a little beyond each odd layer (cell_visibility pads scalar ranges)
    pts = [[z[0] - 1, 0, 0, 0, 0]]
    for k in range(0, layers - 1, 2):
        pts += [[z[k] + gap, 0, 0, 0, 0], [0.5 * (z[k] + z[k + 1]), 0.9, 0.6, 0.3, 4.0], [z[k + 1] - gap, 0, 0, 0, 0]]
    pts.append([z[-1] + 1, 0, 0, 0, 0])
    return m, TransferFunction(pts), len(range(0, layers - 1, 2))


def test_a_ray_re_enters_every_visible_layer_in_its_thread():
    from helpers import scene
    from warpvol.metrics import image_error
    from warpvol.reference.numpy_render import render_reference

    m, tf, visible_layers = banded_slab()
    cam = Camera(projection="orthographic", eye=[0.013, 0.021, 6.0], target=[0.013, 0.021, 0], ortho_height=1.6,
                 width_px=12, height_px=12)
    sc = scene(m, tf, cam)
    res = configured({}).render(sc, quiet=True)
    st = res.report["stats"]
    n = cam.width_px * cam.height_px  # every ray crosses the slab from top to bottom
    assert st["visibility"]["visible"] == m.n_tets // 2
    assert st["raycast"]["entries"] == n and st["raycast"]["reentries"] == (visible_layers - 1) * n
    assert st["peel"]["passes"] == 0 and st["peel"]["reentries"] == (visible_layers - 1) * n
    per_pass = configured({}, raycast={"reentries": 0}, peel={"reentries": 0}).render(sc, quiet=True)
    assert per_pass.report["stats"]["peel"]["passes"] == visible_layers - 1
    assert np.array_equal(res.image, per_pass.image)
    tol = preset_tolerance("raycast")
    err = image_error(res.image, render_reference(m, tf, cam))
    assert err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"], err


def test_face_depths_bound_each_triangle_outward():
    from helpers import noisy_shell

    sc = noisy_shell(3, 16)
    tris = sc.mesh.tets[:, [0, 1, 2]]  # triangles at every depth of the mesh
    d = entry_bins.face_depths(sc.mesh, sc.camera, tris).astype(np.float64)
    z = (sc.mesh.points[tris] - sc.camera.eye) @ sc.camera.forward
    assert np.all(d[:, 0] <= z.min(axis=1)) and np.all(d[:, 1] >= z.max(axis=1))
    assert np.allclose(d[:, 0], z.min(axis=1), rtol=1e-5) and np.allclose(d[:, 1], z.max(axis=1), rtol=1e-5)


def no_face_depths(mesh, camera, tris):
    """Depth bounds that leave no face untested."""
    return np.tile(np.array([-np.inf, np.inf], np.float32), (len(tris), 1))


def harc_counts(report):
    st = report["stats"]
    drop = ("pass_s", "float64_s")
    return [{k: v for k, v in st[key].items() if k not in drop} for key in ("harc", "harc_peel")]


@pytest.mark.parametrize("name", ["perspective", "orthographic"])  # (an eye inside: harc_best traces in float64)
def test_harc_reentry_search_leaves_out_only_faces_before_its_start(name, monkeypatch):
    """harc_best's re-entry search over the 8 neighbouring pixels' lists and the open-edge faces skips the faces
    wholly before its start untested: the same pass, bit for bit, as testing them all."""
    sc = SCENES[name]()
    got = Pipeline.load("harc_best").render(sc, quiet=True)
    with monkeypatch.context() as mp:
        mp.setattr(entry_bins, "face_depths", no_face_depths)
        want = Pipeline.load("harc_best").render(sc, quiet=True)
    assert want.report["stats"]["harc_peel"]["reentries"] > 0
    assert np.array_equal(got.image, want.image)
    assert harc_counts(got.report) == harc_counts(want.report)


def centres_on_edges():
    """Pixel centres exactly on the grid's edges and face diagonals (orthographic, axis-aligned, 5 px over 2 units:
    a centre at x = 0 and y = 0), a field with a visible shell: ties the consistent edge test breaks."""
    from helpers import box_mesh, scene

    m = box_mesh(dims=(5, 5, 5), scalar=lambda p: (p ** 2).sum(axis=1))
    tf = TransferFunction([[0, 0, 0, 0, 0], [0.6, 0, 0, 0, 0], [1.0, 0.9, 0.6, 0.2, 3.0], [1.4, 0, 0, 0, 0],
                           [3.0, 0, 0, 0, 0]])
    cam = Camera(projection="orthographic", eye=[0, 0, 5], target=[0, 0, 0], ortho_height=2.0, width_px=5, height_px=5)
    return scene(m, tf, cam)


def grazing_box():
    """Rays 3e-5 rad off a box's side face, over a window 1.2e-4 wide (a pixel far below the float32 ray's
    uncertainty relative to the mesh: the box margin grows with it)."""
    from helpers import box_mesh, scene

    angle = 3e-5
    d = np.array([-np.sin(angle), 0.0, -np.cos(angle)])
    c = np.array([1.0 + angle, 0.0, 0.0])
    cam = Camera(projection="orthographic", eye=list(c - 5 * d), target=list(c), up=[0, 1, 0], ortho_height=4 * angle,
                 width_px=16, height_px=16)
    return scene(box_mesh(dims=(3, 3, 3)), TransferFunction([[0, 0.8, 0.6, 0.4, 1.0], [2, 0.8, 0.6, 0.4, 1.0]]), cam)


@pytest.mark.parametrize("name", list(SCENES) + ["centres_on_edges", "grazing_box"])
def test_tight_face_boxes_keep_every_face_a_ray_may_cross(name, monkeypatch):
    """A face is listed for the pixels whose centres lie in its projected box grown by a margin (0.05 px plus the
    float32 ray's uncertainty in pixels): the same pass, bit for bit, as with boxes grown by 3 px."""
    sc = {"centres_on_edges": centres_on_edges, "grazing_box": grazing_box}.get(name, SCENES.get(name))()
    got = render_raycast(sc, 8)
    tight = entry_bins.bin_boundary_faces(sc.mesh, sc.camera, 8)
    with monkeypatch.context() as mp:
        mp.setattr(entry_bins, "BOX_MARGIN_PX", 3.0)
        want = render_raycast(sc, 8)
        loose = entry_bins.bin_boundary_faces(sc.mesh, sc.camera, 8)
    assert len(tight["tile_items"]) <= len(loose["tile_items"])
    assert np.array_equal(got.image, want.image)
    assert counts(got.report) == counts(want.report)
    if name != "grazing_box":  # (there the uncertainty margin spans the whole window)
        assert len(tight["tile_items"]) < len(loose["tile_items"])


@wp.kernel
def k_no_face_around(width: int, height: int, frag_start: wp.array(dtype=wp.int32),
                     edge_start: wp.array(dtype=wp.int32), out: wp.array(dtype=wp.int32)):
    i = wp.tid()
    py = i // width
    out[i] = wp.where(kh.no_face_around(i - py * width, py, width, height, frag_start, edge_start), 1, 0)


def test_harc_rays_with_no_face_listed_around_stop_before_the_search():
    """harc_best's march ends a ray at once where no front face is listed at its pixel, its 8 neighbours or its
    open edges (no search has a face to test there): the pixels so found are those the fragment lists say."""
    from helpers import noisy_shell
    from warpvol.raycasting.harc import entry_fragments

    sc = noisy_shell(0, 40)
    e = entry_fragments(sc.mesh, sc.camera)
    w, h = sc.camera.width_px, sc.camera.height_px
    out = wp.zeros(w * h, dtype=wp.int32, device="cpu")
    wp.launch(k_no_face_around, dim=w * h, inputs=[w, h, e["frag_start"], e["edge_start"], out], device="cpu")
    listed = np.pad((np.diff(e["frag_start"].numpy()) > 0).reshape(h, w), 1)
    around = np.zeros((h, w), bool)
    for dy in range(3):
        for dx in range(3):
            around |= listed[dy:dy + h, dx:dx + w]
    around |= (np.diff(e["edge_start"].numpy()) > 0).reshape(h, w)
    got = out.numpy().reshape(h, w).astype(bool)
    assert np.array_equal(got, ~around)
    assert 0 < got.sum() < w * h  # both cases occur


def test_entry_faces_of_an_eye_near_the_mesh_use_its_kept_bounding_radius():
    """Perspective: an eye within the mesh's bounding sphere (about the centre of its bounds, over every point)
    lists every boundary face; the radius is the mesh's own, computed once (``bounding_radius``, set-up of the
    first frame), not per frame."""
    from warpvol.scene.mesh import TetMesh

    sc = builtin_scene("concave")
    m = sc.mesh
    lo, hi = m.bounds
    c = 0.5 * (lo + hi)
    r = float(np.sqrt(((np.asarray(m.points, np.float64) - c) ** 2).sum(axis=1).max()))
    assert m.bounding_radius == r and "bounding_radius" in vars(m)  # cached
    assert "bounding_radius" in entry_bins.ENTRY_MESH_PROPERTIES
    d = np.asarray(sc.camera.forward, np.float64)
    inside = sc.camera.replace(eye=c - 0.99 * r * d, target=c)
    outside = sc.camera.replace(eye=c - 1.01 * r * d, target=c)
    assert entry_bins.entry_face_mask(m, inside).all()
    assert not entry_bins.entry_face_mask(m, outside).all()
    # an unused point far out widens the sphere (every point counts)
    far = TetMesh(np.vstack([m.points, c + [0.0, 0.0, 40.0 * r]]), m.tets, np.append(m.scalars, 0.0), strict=False)
    assert far.bounding_radius > 10 * r
