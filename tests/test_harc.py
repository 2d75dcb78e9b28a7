"""Hardware ray casting (issue 11): Espinha & Celes 2005 presets, harc_best, the VICP baseline.

Whole renders against the exact reference within ``tests/tolerances.py``; depth peeling through three
boundary layers; rays exactly through vertices and along edges; partial pre-integration with iso
splits against the exact segment integral for a 255-segment TF; mesh textures and bytes/tet.
"""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import warp as wp

from helpers import box_mesh, merge, scene
from tolerances import TOLERANCES, preset_tolerance
from warpvol.metrics import image_error
from warpvol.pipeline import Pipeline
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.transfer import TransferFunction

SIZE = 32
_PIPES = {}


def pipe(name):
    if name not in _PIPES:
        _PIPES[name] = Pipeline.load(name)
    return _PIPES[name]


def check(sc, name):
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = pipe(name).render(sc, quiet=True)
    err = image_error(res.image, ref)
    tol = preset_tolerance(name)
    assert ref[..., 3].max() > 0.05
    assert err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"], (name, err, res.report["stats"])
    return res


@pytest.mark.parametrize("scn", ["box", "sphere", "linear_box", "concave", "stiff"])
@pytest.mark.parametrize("name", ["harc_best", "espinha2005_partial"])
def test_ray_presets_on_builtins(name, scn):
    res = check(builtin_scene(scn).with_camera(width_px=SIZE, height_px=SIZE), name)
    skipped = [s["stage"] for s in res.report["skipped"]]
    # a walk confined to the visible cells (harc_best, a TF with zeros) may re-enter a convex mesh too
    vis = res.report["stats"].get("visibility")
    confined = vis is not None and vis["visible"] < vis["cells"]
    assert ("harc_peel" in skipped) == (builtin_scene(scn).mesh.is_convex and not confined)


@pytest.mark.parametrize("scn", ["concave", "stiff"])
@pytest.mark.parametrize("name", ["espinha2005_full", "weiler2003_vicp"])
def test_table_presets_on_builtins(name, scn):
    check(builtin_scene(scn).with_camera(width_px=SIZE, height_px=SIZE), name)


def three_layers():
    rho = 0.7
    tf = TransferFunction([[0, 1, 0.5, 0.2, rho], [2, 0.2, 0.5, 1, rho]])
    m = merge(box_mesh((-1, -1, -3), (1, 1, -2.5), (3, 3, 2)), box_mesh((-1, -1, -1), (1, 1, -0.5), (3, 3, 2)),
              box_mesh((-1, -1, 0.5), (1, 1, 1), (3, 3, 2)))
    cam = Camera(projection="orthographic", eye=[0.1, 0.05, 6.0], target=[0.1, 0.05, 0], ortho_height=3.0, width_px=16,
                 height_px=16)
    return scene(m, tf, cam), rho


@pytest.mark.parametrize("name", ["harc_best", "espinha2005_partial"])
def test_depth_peeling_recovers_every_layer(name):
    sc, rho = three_layers()
    assert not sc.mesh.is_convex
    res = pipe(name).render(sc, quiet=True)
    st = res.report["stats"]
    assert st["harc_raster"]["boundary_layers"] == 3
    o, _ = sc.camera.rays()
    inside = (np.abs(o[..., 0]) < 0.95) & (np.abs(o[..., 1]) < 0.95)
    tol = 1e-6 if name == "harc_best" else 3e-3  # unorm8 frame buffer
    np.testing.assert_allclose(res.image[inside][:, 3], 1 - np.exp(-rho * 1.5), atol=tol)
    covered = int((res.image[..., 3] > 0).sum())
    assert covered >= inside.sum()
    # pass 1 enters the nearest layer, the two peel passes enter the others; a third finds none
    assert st["harc_peel"]["passes"] == 3 and st["harc_peel"]["reentries"] == 2 * covered


def grid_mesh():
    return box_mesh(dims=(5, 5, 5), scalar=lambda p: np.sin(2 * p[:, 0]) + p[:, 1] * p[:, 2])


TF = TransferFunction([[-1.0, 0.1, 0.2, 1.0, 0.4], [0.0, 1.0, 0.6, 0.1, 1.5], [1.0, 0.9, 1.0, 0.3, 0.6],
                       [3.0, 1.0, 0.2, 0.2, 2.0]])


def exact_planes():
    return Pipeline.from_config({"stages": [
        {"stage": "cell_setup"}, {"stage": "harc_mesh"}, {"stage": "harc_raster"},
        {"stage": "harc", "walk": "planes", "integration": "exact"}, {"stage": "harc_peel"}]})


@pytest.mark.parametrize("direction", [(0, 0, 1), (1, 1, 1), (1, 1, 0), (0.3, -1, 1)])
def test_rays_through_vertices_and_edges(direction):
    # pixel centres of a 9x9 image of height 4.5 on the grid's lattice lines (axis views: rays along
    # edges through vertices; diagonal views: the centre ray through vertices along diagonal edges)
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    up = [0, 1, 0] if abs(d[1]) < 0.9 else [1, 0, 0]
    cam = Camera(projection="orthographic", eye=5 * d, target=[0, 0, 0], up=up, ortho_height=4.5, width_px=9, height_px=9)
    sc = scene(grid_mesh(), TF, cam)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    tol = preset_tolerance("raycast")
    for p in (pipe("harc_best"), exact_planes()):  # the consistent walk, and the paper's plane arithmetic
        res = p.render(sc, quiet=True)
        err = image_error(res.image, ref)
        c = res.report["stats"]["harc"]
        assert c["step_bound"] == 0  # every ray terminated
        # nothing lost: within the exact walk's tolerance (rays the walk could not resolve were redone
        # in float64 and are counted in unresolved_rays)
        assert err["rmse"] <= tol["rmse"] and err["max_abs"] <= tol["max_abs"], (err, c)


def segments(mode, tf, sf, sb, l, **kw):
    from warpvol.kernels import harc as kh
    from warpvol.shared.integration import integ_setup

    ig, _keep = integ_setup(mode, tf, "cpu", **kw)
    n = len(sf)
    out = wp.zeros(n, dtype=wp.vec4)
    steps = wp.zeros(n, dtype=wp.int32)
    cnt = wp.zeros((1, 8), dtype=wp.int32)
    wp.launch(kh.segments_kernel, dim=n, inputs=[ig, wp.array(sf), wp.array(sb), wp.array(l), cnt, out, steps])
    return out.numpy(), steps.numpy(), int(cnt.numpy()[0, 5])


@pytest.mark.parametrize("emission", ["color_extinction", "emission_density"])
def test_partial_iso_splits_equal_exact_integral_255_segments(emission):
    from warpvol.tables.isocross import build_isocross
    from warpvol.tables.psi import build_psi

    rng = np.random.default_rng(1)
    k = 256  # 255 linear segments
    tf = TransferFunction(np.c_[np.linspace(-2, 3, k), rng.random((k, 3)), 5 * rng.random(k)], emission=emission)
    n = 1500
    sf = rng.uniform(-2.2, 3.2, n).astype(np.float32)
    sb = np.where(rng.random(n) < 0.3, sf + rng.normal(0, 0.02, n), rng.uniform(-2.2, 3.2, n)).astype(np.float32)
    length = (0.2 * rng.random(n)).astype(np.float32)
    exact, _, _ = segments("exact", tf, sf, sb, length)
    psi = build_psi(n=512, axis="endpoint")
    part, steps, missed = segments("partial", tf, sf, sb, length, psi=psi, iso=build_isocross(tf, n=256, anchor="edge"),
                                   iso_rule="behind", weight_bits=None)
    tol = TOLERANCES["harc/partial_segment"]
    assert missed == 0
    assert np.abs(part - exact).max() <= tol["max_abs"]
    # one sub-step per control point crossed (plus the last piece)
    lo, hi = np.minimum(sf, sb), np.maximum(sf, sb)
    crossed = ((tf.s[None, :] > lo[:, None]) & (tf.s[None, :] < hi[:, None])).sum(axis=1)
    assert (np.abs(steps - (crossed + 1)) <= 1).all()
    # the paper's centre-anchored table misses control points near a texel's centre (counted)
    _, _, missed_paper = segments("partial", tf, sf, sb, length, psi=psi, iso=build_isocross(tf, n=256),
                                  iso_rule="paper", weight_bits=None)
    assert missed_paper > 0


def test_mesh_textures_and_bytes_per_tet():
    from warpvol.raycasting.harc import layout_bytes, mesh_textures

    m = grid_mesh()
    origin = np.array([0.25, -0.5, 0.125])
    st, tex = mesh_textures(m, origin)
    planes = tex[0].values.reshape(-1, 4)[: m.n_tets]
    want = m.face_planes[:, 0].copy()
    want[:, 3] += want[:, :3] @ origin
    np.testing.assert_allclose(planes, want, atol=1e-6)
    adj = tex[5].values.reshape(-1, 4)[: m.n_tets]
    assert ((adj < 0) == (m.adjacency < 0)).all()
    assert layout_bytes(m)["paper96"] == 96.0
    assert 32 < layout_bytes(m)["compact"] < 48
    res = pipe("espinha2005_partial").render(builtin_scene("box").with_camera(width_px=8, height_px=8), quiet=True)
    assert res.report["stats"]["harc_mesh"]["bytes_per_tet"] == 96.0


def test_tf_colour_edit_rebuilds_no_partial_table():
    p = Pipeline.load("espinha2005_partial")
    sc = builtin_scene("concave").with_camera(width_px=8, height_px=8)
    p.render(sc, quiet=True)
    pts = sc.transfer.points.copy()
    pts[:, 1] = 1.0 - pts[:, 1]  # colours edited, control points kept
    res = p.render(dataclasses.replace(sc, transfer=TransferFunction(pts, emission=sc.transfer.emission)), quiet=True)
    skipped = {s["stage"] for s in res.report["skipped"]}
    assert {"table_psi", "table_iso"} <= skipped


@pytest.mark.parametrize("name", ["espinha2005_full", "espinha2005_partial"])
def test_paper_presets_are_modelled_on_the_geforce_6800_gt(name):
    # every counter the HARC stages write is one the throughput model prices (a redraw: tables resident)
    p = Pipeline.load(name)
    sc = builtin_scene("concave").with_camera(width_px=16, height_px=16)
    p.render(sc, quiet=True)
    m = p.render(sc, quiet=True, gpu="geforce6800gt").report["modelled_s"]
    assert m["total"] is not None and m["total"] > 0, m
    assert m["bound"]["harc"] == "shader" and m["stages"]["harc_peel"] > 0


def test_eye_inside_the_mesh_is_redone_in_float64_and_counted():
    # the rasterised start needs the boundary in front of the eye: with the eye inside, every ray is
    # resolved by the float64 redo and counted, never silently wrong
    sc = builtin_scene("linear_box").with_camera(eye=(0.2, 0.1, 0.3), target=(0, 0, -1), projection="perspective",
                                                 width_px=8, height_px=8)
    ref = render_reference(sc.mesh, sc.transfer, sc.camera)
    res = pipe("harc_best").render(sc, quiet=True)
    assert image_error(res.image, ref)["max_abs"] <= preset_tolerance("harc_best")["max_abs"]
    assert res.report["stats"]["harc"]["float64_rays"] == 64


def test_the_float64_redo_has_one_name_and_its_old_names_still_read():
    """Every stage counts the float64 redo as ``float64_rays``; the old names (``unresolved_rays`` in HARC,
    ``float64_pixels`` in pt_integrate) are still in the report with the same value, listed as deprecated, and
    reading one warns."""
    import json

    sc = builtin_scene("linear_box").with_camera(eye=(0.2, 0.1, 0.3), target=(0, 0, -1), projection="perspective",
                                                 width_px=8, height_px=8)
    rep = pipe("harc_best").render(sc, quiet=True).report
    st = rep["stats"]["harc"]
    assert rep["deprecated"]["stats.harc.unresolved_rays"] == "stats.harc.float64_rays"
    with pytest.warns(DeprecationWarning, match="'unresolved_rays' is the old name of 'float64_rays'"):
        assert st["unresolved_rays"] == st["float64_rays"] == 64
    back = json.loads(json.dumps(rep, default=str))  # a report file: both names, no warning needed
    assert back["stats"]["harc"]["unresolved_rays"] == back["stats"]["harc"]["float64_rays"] == 64
    rep = pipe("harc_best").render(builtin_scene("concave").with_camera(width_px=8, height_px=8), quiet=True).report
    assert "harc_peel" in rep["stats"] and rep["deprecated"]["stats.harc_peel.unresolved_rays"]
    assert dict(rep["stats"]["harc_peel"])["unresolved_rays"] == dict(rep["stats"]["harc_peel"])["float64_rays"]
    rep = pipe("pt_best").render(builtin_scene("box").with_camera(width_px=8, height_px=8), quiet=True).report
    assert rep["deprecated"]["stats.pt_integrate.float64_pixels"] == "stats.pt_integrate.float64_rays"
    with pytest.warns(DeprecationWarning, match="'float64_pixels' is the old name of 'float64_rays'"):
        assert rep["stats"]["pt_integrate"].get("float64_pixels") == rep["stats"]["pt_integrate"]["float64_rays"]


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("name", ["harc_best", "espinha2005_partial"])
def test_camera_looking_away_is_transparent(name, projection):
    # the mesh wholly behind the eye: nothing is rasterised, no ray starts, the image is transparent
    # (was a 'near plane must be > 0' refusal from the rasterised ray start)
    sc = builtin_scene("box")
    eye = np.asarray(sc.camera.eye)
    sc = sc.with_camera(projection=projection, target=2 * eye, ortho_height=2.0, width_px=8, height_px=8)
    assert (render_reference(sc.mesh, sc.transfer, sc.camera) == 0).all()
    res = pipe(name).render(sc, quiet=True)
    assert (res.image == 0).all()


SPX = Path(__file__).resolve().parents[2] / "shared" / "data" / "spx.vtk"


@pytest.mark.skipif(not SPX.is_file(), reason=f"data set {SPX} not present")
def test_harc_best_reenters_where_the_rasterised_layer_has_a_hole():
    """SPX filling a 512² image: at pixel (194, 361) a ray leaves the mesh and re-enters 1e-4 later through a
    face the snapped coverage of that layer does not give to this pixel (an inner silhouette within 1/256
    pixel); the neighbouring pixels' lists hold it and the exact face test takes it."""
    import warpvol

    sc = warpvol.load_scene(Path(__file__).resolve().parents[1] / "scenes" / "spx_fill.toml")
    ray = warpvol.Pipeline.load("raycast").render(sc, quiet=True).image
    harc = warpvol.Pipeline.load("harc_best").render(sc, quiet=True).image
    assert np.abs(harc[194, 361] - ray[194, 361]).max() < 1e-4
    assert np.abs(harc - ray).max() < 2e-4  # both within 1e-4 of the reference


@pytest.mark.parametrize("case", ["three_layers", "concave"])
def test_reentry_bound_prunes_no_reentry(case, monkeypatch):
    """The peel passes of ``harc_best`` skip a ray whose last exit lies beyond every face its entry search can
    reach (:func:`warpvol.raycasting.harc.reentry_bound`); with the bound switched off (+inf) the passes search
    every exited ray: the images agree (up to the float64 redo of rays the unpruned search gives up on)."""
    import warpvol.raycasting.harc as H

    if case == "three_layers":
        sc, _ = three_layers()
    else:
        sc = builtin_scene("concave").with_camera(width_px=40, height_px=40)
    assert not sc.mesh.is_convex
    pruned = pipe("harc_best").render(sc, quiet=True)
    monkeypatch.setattr(H, "reentry_bound", lambda mesh, camera, *a: np.full(camera.width_px * camera.height_px,
                                                                              np.inf, np.float32))
    full = pipe("harc_best").render(sc, quiet=True)
    assert np.abs(pruned.image - full.image).max() <= 1e-6
    assert pruned.report["stats"]["harc_peel"]["reentries"] == full.report["stats"]["harc_peel"]["reentries"] > 0


def test_reentry_bound_holds_every_listed_face():
    """The bound at a pixel is at least the eye distance of every vertex of the front faces listed at that
    pixel and its neighbours (perspective), and -inf where no face is listed around it."""
    from warpvol.raycasting.harc import entry_fragments

    sc = builtin_scene("concave").with_camera(width_px=24, height_px=24)
    e = entry_fragments(sc.mesh, sc.camera)
    far = e["far"].numpy().reshape(24, 24)
    start, fbf = e["frag_start"].numpy(), e["frag_bf"].numpy()
    from warpvol.shared.entry_bins import entry_face_mask

    tris = sc.mesh.boundary_triangles()[entry_face_mask(sc.mesh, sc.camera)]
    g = np.linalg.norm(sc.mesh.points - np.asarray(sc.camera.eye), axis=1)
    assert np.isfinite(far).any()
    for p in range(24 * 24):
        y, x = divmod(p, 24)
        faces = fbf[start[p]:start[p + 1]]
        if len(faces):
            need = g[tris[faces]].max()
            for dy in (-1, 0, 1):
                for dx in (-1, 0, 1):
                    if 0 <= y + dy < 24 and 0 <= x + dx < 24:
                        assert far[y + dy, x + dx] >= need
    listed = np.diff(start).reshape(24, 24) > 0
    grown = np.zeros_like(listed)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            grown |= np.roll(np.roll(np.pad(listed, 1), dy, 0), dx, 1)[1:-1, 1:-1]
    assert np.all(np.isneginf(far[~grown]))


@pytest.mark.parametrize("preset", ["espinha2005_full", "espinha2005_partial"])
def test_per_pixel_loop_work_adds_up_to_the_counted_program_and_batches_cost_more(preset):
    """The lock-step batches of the throughput model rest on each pixel's (cells, steps) of a pass: summed
    over the pixels, their issue slots equal the pass's counted instructions and loop fetches exactly (first
    pass and peel passes of the concave mesh), and a 32 x 32 batch never runs shorter than its rays."""
    from warpvol.gpu import programs

    r = Pipeline.load(preset).render(builtin_scene("concave").with_camera(width_px=48, height_px=40), quiet=True)
    c = r.report["counters"]
    for g in ("harc", "harc_peel"):
        h = c[g]
        tex = sum(v for k, v in h.items() if k.startswith("tex_"))
        assert h["loop_slots"] == h["combiner_ops"] + tex > 0
        assert h["loop_slots"] < h["loop_slots_batch1024"] <= 48 * 40 * h["loop_slots"]
    s = np.array([[5, 1, 0], [2, 2, 7]])
    run, batched = programs.batched_slots(s, s > 0, tile=2)
    assert (run, batched) == (17, 5 * 4 + 7 * 1)  # tiles [[5,1],[2,2]] (4 ran, max 5) and [[0],[7]] (1 ran)


def test_peel_pass_resolves_a_rejected_rasterised_face_in_float32():
    """A re-entry whose rasterised face the consistent edge test rejects (the pixel centre within 1/256
    pixel of a projected edge) is found by the exact face test over the lists of the pixel and its 8
    neighbours, in float32: no ray left to the float64 redo, the same re-entries as raycast's, the image
    within harc_best's tolerance row (concave at 96^2: 3 such re-entries)."""
    sc = builtin_scene("concave").with_camera(width_px=96, height_px=96)
    h = Pipeline.load("harc_best").render(sc, quiet=True)
    st = h.report["stats"]["harc_peel"]
    assert st["entry_searches"] >= 1, st  # the case occurs
    assert st["failed"] == 0 and st["float64_rays"] == 0, st
    rc = Pipeline.load("raycast").render(sc, quiet=True)
    assert st["reentries"] == rc.report["stats"]["peel"]["reentries"]
    e = image_error(h.image, render_reference(sc.mesh, sc.transfer, sc.camera))
    tol = preset_tolerance("harc_best")
    assert e["rmse"] <= tol["rmse"] and e["max_abs"] <= tol["max_abs"], e
