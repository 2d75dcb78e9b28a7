"""The reference's scalars in float64's normal range: scalars far below it (subnormal, ~1e-311) lose
their bits in every difference, product and slope the reference forms, and scalars near its top
overflow them. :func:`normal_scalars` multiplies the scalars and the transfer function's control points
by one power of two, which is exact and changes no colour: the reference of the scaled scene is the
reference of the scene.
"""

from __future__ import annotations

import math

import numpy as np

from warpvol.scene.mesh import TetMesh, derived_mesh
from warpvol.scene.transfer import TransferFunction

#: scalars whose largest magnitude lies within ``[2^-LIMIT, 2^LIMIT]`` are used as they are
LIMIT = 500

#: what a change of the scalars leaves valid of a mesh's cached properties
_KEEP = ("adjacency", "boundary_faces", "crack_faces", "nonconforming_faces", "is_convex", "_position_ids",
         "point_used", "face_planes", "bounds", "bounding_radius", "edge_lengths", "overlapping_parts")


def scalar_exponent(mesh: TetMesh) -> int:
    """``k`` such that the scalars times ``2^k`` have their largest magnitude in [0.5, 1); 0 when the
    scalars are within ``2^+-LIMIT`` (or all zero)."""
    lo, hi = mesh.scalar_range
    m = max(abs(lo), abs(hi))
    if m == 0 or 2.0 ** -LIMIT <= m <= 2.0 ** LIMIT:
        return 0
    return -math.frexp(m)[1]


def normal_scalars(mesh, tf: TransferFunction):
    """``(mesh, tf)`` with the scalars and the control points (restricted to the data's range, whose
    ends keep the TF's values there) times ``2^k`` (:func:`scalar_exponent`); the inputs themselves
    when ``k`` is 0 or the mesh is not a :class:`TetMesh`.

    Examples
    --------
    >>> m = TetMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]], [0, 1e-311, 2e-311, 3e-311])
    >>> tf = TransferFunction([[-1.0, 0, 0, 0, 0], [0, 0, 0, 0, 0], [4e-311, 1, 1, 1, 2]])
    >>> m2, tf2 = normal_scalars(m, tf)
    >>> round(float(m2.scalars.max()), 4), tf2.srange == (0.0, float(m2.scalars.max()))
    (0.6903, True)
    >>> tf2.evaluate(m2.scalars[1]).tolist() == tf.evaluate(1e-311).tolist()
    True
    """
    if not isinstance(mesh, TetMesh):
        return mesh, tf
    k = scalar_exponent(mesh)
    if k == 0:
        return mesh, tf
    lo, hi = mesh.scalar_range
    if hi > lo:
        inner = (tf.s > lo) & (tf.s < hi)
        s = np.concatenate([[lo], tf.s[inner], [hi]])
        vals = np.concatenate([tf.evaluate(lo)[None], tf.points[inner, 1:], tf.evaluate(hi)[None]])
        s = np.ldexp(s, k)
    else:  # constant data: the TF's value there on both sides of it
        c = math.ldexp(lo, k)
        s, vals = np.array([c - 1.0, c + 1.0]), np.repeat(tf.evaluate(lo)[None], 2, axis=0)
    keep = np.concatenate([[True], np.diff(s) > 0])
    out_tf = TransferFunction(np.column_stack([s[keep], vals[keep]]), tf.emission, where=getattr(tf, "where", "transfer"))
    out = derived_mesh(mesh, _KEEP)
    scalars = np.ldexp(mesh.scalars, k)
    scalars.setflags(write=False)
    out.scalars = scalars
    return out, out_tf
