"""Caches that live as long as the Python session: built pipelines, meshes by content, exact references.

:func:`warpvol.render` and :func:`warpvol.compare` build a pipeline per call from a preset name; a
pipeline keeps what its set-up stages built (per-mesh cell data, pre-integration tables) in its
``persistent`` state, keyed by the mesh *object* and the transfer function's *content*. This module
keeps those pipelines between calls and hands every render the one mesh object it already knows for
the same content (points, tets, scalars, source cells), so a camera orbit in a notebook pays the
set-up once. References are cached by the hash of everything the image depends on.

Memory is bounded: each cache is least-recently-used first out, within :data:`BUDGET_BYTES` for
all of them together (estimated from the arrays they hold); :func:`clear_cache` empties them.

Examples
--------
>>> import warpvol
>>> a, b = warpvol.builtin_scene("box").mesh, warpvol.builtin_scene("box").mesh
>>> a is b, content_hash(a) == content_hash(b), canonical_mesh(a) is canonical_mesh(b)
(False, True, True)
>>> clear_cache()
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from pathlib import Path
from typing import Any, Callable

import numpy as np

#: bytes all session caches together may hold (estimated from their arrays); the least recently used
#: entries go first. 2 GiB by default; set with :func:`set_cache_budget`.
BUDGET_BYTES = 2 << 30
#: entries per cache at most, whatever their size
MAX_ENTRIES = 16

_lock = threading.RLock()
_caches: dict[str, "OrderedDict[Any, tuple[Any, int]]"] = {"mesh": OrderedDict(), "pipeline": OrderedDict(),
                                                           "reference": OrderedDict()}


def _hash_arrays(h, *arrays) -> None:
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())


def content_hash(mesh) -> str:
    """Hash of a mesh's content (points, tets, scalars, source-cell grouping), kept on the mesh."""
    got = getattr(mesh, "_content_hash", None)
    if got is not None:
        return got
    h = hashlib.blake2b(digest_size=20)
    _hash_arrays(h, mesh.points, mesh.tets, mesh.scalars)
    cs = getattr(mesh, "cell_start", None)
    if cs is not None:
        _hash_arrays(h, cs)
    key = h.hexdigest()
    try:
        mesh._content_hash = key  # the arrays are private copies, so the hash stays valid
    except AttributeError:  # pragma: no cover - a mesh type with __slots__
        pass
    return key


def scene_key(scene) -> str:
    """Hash of what an image depends on: mesh content, transfer function, camera."""
    tf, cam = scene.transfer, scene.camera
    h = hashlib.blake2b(digest_size=20)
    h.update(content_hash(scene.mesh).encode())
    _hash_arrays(h, tf.points)
    h.update(tf.emission.encode())
    h.update(repr((cam.projection, tuple(map(float, cam.eye)), tuple(map(float, cam.target)),
                   tuple(map(float, cam.up)), float(cam.fov_y_deg), float(cam.ortho_height),
                   int(cam.width_px), int(cam.height_px))).encode())
    return h.hexdigest()


def nbytes(obj: Any, depth: int = 8, seen: set | None = None) -> int:
    """Bytes of the numpy and Warp arrays reachable from ``obj`` (dicts, lists, tuples, object
    attributes, ``depth`` levels down): the estimate the budget is kept with."""
    seen = set() if seen is None else seen
    if id(obj) in seen or depth < 0:
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        return int(obj.nbytes)
    cap = getattr(obj, "capacity", None)  # warp.array
    if isinstance(cap, int) and hasattr(obj, "ptr"):
        return cap
    if isinstance(obj, dict):
        return sum(nbytes(v, depth - 1, seen) for v in obj.values())
    if isinstance(obj, (list, tuple, set, frozenset)):
        return sum(nbytes(v, depth - 1, seen) for v in obj)
    d = getattr(obj, "__dict__", None)
    if isinstance(d, dict) and not isinstance(obj, type):
        return sum(nbytes(v, depth - 1, seen) for v in d.values())
    return 0


def _total() -> int:
    return sum(size for c in _caches.values() for _, size in c.values())


def _evict() -> None:
    """Drop least recently used entries until every cache holds at most MAX_ENTRIES and all fit the budget."""
    for c in _caches.values():
        while len(c) > MAX_ENTRIES:
            c.popitem(last=False)
    while _total() > BUDGET_BYTES:
        # the oldest entry of the cache holding the most bytes goes first
        name = max(_caches, key=lambda n: sum(s for _, s in _caches[n].values()))
        if not _caches[name]:
            break
        _caches[name].popitem(last=False)


def _get(cache: str, key: Any, build: Callable[[], Any], size: Callable[[Any], int] = nbytes) -> tuple[Any, bool]:
    with _lock:
        c = _caches[cache]
        if key in c:
            c.move_to_end(key)
            return c[key][0], True
    value = build()
    with _lock:
        c[key] = (value, size(value))
        _evict()
    return value, False


def _resize(cache: str, key: Any) -> None:
    """Re-estimate an entry's bytes (a pipeline grows as its set-up stages fill their caches)."""
    with _lock:
        c = _caches[cache]
        if key in c:
            c[key] = (c[key][0], nbytes(c[key][0]))
            _evict()


def canonical_mesh(mesh):
    """The mesh object this session already holds for ``mesh``'s content (``mesh`` itself the first
    time), so caches keyed by the mesh object hit for an equal mesh built again."""
    value, _ = _get("mesh", content_hash(mesh), lambda: mesh)
    return value


def pipeline(spec: Any, device: str, load: Callable[[], Any]) -> tuple[Any, Any]:
    """``(pipeline, key)``: the session's pipeline for a preset name or pipeline file (its content:
    an edited file is a new pipeline) on ``device``, built by ``load()`` on a miss. Pipeline objects
    passed by the caller are not cached (they keep their own state)."""
    s = str(spec)
    p = Path(s)
    ident = ("file", str(p.resolve()), hashlib.blake2b(p.read_bytes(), digest_size=16).hexdigest()) \
        if p.suffix == ".toml" and p.is_file() else ("preset", s)
    key = (ident, str(device))
    pipe, _ = _get("pipeline", key, load)
    return pipe, key


def pipeline_used(key: Any) -> None:
    """Account for what a cached pipeline built during a render (its tables, its per-mesh data)."""
    _resize("pipeline", key)


def reference(scene, compute: Callable[[], np.ndarray]) -> tuple[np.ndarray, bool]:
    """``(image, cached)``: the exact reference of ``scene`` from the session's cache, computed on a miss."""
    return _get("reference", scene_key(scene), compute)


def set_cache_budget(n_bytes: int) -> None:
    """Bytes all session caches together may hold (least recently used entries go first)."""
    global BUDGET_BYTES
    if not isinstance(n_bytes, (int, np.integer)) or isinstance(n_bytes, bool) or n_bytes < 0:
        from warpvol.errors import ConfigError

        raise ConfigError(f"set_cache_budget(n_bytes): expected an integer >= 0, got {n_bytes!r}")
    with _lock:
        BUDGET_BYTES = int(n_bytes)
        _evict()


def cache_info() -> dict[str, dict[str, int]]:
    """Entries and estimated bytes per session cache, and the budget.

    Examples
    --------
    >>> sorted(cache_info())
    ['budget_bytes', 'mesh', 'pipeline', 'reference']
    """
    with _lock:
        out: dict[str, Any] = {n: {"entries": len(c), "bytes": sum(s for _, s in c.values())}
                               for n, c in _caches.items()}
    out["budget_bytes"] = BUDGET_BYTES
    return out


def clear_cache() -> None:
    """Forget every pipeline, mesh and reference this session keeps (the next render builds anew)."""
    with _lock:
        for c in _caches.values():
            c.clear()
