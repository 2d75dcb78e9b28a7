"""Stress cases of the data users bring: log-scaled fields over many decades, parts cut from a larger
model that keep its points, transfer functions of thousands of rough control points.

Each scene builder serves the tests too; :func:`range_cases` registers them with the helpers of
:func:`warpvol.tools.stress._cases` (``simple(name, doc, build)``, ``sc(mesh, tf, camera, name)``).
:func:`silent_wrong` picks the rows of a stress run where an exact preset is beyond its claim and says
nothing.
"""

from __future__ import annotations

import numpy as np

from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction
from warpvol.tools.stress_meshes import _box
from warpvol.tools.stress_real import COND_TF, _cond_field

#: what the exact presets claim against the float64 reference (the README's numbers): rmse, max abs
EXACT_CLAIMS = {"raycast": (2e-6, 1e-4), "harc_best": (2e-6, 1e-4), "vsbuffer_best": (2e-6, 1e-4),
                "pt_best": (2.5e-4, 4e-3)}


def _camera(px: int):
    return Camera(eye=(3.0, 2.0, 4.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov_y_deg=30.0,
                  width_px=px, height_px=px)


def _unit_field(p: np.ndarray) -> np.ndarray:
    """A smooth field over the box ``[-1, 1]^3`` in ``[0, 1]``."""
    return np.clip((np.sin(1.3 * p[:, 0]) + 0.7 * p[:, 1] + 0.5 * p[:, 2] * p[:, 0] + 2.2) / 4.4, 0.0, 1.0)


def log_scene(px: int = 32, decades: int = 9, top: float = 3.0, n: int = 6, seed: int = 3):
    """A density from ``10^(top - decades)`` to ``10^top`` over an ``n^3``-point box grid, varying by
    decades across it, and a transfer function with a control point per decade (random colours and
    extinctions): how concentration, vorticity and density fields are shown."""

    lo = top - decades
    mesh = _box(n, scalar=lambda p: 10.0 ** (lo + decades * _unit_field(p)), name=f"log_{decades}")
    rng = np.random.default_rng(seed)
    s = 10.0 ** np.arange(lo, top + 0.5)
    pts = np.column_stack([s, rng.uniform(0.1, 1.0, (len(s), 3)), rng.uniform(0.2, 2.5, len(s))])
    return Scene(mesh=mesh, transfer=TransferFunction(pts), camera=_camera(px), name=f"log_field_{decades}")


def unused_points_scene(px: int = 32, distance: float = 1e7, n: int = 5, fit: bool = False):
    """A part (an ``n^3``-point box grid, 2 across) that keeps 8 points of its parent no cell uses,
    at ``+-distance`` on every axis, before and after its own points, with scalars outside the part's
    range. ``fit``: the default camera fitted to the mesh instead of one framing the part."""

    part = _box(n, scalar=_cond_field)
    far = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=np.float64) * distance
    mesh = TetMesh(np.vstack([far[:4], part.points, far[4:]]), part.tets + 4,
                   np.concatenate([np.full(4, 5.0), part.scalars, np.full(4, -7.0)]), name=f"part_{distance:.0e}")
    cam = Camera.fit(mesh, width_px=px, height_px=px) if fit else _camera(px)
    return Scene(mesh=mesh, transfer=TransferFunction(np.array(COND_TF)), camera=cam, name=f"unused_points_{distance:.0e}")


def rough_scene(px: int = 32, points: int = 4096, seed: int = 0):
    """The built-in sphere with a transfer function of ``points`` control points of random colour and
    extinction spread evenly over its scalars (a label-like colour map)."""

    base = builtin_scene("sphere")
    lo, hi = base.mesh.scalar_range
    rng = np.random.default_rng(seed + points)
    top = float(base.transfer.points[:, 4].max())
    pts = np.column_stack([np.linspace(lo, hi, points), rng.uniform(0.0, 1.0, (points, 3)),
                           rng.uniform(0.0, top, points)])
    return Scene(mesh=base.mesh, transfer=TransferFunction(pts), camera=base.camera.replace(width_px=px, height_px=px),
                 name=f"rough_tf_{points}")


def subnormal_scene(px: int = 32, scale: float = 1e-311, n: int = 6):
    """The field of :func:`log_scene`'s box in ``[0, scale]`` (default: float64 subnormal numbers) and a
    transfer function over that range: the exact presets and the reference render it as the same data
    scaled into the normal range; the pipelines that cast scalars to float32 as they are decline."""

    mesh = _box(n, scalar=lambda p: _unit_field(p) * scale, name="subnormal_scalars")
    tf = TransferFunction([[0.0, 0.1, 0.2, 0.9, 0.2], [0.5 * scale, 0.9, 0.5, 0.1, 1.5], [scale, 1.0, 1.0, 0.9, 0.6]])
    return Scene(mesh=mesh, transfer=tf, camera=_camera(px), name="subnormal_scalars")


def range_cases(simple, with_ref, sc) -> None:
    """Dynamic range by decades, unused points at growing distance, rough transfer functions."""
    def px(q):
        return 16 if q else 96

    for d in (6, 9, 12):
        simple(f"log_field_{d}_decades", f"density over {d} decades (1e{3 - d} .. 1e3), a TF point per decade",
               lambda q, d=d: log_scene(px(q), decades=d))
    for dist in (1e3, 1e7, 1e30):
        simple(f"unused_points_{dist:.0e}", f"a part 2 across keeping 8 points of its parent no cell uses at +-{dist:g}",
               lambda q, dist=dist: unused_points_scene(px(q), distance=dist))
    simple("subnormal_scalars", "scalars 0 .. 1e-311 (float64 subnormal numbers) and a TF over them: the exact "
           "presets render them, the float32 pipelines decline", lambda q: subnormal_scene(px(q)))
    for k in (4096, 20000):
        simple(f"rough_tf_{k}", f"the sphere with a TF of {k} control points of random colour and extinction",
               lambda q, k=k: rough_scene(px(q), points=k))


def silent_wrong(rows: list[dict]) -> list[dict]:
    """The rows where an exact preset rendered (``ok``) beyond its claim (:data:`EXACT_CLAIMS`) with no
    warning: what must never happen."""
    out = []
    for r in rows:
        claim = EXACT_CLAIMS.get(r.get("pipeline"))
        if claim is None or r.get("status") != "ok" or r.get("message") or r.get("rmse") is None:
            continue
        if r["rmse"] > claim[0] or r["max_abs"] > claim[1]:
            out.append(r)
    return out
