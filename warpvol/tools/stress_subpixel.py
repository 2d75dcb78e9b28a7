"""Scenes of many small, thin and disconnected parts placed on pixel rays, for tests and stress cases.

:func:`subpixel_scene` puts, on the rays of chosen pixels, parts a rasterised ray start can miss: tets
whose cross-section is a fraction of a pixel (``needle``: long along the ray; ``speck``: small every
way), slabs seen edge-on whose middle plane holds a row of pixel rays (``slab``), each on its own
points, in front of and behind a coarse block that covers part of the image.
"""

from __future__ import annotations

import numpy as np

from warpvol.scene.camera import Camera
from warpvol.scene.grids import grid_points, structured_to_tets
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction

#: TF over the parts' scalars [-1, 1]: dense enough that a needle 0.4 long is nearly opaque
SUBPIXEL_TF = ((-1.0, 1.0, 0.3, 0.1, 2.0), (0.0, 0.3, 1.0, 0.4, 6.0), (1.0, 0.2, 0.4, 1.0, 12.0))


def _camera(px: int, perspective: bool) -> Camera:
    if perspective:
        return Camera(eye=(0.4, 0.3, 4.0), target=(0.0, 0.0, 0.0), up=(0, 1, 0), fov_y_deg=32.0, width_px=px,
                      height_px=px)
    return Camera(projection="orthographic", eye=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), up=(0, 1, 0),
                  ortho_height=2.2, width_px=px, height_px=px)


def _frame(d: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors orthogonal to ``d`` and to each other (the first in the plane of ``d`` and ``up``'s normal)."""
    a = np.cross(d, up)
    a /= np.linalg.norm(a)
    return a, np.cross(a, d)


def subpixel_scene(kind: str, size_px: float, n: int = 12, px: int = 24, seed: int = 0,
                   perspective: bool = False, block: bool = True) -> Scene:
    """``n`` parts of ``kind`` (``needle``, ``speck`` or ``slab``) on the rays of random distinct pixels (distinct
    rows for slabs), each on its own points, in front of (z in [0.4, 0.9]) or behind (z in [-0.6, -0.4]) a
    3 x 3 x 2-cell block (``block``, z in [-0.2, 0.2]) over the image's left half; no two parts overlap. ``size_px``: a needle's or speck's width in pixels at its
    depth, or a slab's thickness in scene units. Scalars uniform in [-1, 1], TF :data:`SUBPIXEL_TF`."""
    if kind not in ("needle", "speck", "slab"):
        raise ValueError(f"kind: {kind!r}; allowed: needle, speck, slab")
    rng = np.random.default_rng(seed)
    cam = _camera(px, perspective)
    origins, dirs = cam.rays()
    pixel = cam.ortho_height / px if not perspective else 2.0 * np.tan(np.radians(cam.fov_y_deg) / 2.0) / px
    up = np.asarray(cam.true_up, float)
    pts, tets = [], []
    if kind == "slab":  # distinct rows
        cells = rng.permutation(px)[:n] * px + rng.integers(0, px, min(n, px))
    else:  # distinct pixels
        cells = rng.permutation(px * px)[:n]
    for k, cell in enumerate(cells):
        i, j = divmod(int(cell), px)
        o, d = origins[i, j], dirs[i, j] / np.linalg.norm(dirs[i, j])
        # in front of the block (z in [0.4, 0.9]) or behind it ([-0.6, -0.4]); parts reach 0.25 along the ray
        zt = rng.uniform(0.4, 0.9) if rng.random() < 0.6 else rng.uniform(-0.6, -0.4)
        t = (zt - o[2]) / d[2]
        c = o + t * d
        width = size_px * pixel * (t if perspective else 1.0)  # pixels at this depth, in scene units
        a, b = _frame(d, up)
        if kind == "needle":
            ang = rng.uniform(0.0, 2.0 * np.pi) + np.array([0.0, 2.0, 4.0]) * np.pi / 3.0
            off = rng.uniform(-0.3, 0.3, 2) * width
            base = c + off[0] * a + off[1] * b + width * (np.cos(ang)[:, None] * a + np.sin(ang)[:, None] * b)
            pts.append(np.vstack([base, c + rng.uniform(0.1, 0.25) * d]))
            tets.append(np.arange(4))
        elif kind == "speck":
            q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            unit = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [-1.0, -1.0, -1.0]]) / 2.0
            pts.append(c + width * unit @ q.T + rng.uniform(-0.1, 0.1, 3) * width)
            tets.append(np.arange(4))
        else:  # a slab whose middle plane holds the rays of row i (the plane through the eye, perspective)
            side = np.asarray(cam.right, float)
            nrm = np.cross(side, d)
            nrm /= np.linalg.norm(nrm)
            corners = [c + u * side + v * d + w * 0.5 * size_px * nrm
                       for w in (-1.0, 1.0) for v in (-0.1, 0.1) for u in (-0.7, 0.7)]
            pts.append(np.array(corners))
            tets.append(structured_to_tets((2, 2, 2)))
        tets[-1] = tets[-1] + sum(len(p) for p in pts[:-1])
    if block:
        x = np.linspace(-1.0, 0.0, 4)
        y = np.linspace(-1.0, 1.0, 4)
        z = np.linspace(-0.2, 0.2, 3)
        pts.append(grid_points(x, y, z))
        tets.append(structured_to_tets((4, 4, 3)) + sum(len(p) for p in pts[:-1]))
    p = np.vstack(pts)
    return Scene(mesh=TetMesh(p, np.vstack(tets), rng.uniform(-1.0, 1.0, len(p)), name=f"subpixel_{kind}"),
                 transfer=TransferFunction([list(r) for r in SUBPIXEL_TF]), camera=cam,
                 name=f"subpixel_{kind}_{size_px:g}")


def silhouette_scene(px: int = 16, eps: float = 1e-6) -> Scene:
    """A 2 x 2 x 1-cell block in front of a larger one, seen orthographically down -z, the front block's sides
    ``eps`` (scene units) outside the centres of pixel columns and rows 3 and ``px - 5``: the rasteriser snaps
    those edges onto the centres and its fill rule leaves one column and one row out, where the back block
    is listed behind."""
    pix = 2.0 / px
    lo, hi = -1.0 + 3.5 * pix - eps, -1.0 + (px - 4.5) * pix + eps
    x = np.linspace(lo, hi, 3)
    y = np.linspace(-0.9, 0.9, 3)
    front, back = grid_points(x, x, [0.3, 0.6]), grid_points(y, y, [-0.6, -0.2])
    tets = structured_to_tets((3, 3, 2))
    mesh = TetMesh(np.vstack([front, back]), np.vstack([tets, tets + len(front)]),
                   np.r_[np.full(len(front), 0.8), np.full(len(back), -0.8)], name="silhouette_on_centres")
    cam = Camera(projection="orthographic", eye=(0, 0, 4), target=(0, 0, 0), up=(0, 1, 0), ortho_height=2.0,
                 width_px=px, height_px=px)
    return Scene(mesh=mesh, transfer=TransferFunction([list(r) for r in SUBPIXEL_TF]), camera=cam,
                 name="silhouette_on_centres")


def sheet_scene(thick: float, px: int = 24, perspective: bool = False) -> Scene:
    """A sheet ``thick`` thick (3 x 3 cells across [-1, 1]^2 at z = 0.1), seen nearly face-on, its scalar
    stepping from 0 to 1 across it, with extinction ``0.3 / thick``: optical depth about 0.3 through it."""
    x = np.linspace(-1.0, 1.0, 4)
    mesh = TetMesh(grid_points(x, x, [0.1, 0.1 + thick]), structured_to_tets((4, 4, 2)),
                   np.r_[np.zeros(16), np.ones(16)], name="sheet")
    tf = TransferFunction([[0.0, 0.9, 0.5, 0.2, 0.3 / thick], [1.0, 0.2, 0.5, 0.9, 0.3 / thick]])
    if perspective:
        cam = Camera(eye=(0.3, 0.5, 4.0), target=(0, 0, 0), fov_y_deg=40.0, width_px=px, height_px=px)
    else:
        cam = Camera(projection="orthographic", eye=(0.2, 0.3, 4.0), target=(0, 0, 0), ortho_height=2.4,
                     width_px=px, height_px=px)
    return Scene(mesh=mesh, transfer=tf, camera=cam, name=f"sheet_{thick:g}")


def add_subpixel_cases(simple, sc) -> None:
    """Register the stress cases of this module with ``simple(name, doc, build)`` (``build(quick)`` returns the
    scene; ``sc`` is unused: the scenes are built here)."""
    def px(q: bool) -> int:
        return 24 if q else 96

    simple("subpixel_needles", "needles 2e-3 pixel wide along the rays of a perspective view, in front of and behind "
           "a block (each on its own points)",
           lambda q: subpixel_scene("needle", 2e-3, n=16 if q else 160, px=px(q), seed=1, perspective=True))
    simple("subpixel_specks", "tets 1e-3 pixel across on pixel rays, in front of and behind a block",
           lambda q: subpixel_scene("speck", 1e-3, n=16 if q else 160, px=px(q), seed=2))
    simple("thin_slabs_edge_on", "slabs 1e-6 thick seen edge-on, each holding a row of pixel rays (perspective), "
           "with a block", lambda q: subpixel_scene("slab", 1e-6, n=5 if q else 12, px=px(q), seed=4, perspective=True))
    simple("thin_slab_1e-9_edge_on", "one slab 1e-9 thick whose middle plane holds a row of pixel rays",
           lambda q: subpixel_scene("slab", 1e-9, n=1, px=px(q), seed=0, block=False))
    simple("thin_sheet_1e-8", "a sheet 1e-8 thick seen face-on, optical depth 0.3 through it",
           lambda q: sheet_scene(1e-8, px=px(q)))
    simple("silhouette_on_pixel_centres", "a block in front of another, its sides 1e-6 from pixel centres and its "
           "middle grid plane through a row of them", lambda q: silhouette_scene(px(q), 1e-6))
