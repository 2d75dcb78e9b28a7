"""Image and text output: OpenEXR via OpenImageIO, PNG previews, atomic writes.

Every writer goes through a temporary file in the target folder followed by :func:`os.replace`, so a
failed or interrupted run never leaves a partial output file behind. :class:`Outputs` extends this to
a whole run: all of its files are written to temporary files first and renamed together at the end,
so a run leaves all its outputs or none. Files get the permissions ``open()`` would give them (0666
less the umask); errors name the user's path, never the temporary file.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from warpvol.errors import ConfigError, check_finite_image


def _umask() -> int:
    """The process's umask; read from /proc where possible (``os.umask`` can only be read by setting
    it, which races with other threads creating files)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


class Outputs:
    """A set of output files written all together or not at all.

    Each ``exr`` / ``png`` / ``text`` call writes a temporary file beside its target; leaving the
    ``with`` block normally renames them all onto their targets, an exception (``KeyboardInterrupt``
    included) removes them and leaves the targets untouched.

    Examples
    --------
    >>> import tempfile; d = Path(tempfile.mkdtemp())
    >>> with Outputs() as out:
    ...     out.text(d / "a.json", "{}")
    ...     out.exr(d / "a.exr", np.zeros((2, 2, 4)))
    ...     sorted(p.name for p in d.iterdir() if not p.name.startswith("."))
    []
    >>> sorted(p.name for p in d.iterdir())
    ['a.exr', 'a.json']
    """

    def __init__(self, owned: "OwnedFiles | None" = None) -> None:
        self._staged: list[tuple[str, Path]] = []
        self.owned = owned

    def __enter__(self) -> "Outputs":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.discard()

    def _stage(self, path: str | Path, write: Callable[[str, Path], None]) -> None:
        path = Path(path)
        folder = path.parent if str(path.parent) else Path(".")
        if not folder.is_dir():
            raise ConfigError(f"output folder does not exist: {folder} (for {path})")
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=folder)
        except OSError as e:
            raise OSError(f"cannot write {path}: {e.strerror or e}") from None
        os.close(fd)
        self._staged.append((tmp, path))
        try:
            # mkstemp creates 0600; an output file gets what open() would give it: 0666 less the umask
            os.chmod(tmp, 0o666 & ~_umask())
            write(tmp, path)
        except OSError as e:
            self.discard()
            raise OSError(f"cannot write {path}: {e.strerror or e}") from None
        except BaseException:
            self.discard()
            raise

    def text(self, path: str | Path, text: str) -> None:
        """Stage a UTF-8 text file."""
        self._stage(path, lambda tmp, _: Path(tmp).write_text(text, encoding="utf-8"))

    def bytes(self, path: str | Path, data: bytes) -> None:
        """Stage a binary file (e.g. an encoded PNG)."""
        self._stage(path, lambda tmp, _: Path(tmp).write_bytes(data))

    def exr(self, path: str | Path, image: np.ndarray) -> None:
        """Stage a float RGBA (H, W, 4) image (row 0 = top) as a float32 OpenEXR file."""
        import OpenImageIO as oiio

        img = np.ascontiguousarray(image, dtype=np.float32)
        if img.ndim != 3 or img.shape[2] not in (1, 3, 4):
            raise ValueError(f"write_exr: expected (H, W, 1|3|4) image, got shape {img.shape}")
        check_finite_image(path, img)  # never a NaN or Inf pixel written (float32: values beyond it too)
        self._stage(path, lambda tmp, shown: _write_oiio(tmp, img, oiio.FLOAT, shown))

    def png(self, path: str | Path, image: np.ndarray, background=(0.0, 0.0, 0.0), exposure: float = 1.0) -> None:
        """Stage an 8-bit PNG preview: premultiplied RGBA over ``background`` (or a grey/RGB image)."""
        import OpenImageIO as oiio

        img = np.asarray(image, dtype=np.float64)
        check_finite_image(path, img)  # a NaN would become an ordinary 8-bit code
        if img.ndim == 2:
            img = np.repeat(img[..., None], 3, axis=2)
        rgb = composite_over(img, background) if img.shape[2] == 4 else img[..., :3]
        codes = np.ascontiguousarray(np.clip(np.rint(np.clip(rgb * exposure, 0, 1) * 255.0), 0, 255).astype(np.uint8))
        self._stage(path, lambda tmp, shown: _write_oiio(tmp, codes, oiio.UINT8, shown))

    def commit(self) -> None:
        """Rename every staged file onto its target (targets were checked up front, so a failure here
        is rare; the files not yet renamed are then removed). With ``owned`` (:class:`OwnedFiles`), the
        targets are checked again first (a file a user put there meanwhile is kept: nothing is renamed),
        and recorded once renamed."""
        done: list[Path] = []
        try:
            if self.owned is not None:
                self.owned.check([self._rel(path) for _, path in self._staged])
            while self._staged:
                tmp, path = self._staged[0]
                try:
                    os.replace(tmp, path)
                except OSError as e:
                    raise OSError(f"cannot write {path}: {e.strerror or e}") from None
                self._staged.pop(0)
                done.append(path)
        finally:
            self.discard()
            if self.owned is not None and done:
                self.owned.wrote([self._rel(p) for p in done])

    def _rel(self, path: Path) -> str:
        return os.path.relpath(path, self.owned.folder)

    def discard(self) -> None:
        """Remove every staged temporary file."""
        for tmp, _ in self._staged:
            try:
                os.unlink(tmp)
            except FileNotFoundError:
                pass
        self._staged.clear()


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write a text file atomically (temporary file + rename)."""
    with Outputs() as out:
        out.text(path, text)


def save_result(folder: str | Path, stem: str, record: str, image: np.ndarray | None = None,
                owned: "OwnedFiles | None" = None) -> None:
    """One finished unit of a long run (a sweep task, a bench pipeline, a stress case), whole or
    absent: ``stem.npy`` (the image, if any) first, then the ``stem.json`` text ``record``, whose
    presence marks the unit done; each file atomically, the folder created if missing, and recorded
    in ``owned`` (:class:`OwnedFiles`, if given) once written."""
    import io

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    if image is not None:
        buf = io.BytesIO()
        np.save(buf, np.asarray(image))
        with Outputs(owned) as out:
            out.bytes(folder / f"{stem}.npy", buf.getvalue())
    with Outputs(owned) as out:
        out.text(folder / f"{stem}.json", record)


def available_memory() -> int | None:
    """Bytes of memory available to this process now, ``None`` if unknown: the least of the system's
    ``MemAvailable``, what the address-space limit (``ulimit -v``) leaves and what the cgroup's
    ``memory.max`` leaves."""
    have = []
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                have.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    if not have:
        try:
            have.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            pass
    try:
        import resource

        cap = resource.getrlimit(resource.RLIMIT_AS)[0]
        if cap != resource.RLIM_INFINITY:
            for line in Path("/proc/self/status").read_text().splitlines():
                if line.startswith("VmSize:"):
                    have.append(max(cap - int(line.split()[1]) * 1024, 0))
    except (ImportError, OSError, ValueError, IndexError):
        pass
    try:
        cg = Path("/proc/self/cgroup").read_text().splitlines()
        rel = next(ln.split(":", 2)[2] for ln in cg if ln.startswith("0::"))
        base = Path("/sys/fs/cgroup") / rel.lstrip("/")
        limit = (base / "memory.max").read_text().strip()
        if limit != "max":
            have.append(max(int(limit) - int((base / "memory.current").read_text()), 0))
    except (OSError, ValueError, IndexError, StopIteration):
        pass
    return min(have) if have else None


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two names are one file: the same resolved path (symlinks, ``..``, other spellings)
    or the same inode (hard links)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_inputs(inputs: list[tuple[Path, str]], outputs: dict[str, Path]) -> None:
    """No output may be one of the inputs (compared as files, not as spellings): an input is never
    overwritten. ``inputs``: ``(path, what)``; ``outputs``: flag (or name) -> path."""
    for flag, out in outputs.items():
        for f, what in inputs:
            if same_file(out, f):
                raise ConfigError(f"{flag}: {out} is an input of this run ({what}: {f}); inputs are never "
                                  "overwritten: give the output another name")


#: the record of the files a folder command wrote into its output folder (see :class:`OwnedFiles`)
MANIFEST = ".warpvol-files.json"


class OwnedFiles:
    """The files warpvol wrote into an output folder (``bench``, ``stress``, ``sweep``, ``demo``), recorded
    in ``FOLDER/.warpvol-files.json`` after they are written: each file's path relative to the folder,
    the tool, its size and the SHA-256 of its bytes, and the folder the record describes.

    A file counts as warpvol's only while it is still as recorded: a file a user saved under a recorded
    name, or changed since, is the user's, and is never replaced or deleted. A record written for
    another folder (copied in with a folder) is refused as a whole. :meth:`check` refuses, before any
    work, a run that would write over a file that is not warpvol's; :meth:`wrote` records files once
    they are written (:class:`Outputs` with ``owned`` checks its targets again just before renaming
    onto them, and records them after).

    Examples
    --------
    >>> import tempfile; d = Path(tempfile.mkdtemp())
    >>> _ = (d / "mine.json").write_text("{}")
    >>> own = OwnedFiles(d, "stress")
    >>> with Outputs(owned=own) as out:
    ...     out.text(d / "stress.json", "[]")
    >>> own.owns("stress.json"), own.owns("mine.json")
    (True, False)
    >>> own.check(["mine.json"])
    Traceback (most recent call last):
    ...
    warpvol.errors.ConfigError: -o: ... exists and was not written by warpvol stress; ...
    >>> _ = (d / "stress.json").write_text("my own notes")  # replaced by the user: theirs now
    >>> OwnedFiles(d, "stress").owns("stress.json")
    False
    """

    def __init__(self, folder: str | Path, tool: str, flag: str = "-o") -> None:
        self.folder, self.tool, self.flag = Path(folder), tool, flag
        self.files: dict[str, dict] = {}
        self.refused = ""  # why the record there was not taken, said in errors
        try:
            rec = json.loads((self.folder / MANIFEST).read_text(encoding="utf-8"))
        except FileNotFoundError:
            return
        except (OSError, ValueError):  # unreadable record: nothing counts as written by warpvol
            self.refused = f"the record {MANIFEST} there cannot be read"
            return
        files = rec.get("files") if isinstance(rec, dict) else None
        if not isinstance(files, dict) or rec.get("folder") != self._here():
            where = rec.get("folder") if isinstance(rec, dict) else None
            self.refused = (f"the record {MANIFEST} there describes {where}, not this folder" if isinstance(where, str)
                            else f"the record {MANIFEST} there does not say which folder it describes")
            return
        self.files = {str(k): v for k, v in files.items()
                      if isinstance(v, dict) and isinstance(v.get("size"), int) and isinstance(v.get("sha256"), str)}

    def _here(self) -> str:
        return os.path.realpath(self.folder)

    def owns(self, rel: str) -> bool:
        """Whether ``rel`` is a file warpvol wrote and is still as written (size and content hash)."""
        e = self.files.get(rel)
        p = self.folder / rel
        if e is None or p.is_symlink() or not p.is_file():
            return False
        try:
            return p.stat().st_size == e["size"] and _sha256(p) == e["sha256"]
        except OSError:
            return False

    def owned_in(self, sub: str) -> list[str]:
        """Files directly in the subfolder ``sub`` (relative paths) that warpvol wrote and are as written."""
        return [r for r in self.files if str(Path(r).parent) == sub and self.owns(r)]

    def check(self, rels: Iterable[str]) -> None:
        """Every file in ``rels`` is absent or warpvol's as written (:meth:`owns`), else a
        :class:`~warpvol.errors.ConfigError` naming the first that is not."""
        for rel in rels:
            p = self.folder / rel
            if os.path.lexists(p) and not self.owns(rel):
                kind = "it" if not p.is_dir() else "that folder"
                why = ("; it changed since warpvol wrote it" if rel in self.files else
                       f" ({self.refused})" if self.refused else "")
                raise ConfigError(f"{self.flag}: {p} exists and was not written by warpvol {self.tool}{why}; "
                                  f"warpvol replaces only the files it wrote: move {kind} away or choose another folder")

    def wrote(self, rels: Iterable[str]) -> None:
        """Record ``rels``, written by this tool just now, with their sizes and content hashes."""
        for rel in dict.fromkeys(rels):
            p = self.folder / rel
            if p.is_file():
                self.files[rel] = {"tool": self.tool, "size": p.stat().st_size, "sha256": _sha256(p)}
        self._save()

    def remove(self, rels: Iterable[str]) -> list[str]:
        """Delete the files among ``rels`` that warpvol wrote and are as written; a recorded file that
        changed is the user's now: left alone and no longer recorded. Returns those deleted."""
        gone = []
        for rel in list(rels):
            if rel not in self.files:
                continue
            if self.owns(rel):
                os.unlink(self.folder / rel)
                gone.append(rel)
            del self.files[rel]
        self._save()
        return gone

    def _save(self) -> None:
        atomic_write_text(self.folder / MANIFEST, json.dumps({"folder": self._here(),
                                                              "files": dict(sorted(self.files.items()))}, indent=1))


def _sha256(path: Path) -> str:
    import hashlib

    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def read_record(path: str | Path) -> dict | None:
    """A finished unit's ``.json`` record (:func:`save_result`), or ``None`` when it is missing,
    unreadable or not a JSON object (a file cut short by a kill of an older writer, edited by hand)."""
    try:
        rec = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return rec if isinstance(rec, dict) else None


def saved_records(outdir: str | Path, subdir: str, owned=None) -> list[tuple[Path, dict | None]]:
    """``(path, record or None)`` of the finished units a long run saved under ``outdir/subdir``: the
    ``.json`` files it recorded as its own (``owned``, a manifest with ``owned_in(subdir)``) or, without
    a manifest, every ``.json`` there; hidden files (a writer's temporaries) and non-files are passed
    over; a record that cannot be read comes as ``None`` (the caller runs its unit again)."""
    d = Path(outdir) / subdir
    if owned is not None:
        files = sorted(Path(outdir) / r for r in owned.owned_in(subdir) if r.endswith(".json"))
    else:
        files = sorted(d.glob("*.json")) if d.is_dir() else []
    return [(f, read_record(f)) for f in files if not f.name.startswith(".") and f.is_file()]


def toml_nesting(text: str) -> str:
    r"""Where a TOML text nests deepest, for the error on nesting too deep for Python's parser (which
    raises a ``RecursionError`` and names nothing): ``"at key 'camera.width_px' (line 4: 2000 arrays or
    inline tables inside each other)"``.

    Examples
    --------
    >>> toml_nesting('[camera]\nsize = 1\nup = [[[0]], 1]\n')
    "at key 'camera.up' (line 3: 3 arrays or inline tables inside each other)"
    """
    table, key, depth, line = "", "", 0, 1
    best = (0, "", 0)
    eq_on_line, i, n = False, 0, len(text)
    while i < n:
        c = text[i]
        if c == "\n":
            line, eq_on_line = line + 1, False
        elif c == "#":
            i = text.find("\n", i) - 1 if "\n" in text[i:] else n
        elif c in "\"'":
            q = c * 3 if text.startswith(c * 3, i) else c
            j = i + len(q)
            while j < n and not text.startswith(q, j):
                j += 2 if c == '"' and text[j] == "\\" else 1
            line += text.count("\n", i, j)
            i = j + len(q) - 1
        elif depth == 0 and c == "[" and not eq_on_line:  # a [table] or [[array of tables]] header
            end = text.find("\n", i)
            table, key = text[i:end if end >= 0 else n].split("#")[0].strip().strip("[]").strip(), ""
            i = (end if end >= 0 else n) - 1
        elif depth == 0 and c == "=":
            start = text.rfind("\n", 0, i) + 1
            key, eq_on_line = text[start:i].strip(), True
        elif c in "[{":
            depth += 1
            if depth > best[0]:
                best = (depth, ".".join(k for k in (table, key) if k), line)
        elif c in "]}":
            depth = max(depth - 1, 0)
        i += 1
    return f"at key {best[1]!r} (line {best[2]}: {best[0]} arrays or inline tables inside each other)"


def _write_oiio(tmp: str, pixels: np.ndarray, fmt, shown: Path) -> None:
    import OpenImageIO as oiio

    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(tmp)
    if out is None:
        raise OSError(f"OpenImageIO cannot create {shown}: {oiio.geterror()}")
    spec = oiio.ImageSpec(w, h, c, fmt)
    if c == 4:
        spec.channelnames = ("R", "G", "B", "A")
        spec.alpha_channel = 3
    if not out.open(tmp, spec):
        raise OSError(f"OpenImageIO cannot open {shown}: {out.geterror().replace(tmp, str(shown))}")
    ok = out.write_image(pixels)
    out.close()
    if not ok:
        raise OSError(f"OpenImageIO failed writing {shown}: {out.geterror().replace(tmp, str(shown))}")


def write_exr(path: str | Path, image: np.ndarray) -> None:
    """Write a float RGBA (H, W, 4) image (row 0 = top) as a float32 OpenEXR file."""
    with Outputs() as out:
        out.exr(path, image)


def read_exr(path: str | Path) -> np.ndarray:
    """Read an image written by :func:`write_exr` (or any OIIO-readable file) as float32 (H, W, C)."""
    import OpenImageIO as oiio

    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"image file not found: {path}")
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise ConfigError(f"cannot read image {path}: {oiio.geterror()}")
    try:
        data = inp.read_image(oiio.FLOAT)
    finally:
        inp.close()
    return np.asarray(data, dtype=np.float32)


def composite_over(image: np.ndarray, background=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Premultiplied RGBA over an opaque background colour -> RGB."""
    bg = np.asarray(background, dtype=np.float64)
    return image[..., :3] + (1.0 - image[..., 3:4]) * bg


def write_png(path: str | Path, image: np.ndarray, background=(0.0, 0.0, 0.0), exposure: float = 1.0) -> None:
    """8-bit PNG preview: premultiplied RGBA composited over ``background`` (or a grey/RGB image)."""
    with Outputs() as out:
        out.png(path, image, background, exposure)
