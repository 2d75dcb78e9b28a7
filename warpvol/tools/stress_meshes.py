"""Meshes and transfer functions the stress cases share (a graded box, a scalar-coloured transfer
function)."""

from __future__ import annotations

import numpy as np

from warpvol.scene.grids import grid_points, structured_to_tets
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import TransferFunction


def _box(n: int = 5, lo=-1.0, hi=1.0, zs=None, scalar=None, name="box") -> TetMesh:
    x = np.linspace(lo, hi, n)
    pts = grid_points(x, x, x if zs is None else zs)
    s = pts[:, 2].copy() if scalar is None else scalar(pts)
    return TetMesh(pts, structured_to_tets((n, n, len(x) if zs is None else len(zs))), s, name=name)


def _tf(ext: float) -> TransferFunction:
    """Colour varies with the scalar (-1..1), extinction constant ``ext``."""
    return TransferFunction([[-1.0, 1.0, 0.2, 0.1, ext], [0.0, 0.2, 1.0, 0.3, ext], [1.0, 0.1, 0.3, 1.0, ext]])
