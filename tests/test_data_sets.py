"""The data sets of ``scenes/`` (:mod:`warpvol.scene.datasets`, ``warpvol data``): the registry agrees with
``../shared/data/SHA256SUMS`` and with the data page; ``warpvol data fetch`` downloads through pooch from a
local HTTP server (a thread serving a temporary folder; ``--base-url`` / ``$WARPVOL_DATA_URL`` point at it)
and checks checksums; ``warpvol data`` lists where each set is; a scene's missing data file names the
command that fetches it, and a fetched file is read from the cache.
"""

from __future__ import annotations

import functools
import hashlib
import http.server
import re
import threading
from pathlib import Path

import pytest

from warpvol.cli import main
from warpvol.errors import ConfigError, WarpvolError
from warpvol.scene import datasets as D

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"


@pytest.fixture
def server(tmp_path):
    """``(folder, base_url, hits)``: an HTTP server in a thread serving ``folder``; ``hits`` lists the
    paths it was asked for."""
    folder = tmp_path / "served"
    folder.mkdir()
    hits: list[str] = []

    class Handler(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):  # quiet
            pass

        def do_GET(self):
            hits.append(self.path)
            super().do_GET()

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Handler, directory=str(folder)))
    t = threading.Thread(target=httpd.serve_forever, daemon=True)
    t.start()
    try:
        yield folder, f"http://127.0.0.1:{httpd.server_address[1]}", hits
    finally:
        httpd.shutdown()
        httpd.server_close()


def fake_set(name: str, files: dict[str, bytes]) -> D.DataSet:
    return D.DataSet(name, f"fake {name}", tuple(
        D.DataFile(f, len(b), hashlib.sha256(b).hexdigest(), f"http://127.0.0.1:9/{f}") for f, b in files.items()),
        "a test", "none")


@pytest.fixture
def fake(monkeypatch, tmp_path, server):
    """A registry of two small fake sets served by ``server``; the cache and shared/data in tmp_path."""
    folder, url, hits = server
    files = {"a.bin": b"\x00\x01" * 100, "b.bin": b"bee" * 50}
    for f, b in files.items():
        (folder / f).write_bytes(b)
    sets = {"one": fake_set("one", {"a.bin": files["a.bin"], "b.bin": files["b.bin"]}),
            "two": fake_set("two", {"c.bin": b"sea"})}
    (folder / "c.bin").write_bytes(b"sea")
    monkeypatch.setattr(D, "DATA_SETS", sets)
    monkeypatch.setattr(D, "SHARED_DATA", tmp_path / "shared" / "data")
    monkeypatch.setenv("WARPVOL_DATA", str(tmp_path / "cache"))
    monkeypatch.delenv("WARPVOL_DATA_URL", raising=False)
    return files, url, hits, tmp_path / "cache"


def test_fetch_downloads_into_the_cache_and_checks_checksums(fake):
    files, url, hits, cache = fake
    got = D.fetch(D.DATA_SETS["one"], base_url=url, retries=0)
    assert [p.name for p in got] == ["a.bin", "b.bin"]
    assert all(p.parent == cache for p in got)
    assert {p.name: p.read_bytes() for p in got} == {"a.bin": files["a.bin"], "b.bin": files["b.bin"]}
    assert sorted(hits) == ["/a.bin", "/b.bin"]
    D.fetch(D.DATA_SETS["one"], base_url=url, retries=0)  # present with the right checksum: not downloaded again
    assert len(hits) == 2


def test_fetch_command_with_the_base_url_from_the_environment(fake, monkeypatch, capsys):
    _, url, hits, cache = fake
    monkeypatch.setenv("WARPVOL_DATA_URL", url + "/")
    assert main(["data", "fetch", "all", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "one: 2 file(s), 350 bytes, SHA-256 checked" in out and "two: 1 file(s), 3 bytes" in out
    assert sorted(p.name for p in cache.iterdir()) == ["a.bin", "b.bin", "c.bin"]
    assert sorted(hits) == ["/a.bin", "/b.bin", "/c.bin"]


def test_a_checksum_mismatch_is_an_error_naming_the_file_and_nothing_is_kept(fake, server):
    folder, url, _ = server
    (folder / "b.bin").write_bytes(b"not the bee file")
    with pytest.raises(WarpvolError, match=r"^b\.bin: the file downloaded from http://127\.0\.0\.1:\d+/b\.bin has "
                       r"SHA-256 [0-9a-f]{64}, expected [0-9a-f]{64}; the download was deleted"):
        D.fetch(D.DATA_SETS["one"], base_url=url, retries=0)
    assert not (fake[3] / "b.bin").exists()


def test_the_fetch_command_reports_a_mismatch_in_one_line(fake, server, capsys):
    folder, url, _ = server
    (folder / "c.bin").write_bytes(b"SEA")
    assert main(["data", "fetch", "two", "--base-url", url, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("warpvol: error: c.bin: the file downloaded from") and err.count("\n") == 1


def test_a_failed_download_names_the_file_and_address(fake, server):
    folder, url, _ = server
    (folder / "c.bin").unlink()
    with pytest.raises(WarpvolError, match=r"^c\.bin: download from http://127\.0\.0\.1:\d+/c\.bin failed: .*404"):
        D.fetch(D.DATA_SETS["two"], base_url=url, retries=0)


def test_unknown_names_are_an_error_listing_the_known_ones(fake, capsys):
    assert main(["data", "fetch", "three", "one"]) == 2
    assert "data set 'three': unknown; known: one, two or all" in capsys.readouterr().err
    with pytest.raises(ConfigError, match="none given"):
        D.select([])


def test_list_says_where_each_set_is(fake, capsys):
    files, url, _, cache = fake
    shared = D.SHARED_DATA
    shared.mkdir(parents=True)
    (shared / "c.bin").write_bytes(b"sea")
    D.fetch(D.DATA_SETS["one"], base_url=url, retries=0)
    assert main(["data"]) == 0
    out = capsys.readouterr().out
    rows = [re.split(r"\s{2,}", ln) for ln in out.splitlines()[:3]]
    assert rows == [["name", "files", "size", "shared/data", "cache", "source"],
                    ["one", "a.bin, b.bin", "350 B", "-", "yes", "a test"],
                    ["two", "c.bin", "3 B", "yes", "-", "a test"]]
    assert f"shared/data: {shared.resolve()}" in out and f"cache:       {cache.resolve()}" in out
    assert main(["data", "list"]) == 0 and capsys.readouterr().out == out


def write_scene(repo: Path, data_ref: str) -> Path:
    (repo / "scenes").mkdir(parents=True)
    s = repo / "scenes" / "bucky.toml"
    s.write_text(f'[mesh]\nraw = {{ path = "{data_ref}", dims = [32, 32, 32], dtype = "uint8", '
                 'spacing = [1.0, 1.0, 1.0] }\n[transfer]\npoints = [[0.0, 0, 0, 0, 0], [255.0, 1, 1, 1, 1]]\n'
                 '[camera]\nwidth_px = 8\nheight_px = 8\n')
    return s


def test_a_missing_data_file_names_the_fetch_command_and_a_normalised_path(tmp_path, monkeypatch):
    from warpvol.scene.scene_file import load_scene

    monkeypatch.setenv("WARPVOL_DATA", str(tmp_path / "cache"))
    s = write_scene(tmp_path / "repo", "../../shared/data/bucky.raw")
    with pytest.raises(ConfigError) as e:
        load_scene(s)
    msg = str(e.value)
    want = (tmp_path / "shared" / "data" / "bucky.raw").resolve()
    assert f"mesh.raw.path: file not found: {want} (nor in the data cache {(tmp_path / 'cache').resolve()}); " \
           "it is a file of the data set 'bucky': `warpvol data fetch bucky` downloads it" in msg
    assert "/../" not in msg.split("file not found: ")[1]


def test_a_missing_file_that_is_no_data_set_file_gets_a_normalised_path_only(tmp_path):
    from warpvol.scene.scene_file import load_scene

    s = write_scene(tmp_path / "repo", "../../shared/data/mine.raw")
    with pytest.raises(ConfigError, match=re.escape(f"file not found: {(tmp_path / 'shared/data/mine.raw').resolve()}")
                       + "$"):
        load_scene(s)


@pytest.mark.skipif(not (SHARED / "bucky.raw").is_file(), reason=f"{SHARED}/bucky.raw (../shared/data) is absent")
def test_a_fetched_file_is_read_from_the_cache(tmp_path, monkeypatch, server):
    """bucky.raw served from a copy of ../shared/data, fetched by name, read by a scene whose shared/data lacks it."""
    from warpvol.scene.scene_file import load_scene, scene_files

    folder, url, _ = server
    (folder / "bucky.raw").write_bytes((SHARED / "bucky.raw").read_bytes())
    monkeypatch.setenv("WARPVOL_DATA", str(tmp_path / "cache"))
    monkeypatch.setenv("WARPVOL_DATA_URL", url)
    assert main(["data", "fetch", "bucky", "--quiet"]) == 0
    s = write_scene(tmp_path / "repo", "../../shared/data/bucky.raw")
    scene = load_scene(s)
    assert scene.mesh.n_tets == 6 * 31 ** 3
    assert (tmp_path / "cache" / "bucky.raw", "mesh.raw.path in bucky.toml") in scene_files(s)


@pytest.mark.skipif(not (SHARED / "SHA256SUMS").is_file(), reason=f"{SHARED}/SHA256SUMS (../shared/data) is absent")
def test_the_registry_agrees_with_the_shared_data_folder():
    sums = dict(ln.split()[::-1] for ln in (SHARED / "SHA256SUMS").read_text().splitlines() if ln.strip())
    files = {f.name: f for ds in D.DATA_SETS.values() for f in ds.files}
    assert set(files) == set(sums)
    for name, f in files.items():
        assert f.sha256 == sums[name], name
        assert f.size == (SHARED / name).stat().st_size, name


def test_the_data_page_gives_every_file_its_address_size_and_checksum():
    page = (ROOT / "docs" / "guide" / "data-sets.md").read_text()
    for ds in D.DATA_SETS.values():
        assert f"`warpvol data fetch {ds.name}`" in page or f"| `{ds.name}` |" in page, ds.name
        for f in ds.files:
            assert f.url in page and f.sha256 in page and f"{f.size:,}" in page, f.name
    assert "data-sets.md" in (ROOT / "mkdocs.yml").read_text()


def test_every_shipped_scene_names_data_set_files_only():
    """Each file a shipped scene names in shared/data is a registry file, so a missing one names its set."""
    named = set()
    for s in (ROOT / "scenes").glob("*.toml"):
        named |= set(re.findall(r"shared/data/([\w.]+)", s.read_text()))
    assert named and all(D.data_set_of(n) is not None for n in named), named
