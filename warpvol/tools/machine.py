"""Where and when a benchmark ran: the metadata a bench page and its ``table.json`` carry, so that two
runs can be compared (same commit? same machine? was it loaded?).

Examples
--------
>>> meta = run_metadata("cpu")
>>> [k for k in ("date", "commit", "warpvol", "Warp", "VTK", "CPU", "cores", "load average at the start")
...  if k not in meta]
[]
>>> float(meta["timer resolution [s]"]) > 0
True
"""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path


def timer_resolution() -> float:
    """Seconds: the resolution of the clock the bench times with (``time.perf_counter``)."""
    return float(time.get_clock_info("perf_counter").resolution)


def load_average() -> str:
    """The 1, 5 and 15 minute load averages (``"n/a"`` where the system has none)."""
    try:
        return " / ".join(f"{x:.2f}" for x in os.getloadavg()) + " (1 / 5 / 15 min)"
    except (AttributeError, OSError):
        return "n/a"


#: paths whose changes do not make a run "dirty": the generated files and the pages themselves
NOT_CODE = ("docs",)


def _git(*args: str, cwd: Path | None = None) -> str | None:
    try:
        r = subprocess.run(["git", *args], cwd=cwd or Path(__file__).resolve().parent, capture_output=True,
                           text=True, timeout=20)
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout.strip() if r.returncode == 0 else None


def git_state() -> tuple[str | None, bool | None]:
    """``(commit, dirty)`` of the checkout warpvol runs from: HEAD, and whether tracked files outside
    ``docs/`` differ from it; ``(None, None)`` for an installed copy or without git."""
    top = _git("rev-parse", "--show-toplevel")
    head = _git("rev-parse", "HEAD", cwd=Path(top)) if top else None
    if not head:
        return None, None
    status = _git("status", "--porcelain", "--untracked-files=no", "--", ".",
                  *(f":(exclude){p}" for p in NOT_CODE), cwd=Path(top))
    return head, (None if status is None else bool(status))


def git_commit() -> str:
    """The commit of the checkout warpvol runs from, ``+ local changes`` when tracked files outside
    ``docs/`` differ from it (:func:`git_state`); ``unknown (...)`` for an
    installed copy or without git."""
    commit, dirty = git_state()
    if commit is None:
        return "unknown (not a git checkout, or git not available)"
    return commit + (" + local changes" if dirty else "")


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "not installed"


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def cpu_cores() -> str:
    n = os.cpu_count() or 0
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = n
    return f"{n}" if usable == n else f"{usable} usable of {n}"


def run_metadata(device: str = "cpu", command: str | None = None) -> dict[str, str]:
    """Flat ``name -> text``: date (UTC), git commit, warpvol / Warp / VTK / Python versions, OS, CPU model
    and cores, the load average at the start, the Warp device and the timer's resolution."""
    meta = {
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC"),
        "commit": git_commit(),
        "warpvol": _version("warpvol"),
        "Warp": _version("warp-lang"),
        "VTK": _version("vtk"),
        "Python": platform.python_version(),
        "OS": f"{platform.system()} {platform.release()}",
        "CPU": cpu_model(),
        "cores": cpu_cores(),
        "load average at the start": load_average(),
        "device": str(device),
        "timer resolution [s]": f"{timer_resolution():.1e}",
    }
    if command:
        meta["command"] = command
    if "warp" in sys.modules:  # the device's name where Warp is already loaded (never loaded for this)
        try:
            import warp as wp

            meta["device"] = f"{device} ({wp.get_device(device).name})"
        except Exception:  # noqa: BLE001 - the name is a courtesy
            pass
    return meta
