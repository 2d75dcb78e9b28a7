"""Built-in synthetic scenes, selectable by name (``[mesh] builtin = "NAME"``, ``warpvol demo``).

Each scene has a mesh, a default transfer function and a default camera (128 x 128 pixels, small so
tests stay fast; override with :meth:`warpvol.scene.scene.Scene.with_camera`).

``sphere``
    Roettger & Ertl (2002) Fig. 11: spherical distance volume. 8 x 8 x 8 cubes over ``[-1, 1]^3``,
    each split into 5 tets with the split's parity alternating from cube to cube so that faces
    conform (2,560 tets, 729 points); scalar = distance from the centre (0 .. sqrt 3). The
    ``emission_density`` transfer function has two thin emissive shells (radius 0.5 and 0.9), a test
    of pre-integration: a shell is thinner than a cell.
``box``
    ``[-1, 1]^3`` as a 4 x 4 x 4-cell grid (6-tet split, 384 tets), constant scalar 1.0; constant
    transfer function ``c = (0.8, 0.6, 0.4)``, extinction ``rho = 1.5``, ``color_extinction``.
    Orthographic camera at ``z = 5`` looking down ``-z``, image height 3 world units: a pixel whose
    centre lies inside ``|x|, |y| < 1`` sees thickness 2, so ``alpha = 1 - exp(-3) = 0.950213`` and
    ``rgb = c * alpha``; other pixels are 0.
``linear_box``
    Same grid, scalar ``s = z`` (exact on the tets); transfer function linear between
    ``[-1, 1.0, 0.2, 0.1, 0.5]`` and ``[1, 0.1, 0.3, 1.0, 2.0]`` (``color_extinction``), so
    ``rho(z) = 1.25 + 0.75 z``. Same camera as ``box``; along an interior ray (``t = 1 - z``)
    the optical depth is ``tau(t) = 2 t - 0.375 t^2``, ``tau(2) = 2.5``: ``alpha = 1 - exp(-2.5)``.
``concave``
    Concave *and* disconnected, like the VSBUFFER paper's artificial data set: a U-shaped block
    (x in [-1.5, 0.5], y in [-1, 1], z in [-0.5, 0.5]; arms 0.5 wide, hollow 1.0 wide and 1.5 deep)
    and a separate block (x in [1, 1.5], y in [-0.5, 0.5]) across a gap of 0.5; 0.25-sized cells,
    6-tet split (1,152 tets). Scalar ``|p|^2``. The camera sits on the +x side, so rays pass the block,
    the gap, one arm, the hollow and the other arm: about a tenth of the pixels enter and leave the
    mesh three times.
``stiff``
    ``[-1, 1]^3`` with 4 x 4 cells across and 16 layers along z whose thickness grows geometrically
    from 2e-5 (1e-5 of the box size) to about 1.03: longest / shortest edge about 6e4. Linear scalar
    ``s = 0.5 (1 + z) + 0.25 x``.
"""

from __future__ import annotations

import numpy as np

from warpvol.errors import ConfigError
from warpvol.scene.camera import Camera
from warpvol.scene.grids import grid_points, structured_to_tets, structured_to_tets5
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction

BUILTIN_SCENES = {
    "sphere": "Roettger & Ertl Fig. 11 spherical distance volume, 8^3 cubes x 5 tets, thin emissive shells",
    "box": "cube [-1,1]^3, constant scalar and extinction; closed-form image (orthographic, down -z)",
    "linear_box": "cube [-1,1]^3, scalar = z, linear transfer function; closed-form opacity",
    "concave": "U-shaped block plus a separate block: concave, disconnected, rays cross the boundary often",
    "stiff": "cube with geometrically graded layers, longest/shortest edge ~6e4",
}

def _compact(points, tets):
    """Drop points no tet uses; returns (points, tets, kept point ids)."""
    used = np.unique(tets)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return points[used], remap[tets], used


def _graded(n: int, h0: float, total: float) -> np.ndarray:
    """``n`` steps growing geometrically from ``h0`` that sum to ``total``."""
    lo, hi = 1.0 + 1e-12, 100.0
    for _ in range(200):
        r = 0.5 * (lo + hi)
        s = h0 * (r ** n - 1.0) / (r - 1.0)
        lo, hi = (r, hi) if s < total else (lo, r)
    steps = h0 * r ** np.arange(n)
    return steps * (total / steps.sum())


# -- meshes ---------------------------------------------------------------------------------------
def _sphere(strict):
    x = np.linspace(-1.0, 1.0, 9)
    pts = grid_points(x, x, x)
    tets = structured_to_tets5((9, 9, 9))
    return TetMesh(pts, tets, np.linalg.norm(pts, axis=1), name="builtin:sphere", strict=strict)


def _box_grid():
    x = np.linspace(-1.0, 1.0, 5)
    return grid_points(x, x, x), structured_to_tets((5, 5, 5))


def _box(strict):
    pts, tets = _box_grid()
    return TetMesh(pts, tets, np.ones(len(pts)), name="builtin:box", strict=strict)


def _linear_box(strict):
    pts, tets = _box_grid()
    return TetMesh(pts, tets, pts[:, 2].copy(), name="builtin:linear_box", strict=strict)


def _concave(strict):
    h = 0.25
    xs, ys, zs = -1.5 + h * np.arange(13), -1.0 + h * np.arange(9), -0.5 + h * np.arange(5)
    dims = (13, 9, 5)
    ci, cj, ck = np.meshgrid(np.arange(12), np.arange(8), np.arange(4), indexing="ij")
    ci, cj = ci.transpose(2, 1, 0).ravel(), cj.transpose(2, 1, 0).ravel()  # cell order i fastest
    u_shape = (ci <= 7) & ((ci <= 1) | (ci >= 6) | (cj <= 1))   # arms + bottom, x in [-1.5, 0.5]
    block = (ci >= 10) & (cj >= 2) & (cj <= 5)                   # x in [1, 1.5], y in [-0.5, 0.5]
    keep = u_shape | block
    tets = structured_to_tets(dims).reshape(-1, 6, 4)[keep].reshape(-1, 4)
    pts, tets, _ = _compact(grid_points(xs, ys, zs), tets)
    return TetMesh(pts, tets, (pts ** 2).sum(axis=1), name="builtin:concave", strict=strict)


def _stiff(strict):
    x = np.linspace(-1.0, 1.0, 5)
    z = np.concatenate([[-1.0], -1.0 + np.cumsum(_graded(16, 2e-5, 2.0))])
    z[-1] = 1.0
    pts = grid_points(x, x, z)
    s = 0.5 * (1.0 + pts[:, 2]) + 0.25 * pts[:, 0]
    return TetMesh(pts, structured_to_tets((5, 5, len(z))), s, name="builtin:stiff", strict=strict)


_MESHES = {"sphere": _sphere, "box": _box, "linear_box": _linear_box, "concave": _concave, "stiff": _stiff}


def _check_name(name: str) -> str:
    if not isinstance(name, str) or name not in BUILTIN_SCENES:
        raise ConfigError(f"builtin: unknown built-in scene {name!r}; available: {', '.join(map(repr, BUILTIN_SCENES))}")
    return name


def builtin_mesh(name: str, *, strict: bool = True) -> TetMesh:
    """The mesh of built-in scene ``name`` (validated; strict by default: none has zero-volume tets)."""
    return _MESHES[_check_name(name)](strict)


# -- transfer functions and cameras --------------------------------------------------------------
def builtin_transfer(name: str) -> TransferFunction:
    """Default transfer function of built-in scene ``name``."""
    name = _check_name(name)
    w = f"builtin:{name}.transfer"
    if name == "sphere":
        return TransferFunction([
            [0.00, 0.0, 0.0, 0.0, 0.0],
            [0.45, 0.0, 0.0, 0.0, 0.0],
            [0.50, 4.0, 1.4, 0.4, 4.0],
            [0.55, 0.0, 0.0, 0.0, 0.0],
            [0.85, 0.0, 0.0, 0.0, 0.0],
            [0.90, 0.6, 1.5, 3.0, 2.0],
            [0.95, 0.0, 0.0, 0.0, 0.0],
            [1.80, 0.0, 0.0, 0.0, 0.0],
        ], "emission_density", where=w)
    if name == "box":
        return TransferFunction([[0.0, 0.8, 0.6, 0.4, 1.5], [2.0, 0.8, 0.6, 0.4, 1.5]], "color_extinction", where=w)
    if name == "linear_box":
        return TransferFunction([[-1.0, 1.0, 0.2, 0.1, 0.5], [1.0, 0.1, 0.3, 1.0, 2.0]], "color_extinction", where=w)
    if name == "concave":
        return TransferFunction([
            [0.0, 1.0, 0.9, 0.3, 0.4],
            [1.0, 0.9, 0.4, 0.1, 1.5],
            [2.0, 0.2, 0.6, 0.9, 0.8],
            [3.5, 0.1, 0.2, 1.0, 2.5],
        ], "color_extinction", where=w)
    return TransferFunction([  # stiff: s in [-0.25, 1.25]
        [-0.25, 0.2, 0.4, 1.0, 0.5],
        [0.5, 1.0, 1.0, 0.6, 1.0],
        [1.25, 1.0, 0.3, 0.1, 2.0],
    ], "color_extinction", where=w)


def builtin_camera(name: str) -> Camera:
    """Default camera of built-in scene ``name`` (128 x 128 pixels)."""
    name = _check_name(name)
    w = f"builtin:{name}.camera"
    px = dict(width_px=128, height_px=128, where=w)
    if name in ("box", "linear_box"):
        return Camera(projection="orthographic", eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), ortho_height=3.0, **px)
    if name == "sphere":
        return Camera(eye=(3.0, 2.0, 4.0), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=28.0, **px)
    if name == "concave":
        return Camera(eye=(6.0, 0.5, 1.0), target=(0.0, 0.0, -0.3), up=(0, 1, 0), fov_y_deg=26.0, **px)
    return Camera(eye=(3.5, 2.5, 4.5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=38.0, **px)


def builtin_scene(name: str):
    """Built-in scene ``name`` as a :class:`warpvol.scene.scene.Scene` with its default TF and camera.

    Parameters
    ----------
    name : str
        One of :data:`BUILTIN_SCENES` (``sphere``, ``box``, ``linear_box``, ``concave``, ``stiff``).

    Returns
    -------
    Scene
        128 x 128 pixels; change with ``.with_camera(width_px=..., height_px=...)``.

    Examples
    --------
    >>> s = builtin_scene("sphere")
    >>> s.mesh.n_tets, s.transfer.emission, s.camera.width_px
    (2560, 'emission_density', 128)
    """
    name = _check_name(name)
    return Scene(mesh=builtin_mesh(name), transfer=builtin_transfer(name), camera=builtin_camera(name), name=name)
