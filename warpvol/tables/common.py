"""Helpers shared by the builders: argument checks, axes, TF upload, launching and timing."""

from __future__ import annotations

import threading
import time
from contextlib import contextmanager

import numpy as np

from warpvol.errors import ConfigError, check_choice, check_number
from warpvol.parallel import launch_blocks
from warpvol.progress import detail
from warpvol.scene.transfer import TransferFunction
from warpvol.tables.base import Axis, Table, model_id, quantise, table_key

_KERNELS = None
#: builders that count their own work (GPU units, software samples) rather than host texels
SELF_COUNTING = ("roettger_hw", "pingpong", "roettger_sw")


def kernels():
    """Import (once) the kernel module; all its kernels are defined before any launch."""
    global _KERNELS
    if _KERNELS is None:
        import warp as wp

        wp.init()
        from warpvol.kernels import preint

        _KERNELS = preint
    return _KERNELS


def check_tf(tf, where: str = "tf") -> TransferFunction:
    if not isinstance(tf, TransferFunction):
        raise ConfigError(f"{where}: expected a TransferFunction, got {type(tf).__name__}")
    return tf


def check_res(name: str, n, lo: int = 1, hi: int = 4096) -> int:
    return int(check_number(name, n, lo=lo, hi=hi, integer=True))


def check_lmax(lmax) -> float:
    return float(check_number("lmax", lmax, lo=0.0, lo_open=True))


def scalar_axis(name: str, tf: TransferFunction, n: int, kind: str = "centred") -> Axis:
    lo, hi = tf.srange
    return Axis(name, n, kind, scale=hi - lo, offset=lo)


def farr(x, device: str):
    import warp as wp

    return wp.array(np.ascontiguousarray(x, dtype=np.float32), dtype=wp.float32, device=device)


#: texel-pieces (texels times TF pieces a texel may cross) in one launch: ~0.1 s of one CPU core, so
#: Ctrl-C stops a build within about a launch and progress advances in small steps
BAND_WORK = 4_000_000
#: a build running longer than this (seconds) reports its progress, then again every this often
PROGRESS_EVERY = 2.0
_progress = threading.local()


@contextmanager
def progress_to(report):
    """Table builds started in this block (on this thread) report long builds through ``report(msg)``
    (a stage's ``ctx.progress``)."""
    saved = getattr(_progress, "fn", None)
    _progress.fn = report
    try:
        yield
    finally:
        _progress.fn = saved


def launch_bands(kernel, n_l: int | None, n_rows: int, n_cols: int, device: str, inputs, *, pieces: int = 1,
                 what: str = "table") -> None:
    """Launch a table kernel of dim ``(n_l, n_rows, n_cols)`` (``(n_rows, n_cols)`` with ``n_l=None``)
    in blocks of one l-slice and a band of rows, the blocks running concurrently on the CPU cores.

    ``inputs(l0, nl, j0, nj)`` returns the kernel inputs for slices ``l0 .. l0 + nl`` and rows
    ``j0 .. j0 + nj`` (the l- and row-indexed arrays sliced accordingly; ``l0, nl`` are ``0, 1``
    for a 2D kernel). A band holds about :data:`BAND_WORK` texel-pieces (``pieces``: the TF pieces a
    texel's segment may cross), so every launch is short: Ctrl-C (``KeyboardInterrupt``) drops the
    blocks not started and returns after the launches in flight, and a build longer than
    :data:`PROGRESS_EVERY` seconds reports its progress through :func:`progress_to`'s callback.
    Texels are computed the same way whatever the banding (images do not depend on it).
    """
    import warp as wp


    rows = max(1, min(n_rows, BAND_WORK // max(1, n_cols * (1 + max(1, pieces)))))
    slabs = [(l0, j0, min(rows, n_rows - j0)) for l0 in range(n_l or 1) for j0 in range(0, n_rows, rows)]
    report = getattr(_progress, "fn", None)
    lock = threading.Lock()
    state = {"done": 0, "t0": time.perf_counter(), "last": time.perf_counter()}

    def launch(b: int) -> None:
        l0, j0, nj = slabs[b]
        dim = (nj, n_cols) if n_l is None else (1, nj, n_cols)
        wp.launch(kernel, dim=dim, device=device, inputs=inputs(l0, 1, j0, nj))
        with lock:
            state["done"] += 1
            detail(what, state["done"] / len(slabs))  # the build's share done, where a progress bar is open
        if report is None:
            return
        with lock:
            now = time.perf_counter()
            if now - state["last"] >= PROGRESS_EVERY and state["done"] < len(slabs):
                state["last"] = now
                report(f"{what}: {state['done']}/{len(slabs)} blocks ({100.0 * state['done'] / len(slabs):.0f} %, "
                       f"{now - state['t0']:.0f} s)")

    launch_blocks(device, len(slabs), launch, modules=[kernel])


def tf_pieces(tf: TransferFunction) -> int:
    """Pieces of the TF as the kernels see it (collinear runs merged: :func:`warpvol.kernels.tf.device_points`)."""
    from warpvol.kernels.tf import device_points

    return max(1, len(device_points(tf.points)) - 1)


def tf_arrays(tf: TransferFunction, device: str):
    return tf.to_warp(device)


def linear_index_map(axis: Axis) -> tuple[float, float]:
    """``(a, b)`` with continuous texel index ``a x + b`` for a linear axis kind."""
    if axis.kind == "centred":
        return float(axis.n), -0.5
    if axis.kind == "endpoint":
        return float(axis.n - 1), 0.0
    raise ConfigError(f"axis {axis.name}: kind {axis.kind!r} is not linear")


@contextmanager
def timed(meta: dict, key: str = "build_s", device: str = "cpu"):
    import warp as wp

    t0 = time.perf_counter()
    yield
    wp.synchronize_device(device)
    meta[key] = meta.get(key, 0.0) + time.perf_counter() - t0


def finish(name: str, values: np.ndarray, axes, channels, fmt: str, key: tuple, meta: dict,
           extra: dict | None = None) -> Table:
    """Quantise to the stored format, check finiteness, wrap as a :class:`Table`."""
    v = np.asarray(values, dtype=np.float32)
    if not np.isfinite(v).all():  # a builder bug, never an input problem: fail loudly
        raise FloatingPointError(f"table {name}: {int((~np.isfinite(v)).sum())} non-finite entries")
    if name not in SELF_COUNTING:  # texels computed on the host (the hardware builders count their units)
        from warpvol.gpu import counters as cnt

        cnt.count(host_texels=int(np.prod(v.shape[:-1])))
    dec, raw = quantise(v, fmt)
    return Table(name, dec, tuple(axes), tuple(channels), fmt, key, raw, meta, extra or {})


__all__ = ["Axis", "Table", "check_choice", "check_lmax", "check_res", "check_tf", "farr", "finish", "kernels",
           "launch_bands", "linear_index_map", "model_id", "progress_to", "scalar_axis", "table_key", "tf_arrays",
           "tf_pieces", "timed"]
