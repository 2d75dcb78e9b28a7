"""An offline wheelhouse for a GPU machine without a package index: the wheels scripts/check_cuda.py needs
there, warpvol's own wheel, the Blunt Fin files, and what joins and installs them.

    ./run.sh python scripts/build_wheelhouse.py [-o out/wheelhouse] [--python-version 3.11]
        [--platform manylinux_2_28_x86_64] [--full] [--max-part-mib 64] [--data-sets bluntfin]

* Wheels: ``pip download`` of the packages for the target platform and Python (binary wheels only), by
  default what check_cuda.py imports (``warp-lang`` and ``numpy``, at the versions installed here, so that
  the GPU runs what the CPU tests ran); ``--full`` takes every dependency in pyproject.toml instead
  (pyvista, VTK, OpenImageIO, Dask, ...: several hundred MiB). ``--no-pin`` takes the newest versions.
* warpvol's own wheel (``pip wheel --no-deps`` of this repository; pure Python).
* ``data/``: the files of ``--data-sets`` (default: the Blunt Fin) from ``../shared/data`` or the data
  cache, checksums checked; ``check_cuda.py --data DIR/data`` reads them.
* ``--max-part-mib N``: every file larger than N MiB (warp-lang's wheel is about 142 MiB) is split into
  ``NAME.part000``, ``NAME.part001``, ... of at most N MiB each, listed in ``parts.json`` with the whole
  file's size and SHA-256, for a transfer that limits the size of one file.
* ``SHA256SUMS`` (every whole file), ``reassemble.py`` (standard library only: joins the parts, checks
  every checksum) and ``install.sh`` (reassemble, then a venv with ``pip install --no-index --no-deps``).

On the GPU machine::

    sh WHEELHOUSE/install.sh                # -> WHEELHOUSE/.venv ($VENV to choose another folder)
    WHEELHOUSE/.venv/bin/python scripts/check_cuda.py --data WHEELHOUSE/data --budget 480
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.metadata
import json
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: what scripts/check_cuda.py imports beyond the standard library and warpvol (tests/test_check_cuda.py)
CHECK_CUDA_NEEDS = ("warp-lang", "numpy")

INSTALL_SH = """#!/bin/sh
# Join split files, check every SHA-256, install every wheel here into a venv: no package index needed.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
VENV=${VENV:-$HERE/.venv}
python3 "$HERE/reassemble.py" "$HERE"
python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install --no-index --no-deps --disable-pip-version-check -q "$HERE"/*.whl
"$VENV/bin/python" -c "import warp, warpvol; print('installed: warp', warp.config.version, 'into $VENV')"
"""


def sha256(path: Path) -> str:
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def requirements(full: bool, pin: bool) -> list[str]:
    """Requirement strings: check_cuda.py's imports, or every dependency of pyproject.toml (``full``),
    each pinned to the version installed here where ``pin`` and it is installed."""
    if full:
        reqs = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    else:
        reqs = list(CHECK_CUDA_NEEDS)
    out = []
    for r in reqs:
        name = re.match(r"[A-Za-z0-9_.-]+", r).group(0)
        extras = re.search(r"\[[^\]]*\]", r)
        try:
            version = importlib.metadata.version(name) if pin else None
        except importlib.metadata.PackageNotFoundError:
            version = None
        out.append(f"{name}{extras.group(0) if extras else ''}=={version}" if version else r)
    return out


def pip_download(reqs: list[str], folder: Path, platform: str, python_version: str) -> None:
    cmd = [sys.executable, "-m", "pip", "download", "--only-binary=:all:", "--platform", platform,
           "--python-version", python_version, "--implementation", "cp", "-d", str(folder), *reqs]
    print("$ " + " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)


def project_wheel(folder: Path) -> None:
    cmd = [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(folder), str(ROOT)]
    print("$ " + " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)


def copy_data(folder: Path, names: list[str]) -> list[Path]:
    """The files of the data sets ``names`` into ``folder`` (from ../shared/data or the data cache),
    each checked against its SHA-256."""
    from warpvol.scene import datasets as D

    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for ds in D.select(names):
        for f in ds.files:
            src = D.resolve(D.SHARED_DATA / f.name)
            if src is None:
                raise SystemExit(f"build_wheelhouse: {f.name} is neither in {D.SHARED_DATA} nor in the data cache "
                                 f"{D.cache_dir()}; `warpvol data fetch {ds.name}` downloads it")
            if sha256(src) != f.sha256:
                raise SystemExit(f"build_wheelhouse: {src} does not have the SHA-256 of {f.name} ({f.sha256})")
            shutil.copyfile(src, folder / f.name)
            out.append(folder / f.name)
    return out


def split_large(folder: Path, max_bytes: int, files: list[Path] | None = None) -> dict:
    """Split each file of ``files`` (default: every file directly in ``folder``) larger than ``max_bytes``
    into ``NAME.partNNN`` files of at most ``max_bytes``; the original is removed. Returns the entries
    of ``parts.json`` (name relative to ``folder`` -> size, SHA-256, parts in order)."""
    entries = {}
    for f in sorted(files if files is not None else [p for p in folder.iterdir() if p.is_file()]):
        size = f.stat().st_size
        if size <= max_bytes:
            continue
        rel = f.relative_to(folder).as_posix()
        entry = {"size": size, "sha256": sha256(f), "parts": []}
        with open(f, "rb") as fh:
            k = 0
            while block := fh.read(max_bytes):
                part = f.with_name(f"{f.name}.part{k:03d}")
                part.write_bytes(block)
                entry["parts"].append(part.relative_to(folder).as_posix())
                k += 1
        f.unlink()
        entries[rel] = entry
    return entries


def finish(folder: Path, max_part_mib: float | None) -> None:
    """SHA256SUMS of every whole file, the split (``max_part_mib``), parts.json, reassemble.py, install.sh."""
    whole = sorted(p for p in folder.rglob("*") if p.is_file() and p.name not in ("SHA256SUMS", "parts.json"))
    (folder / "SHA256SUMS").write_text("".join(f"{sha256(p)}  {p.relative_to(folder).as_posix()}\n" for p in whole))
    entries = split_large(folder, int(max_part_mib * 2**20), whole) if max_part_mib else {}
    (folder / "parts.json").write_text(json.dumps(entries, indent=1) + "\n")
    shutil.copyfile(ROOT / "scripts" / "wheelhouse_reassemble.py", folder / "reassemble.py")
    (folder / "install.sh").write_text(INSTALL_SH)
    (folder / "install.sh").chmod(0o755)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--out", default="out/wheelhouse", help="the wheelhouse folder (emptied first)")
    ap.add_argument("--python-version", default=f"{sys.version_info.major}.{sys.version_info.minor}",
                    help="the target machine's Python (default: this one's)")
    ap.add_argument("--platform", default="manylinux_2_28_x86_64", help="pip's platform tag of the target machine")
    ap.add_argument("--full", action="store_true", help="every dependency of pyproject.toml, not only what "
                    "check_cuda.py imports")
    ap.add_argument("--no-pin", action="store_true", help="the newest versions, not those installed here")
    ap.add_argument("--max-part-mib", type=float, help="split files larger than this many MiB into parts")
    ap.add_argument("--data-sets", nargs="*", default=["bluntfin"], help="data sets to copy into data/ "
                    "(default: bluntfin; none: no data)")
    args = ap.parse_args(argv)
    if args.max_part_mib is not None and args.max_part_mib <= 0:
        ap.error("--max-part-mib: expected a size in MiB > 0")
    out = Path(args.out)
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    pip_download(requirements(args.full, not args.no_pin), out, args.platform, args.python_version)
    project_wheel(out)
    if args.data_sets:
        copy_data(out / "data", args.data_sets)
    finish(out, args.max_part_mib)
    total = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    for p in sorted(out.rglob("*")):
        if p.is_file():
            print(f"{p.stat().st_size / 2**20:9.2f} MiB  {p.relative_to(out)}")
    print(f"{out}: {total / 2**20:.1f} MiB; on the target: sh {out}/install.sh, then "
          f"<venv>/bin/python scripts/check_cuda.py --data {out}/data")
    return 0


if __name__ == "__main__":
    sys.exit(main())
