"""Stress cases of the inputs real data has every day: scalars with a large offset, georeferenced
coordinates, cells that meet without sharing faces, non-planar hexahedra, thin layers and the ranges of
float32 itself.

Each group is one function taking the registration helpers of :func:`warpvol.tools.stress._cases`:
``simple(name, doc, build)`` registers a case whose reference is warpvol's exact float64 reference,
``with_ref(name, doc, build)`` one that returns ``(scene, reference_fn)``; ``sc(mesh, tf, camera, name)``
builds the scene. ``build(quick)`` takes the ``--quick`` flag (smaller images for CI).
"""

from __future__ import annotations

from warpvol.scene.camera import Camera
from warpvol.scene.grids import grid_points, structured_to_tets
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction
from warpvol.tools.stress_file_classes import file_class_cases
from warpvol.tools.stress_files import file_cases
from warpvol.tools.stress_meshes import _box, _tf
from warpvol.tools.stress_topology import add_topology_cases


#: the field of the conditioning cases on the unit box grid (varied, so a lost bit shows as colour)
def _cond_field(p):
    import numpy as np

    return 0.6 * np.sin(1.7 * p[:, 0]) + 0.5 * p[:, 1] - 0.4 * p[:, 2] * p[:, 0]


#: TF of the conditioning cases over the field's range ``[-1.5, 1.5]``: [s, r, g, b, extinction]
COND_TF = ((-1.5, 0.1, 0.2, 1.0, 0.6), (-0.3, 1.0, 0.6, 0.1, 2.0), (0.4, 0.9, 1.0, 0.3, 0.4), (1.5, 1.0, 0.2, 0.2, 1.8))


def offset_scene(px: int = 32, *, scalar_offset: float = 0.0, scalar_span: float = 3.0, origin=(0.0, 0.0, 0.0),
                 scale: float = 1.0, emission: str = "color_extinction", projection: str = "perspective",
                 name: str = "offset"):
    """A 4^3-point box grid (2 across, 162 tets) with a smooth field, seen from outside: the same
    image for every ``scalar_offset`` / ``scalar_span`` (scalars and TF points mapped alike),
    ``origin`` and ``scale`` (points, camera, and extinction and emission-density colour per unit
    length mapped alike). Returns a :class:`warpvol.scene.scene_file.Scene`.

    Examples
    --------
    >>> s = offset_scene(8, scalar_offset=3e6, origin=(4.5e5, 5.8e6, 150.0), scale=0.5)
    >>> s.mesh.bounds[0].tolist(), s.transfer.srange
    ([449999.5, 5799999.5, 149.5], (2999998.5, 3000001.5))
    """
    import numpy as np


    x = np.linspace(-1.0, 1.0, 4)
    unit = grid_points(x, x, x)
    k = scalar_span / 3.0
    tf = np.array(COND_TF)
    tf[:, 0] = tf[:, 0] * k + scalar_offset
    tf[:, 4] /= scale
    if emission == "emission_density":
        tf[:, 1:4] /= scale
    o = np.asarray(origin, dtype=np.float64)
    mesh = TetMesh(unit * scale + o, structured_to_tets((4, 4, 4)), _cond_field(unit) * k + scalar_offset, name=name)
    cam = Camera(projection=projection, eye=np.array([2.2, 1.6, 3.1]) * scale + o, target=o, fov_y_deg=40.0,
                 ortho_height=3.2 * scale, width_px=px, height_px=px)
    return Scene(mesh=mesh, transfer=TransferFunction(tf, emission), camera=cam, name=name)


def conditioning_cases(simple, with_ref, sc) -> None:
    """Scalar offsets, georeferenced coordinates, meshes at extreme scales, inputs beyond float32.

    The exact presets condition the scene in float64 first (:mod:`warpvol.conditioning.conditioning`) and stay
    within their tolerances; the paper presets keep their float32 cast and warn with the bits lost
    (``precision``); inputs no float32 format holds are declined naming the field.
    """
    import numpy as np

    def px(q):
        return 24 if q else 96

    for off in (3e6, 1e8):
        simple(f"scalar_offset_{off:.0e}", f"scalars {off:g} + a variation of 5 (a TF over that range): a float32 "
               f"cast as is keeps ~{max(0, 24 - int(np.log2(off / 5)))} of 24 bits",
               lambda q, off=off: offset_scene(px(q), scalar_offset=off, scalar_span=5.0, name=f"scalar_offset_{off:.0e}"))
    simple("georeferenced", "a mesh 1 across near (4.5e5, 5.8e6, 150), as UTM data sits; orthographic view",
           lambda q: offset_scene(px(q), origin=(4.5e5, 5.8e6, 150.0), scale=0.5, projection="orthographic",
                                  name="georeferenced"))
    simple("georeferenced_perspective", "a mesh 1 across near (4.5e5, 5.8e6, 150), perspective view",
           lambda q: offset_scene(px(q), origin=(4.5e5, 5.8e6, 150.0), scale=0.5, name="georeferenced_perspective"))
    for scale, proj in ((1e-12, "perspective"), (1e-13, "orthographic"), (1e14, "orthographic"), (1e16, "perspective")):
        simple(f"mesh_scale_{scale:.0e}", f"the scene scaled by {scale:g} (points, camera; extinction per unit "
               f"length by 1/{scale:g}); {proj} view",
               lambda q, scale=scale, proj=proj: offset_scene(px(q), scale=scale, projection=proj,
                                                              name=f"mesh_scale_{scale:.0e}"))
    simple("emission_density_scale_1e-12", "emission-density model (colour per unit length) on a mesh scaled by 1e-12",
           lambda q: offset_scene(px(q), scale=1e-12, emission="emission_density", name="emission_density_scale_1e-12"))

    def wide_tf(q):
        s = offset_scene(px(q), name="tf_points_1.7e308")
        tf = np.array(s.transfer.points)
        tf = np.vstack([[-1.7e308, *tf[0, 1:]], tf, [1.7e308, *tf[-1, 1:]]])

        return sc(s.mesh, TransferFunction(tf), s.camera, "tf_points_1.7e308")
    simple("tf_points_1.7e308", "TF control points at +-1.7e308 around an ordinary TF (their span overflows float64): "
           "exact presets render, float32 casts as is decline", wide_tf)

    def scalars_huge(q):
        s = offset_scene(px(q), name="scalars_1e39")
        sc_ = np.array(s.mesh.scalars)
        sc_[0] = 1e39

        return sc(TetMesh(s.mesh.points, s.mesh.tets, sc_, name="scalars_1e39"), s.transfer, s.camera, "scalars_1e39")
    simple("scalars_1e39", "one scalar 1e39 (beyond float32) in an ordinary field: declined naming the scalars",
           scalars_huge)

    def extinction_huge(q):
        s = offset_scene(px(q), name="extinction_3e38")
        tf = np.array(s.transfer.points)
        tf[1, 4] = 3e38

        return sc(s.mesh, TransferFunction(tf), s.camera, "extinction_3e38")
    simple("extinction_3e38", "extinction 3e38 per unit length (optical depth beyond float32 across the mesh): "
           "declined naming the extinction", extinction_huge)


def topology_cases(simple, with_ref, sc) -> None:
    """Cells that meet without sharing faces: glued blocks, split hexahedra / wedges / pyramids."""

    add_topology_cases(simple, sc)


def thin_layer_scene(thick: float, depth: float, camera, z0: float = -0.2, name: str = "thin_layer"):
    """Box [-1, 1]^3 (4 x 4 cells across) with a layer ``thick`` thick at ``z0`` across which the scalar
    steps from 0 to 1; extinction is a tent over s in [0.2, 0.8], so the layer alone carries the image,
    with optical depth ``depth`` along z. Returns ``(mesh, tf)``."""
    import numpy as np


    x = np.linspace(-1.0, 1.0, 5)
    zs = np.array([-1.0, z0, z0 + thick, 0.6, 1.0])
    pts = grid_points(x, x, zs)
    s = np.where(pts[:, 2] > z0 + 0.5 * thick, 1.0, 0.0)
    peak = depth / (0.3 * thick)  # mean extinction over s in [0, 1]: 0.3 peak
    tf = TransferFunction([[0.0, 0.9, 0.3, 0.1, 0.0], [0.2, 0.9, 0.3, 0.1, 0.0], [0.5, 0.2, 0.8, 0.4, peak],
                           [0.8, 0.1, 0.3, 0.9, 0.0], [1.0, 0.1, 0.3, 0.9, 0.0]])
    return TetMesh(pts, structured_to_tets((5, 5, len(zs))), s, name=name), tf


def thin_layer_cases(simple, with_ref, sc) -> None:
    """Thin layers that carry the image, huge on-screen extents, edge-on slabs."""

    def persp(px, eye, target=(0.0, 0.0, 0.0), up=(0, 1, 0), fov=35.0):
        return Camera(eye=eye, target=target, up=up, fov_y_deg=fov, width_px=px, height_px=px)

    for name, doc, eye, up in (
            ("thin_layer_oblique", "layer 2.5e-6 thick (edge ratio 2e5) with optical depth 0.35 carries the image, "
             "seen obliquely", (2.3, -1.4, 3.3), (0, 1, 0)),
            ("thin_layer_grazing", "layer 2.5e-6 thick with optical depth 0.35 seen at a grazing angle",
             (3.6, 0.9, 0.5), (0, 0, 1))):
        simple(name, doc, lambda q, eye=eye, up=up, name=name: sc(
            *thin_layer_scene(2.5e-6, 0.35, None), persp(24 if q else 96, eye, (0, 0, -0.2), up), name))
    simple("eye_in_diagonal_face_plane", "perspective eye in the plane x = y of the grid's interior diagonal faces "
           "(those faces are seen edge-on)",
           lambda q: sc(_box(5), _tf(2.5), persp(40 if q else 128, (0.37, 0.37, 3.4), (0.05, 0.05, 0.0)),
                        "eye_in_diagonal_face_plane"))
    simple("slab_edge_on", "a layer 1e-9 thick seen exactly edge-on: the eye lies in its mid-plane, the centre row of rays runs inside it",
           lambda q: sc(*thin_layer_scene(1e-9, 0.3, None, z0=0.0, name="slab"),
                        persp(25 if q else 97, (3.1, 0.4, 5e-10), (0.0, 0.0, 5e-10), (0, 0, 1)), "slab_edge_on"))
    simple("huge_zoom", "a field of view of 3e-6 degrees: the mesh reaches ~1e7 pixels beyond the image, past the "
           "rasteriser's fixed-point guard band (presets that rasterise the mesh decline)",
           lambda q: sc(_box(5), _tf(2.5), persp(12 if q else 48, (0.31, -0.27, 5.0), (0.31, -0.27, 0.0), fov=3e-6),
                        "huge_zoom"))


def jittered_hex_grid(jitter: float, seed: int):
    """A pyvista unstructured grid of 5x4x4 hexahedra (6x5x5 points) with point scalars ``"s"``, every
    point moved by up to ``jitter`` of the spacing: faces non-planar, many cells no longer convex."""
    import numpy as np
    import pyvista as pv

    x, y, z = np.linspace(-1, 1, 6), np.linspace(-0.9, 0.9, 5), np.linspace(-0.8, 0.8, 5)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    sp = np.array([x[1] - x[0], y[1] - y[0], z[1] - z[0]])
    P = np.stack([X, Y, Z], -1) + np.random.default_rng(seed).uniform(-jitter, jitter, X.shape + (3,)) * sp
    g = pv.StructuredGrid(P[..., 0], P[..., 1], P[..., 2]).cast_to_unstructured_grid()
    p = np.asarray(g.points)
    g.point_data["s"] = 0.4 + 0.3 * p[:, 0] - 0.2 * p[:, 1] * p[:, 2]
    return g


def _jittered_hexes(jitter: float, seed: int):
    """:func:`jittered_hex_grid` as a mesh (split by the loader into tets, the cells recorded)."""

    return TetMesh.from_pyvista(jittered_hex_grid(jitter, seed), "s")


def sweep_cases(simple, with_ref, sc) -> None:
    """VSBUFFER-specific: non-planar hexahedra, pixel centres on boundary faces, a thin layer."""
    import numpy as np


    tf_hex = TransferFunction([[0.0, 1.0, 0.1, 0.0, 9.0], [0.4, 0.0, 1.0, 0.1, 0.5], [0.8, 0.1, 0.0, 1.0, 9.0]])
    for jit in (0.05, 0.2):
        simple(f"hexahedra_nonplanar_{round(jit * 100)}pct",
               f"unstructured hexahedra, points jittered by +-{jit:.0%} of the spacing: non-planar faces, "
               "cells no longer convex (vsbuffer_best draws those as their tets)",
               lambda q, jit=jit: sc(_jittered_hexes(jit, 3), tf_hex,
                                     Camera(projection="orthographic", eye=(2.2, 1.7, 3.1), target=(0, 0, 0),
                                            ortho_height=2.8, width_px=24 if q else 96, height_px=24 if q else 96),
                                     f"hexahedra_nonplanar_{round(jit * 100)}pct"))

    def on_faces(q):
        # pixel size 1/4 (--quick) or 1/16: rows and columns of pixel centres in the planes x, y = +-1
        n = 9 if q else 33
        x = np.linspace(-1, 1, 4)
        pts = grid_points(x, x, x)
        mesh = TetMesh(pts, structured_to_tets((4, 4, 4)), 0.6 + 0.25 * pts[:, 0] - 0.15 * pts[:, 1] * pts[:, 2],
                       name="box_on_faces")
        tf = TransferFunction([[0.0, 0.9, 0.5, 0.1, 2.5], [1.0, 0.2, 0.4, 1.0, 5.0]])
        cam = Camera(projection="orthographic", eye=(0, 0, 5), target=(0, 0, 0), ortho_height=2.0 * n / (n - 1),
                     width_px=n, height_px=n)
        return sc(mesh, tf, cam, "pixel_centres_on_boundary_faces")

    simple("pixel_centres_on_boundary_faces", "orthographic view down -z with pixel centres exactly in the "
           "boundary planes x, y = +-1 (faces seen edge-on; the reference's tie rule decides in or out)", on_faces)

    def thin(q):
        th = 1e-6
        x = np.linspace(-0.8, 0.8, 4)
        slab = TetMesh(grid_points(x, x, [0.35, 0.35 + th]), structured_to_tets((4, 4, 2)), np.ones(32))
        y = np.linspace(-1, 1, 3)
        back = TetMesh(grid_points(y, y, [-1.0, -0.45, 0.1]), structured_to_tets((3, 3, 3)), np.zeros(27))
        mesh = TetMesh(np.vstack([slab.points, back.points]), np.vstack([slab.tets, back.tets + 32]),
                       np.concatenate([slab.scalars, back.scalars]), name="thin_layer")
        tf = TransferFunction([[0.0, 0.1, 0.4, 0.8, 0.4], [1.0, 0.9, 0.7, 0.1, 0.25 / th]])
        cam = Camera(projection="orthographic", eye=(0.2, 0.4, 5), target=(0.1, -0.1, 0), ortho_height=2.4,
                     width_px=24 if q else 96, height_px=24 if q else 96)
        return sc(mesh, tf, cam, "thin_layer_1e-6_sweep")

    simple("thin_layer_1e-6_sweep", "a slab 1e-6 thick carrying optical depth 0.25 in front of a dim block "
           "(float32 segment lengths cannot resolve it: warned)", thin)


def add_real_data_cases(simple, with_ref, sc) -> None:
    for group in (conditioning_cases, topology_cases, thin_layer_cases, sweep_cases, file_cases, file_class_cases):
        group(simple, with_ref, sc)
