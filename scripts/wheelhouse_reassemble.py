"""Reassemble the files scripts/build_wheelhouse.py split into parts, and check every file's SHA-256.

    python3 reassemble.py [FOLDER]      # FOLDER: the wheelhouse (default: this file's folder)

Standard library only: it runs on the machine the wheelhouse is carried to, before anything is installed.
``parts.json`` lists each split file's parts in order, size and SHA-256: the parts are joined into the file
(through a temporary name), its size and checksum checked, then the parts are removed. ``SHA256SUMS``
lists every whole file; each is checked at the end. Exit status 0 when every file is whole and checks,
1 (naming the file) otherwise.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def reassemble(folder: Path) -> list[str]:
    """Join every split file of ``folder``; returns the problems, one line each (empty: all well)."""
    problems = []
    manifest = folder / "parts.json"
    entries = json.loads(manifest.read_text()) if manifest.is_file() else {}
    for name, e in entries.items():
        target = folder / name
        if target.is_file() and target.stat().st_size == e["size"] and sha256(target) == e["sha256"]:
            continue  # joined before
        missing = [p for p in e["parts"] if not (folder / p).is_file()]
        if missing:
            problems.append(f"{name}: part(s) missing: {', '.join(missing)}")
            continue
        tmp = folder / (name + ".joining")
        with open(tmp, "wb") as out:
            for p in e["parts"]:
                with open(folder / p, "rb") as fh:
                    for block in iter(lambda: fh.read(1 << 20), b""):
                        out.write(block)
        size, digest = tmp.stat().st_size, sha256(tmp)
        if size != e["size"] or digest != e["sha256"]:
            tmp.unlink()
            problems.append(f"{name}: the joined parts have {size} bytes and SHA-256 {digest}, expected {e['size']} "
                            f"bytes and {e['sha256']} (a part is damaged or from another build)")
            continue
        os.replace(tmp, target)
        for p in e["parts"]:
            (folder / p).unlink()
        print(f"{name}: joined from {len(e['parts'])} parts, SHA-256 checked", flush=True)
    sums = folder / "SHA256SUMS"
    if sums.is_file():
        for line in sums.read_text().splitlines():
            if not line.strip():
                continue
            digest, name = line.split(maxsplit=1)
            f = folder / name.lstrip("*")
            if not f.is_file():
                if not any(p.startswith(name + ":") for p in problems):  # not already said
                    problems.append(f"{name}: missing")
            elif sha256(f) != digest:
                problems.append(f"{name}: SHA-256 {sha256(f)}, expected {digest}")
    return problems


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    folder = Path(argv[0]) if argv else Path(__file__).resolve().parent
    problems = reassemble(folder)
    for p in problems:
        print(f"reassemble: {p}", file=sys.stderr)
    if not problems:
        print(f"{folder}: every file whole, SHA-256 checked")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
