"""The real data sets the shipped scenes (``scenes/*.toml``) read: where each comes from, its files'
sizes and SHA-256 checksums, and where warpvol finds them.

A scene names its data files as ``../../shared/data/FILE`` (the read-only ``shared/data`` folder
beside the repository). A file that is not there is looked for in the data cache, where
``warpvol data fetch NAME`` puts it: ``$WARPVOL_DATA`` if set, else ``data`` in pooch's per-user
cache folder for warpvol (``~/.cache/warpvol/data`` on Linux). Downloads go through pooch (checksums, retries, the cache folder);
``$WARPVOL_DATA_URL`` (or ``base_url=``) replaces every file's public address by ``BASE/FILE``, for a
mirror or a local server. docs/guide/data-sets.md is the page for users.

Examples
--------
>>> ds = DATA_SETS["bluntfin"]
>>> [f.name for f in ds.files], ds.size
(['bluntfinxyz.bin', 'bluntfinq.bin'], 1311244)
>>> data_set_of("spx.vtk").name
'spx'
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

from warpvol.errors import ConfigError, WarpvolError

#: the repository's root (this file is warpvol/scene/datasets.py)
ROOT = Path(__file__).resolve().parents[2]
#: the read-only data folder beside the repository the shipped scenes name first
SHARED_DATA = ROOT.parent / "shared" / "data"

# the public copies: a commit of each repository, so that what the address serves cannot change
_VTK_DATA = "https://raw.githubusercontent.com/pyvista/vtk-data/126ee906165a8b2f984f08259a4a2d32cf3b3409/Data/"
_VISTRAILS = ("https://raw.githubusercontent.com/VisTrails/VisTrails/d48ac3d488ad390b10ca5d333d6e0aba1413cd55/"
              "examples/data/")
_CUDA_SAMPLES = ("https://raw.githubusercontent.com/NVIDIA/cuda-samples/c94ff366aed18c797b8a85dfaac7817b0228b420/"
                 "Samples/5_Domain_Specific/volumeRender/data/")


@dataclass(frozen=True)
class DataFile:
    """One file of a data set: its name on disk, size in bytes, SHA-256 and public address."""

    name: str
    size: int
    sha256: str
    url: str


@dataclass(frozen=True)
class DataSet:
    """A data set: a short name (``warpvol data fetch NAME``), its files, where it comes from."""

    name: str
    title: str
    files: tuple[DataFile, ...]
    source: str
    licence: str
    scenes: tuple[str, ...] = ()

    @property
    def size(self) -> int:
        return sum(f.size for f in self.files)


DATA_SETS: dict[str, DataSet] = {d.name: d for d in (
    DataSet("bluntfin", "NASA Blunt Fin (PLOT3D, 40x32x32 curvilinear)", (
        DataFile("bluntfinxyz.bin", 491532, "b0748b066152c7001d2979245e729da32b44eb6f171b0c49cf6ed0eb84fe0e6a",
                 _VTK_DATA + "bluntfinxyz.bin"),
        DataFile("bluntfinq.bin", 819712, "1fa8642d08f6bbbda6a7bc95571a06ec26afa8abac556a7330bfc74b60899397",
                 _VTK_DATA + "bluntfinq.bin")),
        "VTK test data (pyvista/vtk-data)", "BSD-3-Clause (VTK Data)", ("bluntfin", "bluntfin_close")),
    DataSet("loxpost", "NASA Liquid Oxygen Post (PLOT3D, 38x76x38)", (
        DataFile("postxyz.bin", 1755916, "578733b095c9a4776ad35c11c0e0f95a563bd7e9da0922045620c09991992da6",
                 _VTK_DATA + "postxyz.bin"),
        DataFile("postq.bin", 2194908, "25ac2ed16d9df263541f3daa1ddda097210f31ca73b192cbac9d5182c042adfb",
                 _VTK_DATA + "postq.bin")),
        "VTK test data (pyvista/vtk-data)", "BSD-3-Clause (VTK Data)", ("loxpost",)),
    DataSet("combustor", "Combustor (PLOT3D, 57x33x25)", (
        DataFile("combxyz.bin", 564312, "75e20a039c7bfc02d724ef18a411ef27cbf8977926d0f4b0208ca28817e1288f",
                 _VTK_DATA + "combxyz.bin"),
        DataFile("combq.bin", 940528, "a59dfe6faa76d4bc1b82a718636742e1a7220d06da17bb1ee5ab815432f9baea",
                 _VTK_DATA + "combq.bin")),
        "VTK test data (pyvista/vtk-data)", "BSD-3-Clause (VTK Data)", ("combustor",)),
    DataSet("spx", "SPX (tetrahedral mesh, legacy VTK)", (
        DataFile("spx.vtk", 506752, "15ac02eeef1ec8cde16e117c244f66924c3303c4ab5e7dbf7c096e4cc43ae10e",
                 _VISTRAILS + "spx.vtk"),),
        "VisTrails examples", "BSD-3-Clause (VisTrails)", ("spx", "spx_fill")),
    DataSet("bucky", "Bucky Ball (32^3 uint8 raw volume)", (
        DataFile("bucky.raw", 32768, "8976ab31eb1944d2c9bbbe825935357cd25f65b48d3e13ba45427bf80418232d",
                 _CUDA_SAMPLES + "Bucky.raw"),),
        "NVIDIA cuda-samples", "BSD-3-Clause (cuda-samples)"),
)}


def data_set_of(file_name: str) -> DataSet | None:
    """The data set a file name (no folder) belongs to, or ``None``."""
    for ds in DATA_SETS.values():
        if any(f.name == file_name for f in ds.files):
            return ds
    return None


def data_file(file_name: str) -> DataFile:
    ds = data_set_of(file_name)
    if ds is None:
        raise KeyError(file_name)
    return next(f for f in ds.files if f.name == file_name)


def cache_dir() -> Path:
    """Where ``warpvol data fetch`` puts files: ``$WARPVOL_DATA``, else pooch's user cache for warpvol."""
    env = os.environ.get("WARPVOL_DATA")
    if env:
        return Path(env).expanduser()
    import pooch

    return Path(pooch.os_cache("warpvol")) / "data"


def sha256(path: Path | str) -> str:
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def normal(path: Path | str) -> Path:
    """``path`` absolute and without ``..`` or symbolic links, for messages."""
    return Path(path).expanduser().resolve()


def _in_shared_data(path: Path) -> bool:
    """``path`` names a file in a ``shared/data`` folder (as the shipped scenes do)."""
    parent = normal(path).parent
    return parent.name == "data" and parent.parent.name == "shared"


def cached_copy(path: Path | str, cache: Path | None = None) -> Path | None:
    """The data cache's copy of a data-set file that a scene names in ``shared/data`` and that is not
    there, or ``None`` (not such a file, or not in the cache). A cached copy whose checksum is wrong
    is an error naming the file and the command that downloads it again."""
    p = Path(path)
    ds = data_set_of(p.name)
    if ds is None or not _in_shared_data(p):
        return None
    c = Path(cache) if cache is not None else cache_dir()
    f = c / p.name
    if not f.is_file():
        return None
    if sha256(f) != data_file(p.name).sha256:
        raise ConfigError(f"{normal(f)}: the cached copy of {p.name} does not have the expected SHA-256 "
                          f"(damaged or replaced); `warpvol data fetch {ds.name}` downloads it again")
    return f


def missing_hint(path: Path | str) -> str:
    """What to add to a "file not found" message for ``path``: for a data-set file, the cache folder
    looked in and the command that fetches it; else ``""``."""
    p = Path(path)
    ds = data_set_of(p.name)
    if ds is None or not _in_shared_data(p):
        return ""
    return (f" (nor in the data cache {normal(cache_dir())}); it is a file of the data set {ds.name!r}: "
            f"`warpvol data fetch {ds.name}` downloads it")


def resolve(path: Path | str) -> Path | None:
    """``path`` if it is a file, else the data cache's copy of it (:func:`cached_copy`), else ``None``."""
    p = Path(path)
    if p.is_file():
        return p
    return cached_copy(p)


def where(ds: DataSet, *, shared: Path | None = None, cache: Path | None = None) -> dict[str, bool]:
    """Whether every file of ``ds`` is in the shared data folder and in the cache (sizes compared;
    :func:`fetch` and the loaders check the checksums)."""
    shared = SHARED_DATA if shared is None else Path(shared)
    cache = cache_dir() if cache is None else Path(cache)

    def has(folder: Path) -> bool:
        return all((folder / f.name).is_file() and (folder / f.name).stat().st_size == f.size for f in ds.files)

    return {"shared": has(shared), "cache": has(cache)}


def select(names: list[str] | tuple[str, ...]) -> list[DataSet]:
    """The data sets named (``all``: every one); an unknown name is an error listing the known ones."""
    if list(names) == ["all"]:
        return list(DATA_SETS.values())
    unknown = [n for n in names if n not in DATA_SETS]
    if unknown or not names:
        raise ConfigError(f"data set {', '.join(map(repr, unknown)) or '(none given)'}: unknown; known: "
                          f"{', '.join(DATA_SETS)} or all")
    return [DATA_SETS[n] for n in names]


def fetch(ds: DataSet, *, cache: Path | None = None, base_url: str | None = None, retries: int = 2,
          log=None) -> list[Path]:
    """Download the files of ``ds`` that the cache lacks (or has with another checksum) into the cache
    with pooch, checking each file's SHA-256; ``retries`` more tries after a failed one. ``base_url``
    (else ``$WARPVOL_DATA_URL``) replaces the public addresses by ``BASE/FILE``. A checksum that differs,
    or a download that fails after the retries, is a :class:`~warpvol.errors.WarpvolError` naming the
    file and its address; a bad download is deleted, not kept."""
    import logging
    import re

    import pooch

    cache = cache_dir() if cache is None else Path(cache)
    base_url = base_url if base_url is not None else os.environ.get("WARPVOL_DATA_URL")
    urls = {f.name: (base_url.rstrip("/") + "/" + f.name) if base_url else f.url for f in ds.files}
    fetcher = pooch.create(path=cache, base_url="", registry={f.name: f"sha256:{f.sha256}" for f in ds.files},
                           urls=urls, retry_if_failed=retries)
    logger = pooch.get_logger()
    level = logger.level
    logger.setLevel(logging.WARNING)  # warpvol says what it downloads itself
    out = []
    try:
        for f in ds.files:
            if log:
                log(f"{ds.name}: {f.name} ({f.size:,} bytes) from {urls[f.name]}")
            try:
                out.append(Path(fetcher.fetch(f.name)))
            except Exception as e:  # noqa: BLE001 - pooch's hash check, requests' and the file system's errors
                got = re.search(r"but got (\w+)", str(e))
                if "does not match the known hash" in str(e):
                    raise WarpvolError(f"{f.name}: the file downloaded from {urls[f.name]} has SHA-256 "
                                       f"{got.group(1) if got else '(another)'}, expected {f.sha256}; the download "
                                       "was deleted") from None
                raise WarpvolError(f"{f.name}: download from {urls[f.name]} failed: {type(e).__name__}: {e}") from None
    finally:
        logger.setLevel(level)
    return out
