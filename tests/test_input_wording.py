"""What the command line says about inputs it cannot use: each error is one line that names the flag,
key or file and what to do, never a raw ``[Errno ...]``."""

import re

import numpy as np
import pytest

from warpvol.cli import main


def _err(capsys, argv) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("warpvol: error: ") and len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("where", ["file", "under a file", "file in a folder"])
def test_cache_dir_naming_a_file_says_so(tmp_path, capsys, where):
    (tmp_path / "f").write_text("mine")
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "g").write_text("mine")
    cache = {"file": tmp_path / "f", "under a file": tmp_path / "f" / "sub", "file in a folder": tmp_path / "d" / "g"}
    err = _err(capsys, ["bench", "builtin:box", "--pipelines", "raycast", "--width", "8", "--height", "8",
                        "--cache-dir", str(cache[where]), "-o", str(tmp_path / "out"), "--quiet"])
    assert err.startswith("warpvol: error: --cache-dir: ") and "Errno" not in err
    assert "not a folder" in err or "a file of that name is on its path" in err
    assert (tmp_path / "f").read_text() == "mine" and (tmp_path / "d" / "g").read_text() == "mine"


@pytest.mark.parametrize("dims,dtype,nbytes", [
    ([4000, 4000, 4000], "uint8", 100),     # far too large for memory too: the file is what is wrong
    ([40, 40, 40], "uint16", 1000),
    ([64, 64, 32], "float32", 64 * 64 * 32),  # the dims of a uint8 volume read as float32
    ([10, 10, 10], "float32", 4100),        # longer than the dims
])
def test_raw_file_that_does_not_match_its_dims_says_what_it_holds(tmp_path, capsys, dims, dtype, nbytes):
    (tmp_path / "v.raw").write_bytes(bytes(nbytes))
    f = tmp_path / "v.toml"
    f.write_text(f'[mesh]\nraw = {{ path = "v.raw", dims = {dims}, dtype = "{dtype}", spacing = [1, 1, 1] }}\n')
    err = _err(capsys, ["render", str(f), "-o", str(tmp_path / "o.exr"), "--quiet"])
    need = int(np.prod(dims)) * np.dtype(dtype).itemsize
    assert f"holds {nbytes:,} bytes" in err and f"need {need:,}" in err and "x".join(map(str, dims)) in err
    assert ("shorter" if nbytes < need else "longer") in err and "memory" not in err


def _nest(style: str, depth: int) -> str:
    return ("[" * depth + "1" + "]" * depth) if style == "array" else ("{ y = " * depth + "1" + " }" * depth)


@pytest.mark.parametrize("kind,table,key,style,depth", [
    ("scene", "camera", "up", "array", 1500), ("scene", "transfer", "points", "table", 1200),
    ("scene", "", "extra", "array", 3000), ("pipeline", "", "description", "table", 1200),
    ("sweep", "", "views", "array", 2000)])
def test_toml_nested_too_deeply_names_the_key(tmp_path, capsys, kind, table, key, style, depth):
    (tmp_path / "ok.toml").write_text('[mesh]\nbuiltin = "box"\n')
    head = {"scene": '[mesh]\nbuiltin = "box"\n', "pipeline": 'name = "p"\n', "sweep": 'scenes = ["ok.toml"]\n'}[kind]
    body = head + (f"[{table}]\n" if table else "") + "# a comment with [ brackets {\n" + \
        f'note = "a string with [[ and {{"\n{key} = {_nest(style, depth)}\n'
    f = tmp_path / f"{kind}.toml"
    f.write_text(body)
    argv = {"scene": ["render", str(f), "-o", str(tmp_path / "o.exr"), "--quiet"],
            "pipeline": ["render", str(tmp_path / "ok.toml"), "--pipeline", str(f), "-o", str(tmp_path / "o.exr"),
                         "--quiet"],
            "sweep": ["sweep", str(f), "--serial", "-o", str(tmp_path / "out"), "--quiet"]}[kind]
    err = _err(capsys, argv)
    line = body.splitlines().index(next(ln for ln in body.splitlines() if ln.startswith(f"{key} =")))
    full = ".".join(k for k in (table or ("mesh" if kind == "scene" else ""), key) if k)  # [mesh] is open
    assert f"{f}: " in err and f"nested too deeply at key '{full}' (line {line + 1}: {depth} " in err, err


@pytest.mark.parametrize("n_blocks", [2, 3])
def test_multiblock_file_suggests_how_to_combine_it(tmp_path, capsys, monkeypatch, n_blocks):
    import pyvista as pv

    g = pv.ImageData(dimensions=(3, 3, 3)).cast_to_unstructured_grid()
    g.point_data["s"] = np.linspace(0, 1, g.n_points)
    pv.MultiBlock([g.translate((2 * k, 0, 0)) for k in range(n_blocks)]).save(tmp_path / "parts.vtm")
    monkeypatch.chdir(tmp_path)
    err = _err(capsys, ["render", "parts.vtm", "-o", "o.png", "--quiet", "--width", "8", "--height", "8"])
    assert f"holds {n_blocks} blocks" in err and "Merge Blocks" in err
    code = re.search(r'python -c "(.*?)"', err).group(1)
    exec(code)  # the suggestion as written makes the one file it names
    assert main(["render", "parts.vtu", "-o", "o.png", "--quiet", "--width", "8", "--height", "8"]) == 0
