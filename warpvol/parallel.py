"""Concurrent Warp launches on the CPU.

Warp's CPU backend runs all threads of one launch serially on the calling host thread, but releases
the GIL while the kernel runs. Work that splits into independent blocks (row blocks of an image,
slices of a table) can therefore use every core by launching the blocks from a pool of host threads.
On CUDA one launch already fills the device, so blocks run in order on the calling thread.
"""

from __future__ import annotations

import os
import random
import threading
from concurrent.futures import ThreadPoolExecutor, wait
from typing import Callable, Iterable


def cpu_threads() -> int:
    """Cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def blocks(n: int, size: int) -> list[tuple[int, int]]:
    """``(start, count)`` blocks covering ``range(n)``."""
    return [(s, min(size, n - s)) for s in range(0, n, max(1, size))]


_pools: dict[int, ThreadPoolExecutor] = {}  # by thread count, for this process (see _shared_pool)
_pools_pid = os.getpid()
_pools_lock = threading.Lock()
_worker = threading.local()


def _mark_worker() -> None:
    _worker.shared = True


def _shared_pool(threads: int) -> ThreadPoolExecutor | None:
    """The process's pool of ``threads`` host threads for :func:`launch_blocks`, kept between calls (a
    pool per call started its threads again: about a millisecond per call on a loaded 2-core machine);
    ``None`` on one of its own threads (blocks launching blocks get a pool of their own instead of waiting
    on the one they run in). A forked child starts new pools (threads do not survive a fork)."""
    global _pools_pid
    if getattr(_worker, "shared", False):
        return None
    with _pools_lock:
        if _pools_pid != os.getpid():
            _pools.clear()
            _pools_pid = os.getpid()
        pool = _pools.get(threads)
        if pool is None:
            pool = _pools[threads] = ThreadPoolExecutor(max_workers=threads, initializer=_mark_worker,
                                                        thread_name_prefix=f"warpvol-blocks-{threads}")
        return pool


def launch_blocks(device: str, n_blocks: int, launch: Callable[[int], None], threads: int = 0, *,
                  modules: Iterable = ()) -> None:
    """Call ``launch(b)`` for every block ``b``; concurrently from ``threads`` host threads on the CPU
    (0: all cores), in order on other devices.

    ``modules`` names what the launches run (Warp kernels, Warp modules or Python modules of kernels):
    they are compiled or loaded here, on the calling thread, before any block starts (:func:`preload`),
    so that no two host threads compile the same module at once. A module not named still compiles
    once: before the threads start, Warp's loader is wrapped to let one thread at a time into a
    module's load (:func:`warpvol.timing.install_loader`); the others wait for it.

    The host threads are kept for the next call (:func:`_shared_pool`). An exception in the calling thread
    while it waits (``KeyboardInterrupt`` from Ctrl-C) or in a block cancels the blocks not yet started; a
    CPU launch in flight cannot be interrupted, so the wait is one block's time. With :func:`launch_order` ``reversed`` or ``shuffled`` (a debug mode) the CPU
    blocks start in that order, from at least two host threads."""
    threads = threads or cpu_threads()
    if n_blocks > 0:
        preload(device, *modules)
    order = list(range(n_blocks))
    if str(device).startswith("cpu") and (mode := launch_order()) != "serial":  # debug: blocks in another order
        order = order[::-1] if mode == "reversed" else random.Random(n_blocks).sample(order, n_blocks)
        threads = max(2, threads)
    if str(device).startswith("cpu") and threads > 1 and n_blocks > 1:
        from warpvol.timing import install_loader

        install_loader()
        failed = threading.Event()  # set by the first block that raises: queued blocks then do nothing

        def guarded(b: int) -> None:
            if failed.is_set():
                return
            try:
                launch(b)
            except BaseException:
                failed.set()
                raise

        shared = _shared_pool(threads)
        pool = shared or ThreadPoolExecutor(max_workers=min(threads, n_blocks))
        futures = []
        try:
            futures = [pool.submit(guarded, b) for b in order]
            for f in futures:
                f.result()
        except BaseException:
            # Ctrl-C (or a failed block): drop the queued blocks; only launches in flight finish
            failed.set()
            for f in futures:
                f.cancel()
            wait(futures)
            raise
        finally:
            if shared is None:
                pool.shutdown(wait=True, cancel_futures=True)
    else:
        for b in order:
            launch(b)


def row_blocks(n_rows: int, n_jobs: int, threads: int, device: str) -> list[tuple[int, int]]:
    """Row blocks splitting each of ``n_jobs`` equal-cost slice draws so the CPU cores get >= 4 jobs
    each (one block, all rows, on other devices or when there are enough slices)."""
    threads = threads or cpu_threads()
    if not str(device).startswith("cpu") or threads == 1:
        return [(0, n_rows)]
    want = 4 * threads
    per = max(1, -(-want // max(1, n_jobs)))
    return blocks(n_rows, -(-n_rows // min(per, n_rows)))


def preload(device: str, *modules) -> None:
    """Compile and load Warp ``modules`` (Warp kernels, Warp modules or Python modules of kernels) for
    ``device`` on the calling thread, before host threads launch their kernels (a module's first launch
    compiles it; two threads would each compile it). Each module is loaded once however often it is
    named; one already loaded returns at once."""
    import warp as wp

    seen: list = []
    for m in modules:
        m = getattr(m, "module", m) if isinstance(m, wp.Kernel) else m
        if any(m is s for s in seen):
            continue
        seen.append(m)
        wp.load_module(m, device=device)


# ------------------------------------------------------------------------------------------------
# debug launch order: every launch's threads in another order on the CPU
# ------------------------------------------------------------------------------------------------

#: ``WARPVOL_LAUNCH_ORDER``: ``serial`` (Warp's CPU order, thread 0 first), ``reversed`` (last thread
#: first; blocks of :func:`launch_blocks` last first, concurrently), ``shuffled`` (blocks of 32 threads
#: in a scattered order, each block's threads last first; blocks of :func:`launch_blocks` shuffled,
#: concurrently)
LAUNCH_ORDERS = ("serial", "reversed", "shuffled")

_SERIAL_LOOP = """    for (size_t task_index = 0; task_index < dim->size; ++task_index)
    {{
        {name}_cpu_kernel_forward<wp_linear_contiguous>(*dim, task_index, _wp_args);
    }}"""

_ORDERED_LOOP = {
    "reversed": """    for (size_t wp_k = dim->size; wp_k-- > 0;)
    {{
        {name}_cpu_kernel_forward<wp_linear_contiguous>(*dim, wp_k, _wp_args);
    }}""",
    # blocks of 32 threads visited as q -> (q * step + 5) mod nb, step coprime with nb (a permutation
    # that scatters neighbouring blocks), the threads of each block last first
    "shuffled": """    const size_t wp_n = dim->size;
    const size_t wp_nb = (wp_n + 31) / 32;
    size_t wp_step = wp_nb / 2 + 1;
    for (;; ++wp_step)
    {{
        size_t wp_a = wp_step, wp_b = wp_nb;
        while (wp_b) {{ size_t wp_t = wp_a % wp_b; wp_a = wp_b; wp_b = wp_t; }}
        if (wp_a == 1) break;
    }}
    for (size_t wp_q = 0; wp_q < wp_nb; ++wp_q)
    {{
        const size_t wp_lo = ((wp_q * wp_step + 5) % wp_nb) * 32;
        const size_t wp_hi = wp_lo + 32 < wp_n ? wp_lo + 32 : wp_n;
        for (size_t wp_k = wp_hi; wp_k-- > wp_lo;)
        {{
            {name}_cpu_kernel_forward<wp_linear_contiguous>(*dim, wp_k, _wp_args);
        }}
    }}""",
}


def launch_order() -> str:
    """The debug launch order from ``WARPVOL_LAUNCH_ORDER`` (default ``serial``)."""
    order = os.environ.get("WARPVOL_LAUNCH_ORDER", "serial") or "serial"
    if order not in LAUNCH_ORDERS:
        raise ValueError(f"WARPVOL_LAUNCH_ORDER: {order!r} not allowed; allowed: {', '.join(LAUNCH_ORDERS)}")
    return order


def apply_launch_order() -> str:
    """Make Warp's CPU kernels run their threads in :func:`launch_order` (a debug mode that finds kernels
    depending on the CPU's serial order, which a GPU does not keep). Called when ``warpvol.kernels`` is
    first imported, before any kernel compiles: Warp's CPU code template gets the other loop, and the
    kernels are compiled into their own cache (``WARPVOL_ORDER_CACHE``, else
    ``~/.cache/warpvol/warp-order-<order>``; the module hashes do not see the template). Relies on
    Warp's code template (checked: an error if the serial loop is not where it is expected)."""
    order = launch_order()
    if order == "serial":
        return order
    import warp as wp
    from warp._src import build, codegen

    tpl = codegen.cpu_module_template_forward
    if _SERIAL_LOOP not in tpl and all(v not in tpl for v in _ORDERED_LOOP.values()):
        raise RuntimeError(f"WARPVOL_LAUNCH_ORDER={order}: Warp {wp.config.version}'s CPU kernel template has no "
                           "serial thread loop where it is expected; this debug mode does not support it")
    for v in _ORDERED_LOOP.values():
        tpl = tpl.replace(v, _SERIAL_LOOP)
    codegen.cpu_module_template_forward = tpl.replace(_SERIAL_LOOP, _ORDERED_LOOP[order])
    cache = os.environ.get("WARPVOL_ORDER_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "warpvol",
                                                                  f"warp-order-{order}")
    os.makedirs(cache, exist_ok=True)
    build.init_kernel_cache(cache)  # before wp.init() or after: later compiles go there
    return order
