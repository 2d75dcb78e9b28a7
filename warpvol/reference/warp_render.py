"""Exact float64 reference renderer on Warp (the default of :func:`warpvol.reference.numpy_render.render_reference`).

The same image as the NumPy reference (:mod:`warpvol.reference.numpy_render`, the oracle it is tested against),
computed by its own float64 kernels (:mod:`warpvol.kernels.reference`):

1. **Per-mesh data.** Points in camera coordinates (``(p - eye)`` projected on right, up, forward),
   each tet's vertices in ascending global order with its orientation, the neighbour across each
   face, the scalar at the eye per tet (perspective).
2. **Boundary entries.** Every boundary face that can be an entry (orthographic: facing the
   camera; perspective: the eye on its outer side) is tested against the pixel centres of its screen
   box with the exact edge signs; a pixel keeps the faces its line enters through (perspective:
   only in front of the eye; orthographic: along the whole line, segments are clipped at the eye
   plane).
3. **Walk.** One thread per pixel walks each chord of its line tet to tet through the adjacency, in
   depth order: first, for a perspective eye inside the mesh, the chord through the eye (started in
   the tet near the eye whose segment holds ``t = 0``), then every boundary entry. Rays leave and
   re-enter non-convex meshes this way. Shared faces are decided by the same three edge signs from
   both tets, so the walk neither skips nor repeats a tet; a tet without a single exit face ends the
   walk and is counted (``n_failed``).
4. **Integration and compositing** per segment as in the NumPy reference; a ray stops once what is
   left can change no channel by more than 1e-17 (``terminate``; a float64 redo of a renderer's rays
   passes that renderer's own bound).

The image is rendered in row blocks, launched concurrently from host threads on the CPU
(:mod:`warpvol.parallel`); ``progress`` gets the fraction of rows done, and a progress bar with the
time left is shown on a terminal or in a notebook (``show_progress``).
"""

from __future__ import annotations

import sys
import threading
import time
import weakref
from collections import OrderedDict
from typing import Callable

import numpy as np

from warpvol.conditioning.visibility import cell_visibility, cut_at_invisible
from warpvol.errors import ConfigError, check_choice
from warpvol.parallel import blocks, cpu_threads, launch_blocks, preload
from warpvol.reference.entries import _MIN_BLOCK, _box_area, _entry_faces, _entry_table, _uploader
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh
from warpvol.scene.transfer import EMISSION_MODELS, TransferFunction

_TRI_EDGES = ((0, 1), (0, 2), (1, 2))
_BOX_MARGIN = 1e-6  # pixels (relative): a face's box only has to contain every pixel it is hit at


class _View:
    """Pixel rays of a camera in its own frame (x right, y up, z forward)."""

    def __init__(self, camera: Camera):
        self.persp = camera.projection == "perspective"
        self.W, self.H = int(camera.width_px), int(camera.height_px)
        self.eye = np.asarray(camera.eye, dtype=np.float64)
        self.basis = np.stack([camera.right, camera.true_up, camera.forward]).astype(np.float64)
        if self.persp:
            th = np.tan(np.radians(camera.fov_y_deg) / 2.0)
            self.sx, self.sy = th * camera.aspect, th
        else:
            self.sx = self.sy = camera.ortho_height / 2.0
            self.sx = self.sx * camera.aspect
        # direction slopes (perspective) or positions (orthographic) of the pixel centres
        self.cx = (2.0 * (np.arange(self.W) + 0.5) / self.W - 1.0) * self.sx
        self.cy = (1.0 - 2.0 * (np.arange(self.H) + 0.5) / self.H) * self.sy

    def camera_coords(self, p: np.ndarray) -> np.ndarray:
        d = p - self.eye
        b = self.basis
        return np.stack([d[:, 0] * b[k, 0] + d[:, 1] * b[k, 1] + d[:, 2] * b[k, 2] for k in range(3)], axis=1)

    def boxes(self, x: np.ndarray, y: np.ndarray, z: np.ndarray):
        """Inclusive pixel boxes ``(i0, i1, j0, j1)`` of triangles (rows of ``x, y, z``) and which
        are on screen (perspective: the part in front of the eye)."""
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.persp:
                front = z > 0
                zs = np.where(front, z, 1.0)
                X, Y = x / zs, y / zs
                xlo = np.where(front, X, np.inf).min(axis=1)
                xhi = np.where(front, X, -np.inf).max(axis=1)
                ylo = np.where(front, Y, np.inf).min(axis=1)
                yhi = np.where(front, Y, -np.inf).max(axis=1)
                r = np.arange(len(x))
                for a, b in _TRI_EDGES:  # an edge through the eye plane: unbounded towards its crossing
                    cr = front[:, a] != front[:, b]
                    if not cr.any():
                        continue
                    p = np.where(front[:, a], a, b)
                    q = np.where(front[:, a], b, a)
                    zp, zq = z[r, p], z[r, q]
                    lam = np.where(cr, zp / np.where(cr, zp - zq, 1.0), 0.0)
                    px = x[r, p] + lam * (x[r, q] - x[r, p])
                    py = y[r, p] + lam * (y[r, q] - y[r, p])
                    at0 = cr & (px == 0) & (py == 0)
                    xlo = np.where((cr & (px <= 0)) | at0, -np.inf, xlo)
                    xhi = np.where((cr & (px >= 0)) | at0, np.inf, xhi)
                    ylo = np.where((cr & (py <= 0)) | at0, -np.inf, ylo)
                    yhi = np.where((cr & (py >= 0)) | at0, np.inf, yhi)
                valid = front.any(axis=1)
            else:
                xlo, xhi, ylo, yhi = x.min(axis=1), x.max(axis=1), y.min(axis=1), y.max(axis=1)
                valid = np.ones(len(x), dtype=bool)
            big = 1e15
            jlo = np.clip((xlo / self.sx + 1.0) * self.W / 2.0 - 0.5, -big, big)
            jhi = np.clip((xhi / self.sx + 1.0) * self.W / 2.0 - 0.5, -big, big)
            ilo = np.clip((1.0 - yhi / self.sy) * self.H / 2.0 - 0.5, -big, big)
            ihi = np.clip((1.0 - ylo / self.sy) * self.H / 2.0 - 0.5, -big, big)
        jlo = np.ceil(np.nan_to_num(jlo, nan=-big) - _BOX_MARGIN * (1.0 + np.abs(jlo)))
        jhi = np.floor(np.nan_to_num(jhi, nan=big) + _BOX_MARGIN * (1.0 + np.abs(jhi)))
        ilo = np.ceil(np.nan_to_num(ilo, nan=-big) - _BOX_MARGIN * (1.0 + np.abs(ilo)))
        ihi = np.floor(np.nan_to_num(ihi, nan=big) + _BOX_MARGIN * (1.0 + np.abs(ihi)))
        valid &= (jhi >= jlo) & (jhi >= 0) & (jlo <= self.W - 1) & (ihi >= ilo) & (ihi >= 0) & (ilo <= self.H - 1)
        box = np.stack([np.clip(ilo, 0, self.H - 1), np.clip(ihi, 0, self.H - 1),
                        np.clip(jlo, 0, self.W - 1), np.clip(jhi, 0, self.W - 1)], axis=1).astype(np.int32)
        return box, valid


def _mesh_data(mesh: TetMesh, view: _View, visible: np.ndarray | None = None) -> dict:
    """Per-mesh arrays of the walk, in camera coordinates (NumPy); with ``visible``, of the visible
    sub-mesh: faces into invisible tets are boundary faces (walks end there, entries start there) and
    only visible tets can hold the eye's chord."""
    Pc = view.camera_coords(np.asarray(mesh.points, dtype=np.float64))
    T, parity, perm = mesh.sorted_tets  # per mesh, kept by it
    hand = 1.0 if np.linalg.det(view.basis) > 0 else -1.0
    orient = parity * hand
    adj = np.take_along_axis(np.asarray(mesh.adjacency, dtype=np.int64), perm, axis=1)  # across face opposite T[:, f]
    if visible is not None:
        adj = cut_at_invisible(adj, visible)
    s_eye = np.zeros(1)
    if view.persp:  # not ``gradients @ eye``: a BLAS call leaves OpenBLAS's threads spinning for ~0.1 s,
        g, e = mesh.gradients, view.eye  # on the cores the walk's launches then wait for
        s_eye = g[:, 0] * e[0] + g[:, 1] * e[1] + g[:, 2] * e[2] + mesh.offsets
    near = np.zeros(0, dtype=np.int64)
    tol = 1e-9 * max(1.0, float(np.abs(Pc).max())) if len(Pc) else 0.0
    # tets whose (slightly grown) box holds the eye (the camera-frame origin): candidates for the chord
    # through it; none unless the mesh's own grown box holds the eye (each tet's box lies within it)
    if view.persp and len(Pc) and ((Pc.min(axis=0) <= tol) & (Pc.max(axis=0) >= -tol)).all():
        tp = Pc[T]
        lo, hi = tp.min(axis=1), tp.max(axis=1)
        near = np.flatnonzero(((lo <= tol) & (hi >= -tol)).all(axis=1) & (True if visible is None else visible))
    return dict(Pc=Pc, T=T, orient=orient, adj=adj, s_eye=s_eye, near=near, visible=visible)


#: the set-up of the pixel-list redos per mesh (kept while the mesh lives, as its cached properties):
#: (view key, mask key) -> :class:`_Setup`, the :data:`_PIXEL_SETUP_KEEP` last used of each mesh
_PIXEL_SETUP: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_PIXEL_SETUP_KEEP = 4
_PIXEL_SETUP_LOCK = threading.Lock()
#: devices the reference kernels are loaded on (a load that finds them loaded still costs ~50 ms of hashing)
_LOADED: set = set()


class _Setup:
    """A pixel-list redo's set-up for one (mesh, view, visibility mask): :func:`_mesh_data`, the entry
    faces of all rows (:func:`_entry_faces`), the walk's arrays per device (:func:`_walk_arrays`) and the
    view's entry table per device once a list needed most of it (:func:`_list_entries`)."""

    def __init__(self, md: dict, ent: tuple):
        self.md, self.ent = md, ent
        self.arrays: dict = {}
        self.tables: dict = {}


def _view_key(view: _View) -> tuple:
    return (view.persp, view.W, view.H, view.eye.tobytes(), view.basis.tobytes(), float(view.sx), float(view.sy))


def _mask_key(visible: np.ndarray | None):
    """The mask by content (a renderer's mask is a new array after a TF change; two equal masks share)."""
    return None if visible is None else (len(visible), np.packbits(visible).tobytes())


def _pixel_setup(mesh: TetMesh, view: _View, visible: np.ndarray | None = None) -> _Setup:
    """:class:`_Setup` of (mesh, view, mask), kept with the mesh for its last few (view, mask) pairs: a
    renderer redoes a few pixels in float64 once or twice per frame, and the set-up (~0.15 s on a 224k-tet
    mesh) would otherwise cost more than the walk."""
    key = (_view_key(view), _mask_key(visible))
    with _PIXEL_SETUP_LOCK:
        kept = _PIXEL_SETUP.setdefault(mesh, OrderedDict())
        hit = kept.get(key)
        if hit is not None:
            kept.move_to_end(key)
            return hit
    md = _mesh_data(mesh, view, visible)
    setup = _Setup(md, _entry_faces(md, view, 0, view.H - 1))
    with _PIXEL_SETUP_LOCK:
        kept[key] = setup
        while len(kept) > _PIXEL_SETUP_KEEP:
            kept.popitem(last=False)
    return setup


def _visible_mask(mesh: TetMesh, visible) -> np.ndarray | None:
    """``visible`` as a bool array over the tets (``None`` when absent or when every tet is visible)."""
    if visible is None:
        return None
    vis = np.asarray(visible)
    if vis.dtype != bool or vis.shape != (int(mesh.n_tets),):
        raise ConfigError(f"visible: expected a bool array of shape ({int(mesh.n_tets)},), got {vis.dtype} "
                          f"{vis.shape}")
    return None if vis.all() else vis


#: (mesh id, mask key, TF hash) of the masks checked against a transfer function, the last few
_CHECKED: OrderedDict = OrderedDict()


def _check_visible(mesh: TetMesh, tf: TransferFunction, visible: np.ndarray) -> None:
    """Refuse a mask that leaves out a tet the transfer function can make visible (one from another
    transfer function): its pixels would be silently wrong. Once per (mesh, mask, transfer function)."""

    key = (id(mesh), _mask_key(visible), tf.hash)
    with _PIXEL_SETUP_LOCK:
        if key in _CHECKED and _CHECKED[key]() is mesh:
            return
    n = int(np.count_nonzero(cell_visibility(mesh, tf, pad=0.0) & ~visible))
    if n:
        raise ConfigError(f"visible: the mask leaves out {n:,} tets whose scalar range the transfer function maps "
                          "above zero (a mask made for another transfer function?)")
    with _PIXEL_SETUP_LOCK:
        _CHECKED[key] = weakref.ref(mesh)
        while len(_CHECKED) > 16:
            _CHECKED.popitem(last=False)


def _walk_arrays(mesh: TetMesh, md: dict, view: _View, device: str) -> dict:
    """The walk's per-mesh arrays on ``device``."""
    import warp as wp

    arr = _uploader(device)
    f64 = wp.float64
    return dict(P=arr(md["Pc"], wp.vec3d), S=arr(np.asarray(mesh.scalars, dtype=np.float64), f64),
                T=arr(md["T"].astype(np.int32), wp.int32), adj=arr(md["adj"].astype(np.int32), wp.int32),
                orient=arr(md["orient"], f64), s_eye=arr(md["s_eye"], f64),
                near=arr(md["near"].astype(np.int32), wp.int32), cxs=arr(view.cx, f64), cys=arr(view.cy, f64))


#: a pixel list whose entry faces' boxes cover more than this share of all entry faces' boxes of the view
#: gets every entry of the view (about the same work), kept for the next lists on the same view
_WHOLE_VIEW_SHARE = 0.5


def _list_entries(setup: _Setup, plist: np.ndarray, first: int, last: int, wa: dict, view: _View, device: str,
                  threads: int) -> tuple[dict, bool]:
    """The entry table a pixel list needs (rows ``first..last``) and whether it is the whole view's: the
    walk reads only the listed pixels' entries, so only faces whose box holds one (counted on a summed-area
    table of the listed pixels over the rows) are searched, unless they cover most of the view's boxes."""
    W = view.W
    ftet, floc, fbox = setup.ent  # the kept faces of all rows
    if not len(ftet):
        return _entry_table(setup.ent, wa, view, device, threads), True
    if len(plist) * len(ftet) <= _DIRECT_PAIRS:  # a short list: each (face, pixel) pair tested
        keep = np.zeros(len(ftet), dtype=bool)
        pr, pc = plist // W, plist % W  # the listed pixels' rows lie in first..last: the boxes need no clipping
        step = max(1, _DIRECT_PAIRS // 4 // len(plist))
        for f0 in range(0, len(ftet), step):
            b = fbox[f0:f0 + step].astype(np.int64)
            keep[f0:f0 + step] = ((pr >= b[:, 0:1]) & (pr <= b[:, 1:2]) & (pc >= b[:, 2:3]) & (pc <= b[:, 3:4])).any(axis=1)
    else:
        sat = np.zeros((last - first + 2, W + 1), np.int64)
        np.add.at(sat, (plist // W - first + 1, plist % W + 1), 1)
        sat = sat.cumsum(axis=0).cumsum(axis=1)
        # boxes clipped to these rows as _entry_faces(first, last) clips them
        i0 = np.minimum(np.maximum(fbox[:, 0], first).astype(np.int64) - first, last - first + 1)
        i1 = np.minimum(fbox[:, 1], last).astype(np.int64) - first + 1
        i1 = np.maximum(i1, i0)  # a box outside the rows: empty
        j0, j1 = fbox[:, 2].astype(np.int64), fbox[:, 3].astype(np.int64) + 1
        keep = sat[i1, j1] - sat[i0, j1] - sat[i1, j0] + sat[i0, j0] > 0
    if _box_area(fbox[keep]) > _WHOLE_VIEW_SHARE * _box_area(fbox):
        return _entry_table(setup.ent, wa, view, device, threads), True
    box = fbox[keep].copy()
    box[:, 0] = np.maximum(box[:, 0], first)
    box[:, 1] = np.minimum(box[:, 1], last)
    return _entry_table((ftet[keep], floc[keep], box), wa, view, device, threads), False


def _progress_bar(show: bool | None, total: int):
    if show is None:
        show = (sys.stderr.isatty() or "ipykernel" in sys.modules) and total > 1
    if not show:
        return None
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    # stderr: stdout stays the caller's (a notebook cell's output, a command's summary)
    bar = Progress(TextColumn("exact reference"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
                   TextColumn("left"), TimeRemainingColumn(), transient=True, redirect_stdout=False,
                   console=Console(file=sys.stderr))
    bar.start()
    return bar


#: a pixel list times the entry faces up to this many pairs is matched face by pixel (else by a summed-area
#: table over the list's rows: two cumulative sums of the whole band, more work for a few hundred pixels)
_DIRECT_PAIRS = 1 << 22

_QUAD: dict = {}  # device -> the Gauss-Legendre nodes and weights on it (RefQuad), built once


def _quadrature(device: str):
    """The walk's 10- and 5-point Gauss-Legendre nodes and weights on ``device``, kept for the next calls
    (``leggauss`` solves an eigenproblem: milliseconds per call on a loaded machine, a float64 redo's whole
    budget for a few pixels)."""
    quad = _QUAD.get(device)
    if quad is None:
        import warp as wp

        from warpvol.kernels import reference as K

        arr, f64 = _uploader(device), wp.float64
        x10, w10 = np.polynomial.legendre.leggauss(10)
        x5, w5 = np.polynomial.legendre.leggauss(5)
        quad = K.RefQuad()
        quad.gx10, quad.gw10, quad.gx5, quad.gw5 = arr(x10, f64), arr(w10, f64), arr(x5, f64), arr(w5, f64)
        _QUAD[device] = quad
    return quad


def render_reference_warp(mesh: TetMesh, tf: TransferFunction, camera: Camera, *, device: str | None = None,
                          progress: Callable[[float], None] | None = None, stats: dict | None = None,
                          show_progress: bool | None = None, threads: int = 0,
                          rows_per_block: int = 0, rows: tuple[int, int] | None = None,
                          pixels: np.ndarray | None = None, visible: np.ndarray | None = None,
                          terminate: float | None = None, closed_form: bool = False) -> np.ndarray:
    """Exact float64 reference image, Warp kernels (same contract as the NumPy
    :func:`warpvol.reference.numpy_render.render_reference`).

    Parameters
    ----------
    mesh, tf, camera
        Mesh (need not be convex or connected), transfer function and camera; one ray per pixel
        centre (Contract 2), perspective eye anywhere (also inside the mesh or on a vertex).
    device : str, optional
        Warp device (default: Warp's preferred device).
    progress : callable, optional
        ``progress(done_fraction)`` after each block of rows.
    stats : dict, optional
        Filled with ``n_pairs`` (tet / boundary-face and pixel pairs tested), ``n_segments``,
        ``n_steps`` (tets visited), ``n_exact`` (edge predicates the
        float filter could not decide, evaluated exactly), ``n_entries`` (boundary entries),
        ``n_failed`` (walks that met a tet without one exit face; 0 for a valid mesh), ``warning``
        and ``failed_at`` (their flat positions in the output) when ``n_failed > 0``, and ``setup_s`` /
        ``render_s``.
    show_progress : bool, optional
        Progress bar with the time left (default: on a terminal or in a notebook, unless ``progress``
        is given).
    threads : int
        Host threads launching row blocks on the CPU (0: all cores).
    rows_per_block : int
        Rows per launch (0: chosen from the image and the cores).
    rows : (int, int), optional
        First and last image row (inclusive) to render; each pixel is computed on its own, so a
        band is bit-identical to the same rows of the whole image.
    pixels : array of int, optional
        Flat pixel indices (row * width + column) to render instead of whole rows (the rays a float32
        renderer could not resolve); each the same value as in the whole image. Overrides ``rows``.
    visible : bool array (n_tets,), optional
        The tets the transfer function can make visible (the ``visibility`` stage's ``visible_cells``):
        only these are walked, rays entering and re-entering at the visible sub-mesh's boundary faces
        (faces of visible tets whose neighbour is invisible or absent). Each tet's segment is computed
        from the tet alone, and one the transfer function maps to zero over its (padded) scalar range
        integrates to exactly zero colour and optical depth (``0 * finite``, ``exp(-0) = 1``), so the image
        is the one without the mask, bit for bit, as long as the float64 crossing scalars (convex
        combinations of vertex scalars) stay within the pad (the ``visibility`` stage pads by 8 float32
        ulps; not so for a ray in a face plane through a perspective eye, which takes the eye's
        scalar). A mask that leaves out a tet the transfer function can make visible is refused
        (``ConfigError``).
    terminate : float, optional
        Early ray termination: a ray stops once what lies behind can change no channel by more than this
        (default 1e-17: the reference image). A float64 redo of a renderer's rays passes that renderer's
        own bound (``raycast``'s ``t_min``), so the redone pixels leave out no more than its other pixels.
        In ``(0, 1]``.
    closed_form : bool
        Integrate each piece of one colour under ``color_extinction`` in closed form, ``c (1 - exp(-tau))``,
        instead of by quadrature (a renderer's float64 redo: within 1e-12 of the reference image's pixels,
        several times fewer exponentials on a transfer function of one colour). Default off: the reference
        image.

    Returns
    -------
    (H, W, 4) float64
        Premultiplied RGBA composited front to back over transparent black, row 0 = top; with
        ``rows``, ``(last - first + 1, W, 4)``; with ``pixels``, ``(len(pixels), 4)``.
    """
    import warp as wp

    from warpvol.kernels import reference as K

    check_choice("tf.emission", tf.emission, EMISSION_MODELS)
    terminate = K.TERMINATE if terminate is None else float(terminate)
    if not 0.0 < terminate <= 1.0:
        raise ConfigError(f"render_reference_warp: terminate must lie in (0, 1], got {terminate!r}")
    if int(threads) < 0:
        raise ConfigError(f"render_reference_warp: threads must be >= 0, got {threads}")
    t0 = time.perf_counter()
    wp.init()
    device = str(device or wp.get_preferred_device())
    on_cpu = device.startswith("cpu")
    threads = int(threads) or cpu_threads()
    view = _View(camera)
    W, H = view.W, view.H
    plist = None
    if pixels is not None:
        plist = np.asarray(pixels, dtype=np.int64).ravel()
        if len(plist) and (plist.min() < 0 or plist.max() >= W * H):
            raise ConfigError(f"pixels: flat indices must lie in [0, {W * H}), got {plist.min()} .. {plist.max()}")
        if len(plist) == 0:
            return np.zeros((0, 4))
        rows = (int(plist.min() // W), int(plist.max() // W))
    first, last = (0, H - 1) if rows is None else (int(rows[0]), int(rows[1]))
    if not 0 <= first <= last < H:
        raise ConfigError(f"rows: expected (first, last) with 0 <= first <= last < {H}, got {rows!r}")
    nrows = last - first + 1
    visible = _visible_mask(mesh, visible)
    if visible is not None:
        _check_visible(mesh, tf, visible)
    if plist is None:
        md = _mesh_data(mesh, view, visible)
        wa = _walk_arrays(mesh, md, view, device)
    else:  # per (mesh, view, mask), kept
        setup = _pixel_setup(mesh, view, visible)
        md = setup.md
        wa = setup.arrays.get(device)
        if wa is None:
            wa = setup.arrays[device] = _walk_arrays(mesh, md, view, device)
    if device not in _LOADED:
        preload(device, K)
        _LOADED.add(device)

    arr = _uploader(device)

    f64 = wp.float64
    P, S, T, adj, orient, s_eye, near, cxs, cys = (wa[k] for k in ("P", "S", "T", "adj", "orient", "s_eye", "near",
                                                                   "cxs", "cys"))
    persp = int(view.persp)

    # -- boundary entries per pixel ------------------------------------------------------------------
    if plist is None:
        tab = _entry_table(_entry_faces(md, view, first, last), wa, view, device, threads)
    else:
        tab = setup.tables.get(device)
        n_box = 0
        if tab is None:
            tab, whole = _list_entries(setup, plist, first, last, wa, view, device, threads)
            n_box = tab["n_box"]
            if whole:  # every entry of the view: kept for the next lists on it
                setup.tables[device] = tab
        cnt = tab["start"][plist + 1] - tab["start"][plist]
        tab = dict(tab, n_ent=int(cnt.sum()), n_box=n_box, n_exact=tab["n_exact"] if n_box else 0)
    ent_start, ent_t, ent_tet = tab["ent_start"], tab["ent_t"], tab["ent_tet"]

    # -- transfer function, quadrature, termination bound ---------------------------------------------
    pts = np.asarray(tf.points, dtype=np.float64)
    tf_s, tf_c = arr(pts[:, 0], f64), arr(pts[:, 1:5], wp.vec4d)
    ed = int(tf.emission == "emission_density")
    lo, hi = mesh.bounds
    cmax = float(np.abs(pts[:, 1:4]).max())
    c_bound = max(1.0, cmax * (float(np.linalg.norm(np.asarray(hi) - np.asarray(lo))) if ed else 1.0)) * 1.01
    setup_s = time.perf_counter() - t0

    # -- walk ------------------------------------------------------------------------------------------
    n_out = W * nrows if plist is None else len(plist)
    img = wp.zeros(n_out, dtype=wp.vec4d, device=device)
    counters = wp.zeros((n_out, 4), dtype=wp.int64, device=device)
    rpb = int(rows_per_block) or (max(1, nrows // (8 * threads)) if on_cpu else max(1, nrows // 16))
    rblocks = [(first + r0, nr) for r0, nr in blocks(nrows, rpb)]
    pix_arr = wp.zeros(0, dtype=wp.int32, device=device)
    if plist is not None:  # blocks of the list: (offset, count), one thread per listed pixel
        pix_arr = arr(plist.astype(np.int32), wp.int32)
        rblocks = blocks(len(plist), max(_MIN_BLOCK, -(-len(plist) // (8 * threads))) if on_cpu else len(plist))
        show_progress = False
    ents = K.RefEntries()
    ents.near, ents.ent_start, ents.ent_t, ents.ent_tet = near, ent_start, ent_t, ent_tet
    quad = _quadrature(device)
    common = [P, S, T, adj, orient, s_eye, ents, cxs, cys, persp, int(mesh.n_tets) + 1, f64(c_bound), f64(terminate),
              tf_s, tf_c, quad, ed, int(bool(closed_form)), img, counters]
    # a caller's own progress callback (the command line's bar, bench, stress) replaces the default bar
    bar = _progress_bar(show_progress if show_progress is not None or progress is None else False, len(rblocks))
    task = bar.add_task("reference", total=nrows) if bar is not None else None
    lock = threading.Lock()
    done = [0]

    def launch(b: int) -> None:
        r0, nr = rblocks[b]
        wp.launch(K.render_rows, dim=nr * W if plist is None else nr, device=device,
                  inputs=[r0, first, W, pix_arr] + common)
        if not on_cpu:
            wp.synchronize_device(device)
        with lock:
            done[0] += nr
            if bar is not None:
                bar.update(task, completed=done[0])
            if progress is not None:
                progress(done[0] / (nrows if plist is None else len(plist)))

    t1 = time.perf_counter()
    try:
        launch_blocks(device, len(rblocks), launch, threads)
    finally:
        if bar is not None:
            bar.stop()
    out_img = img.numpy().reshape(nrows, W, 4) if plist is None else img.numpy()
    render_s = time.perf_counter() - t1
    if stats is not None:
        c = counters.numpy().sum(axis=0)
        stats.update(n_pairs=int(c[1]) + tab["n_box"] + len(md["near"]) * W * nrows, n_segments=int(c[0]),
                     n_steps=int(c[1]), n_exact=int(c[2]) + tab["n_exact"], n_failed=int(c[3]),
                     n_entries=tab["n_ent"], n_bands=len(rblocks), setup_s=setup_s, render_s=render_s)
        if c[3]:  # flat positions in the output (pixel list: positions in the list)
            stats["failed_at"] = np.flatnonzero(counters.numpy()[:, 3] > 0)
        if c[3]:
            stats["warning"] = (f"exact reference: {int(c[3])} ray walk(s) met a tet without a single exit face; "
                                "those pixels are incomplete")
    return out_img
