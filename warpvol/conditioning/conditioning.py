"""Host-side conditioning of a scene before any float32 cast, and the precision checks of the rest.

Real data is rarely centred on the origin at unit size: georeferenced meshes sit millions of metres
from it, pressures are ``1e5`` Pa give or take a few, meshes come in metres or in nanometres. A float32
cast of such inputs keeps only the bits the offset leaves over.

:func:`condition_scene` (the ``condition`` stage, first in the exact presets ``raycast``,
``harc_best``, ``pt_best`` and ``vsbuffer_best``) maps a scene, in float64, to one that renders the
same image:

============  ===========================================================================================
input         mapped to
============  ===========================================================================================
points        ``(p - c) / h``: ``c`` the centre of the mesh's bounding box, ``h`` its largest half-extent,
              so the mesh fills ``[-1, 1]`` along its longest axis
camera        ``eye``, ``target`` the same way; orthographic ``height / h``; field of view and ``up`` as
              they are (a similarity transform keeps every ray through every pixel centre)
scalars       ``(s - m) / r``: ``m`` the midpoint of the scalars that matter (the transfer function's
              range within the data's, :func:`scalar_frame`), or the control point that keeps the
              narrowest transfer-function segments apart in float32 when the midpoint does not (a
              log-scaled field: :func:`scalar_mapping`); ``r`` the largest distance from ``m`` to their
              ends. The control points the same way, restricted to the data's range (no scalar beyond
              it is looked up)
extinction    ``rho * h`` (extinction is per world unit of length, the new unit is ``h`` long)
colour        as it is for ``color_extinction``; ``c * h`` for ``emission_density`` (``c`` is an
              emission per unit length there)
============  ===========================================================================================

Every ray integral is unchanged: a ray parameter ``t`` becomes ``t / h`` and both ``rho dt`` and
``c dt`` (emission density) keep their value. Thresholds of the later stages then act relative to
the mesh's size, whatever its units.

Inputs the pipeline's float32 formats cannot hold are refused naming the field and the range
(:func:`check_float32_ranges`). Pipelines without the ``condition`` stage (the paper presets) keep
their hardware's arithmetic; :func:`precision_warnings` says how many bits their float32 cast of the
input loses, and the render report carries it under ``stats["precision"]["warning"]``.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from warpvol.conditioning.reorder import needs_reorder, reordered_mesh
from warpvol.errors import ConfigError
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh, derived_mesh
from warpvol.scene.transfer import TransferFunction

#: largest finite float32
FLOAT32_MAX = float(np.finfo(np.float32).max)
#: bound on optical depths and scaled inputs: kernels form sums and products of a few of them
#: (e.g. ``rho_a l + rho_b l``, ``(rho_b - rho_a) l^2 / 2``) before the exponential
FLOAT32_SAFE = FLOAT32_MAX / 1024.0
#: smallest normal float32
FLOAT32_TINY = float(np.finfo(np.float32).tiny)
#: smallest span of scalars (or extent of a mesh) a pipeline that casts it to float32 as it is takes:
#: float32's smallest normal number with the same headroom as :data:`FLOAT32_SAFE` (differences and
#: products of such values stay normal)
FLOAT32_TINY_SAFE = FLOAT32_TINY * 1024.0
#: float32 significand bits (implicit bit included)
FLOAT32_BITS = 24
#: precision warnings are given from this many lost bits on
WARN_BITS = 4
#: smallest width of a transfer-function segment the exact presets keep their tolerance with, relative
#: to its far end's distance from the scalars' float32 origin (:func:`scalar_mapping`): float32 keeps
#: 2^13 steps across it; less is reported with a warning. Measured with raycast (max abs, 96^2): the
#: sphere with 4,096 / 8,192 evenly spaced control points of random colour and extinction (2^-11 /
#: 2^-12) 9.6e-5 / 1.5e-4; a field dwelling in one segment of 2^-13.5 gave 6.5e-5 (rmse 2.5e-6)
MIN_RESOLUTION = 2.0 ** -11
#: under this (16 float32 steps) control points cannot be kept apart: the scene is declined
DECLINE_RESOLUTION = 2.0 ** -20
#: the midpoint of the scalars stays the offset while every segment keeps this much there
PREFER_RESOLUTION = 2.0 ** -8

#: cached properties of a :class:`TetMesh` that describe its topology only; a similarity transform
#: keeps them, so the conditioned mesh takes them over instead of computing them again
TOPOLOGY_CACHE = ("adjacency", "boundary_faces", "crack_faces", "nonconforming_faces", "is_convex",
                  "_position_ids", "point_used", "overlapping_parts")


def _shift_scale(x: np.ndarray, centre, scale: float, field: str) -> np.ndarray:
    """``(x - centre) / scale`` in float64 without intermediate overflow; a result beyond float64
    is an error naming ``field``."""
    x = np.asarray(x, dtype=np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        out = (x - centre) / scale
        bad = ~np.isfinite(out)
        if bad.any():  # x - centre overflowed (inputs near +-1.8e308): scale first
            alt = np.broadcast_to(x / scale - np.asarray(centre) / scale, out.shape)
            out = np.where(bad, alt, out)
    if not np.isfinite(out).all():
        raise ConfigError(f"{field}: values up to {float(np.abs(x).max()):.3g} are too far from the centre "
                          f"{np.asarray(centre).tolist()} for a scale of {scale:.3g}; float64 cannot hold them")
    return out


def mesh_frame(mesh: TetMesh) -> tuple[np.ndarray, float]:
    """``(centre, h)``: the bounding-box centre and largest half-extent, both finite (no overflow of
    the extent for coordinates near +-1.8e308)."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds)
    centre = 0.5 * lo + 0.5 * hi
    h = float((0.5 * hi - 0.5 * lo).max())
    if not h > 0:  # extents below the smallest normal float64 (a tet has volume, so not all zero)
        h = float((hi - lo).max())
    return centre, h


def scalar_frame(tf: TransferFunction, data_range: tuple[float, float]) -> tuple[float, float]:
    """``(midpoint, half-span)`` of the scalars that matter: the transfer function's range within the
    data's (where both vary), else the data's range (the TF is constant over the data), else
    ``(value, 1)`` for constant data. Both finite (no overflow of a span near +-1.8e308)."""
    t_lo, t_hi = tf.srange
    d_lo, d_hi = (float(v) for v in data_range)
    lo, hi = max(t_lo, d_lo), min(t_hi, d_hi)
    if not hi > lo:
        lo, hi = d_lo, d_hi
    if not hi > lo:
        return lo, 1.0
    mid = 0.5 * lo + 0.5 * hi
    half = 0.5 * hi - 0.5 * lo
    if not half > 0:
        half = hi - lo
    return mid, half


def _segments(tf: TransferFunction, data_range: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """``(knots, values)`` of the transfer function restricted to the data's range: its value at both
    ends and the control points between (what :func:`conditioned_transfer` keeps), float64."""
    d_lo, d_hi = (float(v) for v in data_range)
    inner = (tf.s > d_lo) & (tf.s < d_hi)
    s = np.concatenate([[d_lo], tf.s[inner], [d_hi]])
    vals = np.concatenate([tf.evaluate(d_lo)[None], tf.points[inner, 1:], tf.evaluate(d_hi)[None]])
    return s, vals


def _resolution(knots: np.ndarray, m: float) -> np.ndarray:
    """Per segment ``[knots[i], knots[i + 1]]``: its width over its far end's distance from ``m`` (a
    float32 value ``s - m`` is rounded by up to 2^-24 of that distance, so the segment keeps about
    ``resolution * 2^24`` float32 steps); ``inf`` for a segment ending at ``m`` on both sides."""
    far = np.maximum(np.abs(knots[:-1] - m), np.abs(knots[1:] - m))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(far > 0, np.diff(knots) / np.where(far > 0, far, 1.0), np.inf)


def scalar_mapping(tf: TransferFunction, scalars: np.ndarray, data_range: tuple[float, float],
                   where: str = "transfer") -> tuple[float, float, dict]:
    """``(offset, scale, info)`` of the affine scalar map ``s' = (s - offset) / scale`` of the exact
    presets. Only an affine map keeps the image: a tet interpolates its vertex scalars linearly, and
    the map must commute with that.

    float32 rounds ``s'`` relative to its size, so the offset decides which transfer-function segments
    float32 still resolves. A segment counts where the colour or extinction changes and data scalars
    fall into it; it keeps ``resolution * 2^24`` float32 steps (:func:`_resolution`). The midpoint of
    the scalars that matter (:func:`scalar_frame`) is the offset while every segment keeps
    :data:`PREFER_RESOLUTION` there; else the control point (or 0) that resolves the narrowest
    segments best: a log-scaled field (density 1e-6 .. 1e3, a control point per decade) is mapped
    about its smallest decade. ``scale`` is the largest distance from the offset to the ends of the
    scalars that matter, so they map into [-1, 1].

    ``info``: ``resolution`` (the smallest over the segments) and, when a segment keeps less than
    :data:`MIN_RESOLUTION` at the best offset, ``warning`` naming those control points. Under
    :data:`DECLINE_RESOLUTION` float32 cannot keep the control points apart and the transfer
    function is declined naming them.

    Examples
    --------
    >>> tf = TransferFunction([[10.0 ** k, 0.5, 0.5, 0.5, 7.0 + k] for k in range(-6, 4)])
    >>> s = 10.0 ** np.linspace(-6, 3, 50)
    >>> offset, scale, info = scalar_mapping(tf, s, (1e-6, 1e3))
    >>> offset, round(info["resolution"], 2)
    (1e-05, 0.9)
    """
    mid, half = scalar_frame(tf, data_range)
    lo, hi = mid - half, mid + half
    knots, vals = _segments(tf, data_range)
    live = (np.abs(np.diff(vals, axis=0)) > 0).any(axis=1) & (np.diff(knots) > 0)
    if len(knots) > 2:  # segments data scalars fall into (a scalar on a control point: both sides)
        s = np.asarray(scalars, dtype=np.float64)
        occupied = np.zeros(len(knots) - 1, dtype=bool)
        for side in ("left", "right"):
            occupied[np.clip(np.searchsorted(knots, s, side=side) - 1, 0, len(occupied) - 1)] = True
        live &= occupied
    if not live.any():
        return mid, half, {"resolution": None}

    def worst(m):
        return float(_resolution(knots, m)[live].min())

    best, best_res = mid, worst(mid)
    if best_res < PREFER_RESOLUTION:
        narrow = np.argsort(np.where(live, np.diff(knots), np.inf), kind="stable")[:8]
        for m in np.unique(np.concatenate([knots[narrow], knots[narrow + 1], [0.0, lo, hi]])):
            r = worst(float(m)) if lo <= m <= hi else -1.0
            if r > best_res:
                best, best_res = float(m), r
    info: dict = {"resolution": best_res}
    if best_res < MIN_RESOLUTION:
        res = _resolution(knots, best)
        bad = np.flatnonzero(live & (res < MIN_RESOLUTION))
        bad = bad[np.argsort(res[bad], kind="stable")]  # the least resolved first
        pairs = ", ".join(f"[{knots[i]:.10g}, {knots[i + 1]:.10g}]" for i in bad[:4])
        more = f" and {len(bad) - 4} more" if len(bad) > 4 else ""
        steps = max(1, int(best_res * 2.0 ** FLOAT32_BITS))
        text = (f"{where}.points: float32 keeps only {steps} step(s) across the segment(s) {pairs}{more} with the "
                f"scalars {lo:.6g} .. {hi:.6g} centred on {best:.6g}")
        if best_res < DECLINE_RESOLUTION:
            raise ConfigError(text + f" (at least {DECLINE_RESOLUTION * 2.0 ** FLOAT32_BITS:.0f} needed to keep its "
                              "control points apart); narrow the transfer function's range, or render the scalars' logarithm")
        info["warning"] = (text + f", fewer than the {MIN_RESOLUTION * 2.0 ** FLOAT32_BITS:.0f} that keep the "
                           "preset's tolerance: pixels whose scalars lie there may be off by more")
    scale = max(hi - best, best - lo)
    return best, (scale if scale > 0 else half), info


def _scatter(values: np.ndarray, used: np.ndarray) -> np.ndarray:
    """``values`` of the used points at their places, zeros (the conditioned centre) elsewhere."""
    out = np.zeros((len(used),) + values.shape[1:])
    out[used] = values
    return out


def _conditioned_mesh(mesh: TetMesh, centre: np.ndarray, h: float, s_mid: float, s_half: float) -> TetMesh:
    """The mesh with points ``(p - centre) / h`` and scalars ``(s - s_mid) / s_half``, sharing the
    tets, cells and topology of ``mesh`` (no validation again: the same tets stay, the same ones
    dropped)."""
    name = getattr(mesh, "name", "mesh")
    used = mesh.point_used  # points no tet uses (a part cut from a larger model) go to the centre
    pts = _shift_scale(mesh.points if used is None else mesh.points[used], centre, h, f"{name}: points")
    s = _shift_scale(mesh.scalars if used is None else mesh.scalars[used], s_mid, s_half, f"{name}: scalars")
    if used is not None:
        pts, s = _scatter(pts, used), _scatter(s, used)
    if np.abs(s).max() > FLOAT32_SAFE:
        k = int(np.abs(s).argmax())
        raise ConfigError(
            f"{name}: scalars: {float(mesh.scalars[k]):.6g} lies {abs(float(s[k])):.3g} times {s_half:.3g} from "
            f"{s_mid:.6g}, the middle of the transfer function's range within the data; float32 holds up to "
            f"{FLOAT32_SAFE:.3g} (widen the transfer function's range or clip the data)")
    out = derived_mesh(mesh, TOPOLOGY_CACHE)  # geometry (bounds, planes, gradients, ...) is computed again
    for arr in (pts, s):
        arr.setflags(write=False)
    out.points, out.scalars = pts, s
    return out


def _tets_of(mesh):
    """The TetMesh of a scene's mesh: itself, or the tets (``pieces``) of convex cells drawn whole
    (:class:`warpvol.vsbuffer.cells.ConvexCellMesh`)."""
    pieces = getattr(mesh, "pieces", None)
    return pieces if not isinstance(mesh, TetMesh) and isinstance(pieces, TetMesh) else mesh


def _diagonal(mesh: TetMesh) -> float:
    lo, hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds)
    return 2.0 * float(np.linalg.norm(0.5 * hi - 0.5 * lo))


def _check_values(values: np.ndarray, s: np.ndarray, emission: str, diag: float, where: str) -> None:
    """Optical depth ``max extinction x mesh diagonal`` (the same in any unit of length) and colours
    (``emission_density``: colour x mesh diagonal) within what float32 formats hold. ``values`` are
    rows ``[r, g, b, extinction]`` at the scalars ``s``."""
    k = int(np.argmax(values[:, 3]))
    tau = float(values[k, 3]) * diag
    if not tau <= FLOAT32_SAFE:
        raise ConfigError(
            f"{where}.points: extinction {float(values[k, 3]):.3g} (at s = {float(s[k]):.6g}) over the mesh's diagonal "
            f"{diag:.3g} is an optical depth of {tau:.3g}; float32 formats hold up to {FLOAT32_SAFE:.3g}")
    rgb = values[:, :3] * (diag if emission == "emission_density" else 1.0)
    if not rgb.max() <= FLOAT32_SAFE:
        k = int(np.argmax(rgb.max(axis=1)))
        what = " times the mesh diagonal" if emission == "emission_density" else ""
        raise ConfigError(f"{where}.points: colour {values[k, :3].tolist()} (at s = {float(s[k]):.6g}){what} exceeds "
                          f"what float32 formats hold ({FLOAT32_SAFE:.3g})")


def check_float32_ranges(scene) -> None:
    """Refuse inputs a pipeline that casts them to float32 as they are cannot hold, naming the field
    and the range: the optical depth and colours (:func:`_check_values`), points, scalars and
    transfer-function points beyond +-:data:`FLOAT32_SAFE`."""
    mesh, tf = _tets_of(scene.mesh), scene.transfer
    where = getattr(tf, "where", "transfer")
    _check_values(np.asarray(tf.points[:, 1:], dtype=np.float64), tf.s, tf.emission, _diagonal(mesh), where)
    name = getattr(mesh, "name", "mesh")
    for field, arr in ((f"{name}: points", mesh.bounds), (f"{name}: scalars", mesh.scalar_range),
                       (f"{where}.points (s)", tf.srange)):
        m = float(np.abs(np.asarray(arr, dtype=np.float64)).max())  # cached extremes, not a pass over the data
        if m > FLOAT32_SAFE:
            raise ConfigError(f"{field}: |value| up to {m:.3g} is beyond float32's range (+-{FLOAT32_SAFE:.3g} "
                              "with headroom); this pipeline casts it to float32 as it is (the exact presets "
                              "'raycast', 'harc_best', 'pt_best', 'vsbuffer_best' condition it first)")
    exact = "the exact presets 'raycast', 'harc_best', 'pt_best', 'vsbuffer_best' condition it first"
    lo, hi = mesh.scalar_range
    mid, half = scalar_frame(tf, (lo, hi))
    if 0 < 2.0 * half < FLOAT32_TINY_SAFE:
        raise ConfigError(f"{name}: scalars: the scalars that matter span only {2.0 * half:.3g} ({mid - half:.6g} .. "
                          f"{mid + half:.6g}), below float32's smallest normal number {FLOAT32_TINY:.3g} (with headroom "
                          f"{FLOAT32_TINY_SAFE:.3g}); this pipeline casts them to float32 as they are, which flushes "
                          f"them towards zero ({exact}; or scale the data)")
    extent = float(np.max(np.asarray(mesh.bounds[1], np.float64) - np.asarray(mesh.bounds[0], np.float64)))
    if extent < FLOAT32_TINY_SAFE:
        raise ConfigError(f"{name}: points: the mesh is only {extent:.3g} across, below float32's smallest normal "
                          f"number {FLOAT32_TINY:.3g} (with headroom {FLOAT32_TINY_SAFE:.3g}); this pipeline casts the "
                          f"points to float32 as they are ({exact}; or scale the mesh)")
    if mesh.point_used is not None:  # points no tet uses are cast too (their values never reach a pixel)
        m = float(np.abs(mesh.points).max())
        if not m <= FLOAT32_SAFE:
            raise ConfigError(f"{name}: points: {mesh.n_unused_points:,} points no cell uses lie up to {m:.3g} from "
                              f"the origin, beyond float32's range; this pipeline casts every point as it is: drop "
                              "the unused points (pyvista: clean()) or use an exact preset ('raycast', 'harc_best', "
                              "'pt_best', 'vsbuffer_best')")


def check_conditionable(scene) -> None:
    """What :func:`condition_scene` refuses (a transfer function float32 cannot resolve over the data,
    an optical depth or colour beyond float32), checked without conditioning the mesh: cheap, so that
    a command declines before any costly work."""
    mesh, tf = _tets_of(scene.mesh), scene.transfer
    where = getattr(tf, "where", "transfer")
    scalar_mapping(tf, mesh.scalars, mesh.scalar_range, where)
    s, vals = _segments(tf, mesh.scalar_range)
    _check_values(vals, s, tf.emission, _diagonal(mesh), where)


def condition_scene(scene, cache: dict | None = None, reorder: str = "none",
                    frame: dict | None = None) -> tuple[object, dict]:
    """``(conditioned scene, info)``: the scene mapped as in the module docstring, in float64.

    ``info`` holds ``origin`` (the world point that becomes 0), ``scale`` (the world length that
    becomes 1), ``scalar_offset`` and ``scalar_scale`` (``s' = (s - offset) / scale``), ``reordered``
    (cells and points renumbered along a space-filling curve: ``reorder`` is ``"morton"``, or ``"auto"``
    and the mesh's order is incoherent, :func:`warpvol.conditioning.reorder.needs_reorder`), ``cached``,
    ``unused_points`` (points no tet uses: left out of every bound and frame, mapped to the centre),
    ``scalar_resolution`` (the narrowest transfer-function segment the data reaches over its distance
    from the offset, :func:`scalar_mapping`; ``None`` without one) and, when float32 resolves such a
    segment too coarsely for the exact presets' tolerance, ``warning``.
    The scene object is copied (any object with ``mesh``, ``transfer`` and ``camera``), the input
    untouched. With ``cache`` (a dict kept across calls) the conditioned mesh is reused while the
    mesh object and the scalar mapping stay the same, so per-mesh caches downstream keep hitting.
    ``frame`` (:func:`shared_frame`), for a piece of a larger mesh: the whole mesh's ``centre``, ``h``,
    ``scalar_offset``, ``scalar_scale``, ``data_range`` and ``diagonal`` instead of the piece's own, so that
    every piece is conditioned alike (the same float32 points on both sides of a piece boundary).

    Examples
    --------
    >>> from warpvol.scene.builtin import builtin_scene
    >>> s = builtin_scene("box")
    >>> c, info = condition_scene(s)
    >>> info["scale"], [float(v) for v in c.mesh.bounds[1]]
    (1.0, [1.0, 1.0, 1.0])
    """
    import weakref

    source, tf = scene.mesh, scene.transfer
    if frame is not None:  # a piece in another mesh's frame: not the piece's own conditioning, not cached
        cache = None
    mesh = _tets_of(source)  # convex cells drawn whole are conditioned through their tets
    if frame is None:
        centre, h = mesh_frame(mesh)
        data_range = mesh.scalar_range
        s_mid, s_half, mapping = scalar_mapping(tf, mesh.scalars, data_range, getattr(tf, "where", "transfer"))
        diag = _diagonal(mesh)
    else:  # a piece of a larger mesh: the whole mesh's frame
        centre, h = np.asarray(frame["centre"], dtype=np.float64), float(frame["h"])
        data_range = tuple(float(v) for v in frame["data_range"])
        s_mid, s_half, mapping = float(frame["scalar_offset"]), float(frame["scalar_scale"]), {"resolution": None}
        diag = float(frame["diagonal"])
    hit = None if cache is None else cache.get("mesh")  # (weakref to the source, mapping, renumbering, result)
    if hit is not None and hit[0]() is source and hit[1] == (s_mid, s_half) and hit[2] == reorder:
        cmesh, cached = hit[3], True
    else:
        cmesh, cached = _conditioned_mesh(mesh, centre, h, s_mid, s_half), False
        if mesh is not source:
            cmesh = type(source)(cmesh, source.cell_start, name=source.name)
        elif needs_reorder(cmesh, reorder):
            cmesh = reordered_mesh(cmesh)
        if cache is not None:
            cache["mesh"] = (weakref.ref(source), (s_mid, s_half), reorder, cmesh)
    out = copy.copy(scene)
    out.mesh = cmesh
    out.transfer = conditioned_transfer(tf, h, s_mid, s_half, data_range, diag)
    out.camera = conditioned_camera(scene.camera, centre, h)
    info = {"origin": [float(v) for v in centre], "scale": h, "scalar_offset": s_mid, "scalar_scale": s_half,
            "reordered": getattr(cmesh, "cell_order", None) is not None, "cached": cached,
            "scalar_resolution": mapping["resolution"], "unused_points": mesh.n_unused_points}
    if "warning" in mapping:
        info["warning"] = mapping["warning"]
    return out, info


def shared_frame(tf: TransferFunction, lo, hi, data_range: tuple[float, float]) -> dict:
    """The frame of a mesh known by its bounds ``lo``, ``hi`` and scalar range alone (the union of its pieces'):
    what :func:`condition_scene` takes as ``frame``, plus ``cells_origin`` and ``cells_radius``, the conditioned
    bounding box's centre and half diagonal (a bound on every point's distance from it), for the ray casters'
    cell set-up."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    centre = 0.5 * lo + 0.5 * hi
    h = float((0.5 * hi - 0.5 * lo).max())
    if not h > 0:
        h = float((hi - lo).max())
    d_lo, d_hi = (float(v) for v in data_range)
    s_mid, s_half, _ = scalar_mapping(tf, np.array([d_lo, d_hi]), (d_lo, d_hi), getattr(tf, "where", "transfer"))
    c_lo, c_hi = (lo - centre) / h, (hi - centre) / h
    return {"centre": centre.tolist(), "h": h, "scalar_offset": s_mid, "scalar_scale": s_half,
            "data_range": [d_lo, d_hi], "diagonal": 2.0 * float(np.linalg.norm(0.5 * hi - 0.5 * lo)),
            "cells_origin": (0.5 * (c_lo + c_hi)).tolist(), "cells_radius": 0.5 * float(np.linalg.norm(c_hi - c_lo))}


def conditioned_transfer(tf: TransferFunction, h: float, s_mid: float, s_half: float,
                         data_range: tuple[float, float], diag: float) -> TransferFunction:
    """The transfer function in conditioned units (see :func:`condition_scene`), restricted to the
    data's scalar range ``data_range``: its value at both ends and the control points between. A tet
    interpolates its vertex scalars linearly, so no scalar outside that range is ever looked up and
    the restriction changes no colour; control points far outside (e.g. at +-1.7e308) drop out.
    ``diag``: the mesh diagonal in world units (optical depth and emission bounds)."""
    where = getattr(tf, "where", "transfer")
    s, vals = _segments(tf, data_range)
    _check_values(vals, s, tf.emission, diag, where)
    u = _shift_scale(s, s_mid, s_half, f"{where}.points (s)")
    if not u[-1] > u[0]:  # constant data: the TF is constant on it
        u, vals = np.array([u[0] - 1.0, u[0] + 1.0]), vals[[0, 0]]
    keep = np.concatenate([[True], np.diff(u) > 0])  # points within float64 rounding of each other: the first
    u, vals = u[keep], vals[keep]
    vals = vals.copy()
    vals[:, 3] *= h
    if tf.emission == "emission_density":
        vals[:, :3] *= h
    return TransferFunction(np.column_stack([u, vals]), tf.emission, where=where)


def conditioned_camera(cam: Camera, centre: np.ndarray, h: float) -> Camera:
    """The camera in conditioned units: the same rays through the same pixel centres."""
    w = getattr(cam, "where", "camera")
    eye = _shift_scale(cam.eye, centre, h, f"{w}.eye")
    target = _shift_scale(cam.target, centre, h, f"{w}.target")
    if np.array_equal(eye, target):  # target - eye below the rounding of the mapping: keep the direction
        target = eye + cam.forward
    return Camera(projection=cam.projection, eye=eye, target=target, up=cam.up, fov_y_deg=cam.fov_y_deg,
                  ortho_height=cam.ortho_height / h, width_px=cam.width_px, height_px=cam.height_px, where=w)


# ------------------------------------------------------------------------------------------------
# faithful pipelines: what the float32 cast of the input loses
# ------------------------------------------------------------------------------------------------


def _bits_lost(magnitude: float, span: float) -> int:
    """Significand bits of a float32 value of size ``magnitude`` spent on its offset, not on the
    ``span`` the data varies over: ``floor(log2(magnitude / span))``, at least 0."""
    if not (span > 0 and magnitude > span):
        return 0
    return int(math.floor(math.log2(magnitude / span)))


def precision_bits(scene) -> dict[str, int]:
    """Bits a float32 cast of the scene's inputs as they are loses: ``scalars`` (the largest
    |value| of the transfer function's range over its span) and ``points`` (the largest |coordinate|
    of the mesh over its largest extent)."""
    mesh = _tets_of(scene.mesh)
    mid, half = scalar_frame(scene.transfer, mesh.scalar_range)
    bounds_lo, bounds_hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds)
    centre, h = mesh_frame(mesh)
    mag = float(np.maximum(np.abs(bounds_lo), np.abs(bounds_hi)).max())
    return {"scalars": _bits_lost(abs(mid) + half, 2.0 * half), "points": _bits_lost(mag, 2.0 * h)}


def precision_warnings(scene) -> dict | None:
    """For a pipeline that casts the input to float32 as it is: ``{"warning": text, "bits_lost":
    {...}}`` when a cast loses more than :data:`WARN_BITS` of float32's 24 significand bits, else
    ``None``. Inputs beyond float32's range are refused (:func:`check_float32_ranges`).

    Examples
    --------
    >>> from warpvol.tools.stress_real import offset_scene
    >>> print(precision_warnings(offset_scene(8, scalar_offset=2e5, scalar_span=4.0))["warning"])
    scalars: offset 2e+05 over a range of 3.99 (where data and transfer function overlap): 15 of float32's 24 bits lost; the exact presets (raycast, harc_best, pt_best, vsbuffer_best) condition the input first
    >>> precision_warnings(offset_scene(8)) is None
    True
    """
    check_float32_ranges(scene)
    bits = precision_bits(scene)
    parts = []
    if bits["scalars"] > WARN_BITS:
        mid, half = scalar_frame(scene.transfer, _tets_of(scene.mesh).scalar_range)
        parts.append(f"scalars: offset {abs(mid) + half:.3g} over a range of {2 * half:.3g} (where data and transfer "
                     f"function overlap): {bits['scalars']} of float32's {FLOAT32_BITS} bits lost")
    if bits["points"] > WARN_BITS:
        blo, bhi = _tets_of(scene.mesh).bounds
        mag = float(np.maximum(np.abs(blo), np.abs(bhi)).max())
        parts.append(f"points: coordinates up to {mag:.3g} for a mesh {float((bhi - blo).max()):.3g} across: "
                     f"{bits['points']} of float32's {FLOAT32_BITS} bits lost")
    if not parts:
        return None
    text = "; ".join(parts) + "; the exact presets (raycast, harc_best, pt_best, vsbuffer_best) condition the input first"
    return {"warning": text, "bits_lost": bits}
