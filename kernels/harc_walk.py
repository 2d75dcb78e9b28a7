"""HARC's entry searches for the consistent walk (``walk = plucker``) outside the march kernel body: the entry
face search around a rasterised face (:func:`ring_search`), over listed faces (:func:`nearest_listed`) and over a
face's surface rings (:func:`nearest_in_rings`), on the ``@wp.func`` s of :mod:`warpvol.kernels.walk`, and the
front-to-back "under" compositing of the paper (:func:`composite`). The cell walk itself is
:func:`warpvol.kernels.cellwalk.make_walk`'s, shared with ``raycast``.
"""

import warp as wp

from .walk import Face, Ray, boundary_face, face_hit

wp.set_module_options({"enable_backward": False, "fuse_fp": False})


@wp.func
def ring_search(b: int, bf_tet: wp.array(dtype=wp.int32), bf_face: wp.array(dtype=wp.int32),
                bf_nbr: wp.array(dtype=wp.vec3i), tets: wp.array(dtype=wp.vec4i), verts: wp.array(dtype=wp.vec4),
                r: Ray):
    """First front boundary face among the edge neighbours of face ``b`` and their edge neighbours
    that the ray crosses (consistent edge test): ``(face, crossed, t, s)``."""
    nb = bf_nbr[b]
    for k in range(3):
        n1 = nb[k]
        if n1 >= 0:
            ok, t, s = face_hit(boundary_face(tets[bf_tet[n1]], bf_face[n1], verts, r))
            if ok:
                return n1, True, t, s
    for k in range(3):
        n1 = nb[k]
        if n1 >= 0:
            nb2 = bf_nbr[n1]
            for j in range(3):
                n2 = nb2[j]
                if n2 >= 0 and n2 != b:
                    ok, t, s = face_hit(boundary_face(tets[bf_tet[n2]], bf_face[n2], verts, r))
                    if ok:
                        return n2, True, t, s
    return int(-1), False, float(0.0), float(0.0)


@wp.func
def nearest_listed(lo: int, hi: int, items: wp.array(dtype=wp.int32), bf_tet: wp.array(dtype=wp.int32),
                   bf_face: wp.array(dtype=wp.int32), bf_depth: wp.array(dtype=wp.vec2), z_lo: float,
                   tets: wp.array(dtype=wp.vec4i), verts: wp.array(dtype=wp.vec4), r: Ray, prev: int, t_start: float,
                   t_tol: float, cell: int, face_in: int, t_in: float, s_in: float, fc: Face):
    """The nearer of the entry ``(cell, face_in, t_in, s_in, fc)`` (``cell < 0``: none yet) and the first crossing
    beyond ``t_start - t_tol`` of the front faces ``items[lo:hi]`` (consistent edge test), faces of ``prev`` (the
    cell just left) skipped; the ray parameter is clamped to ``t_start``. A face whose farthest depth
    (``bf_depth[b][1]``) is below ``z_lo`` (:func:`warpvol.kernels.raycast.depth_before` of ``t_start - t_tol``)
    is crossed, if at all, before that: skipped untested."""
    for it in range(lo, hi):
        b = int(items[it])
        if bf_depth[b][1] < z_lo:
            continue
        c = int(bf_tet[b])
        f = int(bf_face[b])
        if c != prev:
            cand = boundary_face(tets[c], f, verts, r)
            ok, t, s = face_hit(cand)
            if ok and t > t_start - t_tol and (cell < 0 or t < t_in):
                cell = c
                face_in = f
                t_in = wp.max(t, t_start)
                s_in = s
                fc = cand
    return cell, face_in, t_in, s_in, fc


@wp.func
def nearest_in_rings(b: int, bf_tet: wp.array(dtype=wp.int32), bf_face: wp.array(dtype=wp.int32),
                     bf_nbr: wp.array(dtype=wp.vec3i), tets: wp.array(dtype=wp.vec4i), verts: wp.array(dtype=wp.vec4),
                     r: Ray, prev: int, t_start: float, t_tol: float, cell: int, face_in: int, t_in: float,
                     s_in: float, fc: Face):
    """As :func:`nearest_listed` over the two rings of front faces around face ``b`` (its edge neighbours and
    theirs, :func:`ring_search`'s faces): a re-entry whose listed face the edge test rejects, where the face
    the ray crosses is a sliver beside it that no pixel near this one lists."""
    nb = bf_nbr[b]
    for k in range(3):
        n1 = nb[k]
        if n1 >= 0:
            nb2 = bf_nbr[n1]
            for j in range(4):
                n2 = n1
                if j < 3:
                    n2 = nb2[j]
                if n2 >= 0 and n2 != b:
                    c = int(bf_tet[n2])
                    if c != prev:
                        cand = boundary_face(tets[c], int(bf_face[n2]), verts, r)
                        ok, t, s = face_hit(cand)
                        if ok and t > t_start - t_tol and (cell < 0 or t < t_in):
                            cell = c
                            face_in = int(bf_face[n2])
                            t_in = wp.max(t, t_start)
                            s_in = s
                            fc = cand
    return cell, face_in, t_in, s_in, fc


@wp.func
def composite(acc: wp.vec4, c: wp.vec4) -> wp.vec4:
    """Front-to-back "under": ``(R, G, B, A) + (1 - A) (r, g, b, a)`` (Fig. 6 line 24)."""
    return acc + (1.0 - acc[3]) * c
