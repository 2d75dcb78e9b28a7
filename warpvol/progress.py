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
