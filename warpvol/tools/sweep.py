"""``warpvol sweep``: scenes x views x presets x options as independent tasks on Dask.

A sweep config (TOML)::

    name = "fb-bits"
    scenes = ["builtin:sphere", "../scenes/bluntfin.toml"]   # relative to the config file
    presets = ["all"]                # or preset names / pipeline files
    repeats = 1                      # timed renders per task after a warm-up (median)
    kernel_cache_dir = ""            # optional: WARP_CACHE_PATH for the workers (see below)
    [[views]]                        # Camera fields replaced in each scene's camera; none = its own
    name = "small"
    width_px = 64
    height_px = 64
    [[options]]                      # stage parameter overrides "stage.param" = value; none = defaults
    name = "default"
    [[options]]
    name = "no-early-termination"
    overrides = { "raycast.early_termination" = 0.0 }
    [[options]]
    name = "no-skip"                 # skip = false: every render does all the work (render --no-skip)
    skip = false

Every (scene, view, preset, option) is one task. An option that sets a parameter of a stage the
preset does not have is *not applicable* to it: a row says so, no task runs. The exact reference of
each (scene, view) is one task too, computed once and shared by its render tasks through the
on-disk reference cache (``OUTDIR/references``). Each render task writes its row
(``OUTDIR/tasks/KEY.json``) and image (``KEY.npy``) when it finishes; a sweep started again skips
every task whose row is there, so an interrupted sweep resumes. A task that raises becomes a row with
status ``failed`` and its error (not stored, so the next run retries it); the others finish. A worker
that dies mid-task loses nothing: the scheduler runs its tasks again elsewhere.

Workers: a local cluster (``LocalCluster``, one thread per worker process, on 127.0.0.1) unless
``--scheduler tcp://HOST:PORT`` names a running scheduler. Workers must see ``OUTDIR`` and the
scene files under the same paths (a shared file system). Warp compiles kernels per host into its
kernel cache; a worker compiles what it lacks on first use (a few seconds per kernel module) and
reuses it afterwards. Workers on one host share the default cache (``~/.cache/warp/VERSION``);
``kernel_cache_dir`` sets ``WARP_CACHE_PATH`` in each task before Warp is initialised, so workers on
several hosts can share one pre-filled cache on a shared file system (compile once with
``warpvol demo`` on a host of the same architecture and Warp version).
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import re
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from warpvol.errors import ConfigError, check_keys
from warpvol.io import Outputs, save_result
from warpvol.pipeline import Pipeline, _read_pipeline_text, quiet_warp, report_json
from warpvol.progress import ProgressBar
from warpvol.scene.scene_file import load_scene, scene_digest
from warpvol.tools import report_html as rh
from warpvol.tools.bench import (
    BenchResult,
    bench_pipeline,
    cached_reference,
    mark_pareto,
    pipeline_digest,
    resolve_pipelines,
    scene_hash,
)

CONFIG_KEYS = ("name", "scenes", "presets", "repeats", "kernel_cache_dir", "views", "options")


@dataclass(frozen=True)
class Task:
    """One render: scene spec, view (name + Camera overrides), preset and option (name + overrides);
    ``scene_sha`` / ``preset_sha``: content hashes of the scene's files
    (:func:`warpvol.scene.scene_file.scene_digest`) and of the preset's TOML, part of :attr:`key`, so that a
    changed file is a new task, never a reused row."""

    scene: str
    view: tuple
    preset: str
    option: tuple
    repeats: int = 1
    scene_sha: str = ""
    preset_sha: str = ""

    @property
    def view_name(self) -> str:
        return self.view[0]

    @property
    def option_name(self) -> str:
        return self.option[0]

    @property
    def key(self) -> str:
        h = hashlib.sha1(repr((self.scene, self.view, self.preset, self.option, self.repeats, self.scene_sha,
                               self.preset_sha)).encode()).hexdigest()[:10]
        label = "-".join((Path(self.scene).stem if not self.scene.startswith("builtin:") else self.scene[8:],
                          self.view_name, Path(self.preset).stem, self.option_name))
        return re.sub(r"[^A-Za-z0-9_.-]+", "_", label)[:80] + "-" + h


@dataclass
class SweepConfig:
    name: str
    scenes: list[str]
    presets: list[str]
    repeats: int = 1
    kernel_cache_dir: str | None = None
    views: list[tuple] = field(default_factory=lambda: [("default", ())])
    options: list[tuple] = field(default_factory=lambda: [("default", ())])


def _named(where: str, items: Any, allowed_extra: tuple[str, ...] | None) -> list[tuple]:
    if not isinstance(items, list) or not items:
        raise ConfigError(f"{where}: expected a non-empty list of [[{where.split('.')[-1]}]] tables")
    out, seen = [], set()
    for k, it in enumerate(items):
        w = f"{where}[{k}]"
        if not isinstance(it, dict) or not isinstance(it.get("name"), str) or not it["name"]:
            raise ConfigError(f"{w}: expected a table with a non-empty 'name'")
        if it["name"] in seen:
            raise ConfigError(f"{w}.name: {it['name']!r} used twice")
        seen.add(it["name"])
        if allowed_extra is None:  # options: name + overrides (+ skip = false)
            check_keys(w, it, ["name", "overrides", "skip"])
            ov = it.get("overrides", {})
            if not isinstance(ov, dict) or any("." not in str(k2) for k2 in ov):
                raise ConfigError(f"{w}.overrides: expected a table of \"stage.param\" = value")
            if not isinstance(it.get("skip", True), bool):
                raise ConfigError(f"{w}.skip: expected true or false, got {it['skip']!r}")
            # (name, overrides), and skip only where it is off: the task keys of other options stay as they were
            out.append((it["name"], tuple(sorted(ov.items()))) + (() if it.get("skip", True) else (False,)))
        else:  # views: name + Camera fields
            rest = {k2: (tuple(v) if isinstance(v, list) else v) for k2, v in it.items() if k2 != "name"}
            check_keys(w, rest, list(allowed_extra))
            out.append((it["name"], tuple(sorted(rest.items()))))
    return out


def load_config(path: str | Path) -> SweepConfig:
    """Read and check a sweep config; scene files are resolved relative to it, presets checked."""

    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"sweep config not found: {p}")
    try:
        text = p.read_text()
        cfg = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ConfigError(f"{p}: invalid TOML: {e}") from None
    except RecursionError:
        from warpvol.io import toml_nesting

        raise ConfigError(f"{p}: invalid TOML: nested too deeply {toml_nesting(text)}") from None
    check_keys(str(p), cfg, list(CONFIG_KEYS))
    scenes = cfg.get("scenes")
    if not isinstance(scenes, list) or not scenes or not all(isinstance(s, str) for s in scenes):
        raise ConfigError(f"{p}: scenes: expected a non-empty list of scene files or 'builtin:NAME'")
    scenes = [s if s.startswith("builtin:") else str((p.parent / s).resolve()) for s in scenes]
    for s in scenes:
        if not s.startswith("builtin:") and not Path(s).is_file():
            raise ConfigError(f"{p}: scenes: file not found: {s}")
    presets = resolve_pipelines(cfg.get("presets", "all"))
    presets = [n if not n.endswith(".toml") else str((p.parent / n).resolve()) for n in presets]
    for n in presets:
        _read_pipeline_text(n)
    repeats = cfg.get("repeats", 1)
    if not isinstance(repeats, int) or isinstance(repeats, bool) or repeats < 1:
        raise ConfigError(f"{p}: repeats: expected an integer >= 1, got {repeats!r}")
    cam_fields = ("projection", "eye", "target", "up", "fov_y_deg", "height", "width_px", "height_px")
    views = _named(f"{p}: views", cfg["views"], cam_fields) if "views" in cfg else [("default", ())]
    options = _named(f"{p}: options", cfg["options"], None) if "options" in cfg else [("default", ())]
    kdir = cfg.get("kernel_cache_dir") or None
    if kdir is not None:
        kdir = str((p.parent / kdir).resolve())
    return SweepConfig(str(cfg.get("name", p.stem)), scenes, presets, repeats, kdir, views, options)


def pipeline_config(preset: str, overrides: tuple) -> dict | str:
    """The preset's config with ``stage.param`` overrides applied, or a sentence why they do not apply."""

    text, where = _read_pipeline_text(preset)
    try:
        cfg = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError) as e:
        raise ConfigError(f"{where}: invalid TOML: {e}") from None
    cfg.setdefault("name", Path(preset).stem)
    hit = set()
    for st in cfg["stages"]:
        for k, v in overrides:
            stage, param = k.split(".", 1)
            if st.get("stage") == stage:
                st[param] = v
                hit.add(k)
    missing = [k for k, _ in overrides if k not in hit]
    if missing:
        return f"not applicable: preset {cfg['name']!r} has no stage {missing[0].split('.')[0]!r} (option sets {missing[0]})"
    return cfg


def plan_tasks(cfg: SweepConfig) -> tuple[list[Task], list[dict]]:
    """Tasks to run, and rows for the combinations an option does not apply to."""

    tasks, na = [], []
    scene_sha = {s: scene_digest(s) for s in cfg.scenes}
    preset_sha = {pr: pipeline_digest(pr) for pr in cfg.presets}
    for s in cfg.scenes:
        for v in cfg.views:
            for pr in cfg.presets:
                for o in cfg.options:
                    t = Task(s, v, pr, o, cfg.repeats, scene_sha[s], preset_sha[pr])
                    pc = pipeline_config(pr, o[1])
                    if isinstance(pc, str):
                        na.append({**_ids(t), "status": "n/a", "message": pc})
                    else:
                        tasks.append(t)
    return tasks, na


def _ids(t: Task) -> dict:
    return {"scene": t.scene if t.scene.startswith("builtin:") else Path(t.scene).stem, "view": t.view_name,
            "pipeline": Path(t.preset).stem, "options": t.option_name, "task": t.key}


# ------------------------------------------------------------------------------------------------
# task functions (run on workers; top-level so they pickle)
# ------------------------------------------------------------------------------------------------
def _worker_setup(kernel_cache_dir: str | None) -> None:
    if kernel_cache_dir:
        os.environ.setdefault("WARP_CACHE_PATH", kernel_cache_dir)  # read by wp.init() below

    quiet_warp()


@functools.lru_cache(maxsize=4)
def _scene(spec: str, sha: str = ""):
    """The scene of ``spec`` (cached by its path and ``sha``, the content hash: a changed file is read again)."""

    return load_scene(spec)


def _view_scene(spec: str, view: tuple, sha: str = ""):
    scene = _scene(spec, sha)
    return scene.with_camera(**{("ortho_height" if k == "height" else k): v for k, v in view[1]}) if view[1] else scene


def reference_task(spec: str, view: tuple, sha: str, cache_dir: str, kernel_cache_dir: str | None = None) -> str:
    """Compute (or find) the exact reference of one scene (content hash ``sha``) and view; returns its
    cache file."""

    _worker_setup(kernel_cache_dir)
    scene = _view_scene(spec, view, sha)
    cached_reference(scene, cache_dir)
    return str(Path(cache_dir) / f"reference-{scene_hash(scene)}.npy")


def run_task(task: Task, ref_path: str, outdir: str, kernel_cache_dir: str | None = None) -> dict:
    """Render one task (warm-up + repeats), store its row and image; a failure is a row, not an error."""

    _worker_setup(kernel_cache_dir)
    row = _ids(task)
    try:
        scene = _view_scene(task.scene, task.view, task.scene_sha)
        pipe = Pipeline.from_config(pipeline_config(task.preset, task.option[1]), where=f"preset {task.preset!r}")
        res = bench_pipeline(pipe, scene, np.load(ref_path), repeats=task.repeats, audit=False,
                             skip=task.option[2] if len(task.option) > 2 else True)
    except Exception as e:  # noqa: BLE001 - reported with its error; the other tasks go on
        return {**row, "status": "failed", "message": f"{type(e).__name__}: {e}"}
    img = res.pop("_image")
    res.update(row)
    res["host"] = os.uname().nodename
    d = Path(outdir) / "tasks"
    save_result(d, task.key, report_json(res), img)  # the row is the task's "done" mark: written last
    return json.loads((d / f"{task.key}.json").read_text())


# ------------------------------------------------------------------------------------------------
# the sweep
# ------------------------------------------------------------------------------------------------
@dataclass
class SweepResult:
    config: SweepConfig
    rows: list[dict]
    skipped_done: int
    wall_s: float


def _done_row(outdir: Path, t: Task) -> dict | None:
    f = outdir / "tasks" / f"{t.key}.json"
    if f.is_file() and (outdir / "tasks" / f"{t.key}.npy").is_file():
        try:
            return json.loads(f.read_text())
        except (OSError, ValueError):
            return None
    return None


def run_sweep(cfg: SweepConfig, outdir: str | Path, *, scheduler: str | None = None, workers: int = 2,
              serial: bool = False, quiet: bool = True, progress: bool = False,
              on_result: Callable[[dict, Any], None] | None = None) -> SweepResult:
    """Run every task not yet done (see the module docstring); ``on_result(row, client)`` is called
    as each task finishes (``client`` is ``None`` when serial). Progress (tasks done, the time left) goes
    to stderr on a terminal (``progress``: also elsewhere, as lines; ``quiet``: never)."""

    out = Path(outdir)
    (out / "tasks").mkdir(parents=True, exist_ok=True)
    refs_dir = str(out / "references")
    t0 = time.perf_counter()
    tasks, rows = plan_tasks(cfg)
    todo = []
    for t in tasks:
        done = _done_row(out, t)
        if done is not None:
            rows.append(done)
        else:
            todo.append(t)
    skipped = len(tasks) - len(todo)
    prog = ProgressBar(f"sweep {cfg.name}", max(len(todo), 1), enabled=not quiet, force=progress)
    views = sorted({(t.scene, t.view, t.scene_sha) for t in todo})
    kdir = cfg.kernel_cache_dir

    def finish(row: dict, client: Any) -> None:
        rows.append(row)
        prog.advance(1, f"{row['task']}: {row['status']}")
        if on_result is not None:
            on_result(row, client)

    with prog:  # a task's row arrives as it finishes: serial, or from the Dask workers
        if serial:
            refs = {}
            for sv in views:
                try:
                    refs[sv] = reference_task(*sv, refs_dir, kdir)
                except Exception as e:  # noqa: BLE001
                    refs[sv] = e
            for t in todo:
                r = refs[(t.scene, t.view, t.scene_sha)]
                finish(run_task(t, r, str(out), kdir) if isinstance(r, str) else
                       {**_ids(t), "status": "failed", "message": f"reference: {type(r).__name__}: {r}"}, None)
        elif todo:
            from dask.distributed import Client, LocalCluster, as_completed

            cluster = None
            if scheduler is None:
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                       dashboard_address=None, silence_logs=40)
            client = Client(cluster if cluster is not None else scheduler)
            try:
                ref_f = {sv: client.submit(reference_task, *sv, refs_dir, kdir, pure=False) for sv in views}
                futs = {client.submit(run_task, t, ref_f[(t.scene, t.view, t.scene_sha)], str(out), kdir, key=f"render-{t.key}",
                                      pure=False): t for t in todo}
                for f in as_completed(futs):
                    t = futs[f]
                    try:
                        row = f.result()
                    except Exception as e:  # noqa: BLE001 - reference failed, or workers kept dying on it
                        row = {**_ids(t), "status": "failed", "message": f"{type(e).__name__}: {e}"}
                    finish(row, client)
            finally:
                client.close()
                if cluster is not None:
                    cluster.close()
    order = {t.key: k for k, t in enumerate(tasks)}
    rows.sort(key=lambda r: (r["status"] == "n/a", order.get(r.get("task"), 1 << 30), r.get("task", "")))
    return SweepResult(cfg, rows, skipped, time.perf_counter() - t0)


#: the summary files ``sweep -o`` writes (besides tasks/ and references/)
SWEEP_FILES = ("table.csv", "table.json", "table.md", "pareto.svg", "pareto.png", "index.html")


def write_sweep(result: SweepResult, outdir: str | Path, owned: Any = None) -> None:
    """table.csv / .json / .md, pareto.png / .svg over all rows and index.html with one section per
    scene and view (each with its own Pareto front), all or none."""

    out = Path(outdir)
    groups: dict[tuple, list[dict]] = {}
    for r in result.rows:
        groups.setdefault((r["scene"], r["view"]), []).append(r)
    sections = []
    planned = plan_tasks(result.config)[0]
    for (scene_name, view), rows in groups.items():
        shown = [{**r, "pipeline": f"{r['pipeline']} [{r['options']}]", "scene": None, "view": None, "options": None}
                 for r in rows]
        mark_pareto(shown)
        for r, s in zip(rows, shown):
            r["pareto"] = s["pareto"]
        images = {}
        for r, s in zip(rows, shown):
            f = out / "tasks" / f"{r.get('task')}.npy"
            if r["status"] == "ok" and f.is_file():
                images[s["pipeline"]] = np.load(f)
        task = next((t for t in planned if _ids(t)["scene"] == scene_name), None)
        ref = None
        vdef = next((v for v in result.config.views if v[0] == view), None)
        if task is not None and vdef is not None:
            f = out / "references" / f"reference-{scene_hash(_view_scene(task.scene, vdef, task.scene_sha))}.npy"
            ref = np.load(f) if f.is_file() else None
        br = BenchResult({"name": scene_name, "view": view}, shown, ref, None, True, images)
        sections.append(rh.bench_section(br, title=f"{scene_name} / view {view}"))
    head = (f"<p>{len(result.rows)} rows; {result.skipped_done} tasks read from an earlier run; "
            f"{result.wall_s:.1f} s wall time.</p>")
    with Outputs(owned) as o:
        o.text(out / "table.csv", rh.table_csv(result.rows))
        o.text(out / "table.json", report_json({"name": result.config.name, "rows": result.rows}))
        o.text(out / "table.md", rh.table_markdown(
            [{**r, "pipeline": f"{r['scene']} {r['view']} {r['pipeline']} [{r['options']}]"} for r in result.rows]) + "\n")
        o.text(out / "pareto.svg", rh.pareto_svg(result.rows))
        o.bytes(out / "pareto.png", rh.pareto_png(result.rows))
        o.text(out / "index.html", rh.page(f"warpvol sweep: {result.config.name}", [head] + sections))
