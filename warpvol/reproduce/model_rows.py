"""Counted work of every configuration the throughput-model validation compares (``scripts/validate_model.py``).

Each configuration is rendered once at the paper's image size and its per-frame counters are kept
(stages that build tables or per-mesh textures are left out: the papers' frame rates exclude them).
Counters are cached as JSON under ``out/validate_model/counters/`` (``refresh=True`` re-renders), so
the model can be re-run in seconds. Each file carries :func:`code_key`, a hash of the code that counts
(every module of ``warpvol`` and ``warpvol.kernels``, the presets, ``scenes/*.toml`` and this module's
configurations, but those listed in :data:`NOT_COUNTING`) and Warp's version: a file counted by other
code is stale and counted again, so a cache cannot hide a change. Scenes come from ``scenes/*.toml`` and
``../shared/data``; a configuration whose data are absent raises, and the caller lists its rows as
skipped.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import warnings
from pathlib import Path

from warpvol.pipeline import Pipeline
from warpvol.progress import ProgressBar
from warpvol.reproduce.espinha2005 import resampled_tf
from warpvol.reproduce.roettger2002 import fig9_tf
from warpvol.reproduce.texcache import misses, observe_draws
from warpvol.reproduce.westermann1997 import dataset
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.loaders import load_mesh
from warpvol.scene.scene import Scene
from warpvol.scene.scene_file import scene_from_config
from warpvol.scene.transfer import TransferFunction

ROOT = Path(__file__).resolve().parents[2]
CACHE = ROOT / "out" / "validate_model" / "counters"
#: stages whose work the papers' frame rates exclude (tables, per-mesh textures and cell set-up)
SETUP_PREFIXES = ("table_", "harc_mesh", "cell_setup", "entry_bins")
#: files (paths relative to the repository, prefixes of them) that price, compare or show counters and
#: never change one: left out of :func:`code_key`, so editing them keeps the cache
NOT_COUNTING = ("warpvol/model.py", "warpvol/profiles/", "warpvol/reproduce/agreement.py", "warpvol/cli",
                "warpvol/tools/", "warpvol/figures.py", "warpvol/demo.py", "warpvol/progress.py")


@functools.cache
def code_key() -> str:
    """SHA-256 (16 hex digits) of the code that counts: every ``*.py`` and ``*.toml`` under ``warpvol/``
    and ``kernels/`` and ``scenes/*.toml``, by path and content, but :data:`NOT_COUNTING`, and Warp's
    version. This module is part of it (its configurations define what is counted)."""
    import warp as wp

    h = hashlib.sha256(f"warp {wp.config.version}".encode())
    files = [*(ROOT / "warpvol").rglob("*.py"), *(ROOT / "warpvol").rglob("*.toml"),
             *(ROOT / "kernels").rglob("*.py"), *(ROOT / "scenes").glob("*.toml")]
    for f in sorted(files):
        rel = f.relative_to(ROOT).as_posix()
        if "__pycache__" in rel or rel.startswith(NOT_COUNTING):
            continue
        h.update(f"\0{rel}\0".encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:16]


def _cache_path(key: str, suffix: str = "") -> Path:
    return CACHE / (key.replace("/", "__") + suffix + ".json")


def cached(key: str, suffix: str = "") -> dict | None:
    """The cache file of configuration ``key`` when it was counted by the code at hand (:func:`code_key`),
    else ``None`` (absent or stale)."""
    path = _cache_path(key, suffix)
    if not path.is_file():
        return None
    d = json.loads(path.read_text())
    return d if d.get("code") == code_key() else None


def _write(key: str, data: dict, suffix: str = "") -> None:
    path = _cache_path(key, suffix)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({**data, "code": code_key()}, indent=1, default=str))


def _frame_counters(report: dict) -> dict:
    return {k: dict(v) for k, v in report["counters"].items() if not k.startswith(SETUP_PREFIXES)}


def _scene_file(name: str, w: int, h: int, split: int | None = None):
    import tomllib


    p = ROOT / "scenes" / f"{name}.toml"
    cfg = tomllib.loads(p.read_text())
    if split:
        cfg["mesh"]["split"] = split
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zero-volume tets of the collapsed wall rows
        sc = scene_from_config(cfg, p.parent, name=name)
    sc.camera = sc.camera.replace(width_px=w, height_px=h)
    return sc


def espinha_scene(name: str, segments: int | None = None):
    sc = _scene_file(name, 512, 512)
    return sc if segments is None else dataclasses.replace(sc, transfer=resampled_tf(sc.transfer, segments))


def kraus_stages(*, perspective=False, hilo=False, log=False, buffer="unorm8", dither=False, blend="unit") -> list:
    """Kraus et al. 2004 Table 1 pipeline with the chosen enhancements (256x256x16 tables)."""
    return [{"stage": "vertex"}, {"stage": "sort", "method": "mpvo", "applies_to": "convex"},
            {"stage": "sort", "method": "mpvonc", "applies_to": "non_convex"},
            {"stage": "table_incremental", "n_s": 256, "n_l": 16, "axis": "log2" if log else "uniform",
             "format": "hilo16" if hilo else "rgba8"},
            {"stage": "pt_project"},
            *([{"stage": "pt_perspective", "thickness": "exact"}] if perspective else []),
            {"stage": "pt_table3d", "texel_format": "rgba16" if hilo else "rgba8", "format": buffer,
             "dither": dither, "blend": blend}]


KRAUS_T1 = {"i": {}, "ii": {"perspective": True}, "iii": {"perspective": True, "hilo": True},
            "iv": {"perspective": True, "hilo": True, "log": True},
            "dither": {"perspective": True, "hilo": True, "log": True, "dither": True},
            "fp16": {"perspective": True, "hilo": True, "log": True, "buffer": "fp16", "blend": "readback"}}


def guthe_scene(name: str):
    """Guthe et al. 2002 Table 5 scenes at 1280x960: Blunt Fin (5-tet split) and the Bucky Ball (6-tet split)."""

    if name == "bluntfin":
        return _scene_file("bluntfin", 1280, 960, split=5)
    mesh = load_mesh({"raw": {"path": str(ROOT.parent / "shared" / "data" / "bucky.raw"), "dims": [32, 32, 32],
                              "dtype": "uint8", "spacing": [1, 1, 1]}, "split": 6})
    tf = TransferFunction([[0, 0.0, 0.0, 0.0, 0.0], [60, 0.2, 0.4, 1.0, 0.02], [120, 0.3, 1.0, 0.4, 0.08],
                           [200, 1.0, 0.8, 0.2, 0.3], [255, 1.0, 0.2, 0.1, 0.6]], "color_extinction")
    cam = Camera(eye=(62.0, 48.0, 70.0), target=(15.5, 15.5, 15.5), fov_y_deg=40.0, width_px=1280, height_px=960)
    return Scene(mesh=mesh, transfer=tf, camera=cam, name="bucky")


def guthe_stages(card: str, method: str) -> list:
    return [{"stage": "vertex"}, {"stage": "sort", "method": method},
            {"stage": "table_guthe", "n_s": 512, "degree": 2, "alpha_format": "al16"},
            {"stage": "pt_project"}, {"stage": "pt_guthe", "gpu": card, "format": "unorm8"}]


def roettger_scene():
    """Roettger & Ertl 2002 Fig. 8: the 2,560-tet spherical distance volume, Fig. 9 TF, 512x384 window."""

    sc = builtin_scene("sphere")
    return type(sc)(mesh=sc.mesh, transfer=fig9_tf(), camera=sc.camera.replace(width_px=512, height_px=384),
                    name="sphere_fig9")


ROETTGER_F8 = {"3d": [{"stage": "table_exact", "n_s": 64, "n_l": 64, "format": "rgba8"},
                      {"stage": "pt_table3d", "texel_format": "rgba8"}],
               "2d": [{"stage": "table_cylindrical", "n_s": 64, "planes": "1x", "format": "rgba8"},
                      {"stage": "pt_cylindrical"}],
               # SGI platforms: one 2D texture, nearest (the Fig. 8 caption): pt_cylindrical path = "sgi"
               "2d_sgi": [{"stage": "table_cylindrical", "n_s": 64, "planes": "1x", "format": "rgba8"},
                          {"stage": "pt_cylindrical", "path": "sgi"}]}


#: configurations whose table lookups get the texture-cache term counted from the redraw's fragments
#: (:mod:`warpvol.reproduce.texcache`), and the fragment stages that look up: Roettger & Ertl 2002 (§4)
#: name the 3D texture's "additional texture memory accesses and a reduced texture cache coherency" as
#: the reason for Fig. 8's 2D speed-up; Guthe et al. 2002 (§5) ascribe the Bucky Ball's lower frame rate
#: to "a larger variation of the scalar values which lead to a reduced texture cache coherence"; Kraus et
#: al. 2004 look up the same kind of 3D table as Roettger's
TEXCACHE = {"roettger": ("pt_table3d", "pt_cylindrical"), "kraus": ("pt_table3d",), "guthe": ("pt_guthe",)}


def _pipeline(key: str, device: str):
    """The pipeline of configuration ``key`` (a preset name or a stage list)."""

    pipe = CONFIGS[key][1]
    return Pipeline.load(pipe, device=device) if isinstance(pipe, str) else \
        Pipeline.from_config({"name": key.replace("/", "_"), "stages": pipe}, device=device)


def _with_texcache(key: str, c: dict, make, device: str = "cpu", warm=None) -> dict:
    """Add ``tex_miss_bytes`` (:func:`warpvol.reproduce.texcache.table_misses` of a redraw) to the fragment
    stage of a TEXCACHE configuration. ``warm``: the configuration's pipeline, already rendered on
    ``make()``'s scene (else one is built and rendered first)."""
    stages = [s for s in TEXCACHE.get(key.split("/")[0], ()) if s in c]
    if not stages:
        return c
    tc = cached(key, "__texcache")
    if tc is None:
        from warpvol.reproduce.texcache import table_misses

        tc = table_misses(warm or _pipeline(key, device), make(), warm=warm is not None)
        _write(key, tc, "__texcache")
    g = dict(c[stages[0]])
    g["tex_miss_bytes"] = int(tc["miss_bytes"])
    return {**c, stages[0]: g}


def texcache_at(key: str, c: dict, block: int) -> dict:
    """Counters ``c`` of configuration ``key`` (as :func:`counters` returns them) with the texture-cache
    term counted for memory blocks of ``block`` x ``block`` texels (one of
    :data:`warpvol.reproduce.texcache.SENSITIVITY_BLOCKS`); unchanged where the term is not counted."""
    stages = [s for s in TEXCACHE.get(key.split("/")[0], ()) if s in c and "tex_miss_bytes" in c[s]]
    tc = cached(key, "__texcache")
    if not stages or tc is None:
        return c
    by = tc["miss_bytes_by_block"]
    return {**c, stages[0]: {**c[stages[0]], "tex_miss_bytes": int(by[str(block)])}}


def _westermann(name: str):
    return dataset(name, 450)


def _configs() -> dict:
    """key -> (scene factory, pipeline: preset name or stage list)."""
    out = {}
    for data in ("bluntfin", "loxpost"):
        out[f"espinha/{data}/raycast"] = (lambda d=data: espinha_scene(d), "raycast")
        out[f"espinha/{data}/full"] = (lambda d=data: espinha_scene(d), "espinha2005_full")
        for seg in (10, 255):
            out[f"espinha/{data}/partial{seg}"] = (lambda d=data, s=seg: espinha_scene(d, s), "espinha2005_partial")
        out[f"espinha/{data}/vicp"] = (lambda d=data: espinha_scene(d), "weiler2003_vicp")
    for k, kw in KRAUS_T1.items():
        out[f"kraus/bluntfin/{k}"] = (lambda: _scene_file("bluntfin", 800, 600, split=5), kraus_stages(**kw))
    for data in ("bluntfin", "bucky"):
        for card in ("geforce4", "radeon8500"):
            out[f"guthe/{data}/{card}"] = (lambda d=data: guthe_scene(d), guthe_stages(card, "centroid"))
        for method in ("centroid", "mpvo", "xmpvo"):
            out[f"guthe/{data}/sort_{method}"] = (lambda d=data: guthe_scene(d), ("sort", method))
    for data in ("bluntfin", "fe"):
        out[f"westermann/{data}"] = (lambda d=data: _westermann(d), "westermann1997")
    for k, st in ROETTGER_F8.items():
        out[f"roettger/sphere/{k}"] = (roettger_scene, [{"stage": "vertex"}, {"stage": "sort", "method": "mpvo"},
                                                        st[0], {"stage": "pt_project"}, st[1]])
    return out


CONFIGS = _configs()


def is_cached(key: str) -> bool:
    """Whether configuration ``key``'s counters (and its texture-cache term, where it has one) are in the
    cache, counted by the code at hand."""
    d = cached(key)
    if d is None:
        return False
    return not any(s in d["counters"] for s in TEXCACHE.get(key.split("/")[0], ())) or \
        cached(key, "__texcache") is not None


def counters(key: str, device: str = "cpu", refresh: bool = False) -> dict:
    """Per-frame counters of configuration ``key`` (cached, keyed by :func:`code_key`; see the module
    docstring)."""
    import time

    make, pipe = CONFIGS[key]
    d = None if refresh else cached(key)
    if d is not None:
        return _with_texcache(key, d["counters"], make, device)
    t0, c0, load0 = time.perf_counter(), time.process_time(), os.getloadavg()[0]

    def cost() -> dict:  # what this count took: wall and CPU seconds (all threads), 1-min load at start, end
        return {"seconds": time.perf_counter() - t0, "cpu_s": time.process_time() - c0,
                "load": [round(load0, 2), round(os.getloadavg()[0], 2)]}

    sc = make()
    if isinstance(pipe, tuple):  # the host visibility sort alone, counted as the sort stage counts it
        from warpvol.projection.sort import visibility_order

        r = visibility_order(sc.mesh, sc.camera, pipe[1])
        c = {"sort": {"cells_sorted": len(r.order), "graph_edges": int(r.edges), "cycles_broken": int(r.cycles_broken),
                      **{k: int(v) for k, v in r.extra.items()}}}
        _write(key, {"key": key, "tets": int(sc.mesh.n_tets), "counters": c, **cost(),
                     "stats": {"sort": {"method": r.method, "exact": bool(r.exact)}}})
        return c
    from contextlib import nullcontext


    p = _pipeline(key, device)
    seen: list = []
    tex = bool(TEXCACHE.get(key.split("/")[0]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        p.render(sc, quiet=True)  # tables, per-mesh textures (uploads) and kernels: the redraw below is the frame
        with observe_draws(seen) if tex else nullcontext():  # its lookups also give the texture-cache term
            res = p.render(sc, quiet=True)
    c = _frame_counters(res.report)
    stats = {k: v for k, v in (res.report.get("stats") or {}).items() if k in ("sort", "harc", "vicp")}
    if tex and any(s in c for s in TEXCACHE[key.split("/")[0]]):
        _write(key, misses(seen), "__texcache")
    else:
        _cache_path(key, "__texcache").unlink(missing_ok=True)
    del seen
    _write(key, {"key": key, "tets": int(sc.mesh.n_tets), "counters": c, "stats": stats, **cost()})
    return _with_texcache(key, c, lambda: sc, device, warm=p)


#: seconds a configuration's count is expected to take when no earlier count says (progress weights)
GUESS_S = 30.0


def fill(keys, device: str = "cpu", refresh: bool = False, force_lines: bool = True) -> dict:
    """Count the configurations ``keys`` not in the cache (all with ``refresh``) in this process, with a
    progress bar weighted by each one's time in its last count (a stale file keeps it); returns
    ``{"counted": {key: seconds}, "cached": n, "failed": {key: error}}`` (a failure is left to the caller,
    which lists its rows as skipped)."""
    import time


    todo = [k for k in keys if refresh or not is_cached(k)]
    weight = {}
    for k in todo:
        p = _cache_path(k)
        old = json.loads(p.read_text()).get("seconds") if p.is_file() else None
        weight[k] = float(old) if old else GUESS_S
    out = {"counted": {}, "cached": len(keys) - len(todo), "failed": {}}
    if not todo:
        return out
    with ProgressBar(f"counting {len(todo)} configuration(s)", sum(weight.values()), force=force_lines) as bar:
        for k in todo:
            bar.describe(k)
            t0 = time.perf_counter()
            try:
                counters(k, device, refresh=True)
                out["counted"][k] = time.perf_counter() - t0
            except Exception as e:  # noqa: BLE001 - data absent or a stage failed: the caller skips the rows
                out["failed"][k] = f"{type(e).__name__}: {e}"
            bar.advance(weight[k], f"{k} done in {time.perf_counter() - t0:.0f} s")
    return out


def count_cost(key: str) -> dict | None:
    """What counting configuration ``key`` took when its cached counters were counted (``seconds``,
    ``cpu_s``, ``load``: the 1-minute load average at its start and end); ``None`` when not cached."""
    d = cached(key)
    return None if d is None or "cpu_s" not in d else {k: d[k] for k in ("seconds", "cpu_s", "load")}


def tets(key: str) -> int | None:
    d = cached(key)
    return None if d is None else d["tets"]


if __name__ == "__main__":  # python -m warpvol.reproduce.model_rows [PREFIX ...]: fill the cache
    import sys
    import time

    from warpvol.pipeline import quiet_warp

    quiet_warp()
    keys = [k for k in CONFIGS if len(sys.argv) < 2 or k.startswith(tuple(sys.argv[1:]))]
    t0 = time.perf_counter()
    r = fill(keys, refresh=os.environ.get("REFRESH") == "1")
    for k, v in r["counted"].items():
        print(f"{k}: {v:.1f} s", flush=True)
    for k, v in r["failed"].items():
        print(f"{k}: FAILED {v}", flush=True)
    print(f"{len(r['counted'])} counted in {time.perf_counter() - t0:.0f} s, {r['cached']} from the cache", flush=True)
