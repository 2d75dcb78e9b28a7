"""Where a render's time goes: Warp kernel compilation and module loading, kept apart from the frame.

Warp compiles a kernel module on its first launch on a device (and loads it from the kernel cache on the
first launch of later processes). That work happens once per machine or process, so it must not be
reported as the time of a frame. :class:`CompileClock` measures the wall time spent inside Warp's
module loader while it is active; :class:`~warpvol.pipeline.Pipeline` wraps each stage in one and
reports ``compile_s`` apart from the per-mesh set-up (``setup_s``) and the frame (``render_s``).

The loader is wrapped the first time a clock is used or blocks are launched from host threads
(:func:`install_loader`; never at import), and the wrapper costs a few microseconds per launch: Warp
calls the loader on every launch, which returns at once when the module is already loaded. Calls
shorter than :data:`MIN_LOAD_S` are such fast paths and are not counted. The wrapper also lets one
thread at a time into a module's loader: a thread launching a module another thread is compiling
waits for that compilation and then loads the result, instead of compiling the module a second time.

Examples
--------
>>> import warp as wp
>>> with CompileClock() as clock:
...     pass
>>> clock.seconds, clock.modules
(0.0, [])
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Callable

#: a loader call shorter than this is Warp's "already loaded" fast path, not a compilation or a load
MIN_LOAD_S = 1e-3
#: a load still running after this long is announced (``on_slow``): a kernel compilation
ANNOUNCE_AFTER_S = 0.5

_lock = threading.Lock()
_active: list["CompileClock"] = []
_local = threading.local()
_load_locks: dict[tuple[int, str], threading.RLock] = {}  # see _module_lock
_installed = False


def _module_class():
    """Warp's ``Module`` class (its location differs between Warp versions); ``None`` if not found."""
    try:
        from warp._src import context as ctx  # Warp >= 1.10
    except ImportError:  # pragma: no cover - older Warp
        try:
            from warp import context as ctx
        except ImportError:
            return None
    return getattr(ctx, "Module", None)


def _module_lock(module, device) -> threading.RLock:
    """The lock of one Warp module's loader on one device (made on first use; ``dict.setdefault`` is
    atomic). Loads on different devices, or of different modules, do not wait for each other."""
    key = (id(module), str(device))
    return _load_locks.get(key) or _load_locks.setdefault(key, threading.RLock())


def install_loader() -> bool:
    """Wrap Warp's module loader (:func:`_install`): before blocks are launched from host threads, so
    that two threads never compile one module at once."""
    return _install()


def _install() -> bool:
    """Wrap ``Module.load`` once per process; ``False`` when this Warp has no such method."""
    global _installed
    with _lock:
        if _installed:
            return True
        mod = _module_class()
        orig = getattr(mod, "load", None) if mod is not None else None
        if orig is None:  # pragma: no cover - unknown Warp layout: compile time stays inside the stages
            return False

        def load(self, device, *args, **kwargs):
            with _module_lock(self, device):  # one thread at a time: a module compiles once
                return timed_load(self, device, *args, **kwargs)

        def timed_load(self, device, *args, **kwargs):
            if getattr(_local, "depth", 0) or not _active or _loaded(self, device, args, kwargs):
                return orig(self, device, *args, **kwargs)
            _local.depth = 1
            clocks = list(_active)
            timer = threading.Timer(ANNOUNCE_AFTER_S, _announce, (clocks, getattr(self, "name", "?")))
            timer.daemon = True
            timer.start()
            t0 = time.perf_counter()
            try:
                return orig(self, device, *args, **kwargs)
            finally:
                timer.cancel()
                _local.depth = 0
                dt = time.perf_counter() - t0
                if dt >= MIN_LOAD_S:
                    for c in clocks:
                        c._add(dt, getattr(self, "name", "?"))

        load.__wrapped__ = orig  # type: ignore[attr-defined]
        mod.load = load
        _installed = True
        return True


def _loaded(module, device, args: tuple, kwargs: dict) -> bool:
    """Whether Warp's loader will return at once: ``module``'s executable for ``device`` (and block size)
    is loaded and current -- Warp's own test, repeated here so that such a call starts no announcing
    timer (a thread per launch). ``False`` wherever this Warp keeps its modules otherwise."""
    try:
        import warp as wp

        bd = kwargs.get("block_dim", args[0] if args else None)
        bd = module.options["block_dim"] if bd is None else bd
        ex = module.execs.get((wp.get_device(device).context, bd))
        return ex is not None and bool(module.options["strip_hash"] or ex.module_hash == module.get_module_hash(bd))
    except Exception:  # noqa: BLE001 - another Warp layout: the timed path
        return False


def _announce(clocks: list["CompileClock"], module: str) -> None:
    for c in clocks:
        if c.on_slow is not None:
            c._announce(module)


class CompileClock:
    """Context manager: wall time spent in Warp's module loader (compilation, kernel-cache loads) while
    it is active, on any thread.

    Parameters
    ----------
    on_slow : callable, optional
        Called once, with the module's name, when a load is still running after
        :data:`ANNOUNCE_AFTER_S` seconds (a compilation): lets a command line say so before the wait.

    Attributes
    ----------
    seconds : float
        Loader time (summed over threads; callers cap it at their own wall time).
    modules : list of str
        Modules loaded or compiled, in order.
    available : bool
        ``False`` when this Warp version's loader could not be wrapped (then ``seconds`` stays 0).
    """

    def __init__(self, on_slow: Callable[[str], None] | None = None):
        self.seconds = 0.0
        self.modules: list[str] = []
        self.on_slow = on_slow
        self.available = False
        self._announced = False
        self._mine = threading.Lock()

    def _add(self, dt: float, module: str) -> None:
        with self._mine:
            self.seconds += dt
            self.modules.append(module)

    def _announce(self, module: str) -> None:
        with self._mine:
            if self._announced:
                return
            self._announced = True
        try:
            self.on_slow(module)
        except Exception:  # noqa: BLE001 - a message must never break a render
            pass

    def __enter__(self) -> "CompileClock":
        self.available = _install()
        with _lock:
            _active.append(self)
        return self

    def __exit__(self, *exc) -> None:
        with _lock:
            if self in _active:
                _active.remove(self)


def announce_compile(module: str) -> None:
    """Default ``on_slow`` of the command line and of ``quiet=False`` renders: one line on stderr."""
    print(f"[warpvol] compiling Warp kernels ({module}; once per machine, then loaded from Warp's kernel "
          "cache) ...", file=sys.stderr, flush=True)


def split_times(stage_rows: dict[str, dict], total_s: float) -> dict[str, float]:
    """``compile_s``, ``setup_s``, ``render_s`` and ``total_s`` from per-stage rows ``{"s", "compile_s",
    "setup"}``: compilation wherever it happened, the set-up stages' remaining time plus the per-mesh
    set-up other stages computed on first use (a row's ``first_use_s``), and the rest (the frame,
    including the planner's own time) so that the three add up to ``total_s``.

    Examples
    --------
    >>> rows = {"cell_setup": {"s": 0.5, "compile_s": 0.25, "setup": True},
    ...         "raycast": {"s": 2.0, "compile_s": 1.5, "setup": False}}
    >>> split_times(rows, 2.75)
    {'compile_s': 1.75, 'setup_s': 0.25, 'render_s': 0.75, 'total_s': 2.75}
    """
    compile_s = sum(r["compile_s"] for r in stage_rows.values())
    setup_s = sum(r["s"] - r["compile_s"] if r["setup"] else min(r.get("first_use_s", 0.0), r["s"] - r["compile_s"])
                  for r in stage_rows.values())
    return {"compile_s": compile_s, "setup_s": setup_s, "render_s": max(0.0, total_s - compile_s - setup_s),
            "total_s": total_s}


def process_age_s() -> float | None:
    """Seconds since this process started (the interpreter's start-up and imports included), for a
    command line's ``wall_s``: the system's uptime less the process's start tick (Linux ``/proc``, to
    the clock tick, 10 ms); ``None`` where there is no ``/proc``. (psutil's ``create_time`` rests on the
    boot time in whole seconds, up to a second off.)"""
    import os

    try:
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        with open("/proc/self/stat") as f:
            stat = f.read()
        start_ticks = int(stat[stat.rindex(")") + 2:].split()[19])  # field 22 (starttime), after comm
        return max(0.0, uptime - start_ticks / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError):
        return None


def wall_fields(report: dict, *, startup_s: float, conversion_s: float, wall_s: float) -> dict:
    """Add what a call spent outside the pipeline to ``report``: ``startup_s`` (Warp start-up, the
    pipeline's loading and, on the command line, the interpreter and its imports), ``conversion_s``
    (reading and converting the inputs: mesh, scene, a reference image) and ``wall_s``, what the caller
    waited. ``startup_s + conversion_s + reference_s + total_s`` make up ``wall_s`` but for the report's
    own bookkeeping (the error against the reference, a few milliseconds), kept as ``other_s``.

    Examples
    --------
    >>> r = wall_fields({"total_s": 1.0, "reference_s": 0.5}, startup_s=0.25, conversion_s=0.125, wall_s=1.9)
    >>> r["wall_s"], round(r["other_s"], 3)
    (1.9, 0.025)
    """
    report["startup_s"] = startup_s
    report["conversion_s"] = conversion_s
    report["wall_s"] = wall_s
    report["other_s"] = max(0.0, wall_s - startup_s - conversion_s - (report.get("reference_s") or 0.0)
                            - report["total_s"])
    return report


def time_summary(report: dict) -> str:
    """The frame time first, then what else the render spent, e.g. ``"frame 0.740 s (+ set-up 0.290 s,
    kernel compilation 11.5 s)"``; a report without the split gives its total.

    Examples
    --------
    >>> time_summary({"total_s": 1.2, "render_s": 0.2, "setup_s": 0.0, "compile_s": 1.0})
    'frame 0.200 s (+ kernel compilation 1.000 s)'
    """
    if "render_s" not in report:
        return f"{report['total_s']:.3f} s"
    extra = [f"{what} {report[k]:.3f} s" for k, what in (("setup_s", "set-up"), ("compile_s", "kernel compilation"))
             if report.get(k, 0.0) >= 5e-4]
    return f"frame {report['render_s']:.3f} s" + (f" (+ {', '.join(extra)})" if extra else "")


def wall_summary(report: dict) -> str:
    """The reference's time and what the call waited in all, for the command line's summary line, e.g.
    ``"; reference 1.20 s; wall 3.40 s (start-up 1.10 s, scene 0.20 s)"``; empty for a report without them.

    Examples
    --------
    >>> wall_summary({"reference_s": 1.2, "wall_s": 3.4, "startup_s": 1.1, "conversion_s": 0.2})
    '; reference 1.20 s; wall 3.40 s (start-up 1.10 s, scene 0.20 s)'
    """
    out = f"; reference {report['reference_s']:.2f} s" if report.get("reference_s") is not None else ""
    if report.get("wall_s") is not None:
        out += f"; wall {report['wall_s']:.2f} s (start-up {report['startup_s']:.2f} s, scene " \
               f"{report['conversion_s']:.2f} s)"
    return out


# ------------------------------------------------------------------------------------------------
# device reads: each ``wp.array.numpy()`` is a device-to-host copy and a sync on a GPU
# ------------------------------------------------------------------------------------------------

_reads_active: list["ReadCounter"] = []
_reads_installed = False


def _install_reads() -> bool:
    """Wrap ``warp.array.numpy`` once per process; ``False`` when this Warp has no such method."""
    global _reads_installed
    with _lock:
        if _reads_installed:
            return True
        import warp as wp

        orig = getattr(wp.array, "numpy", None)
        if orig is None:  # pragma: no cover - unknown Warp layout
            return False

        def numpy(self, *args, **kwargs):
            if _reads_active and not getattr(_local, "reading", 0):
                dev = str(getattr(self, "device", ""))
                for c in list(_reads_active):
                    if c.device is None or dev == c.device:
                        c._add()
            _local.reading = getattr(_local, "reading", 0) + 1  # a read inside a read counts once
            try:
                return orig(self, *args, **kwargs)
            finally:
                _local.reading -= 1

        numpy.__wrapped__ = orig  # type: ignore[attr-defined]
        wp.array.numpy = numpy
        _reads_installed = True
        return True


class ReadCounter:
    """Context manager: ``wp.array.numpy()`` calls on arrays of ``device`` (any device if ``None``) while
    it is active, on any thread. On a GPU each is a copy to the host that waits for the device (a
    sync); on the CPU the same calls are views, counted alike, so a CPU run shows what a GPU frame
    would wait for. Concurrent renders in one process count each other's reads.

    >>> import warp as wp
    >>> with ReadCounter("cpu") as reads:
    ...     _ = wp.zeros(3, dtype=float, device="cpu").numpy()
    >>> reads.count
    1
    """

    def __init__(self, device: str | None = None):
        self.device = None if device is None else str(device)
        self.count = 0
        self._mine = threading.Lock()

    def _add(self) -> None:
        with self._mine:
            self.count += 1

    def __enter__(self) -> "ReadCounter":
        _install_reads()
        with _lock:
            _reads_active.append(self)
        return self

    def __exit__(self, *exc) -> None:
        with _lock:
            if self in _reads_active:
                _reads_active.remove(self)
