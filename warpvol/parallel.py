"""Concurrent Warp launches on the CPU.

Warp's CPU backend runs all threads of one launch serially on the calling host thread, but releases
the GIL while the kernel runs. Work that splits into independent blocks (row blocks of an image,
slices of a table) can therefore use every core by launching the blocks from a pool of host threads.
On CUDA one launch already fills the device, so blocks run in order on the calling thread.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Callable


def cpu_threads() -> int:
    """Cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def blocks(n: int, size: int) -> list[tuple[int, int]]:
    """``(start, count)`` blocks covering ``range(n)``."""
    return [(s, min(size, n - s)) for s in range(0, n, max(1, size))]


def launch_blocks(device: str, n_blocks: int, launch: Callable[[int], None], threads: int = 0) -> None:
    """Call ``launch(b)`` for every block ``b``; concurrently from ``threads`` host threads on the CPU
    (0: all cores), in order on other devices.

    An exception in the calling thread while it waits (``KeyboardInterrupt`` from Ctrl-C) or in a block
    cancels the blocks not yet started; a CPU launch in flight cannot be interrupted, so the wait is
    one block's time."""
    threads = threads or cpu_threads()
    if str(device).startswith("cpu") and threads > 1 and n_blocks > 1:
        failed = threading.Event()  # set by the first block that raises: queued blocks then do nothing

        def guarded(b: int) -> None:
            if failed.is_set():
                return
            try:
                launch(b)
            except BaseException:
                failed.set()
                raise

        pool = ThreadPoolExecutor(max_workers=min(threads, n_blocks))
        try:
            for f in [pool.submit(guarded, b) for b in range(n_blocks)]:
                f.result()
        except BaseException:
            # Ctrl-C (or a failed block): drop the queued blocks; only launches in flight finish
            failed.set()
            pool.shutdown(wait=True, cancel_futures=True)
            raise
        pool.shutdown(wait=True)
    else:
        for b in range(n_blocks):
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
    """Compile and load Warp ``modules`` for ``device`` on the calling thread, before host threads
    launch their kernels (a module's first launch compiles it; two threads would each compile it)."""
    import warp as wp

    for m in modules:
        wp.load_module(m, device=device)
