"""Progress of long runs: a bar with the share done, the time spent and the time left (rich), on
stderr only, as wide as the terminal.

A bar is drawn when stderr is a terminal; elsewhere (a log file, a pipe) nothing is written unless
``force`` is given (``--progress`` on the command line), and then plain lines, one per step, never
padded. stdout is never written to.

Long work inside one step (an exact reference, a table build, the sweep planes of a VSBUFFER render,
the tet batches of a projected-tetrahedra draw) reports through :func:`detail`: a second, transient
line under the innermost open bar with its own share done and time left. Without an open bar
:func:`detail` does nothing, so library code can call it freely. A :class:`ProgressBar` opened while
another one is shown becomes such a detail line of it.

Examples
--------
>>> with ProgressBar("reference", enabled=False) as bar:
...     bar.fraction(0.5)
...     bar.fraction(1.0)
>>> bar.done
1.0
>>> import io
>>> log = io.StringIO()
>>> with ProgressBar("bench", 2, force=True, stream=log) as bar:
...     bar.advance(1, "raycast")
...     bar.advance(1, "pt_best")
>>> print(log.getvalue().splitlines()[-1].split(" elapsed")[0])
[warpvol] bench: 2/2 (100 %) 0:00:00
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any

#: bars shown now, the innermost last (:func:`detail` reports to it)
_SHOWN: list["ProgressBar"] = []
_LOCK = threading.Lock()
#: forced line output (not a terminal): a detail line at most this often per bar (seconds)
LINE_EVERY = 5.0


def _clock(seconds: float | None) -> str:
    if seconds is None:
        return "-:--:--"
    s = int(round(max(0.0, seconds)))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


def detail(key: str, fraction: float | None = None, text: str = "") -> bool:
    """Report the progress of long work inside the current step: ``key`` names it (a new key starts
    a new detail line), ``fraction`` is its share done (0..1) or ``None`` (text only). Thread-safe.
    Returns whether an open bar took it (``False``: none is shown, nothing happens)."""
    bar = _SHOWN[-1] if _SHOWN else None
    if bar is None:
        return False
    bar._detail(key, fraction, text)
    return True


class ProgressBar:
    """Context manager: ``advance(n, what)`` adds ``n`` of ``total`` units done and says what comes next,
    ``fraction(f)`` sets the share done (0..1), ``describe(what)`` only says it.

    ``enabled=False`` (``--quiet``): nothing is shown. Otherwise a rich bar when ``stream`` (default
    stderr) is a terminal, plain lines when ``force`` (``--progress``) and it is not, nothing else.
    Opened while another bar is shown, it is drawn as that bar's detail line."""

    def __init__(self, label: str, total: float = 1.0, *, enabled: bool = True, force: bool = False,
                 stream: Any = None):
        self.label, self.total, self.done = label, max(float(total), 1e-12), 0.0
        self.what = ""
        self._stream = stream if stream is not None else sys.stderr
        tty = bool(getattr(self._stream, "isatty", lambda: False)())
        parent = _SHOWN[-1] if _SHOWN else None
        # "rich": own bar; "lines": plain lines; "child": a detail line of ``parent``; None: silent
        self.mode: str | None = None
        if enabled and parent is not None:
            self.mode, self._parent = "child", parent
        elif enabled and tty:
            self.mode = "rich"
        elif enabled and force:
            self.mode = "lines"
        self._rich = self._task = None
        self._details: dict[str, Any] = {}  # key -> rich task id (rich) or time of the last line (lines)
        self._detail_key: str | None = None
        self.t0 = time.perf_counter()
        if self.mode == "rich":
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                Progress,
                TaskProgressColumn,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )
            from rich.table import Column

            self._rich = Progress(
                TextColumn("{task.description}", table_column=Column(ratio=1, no_wrap=True, overflow="ellipsis")),
                BarColumn(bar_width=16), TaskProgressColumn(), TimeElapsedColumn(), TextColumn("+"),
                TimeRemainingColumn(), TextColumn("left"),
                console=Console(file=self._stream), transient=True,
                redirect_stdout=False, redirect_stderr=False, refresh_per_second=4, expand=True)

    # -- context ------------------------------------------------------------------------------
    def __enter__(self) -> "ProgressBar":
        if self.mode == "rich":
            self._task = self._rich.add_task(self.label, total=self.total)
            self._rich.start()
        if self.mode in ("rich", "lines"):
            with _LOCK:
                _SHOWN.append(self)
        if self.mode == "child":
            self._parent._detail(self.label, 0.0, "")
        self.t0 = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        if self.mode in ("rich", "lines"):
            with _LOCK:
                if self in _SHOWN:
                    _SHOWN.remove(self)
        if self.mode == "rich":
            self._rich.stop()
        elif self.mode == "child":
            with _LOCK:
                self._parent._end_detail(self.label)

    # -- the main count -----------------------------------------------------------------------
    def fraction(self, f: float) -> None:
        self._set(max(0.0, min(1.0, float(f))) * self.total, None)

    def advance(self, n: float = 1.0, what: str | None = None) -> None:
        self._set(min(self.total, self.done + n), what)

    def set(self, done: float, what: str | None = None) -> None:
        """Set the units done (e.g. at the end of a group of steps)."""
        self._set(min(self.total, max(0.0, float(done))), what)

    def describe(self, what: str) -> None:
        """Say what runs now, without counting."""
        self._set(self.done, what, line=False)

    def add_total(self, n: float) -> None:
        """More units than planned (e.g. audit renders found on the way)."""
        self.total += n
        if self.mode == "rich":
            self._rich.update(self._task, total=self.total)

    def _set(self, done: float, what: str | None, line: bool = True) -> None:
        self.done = done
        if what is not None:
            self.what = what
        if self.mode == "rich":
            with _LOCK:
                self._end_detail(None)
            desc = self.what or self.label  # the step says more than the run's name, which stays the same
            self._rich.update(self._task, completed=self.done, description=desc)
        elif self.mode == "child":
            self._parent._detail(self.label, self.done / self.total, self.what)
        elif self.mode == "lines" and line:
            self._line(self._status() + (f": {self.what}" if self.what else ""))

    def _status(self) -> str:
        el = time.perf_counter() - self.t0
        left = el / self.done * (self.total - self.done) if self.done > 0 else None
        return (f"{self.label}: {self.done:g}/{self.total:g} ({100.0 * self.done / self.total:.0f} %) "
                f"{_clock(el)} elapsed, {_clock(left)} left")

    def _line(self, text: str) -> None:
        self._stream.write(f"[warpvol] {text}\n")
        self._stream.flush()

    # -- detail lines (work inside the current step) -------------------------------------------
    def _detail(self, key: str, fraction: float | None, text: str) -> None:
        if self.mode == "child":
            self._parent._detail(key if key == self.label else f"{self.label}: {key}", fraction, text)
            return
        with _LOCK:
            if self.mode == "rich":
                if key != self._detail_key:
                    self._end_detail(None)
                    self._detail_key = key
                    self._details[key] = self._rich.add_task("  " + key, total=1.0 if fraction is not None else None)
                desc = "  " + key + (f": {text}" if text else "")
                kw = {"completed": max(0.0, min(1.0, fraction))} if fraction is not None else {}
                self._rich.update(self._details[key], description=desc, **kw)
            elif self.mode == "lines":
                now = time.perf_counter()
                if key != self._detail_key or now - self._details.get(key, 0.0) >= LINE_EVERY:
                    self._detail_key = key
                    self._details[key] = now
                    share = "" if fraction is None else f" {100.0 * max(0.0, min(1.0, fraction)):.0f} %"
                    self._line(f"{self.label}: {key}{share}" + (f": {text}" if text else ""))

    def _end_detail(self, key: str | None) -> None:
        """Remove the detail line (``key``: only if it is that one)."""
        if self.mode == "child":
            self._parent._end_detail(key)
        elif self.mode == "rich" and self._detail_key is not None and key in (None, self._detail_key):
            task = self._details.pop(self._detail_key, None)
            if task is not None:
                self._rich.remove_task(task)
            self._detail_key = None
        elif self.mode == "lines" and key in (None, self._detail_key):
            self._detail_key = None
