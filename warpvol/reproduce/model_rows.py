"""Counted work of every configuration the throughput-model validation compares (``scripts/validate_model.py``).

Each configuration is rendered once at the paper's image size and its per-frame counters are kept
(stages that build tables or per-mesh textures are left out: the papers' frame rates exclude them).
Counters are cached as JSON under ``out/validate_model/counters/`` (``refresh=True`` re-renders), so
the model can be re-run in seconds. Scenes come from ``scenes/*.toml`` and ``../shared/data``; a
configuration whose data are absent raises, and the caller lists its rows as skipped.
"""

from __future__ import annotations

import dataclasses
import json
import os
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CACHE = ROOT / "out" / "validate_model" / "counters"
#: stages whose work the papers' frame rates exclude (tables, per-mesh textures and cell set-up)
SETUP_PREFIXES = ("table_", "harc_mesh", "cell_setup", "entry_bins")


def _frame_counters(report: dict) -> dict:
    return {k: dict(v) for k, v in report["counters"].items() if not k.startswith(SETUP_PREFIXES)}


def _scene_file(name: str, w: int, h: int, split: int | None = None):
    import tomllib

    from warpvol.scene.scene_file import scene_from_config

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
    from warpvol.reproduce.espinha2005 import resampled_tf

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
    from warpvol.scene.camera import Camera
    from warpvol.scene.loaders import load_mesh
    from warpvol.scene.scene import Scene
    from warpvol.scene.transfer import TransferFunction

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
    from warpvol.reproduce.roettger2002 import fig9_tf
    from warpvol.scene.builtin import builtin_scene

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
    from warpvol.pipeline import Pipeline

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
    path = CACHE / (key.replace("/", "__") + "__texcache.json")
    tc = json.loads(path.read_text()) if path.is_file() else None
    if tc is None or "miss_bytes_by_block" not in tc:  # (a file from before the block sensitivity: recount)
        from warpvol.reproduce.texcache import table_misses

        tc = table_misses(warm or _pipeline(key, device), make(), warm=warm is not None)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(tc, indent=1))
    g = dict(c[stages[0]])
    g["tex_miss_bytes"] = int(tc["miss_bytes"])
    return {**c, stages[0]: g}


def texcache_at(key: str, c: dict, block: int) -> dict:
    """Counters ``c`` of configuration ``key`` (as :func:`counters` returns them) with the texture-cache
    term counted for memory blocks of ``block`` x ``block`` texels (one of
    :data:`warpvol.reproduce.texcache.SENSITIVITY_BLOCKS`); unchanged where the term is not counted."""
    stages = [s for s in TEXCACHE.get(key.split("/")[0], ()) if s in c and "tex_miss_bytes" in c[s]]
    path = CACHE / (key.replace("/", "__") + "__texcache.json")
    if not stages or not path.is_file():
        return c
    by = json.loads(path.read_text())["miss_bytes_by_block"]
    return {**c, stages[0]: {**c[stages[0]], "tex_miss_bytes": int(by[str(block)])}}


def _westermann(name: str):
    from warpvol.reproduce.westermann1997 import dataset

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


def counters(key: str, device: str = "cpu", refresh: bool = False) -> dict:
    """Per-frame counters of configuration ``key`` (cached; see the module docstring)."""
    path = CACHE / (key.replace("/", "__") + ".json")
    make, pipe = CONFIGS[key]
    if path.is_file() and not refresh:
        return _with_texcache(key, json.loads(path.read_text())["counters"], make, device)
    sc = make()
    if isinstance(pipe, tuple):  # the host visibility sort alone, counted as the sort stage counts it
        from warpvol.projection.sort import visibility_order

        r = visibility_order(sc.mesh, sc.camera, pipe[1])
        c = {"sort": {"cells_sorted": len(r.order), "graph_edges": int(r.edges), "cycles_broken": int(r.cycles_broken),
                      **{k: int(v) for k, v in r.extra.items()}}}
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"key": key, "tets": int(sc.mesh.n_tets), "counters": c,
                                    "stats": {"sort": {"method": r.method, "exact": bool(r.exact)}}}, indent=1))
        return c
    p = _pipeline(key, device)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        p.render(sc, quiet=True)  # tables, per-mesh textures and kernels: the redraw below is the frame
        res = p.render(sc, quiet=True)
    c = _frame_counters(res.report)
    stats = {k: v for k, v in (res.report.get("stats") or {}).items() if k in ("sort", "harc", "vicp")}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"key": key, "tets": int(sc.mesh.n_tets), "counters": c, "stats": stats},
                               indent=1, default=str))
    (CACHE / (key.replace("/", "__") + "__texcache.json")).unlink(missing_ok=True)
    return _with_texcache(key, c, lambda: sc, device, warm=p)


def tets(key: str) -> int | None:
    path = CACHE / (key.replace("/", "__") + ".json")
    return json.loads(path.read_text())["tets"] if path.is_file() else None


if __name__ == "__main__":  # python -m warpvol.reproduce.model_rows [PREFIX ...]: fill the cache
    import sys
    import time

    from warpvol.pipeline import quiet_warp

    quiet_warp()
    for key in CONFIGS:
        if len(sys.argv) > 1 and not key.startswith(tuple(sys.argv[1:])):
            continue
        t0 = time.perf_counter()
        try:
            c = counters(key, refresh=os.environ.get("REFRESH") == "1")
            print(f"{key}: {time.perf_counter() - t0:.1f} s, {sum(len(v) for v in c.values())} counters", flush=True)
        except Exception as e:  # noqa: BLE001 - reported, next configuration
            print(f"{key}: FAILED {type(e).__name__}: {e}", flush=True)
