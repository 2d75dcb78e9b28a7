"""Helpers shared by the builders: argument checks, axes, TF upload, launching and timing."""

from __future__ import annotations

import time
from contextlib import contextmanager

import numpy as np

from ..errors import ConfigError, check_choice, check_number
from ..transfer import TransferFunction
from .base import Axis, Table, model_id, quantise, table_key

_KERNELS = None
#: builders that count their own work (GPU units, software samples) rather than host texels
SELF_COUNTING = ("roettger_hw", "pingpong", "roettger_sw")


def kernels():
    """Import (once) the kernel module; all its kernels are defined before any launch."""
    global _KERNELS
    if _KERNELS is None:
        import warp as wp

        wp.init()
        from ..kernels import preint

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


def launch_l_slices(kernel, n_l: int, n_s: int, device: str, inputs) -> None:
    """Launch a table kernel of dim ``(n_l, n_s, n_s)`` one l-slice at a time, the slices running
    concurrently on the CPU cores; ``inputs(l0, nl)`` returns the kernel inputs for slices
    ``l0 .. l0 + nl`` (with the l-indexed arrays sliced accordingly)."""
    import warp as wp

    from ..parallel import blocks, launch_blocks

    slabs = blocks(n_l, 1)

    def launch(b: int) -> None:
        l0, nl = slabs[b]
        wp.launch(kernel, dim=(nl, n_s, n_s), device=device, inputs=inputs(l0, nl))

    launch_blocks(device, len(slabs), launch)


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
        from ..gpu import counters as cnt

        cnt.count(host_texels=int(np.prod(v.shape[:-1])))
    dec, raw = quantise(v, fmt)
    return Table(name, dec, tuple(axes), tuple(channels), fmt, key, raw, meta, extra or {})


__all__ = ["Axis", "Table", "check_choice", "check_lmax", "check_res", "check_tf", "farr", "finish", "kernels",
           "linear_index_map", "model_id", "scalar_axis", "table_key", "tf_arrays", "timed"]
