"""``warpvol data``: the real data sets the shipped scenes read (:mod:`warpvol.scene.datasets`).

::

    warpvol data [list]                 # each set: files, size, whether in shared/data and in the cache, source
    warpvol data fetch NAME... | all    # download into the cache (checksums checked)

The cache is ``$WARPVOL_DATA`` or pooch's user cache folder (``~/.cache/warpvol/data`` on Linux);
``$WARPVOL_DATA_URL`` (or ``--base-url``) fetches every file from ``BASE/FILE`` instead of its public
address (a mirror, a local server).
"""

from __future__ import annotations

import sys
from pathlib import Path


def _mib(n: int) -> str:
    return f"{n / 2**20:.1f} MiB" if n >= 2**20 else f"{n / 2**10:.0f} KiB" if n >= 2**10 else f"{n} B"


def list_table(*, shared: Path | None = None, cache: Path | None = None) -> str:
    """The text ``warpvol data list`` prints."""
    from warpvol.scene import datasets as D

    shared = D.SHARED_DATA if shared is None else Path(shared)
    cache = D.cache_dir() if cache is None else Path(cache)
    rows = [("name", "files", "size", "shared/data", "cache", "source")]
    for ds in D.DATA_SETS.values():
        here = D.where(ds, shared=shared, cache=cache)
        rows.append((ds.name, ", ".join(f.name for f in ds.files), _mib(ds.size), "yes" if here["shared"] else "-",
                     "yes" if here["cache"] else "-", ds.source))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]) - 1)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r[:-1], widths)) + "  " + r[-1] for r in rows]
    lines += ["", f"shared/data: {D.normal(shared)}" + ("" if shared.is_dir() else " (absent)"),
              f"cache:       {D.normal(cache)}" + ("" if cache.is_dir() else " (absent)"),
              "Scenes read a data file from shared/data, else from the cache. `warpvol data fetch NAME` (or all) "
              "downloads a set into the cache; docs/guide/data-sets.md gives each file's address and SHA-256."]
    return "\n".join(lines)


def cmd_data(args) -> int:
    from warpvol.scene import datasets as D

    cache = None  # $WARPVOL_DATA or the user cache folder: where scenes look
    if args.action in (None, "list"):
        if args.names:
            from warpvol.errors import ConfigError

            raise ConfigError(f"data list: takes no names (got {' '.join(args.names)}); "
                              "`warpvol data fetch NAME` downloads one")
        print(list_table(cache=cache))
        return 0
    sets = D.select(args.names)
    where = D.normal(cache if cache is not None else D.cache_dir())

    def log(msg: str) -> None:
        if not args.quiet:
            print(msg, file=sys.stderr, flush=True)

    for ds in sets:
        paths = D.fetch(ds, cache=cache, base_url=args.base_url, log=log)
        print(f"{ds.name}: {len(paths)} file(s), {ds.size:,} bytes, SHA-256 checked, in {where}")
    return 0


def add_data_parser(sub) -> None:
    """The ``data`` subcommand on the command line's subparsers."""
    d = sub.add_parser("data", help="the real data sets of scenes/: list them, fetch them into a cache")
    d.add_argument("action", nargs="?", choices=("list", "fetch"), help="list (the default) or fetch")
    d.add_argument("names", nargs="*", help="with fetch: data set names or all")
    d.add_argument("--base-url", help="fetch every file from BASE_URL/FILE (default: $WARPVOL_DATA_URL, else "
                   "each file's public address)")
    d.add_argument("--quiet", action="store_true", help="no progress output on stderr")
    d.set_defaults(func=cmd_data)
