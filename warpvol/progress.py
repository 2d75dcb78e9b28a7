"""Progress of long runs on the terminal: a bar with the fraction done and the time remaining (rich),
drawn on stderr only when it is a terminal (a log file or a pipe stays clean), as wide as the terminal.

Examples
--------
>>> with ProgressBar("reference", enabled=False) as bar:
...     bar.fraction(0.5)
...     bar.fraction(1.0)
>>> bar.done
1.0
"""

from __future__ import annotations

import sys
import time


class ProgressBar:
    """Context manager: ``fraction(f)`` sets the share done (0..1), ``advance(n)`` adds to a count of
    ``total`` units. Nothing is drawn when ``enabled`` is false or stderr is not a terminal (unless
    ``force``)."""

    def __init__(self, label: str, total: float = 1.0, *, enabled: bool = True, force: bool = False):
        self.label, self.total, self.done = label, float(total), 0.0
        self._bar = None
        if enabled and (force or sys.stderr.isatty()):
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeRemainingColumn

            self._bar = Progress(TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(),
                                 TimeRemainingColumn(), console=Console(file=sys.stderr), transient=True)
            self._task = self._bar.add_task(label, total=self.total)

    def __enter__(self) -> "ProgressBar":
        if self._bar is not None:
            self._bar.start()
        return self

    def __exit__(self, *exc) -> None:
        if self._bar is not None:
            self._bar.stop()

    def fraction(self, f: float) -> None:
        self.done = max(0.0, min(1.0, float(f))) * self.total
        if self._bar is not None:
            self._bar.update(self._task, completed=self.done)

    def advance(self, n: float = 1.0) -> None:
        self.done = min(self.total, self.done + n)
        if self._bar is not None:
            self._bar.update(self._task, completed=self.done)


class Progress:
    """A one-line progress bar on stderr (a line per step when stderr is not a terminal)."""

    def __init__(self, total: int, label: str, enabled: bool = True, stream=None):
        self.total, self.label, self.done, self.enabled = max(int(total), 1), label, 0, enabled
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()

    def step(self, what: str, n: int = 1) -> None:
        self.done = min(self.done + n, self.total)
        if not self.enabled:
            return
        frac = self.done / self.total
        bar = "#" * int(frac * 24)
        line = f"[warpvol] {self.label} [{bar:<24}] {self.done}/{self.total} {time.perf_counter() - self.t0:6.1f} s  {what}"
        if self.tty:
            self.stream.write("\r" + line[:150].ljust(150) + ("\n" if self.done >= self.total else ""))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled and self.tty and self.done < self.total:
            self.stream.write("\n")
