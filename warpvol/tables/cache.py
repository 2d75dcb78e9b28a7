"""Table cache keyed by the transfer function's hash and the builder's parameters.

A key is ``(builder, dependency hash, sorted parameters..., format)``. The dependency hash is
``TransferFunction.hash`` for builders that integrate the TF, the hash of the normalised control-point
positions for the iso-crossing table (colour/extinction edits keep it), and ``None`` for TF-free
tables (the psi table): a TF edit therefore rebuilds exactly the tables that depend on what changed.

Examples
--------
>>> from warpvol.tables.cache import TableCache
>>> cache = TableCache()
>>> t = cache.get("psi", None, n=16)          # builds
>>> cache.get("psi", None, n=16) is t          # hit
True
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any

from warpvol.errors import check_choice
from warpvol.tables.base import Table, table_key
from warpvol.tables.cylindrical import build_cylindrical
from warpvol.tables.exact import build_exact3d
from warpvol.tables.guthe2d import build_guthe2d
from warpvol.tables.incremental import build_incremental
from warpvol.tables.isocross import build_isocross
from warpvol.tables.psi import build_psi
from warpvol.tables.roettger_sw import build_roettger_sw


def _builders() -> dict:
    b = {"exact3d": build_exact3d, "roettger_sw": build_roettger_sw, "incremental": build_incremental,
         "cylindrical": build_cylindrical, "guthe2d": build_guthe2d, "psi": build_psi, "isocross": build_isocross}
    try:
        from warpvol.tables.roettger_hw import build_roettger_hw

        b["roettger_hw"] = build_roettger_hw
    except ImportError:  # pragma: no cover - hardware units not available
        pass
    try:
        from warpvol.tables.pingpong import build_pingpong

        b["pingpong"] = build_pingpong
    except ImportError:  # pragma: no cover
        pass
    return b


TF_FREE = {"psi"}


def dependency_hash(builder: str, tf) -> str | None:
    """What a builder's table depends on: ``None`` (TF-free), iso positions, or the full TF hash."""
    if builder in TF_FREE:
        return None
    if builder == "isocross":
        from warpvol.tables.isocross import iso_hash

        return iso_hash(tf)
    return tf.hash


class TableCache:
    """In-memory LRU cache of :class:`Table` objects.

    Parameters
    ----------
    max_bytes : int
        Evict least recently used tables beyond this total size (default 1 GiB).
    """

    def __init__(self, max_bytes: int = 1 << 30):
        self.max_bytes = int(max_bytes)
        self._store: OrderedDict[tuple, Table] = OrderedDict()
        self.builds: list[tuple] = []  # keys built, in order (tests and reports read it)
        self.hits = 0

    def key(self, builder: str, tf, **params: Any) -> tuple:
        return table_key(builder, dependency_hash(builder, tf), **{k: v for k, v in params.items() if k != "device"})

    def get(self, builder: str, tf, **params: Any) -> Table:
        """The table of ``builder`` for ``tf`` and ``params``, built on a miss."""
        b = _builders()
        check_choice("builder", builder, tuple(b))
        key = self.key(builder, tf, **params)
        if key in self._store:
            self._store.move_to_end(key)
            self.hits += 1
            return self._store[key]
        if builder in TF_FREE:
            t = b[builder](**params)
        else:
            t = b[builder](tf, **params)
        self._store[key] = t
        self.builds.append(key)
        self._evict()
        return t

    def _evict(self) -> None:
        total = sum(t.nbytes for t in self._store.values())
        while total > self.max_bytes and len(self._store) > 1:
            _, t = self._store.popitem(last=False)
            total -= t.nbytes

    def invalidate(self, tf=None) -> int:
        """Drop every table depending on ``tf`` (all tables if ``None``); returns how many."""
        if tf is None:
            n = len(self._store)
            self._store.clear()
            return n
        hs = {tf.hash, dependency_hash("isocross", tf)}
        drop = [k for k in self._store if k[1] in hs]
        for k in drop:
            del self._store[k]
        return len(drop)

    def __len__(self) -> int:
        return len(self._store)

    def __contains__(self, key: tuple) -> bool:
        return key in self._store


DEFAULT_CACHE = TableCache()
