"""``warpvol bench``: every preset on one scene against one exact reference.

For each pipeline: one warm-up render (kernel compilation, the mesh's derived data), then
``repeats`` timed renders whose median total and per-stage times are reported; the error against the
exact float64 reference (computed once and cached on disk by scene content, :func:`cached_reference`);
the tables' memory; the counters; and, with a GPU profile, the modelled time. With ``audit`` (``--audit``)
the *planner audit* renders once more per stage the planner left out, with that stage forced on
(``Pipeline.render(force=...)``), and reports the time the omission saves and how far the two images
differ (it doubles the run of a preset that leaves stages out, so it is off by default).
:func:`pareto_front` marks the pipelines no other one beats in both time and error.

Presets are discovered through :func:`warpvol.pipeline.list_presets`, so a new preset file shows up
here without code.

Examples
--------
>>> import tempfile, warpvol
>>> from warpvol.tools.bench import run_bench
>>> scene = warpvol.builtin_scene("box").with_camera(width_px=8, height_px=8)
>>> res = run_bench(scene, ["raycast"], repeats=2, cache_dir=tempfile.mkdtemp(), quiet=True, audit=True)
>>> row = res.rows[0]
>>> row["pipeline"], row["status"], row["pareto"], row["rmse"] < 1e-5
('raycast', 'ok', True, True)
>>> row["min_s"] <= row["total_s"] <= row["max_s"], [a["stage"] for a in row["planner"]]
(True, ['peel'])
"""

from __future__ import annotations

import hashlib
import inspect
import os
import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from warpvol.bands import compute_reference
from warpvol.errors import ConfigError, WarpvolError
from warpvol.io import Outputs, save_result, saved_records
from warpvol.metrics import image_error
from warpvol.pipeline import Pipeline, _read_pipeline_text, list_presets, report_json
from warpvol.progress import ProgressBar
from warpvol.reference import numpy_render as reference
from warpvol.tools import provenance
from warpvol.tools import report_html as rh
from warpvol.tools.machine import load_average, run_metadata
from warpvol.tools.report_html import FRONTS

#: row fields every bench / sweep table has (stage times, counters and options come on top)
ROW_FIELDS = ("pipeline", "status", "message", "total_s", "min_s", "max_s", "first_s", "render_s", "setup_s",
              "compile_s", "repeats",
              "stages_s", "modelled_s",
              "modelled_stages_s", "gpu_note", "rmse", "max_abs", "psnr", "table_bytes", "counters",
              "skipped", "skip", "left_out", "planner", "pareto", "pareto_modelled")


# ------------------------------------------------------------------------------------------------
# reference cache
# ------------------------------------------------------------------------------------------------
def scene_hash(scene: Any) -> str:
    """SHA-256 of what the reference image depends on: mesh (points, tets, scalars), transfer
    function (points, emission model), camera (every field) and the reference code itself.

    Examples
    --------
    >>> import warpvol
    >>> a = warpvol.builtin_scene("box")
    >>> scene_hash(a) == scene_hash(warpvol.builtin_scene("box")), scene_hash(a) == scene_hash(a.with_camera(width_px=7))
    (True, False)
    """

    h = hashlib.sha256()
    m, tf, cam = scene.mesh, scene.transfer, scene.camera
    for a in (m.points, m.tets, m.scalars, tf.points):
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())
    h.update(tf.emission.encode())
    h.update(repr((cam.projection, tuple(map(float, cam.eye)), tuple(map(float, cam.target)),
                   tuple(map(float, cam.up)), float(cam.fov_y_deg), float(cam.ortho_height),
                   int(cam.width_px), int(cam.height_px))).encode())
    from warpvol import kernels

    for name in reference.REFERENCE_SOURCES:  # a change of the reference code invalidates the cache
        h.update((Path(reference.__file__).parent / name).read_bytes())
    h.update((Path(kernels.__file__).parent / "reference.py").read_bytes())  # the Warp reference's kernels
    return h.hexdigest()


def cached_reference(scene: Any, cache_dir: str | Path | None, quiet: bool = True) -> tuple[np.ndarray, float, bool]:
    """``(image, seconds, from_cache)``: the exact reference of ``scene``, read from ``cache_dir``
    (``<scene_hash>.npy``) when there, else computed and stored there (atomically)."""
    path = None
    if cache_dir is not None:
        path = Path(cache_dir) / f"reference-{scene_hash(scene)}.npy"
        if path.is_file():
            try:
                return np.load(path), 0.0, True
            except (OSError, ValueError):  # truncated by a killed writer of an older version: recompute
                pass
    img, dt = compute_reference(scene, quiet)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{time.monotonic_ns()}.tmp")
        with open(tmp, "wb") as fh:
            np.save(fh, img)
        tmp.replace(path)
    return img, dt, False


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------
def pareto_front(points: list[tuple[float, float]]) -> list[bool]:
    """For ``(time, error)`` pairs: ``True`` where no other pair is at least as good in both and
    better in one (both minimised).

    Examples
    --------
    >>> pareto_front([(1, 1e-3), (2, 1e-5), (3, 1e-4), (1, 1e-3), (0.5, 1.0)])
    [True, True, False, True, True]
    """
    out = []
    for i, (t, e) in enumerate(points):
        dominated = any(t2 <= t and e2 <= e and (t2 < t or e2 < e) for j, (t2, e2) in enumerate(points) if j != i)
        out.append(not dominated)
    return out


def resolve_pipelines(names: list[str] | tuple[str, ...] | str | None) -> list[str]:
    """``all`` (or nothing) -> every shipped preset; otherwise the names as given (presets or files), each
    argument also split at commas (``raycast,pt_best`` as ``raycast pt_best``).

    Examples
    --------
    >>> resolve_pipelines(["raycast,pt_best", "harc_best"])
    ['raycast', 'pt_best', 'harc_best']
    """

    if isinstance(names, (list, tuple)):
        names = [n.strip() for a in names for n in (a.split(",") if isinstance(a, str) else [a]) if n != ""]
    if names is None or names == "all" or list(names) == ["all"]:
        return [n for n, _ in list_presets()]
    names = [names] if isinstance(names, str) else list(names)
    if "all" in names:
        raise ConfigError("--pipelines: 'all' stands alone; give it or a list of names")
    return names


#: ``--quick`` (stress, bench): resolution parameters of pre-integration table stages (``table_*``) are capped here, so a
#: table costs milliseconds instead of seconds (the cases still exercise every stage)
QUICK_TABLE_CAPS = {"n_s": 16, "n_l": 16}


def quick_pipeline(pipe: Any) -> Any:
    """``pipe`` with :data:`QUICK_TABLE_CAPS` applied to its ``table_*`` stages (others unchanged).

    Examples
    --------
    >>> from warpvol.pipeline import Pipeline
    >>> [st.config["n_s"] for st in quick_pipeline(Pipeline.load("roettger2000_3d")).stages if "n_s" in st.config]
    [16]
    """

    stages = []
    for st in pipe.stages:
        caps = {k: min(st.config[k], v) for k, v in QUICK_TABLE_CAPS.items()
                if st.name.startswith("table_") and isinstance(st.config.get(k), int)}
        stages.append(type(st)(device=st.device, where=st.where, **{**st.config, **caps}) if caps else st)
    return Pipeline(stages, name=pipe.name, description=pipe.description)


def load_pipelines(names: Any, device: str = "cpu", flag: str = "--pipelines", quick: bool = False) -> list:
    """:func:`resolve_pipelines` then load each (errors name ``flag``), before any work; ``quick``:
    through :func:`quick_pipeline`."""

    out = []
    for n in resolve_pipelines(names):
        try:
            pipe = Pipeline.load(n, device=device)
        except ConfigError as e:
            msg = str(e)
            raise ConfigError(msg.replace("--pipeline:", f"{flag}:", 1) if msg.startswith("--pipeline:") else msg) from None
        out.append(quick_pipeline(pipe) if quick else pipe)
    return out


def gpu_support(gpu: str | None, pipe: Any = None) -> str | None:
    """``None`` if ``gpu`` can be modelled here, else a sentence saying why not.

    GPU profiles arrive with the throughput model (``Pipeline.render(gpu=...)``); in a build without
    it the bench reports emulated times only and says so in the report.
    """

    if gpu is None:
        return "no --gpu given: emulated times only"
    if "gpu" not in inspect.signature(type(pipe).render if pipe is not None else Pipeline.render).parameters:
        return (f"--gpu {gpu}: GPU profiles (modelled time) are not part of this build; "
                "emulated times only")
    return None


def check_gpu(gpu: str | None) -> None:
    """An unknown GPU profile is an error before any work (where the build has profiles)."""
    if gpu is not None and gpu_support(gpu) is None:
        from warpvol.model import load_profile

        load_profile(gpu)


def table_bytes(pipe: Any) -> int:
    """Bytes held by the pre-integration tables the pipeline's renders built (its table cache)."""
    cache = pipe.persistent.get("table_cache")
    store = getattr(cache, "_store", None) or {}  # TableCache keeps its tables in an LRU dict
    return int(sum(getattr(t, "nbytes", 0) for t in store.values()))


def _median_times(reports: list[dict]) -> tuple[float, dict]:
    total = statistics.median(r["total_s"] for r in reports)
    keys = list(reports[-1]["stages"])
    stages = {k: statistics.median(r["stages"].get(k, 0.0) for r in reports) for k in keys}
    return total, stages


# ------------------------------------------------------------------------------------------------
# one pipeline
# ------------------------------------------------------------------------------------------------
def bench_pipeline(pipe: Any, scene: Any, ref: np.ndarray | None, *, repeats: int = 3, gpu: str | None = None,
                   audit: bool = True, device: str | None = None, on_step: Callable[[str], None] | None = None,
                   on_audit: Callable[[int], None] | None = None, skip: bool = True) -> dict:
    """Warm-up + ``repeats`` timed renders of one pipeline (and, with ``audit``, its planner audit): one
    table row; ``total_s`` is the median of the repeats, ``min_s`` / ``max_s`` their spread. ``on_step(what)``
    follows each render; ``on_audit(n)`` is told the audit's renders before they start. ``skip``: as in
    :meth:`warpvol.pipeline.Pipeline.render` (``False``: no culling, empty-space skipping or early ray
    termination, for comparison); the row's ``left_out`` is the last render's ``report["left_out"]``.

    Returns the row (see :data:`ROW_FIELDS`) and, under ``"_image"``, the last image. Exceptions
    propagate (the caller decides whether a failure ends the run).
    """

    step = on_step or (lambda _msg: None)
    kw: dict[str, Any] = {"quiet": True, "device": device, "skip": bool(skip)}
    gpu_note = gpu_support(gpu, pipe) if gpu is not None else None
    if gpu is not None and gpu_note is None:
        kw["gpu"] = gpu
    step("warm-up")
    t0 = time.perf_counter()
    try:
        first = pipe.render(scene, **kw)
    except WarpvolError as e:  # the modelled GPU lacks a capability: say so, time the emulation alone
        if "gpu" not in kw:
            raise
        gpu_note = f"not modelled on {gpu}: {e}"
        kw.pop("gpu")
        first = pipe.render(scene, **kw)
    first_s = time.perf_counter() - t0
    runs = []
    for k in range(repeats):
        step(f"run {k + 1}/{repeats}")
        runs.append(pipe.render(scene, **kw))
    last = runs[-1] if runs else first
    reports = [r.report for r in runs] or [first.report]
    total, stages = _median_times(reports)
    img = last.image
    # total_s: the median warm render; the first render's kernel compilation and set-up apart
    row: dict[str, Any] = {"pipeline": pipe.name, "status": "ok", "message": "", "total_s": total,
                           "min_s": min(r["total_s"] for r in reports), "max_s": max(r["total_s"] for r in reports),
                           "first_s": first_s, "render_s": statistics.median(r.get("render_s", r["total_s"]) for r in reports),
                           "setup_s": first.report.get("setup_s"), "compile_s": first.report.get("compile_s"),
                           "repeats": len(runs), "stages_s": stages,
                           "table_bytes": table_bytes(pipe), "counters": last.report.get("counters", {}),
                           "skipped": last.report.get("skipped", []), "gpu_note": gpu_note,
                           "skip": bool(skip), "left_out": last.report.get("left_out", {}),
                           "modelled_s": None, "modelled_stages_s": {}}
    mod = last.report.get("modelled_s")
    if isinstance(mod, dict):
        row["modelled_s"], row["modelled_stages_s"] = mod.get("total"), dict(mod.get("stages", {}))
        if mod.get("total") is None and mod.get("unmodelled"):
            row["gpu_note"] = "not modelled: " + "; ".join(
                f"{st}: {', '.join(map(str, what))}" for st, what in mod["unmodelled"].items())
    err = image_error(img, ref) if ref is not None else {"rmse": None, "max_abs": None, "psnr": None}
    row.update(rmse=err["rmse"], max_abs=err["max_abs"], psnr=err["psnr"])
    row["planner"] = []
    if audit:
        if on_audit is not None and row["skipped"]:
            on_audit(len(row["skipped"]) * (1 + max(repeats, 1)))
        for sk in row["skipped"]:
            step(f"audit {sk['stage']}")
            entry = audit_skip(pipe, scene, sk, img, total, ref, repeats=max(repeats, 1), kw=kw)
            # a stage skipped only on re-renders (e.g. a table found in the pipeline's cache) ran in
            # the warm-up: its time there is the work the skip avoids on every later render
            entry["warmup_stage_s"] = first.report["stages"].get(sk["stage"])
            row["planner"].append(entry)
    row["_image"] = img
    return row


def audit_skip(pipe: Any, scene: Any, skipped: dict, image: np.ndarray, total_s: float, ref: np.ndarray | None,
               *, repeats: int, kw: dict) -> dict:
    """Render with one skipped stage forced on: the stage's median time (what skipping it saves), the
    whole render's median time and its difference, and how far the images differ."""

    entry = {"stage": skipped["stage"], "reason": skipped["reason"]}
    try:
        pipe.render(scene, force={skipped["stage"]}, **kw)  # warm-up of the forced stage
        runs = [pipe.render(scene, force={skipped["stage"]}, **kw) for _ in range(repeats)]
    except Exception as e:  # noqa: BLE001 - a stage that cannot run where it is skipped says so
        entry.update(forced_total_s=None, saved_s=None, note=f"cannot run when forced: {type(e).__name__}: {e}")
        return entry
    forced = statistics.median(r.report["total_s"] for r in runs)
    entry.update(forced_min_s=min(r.report["total_s"] for r in runs), forced_max_s=max(r.report["total_s"] for r in runs))
    d = image_error(runs[-1].image, image)
    # what leaving the stage out saves is its own time when it runs (median); the difference of the
    # whole renders' medians says the same plus the other stages' timing noise, so it is kept apart
    stage_s = statistics.median(r.report["stages"].get(skipped["stage"], 0.0) for r in runs)
    entry.update(forced_total_s=forced, forced_stage_s=stage_s, saved_s=stage_s, total_diff_s=forced - total_s,
        diff_rmse=d["rmse"], diff_max_abs=d["max_abs"],
        forced_rmse=image_error(runs[-1].image, ref)["rmse"] if ref is not None else None)
    return entry


# ------------------------------------------------------------------------------------------------
# the whole bench
# ------------------------------------------------------------------------------------------------
@dataclass
class BenchResult:
    """Rows (one per pipeline), the reference, its time, the images and the scene's description."""

    scene: dict
    rows: list[dict]
    reference: np.ndarray | None
    reference_s: float | None
    reference_cached: bool
    images: dict[str, np.ndarray] = field(default_factory=dict)
    gpu: str | None = None
    notes: list[str] = field(default_factory=list)
    #: where and when it ran: commit, versions, CPU, load, date (:func:`warpvol.tools.machine.run_metadata`)
    meta: dict = field(default_factory=dict)
    #: commit, command, date, load at the start and end (:mod:`warpvol.tools.provenance`), as every file
    #: under docs/data/ carries it
    provenance: dict | None = None

    def as_json(self) -> dict:
        doc = {"scene": self.scene, "gpu": self.gpu, "notes": self.notes, "reference_s": self.reference_s,
               "reference_cached": self.reference_cached, "meta": self.meta, "rows": self.rows}
        if self.provenance is not None:
            from warpvol.tools.provenance import stamp

            stamp(doc, self.provenance)
        return doc


def describe_scene(scene: Any) -> dict:
    m, c = scene.mesh, scene.camera
    return {"name": scene.name, "source": str(scene.source) if getattr(scene, "source", None) else None,
            "tets": int(m.n_tets), "points": int(m.n_points), "convex": bool(m.is_convex),
            "edge_ratio": float(m.edge_ratio), "projection": c.projection, "image": [int(c.width_px), int(c.height_px)],
            "transfer_points": int(len(scene.transfer.points)), "emission": scene.transfer.emission,
            "hash": scene_hash(scene)[:16]}


def mark_pareto(rows: list[dict]) -> None:
    """Set ``row["pareto"]`` on every row (front of rows that rendered, by median time and RMSE) and,
    where rows have a modelled GPU time, ``row["pareto_modelled"]`` (by modelled time and RMSE)."""
    for time_key, flag in FRONTS.items():
        ok = [r for r in rows if r.get("status") == "ok" and r.get("rmse") is not None and r.get(time_key) is not None]
        front = pareto_front([(r[time_key], r["rmse"]) for r in ok])
        for r in rows:
            if time_key == "total_s" or ok:
                r[flag] = False
        for r, f in zip(ok, front):
            r[flag] = bool(f)


def run_bench(scene: Any, pipelines: Any = "all", *, repeats: int = 3, gpu: str | None = None,
              cache_dir: str | Path | None = None, audit: bool = False, device: str = "cpu",
              quiet: bool = False, progress: bool = False, quick: bool = False, done: dict | None = None,
              on_row: Callable[[str, dict, np.ndarray | None], None] | None = None,
              command: str | None = None, skip: bool = True) -> BenchResult:
    """Bench ``scene`` with each pipeline (see the module docstring); failures become rows.
    ``audit``: the planner audit (forced-stage renders) too. ``quick``: table resolutions capped
    (:func:`quick_pipeline`), noted in the result. ``done``: ``{key: (row, image)}`` of pipelines
    already benched (a resumed run: not run again); ``on_row(key, row, image)`` is called after each
    pipeline that runs (e.g. to save it at once). Progress goes to stderr on a terminal
    (:class:`warpvol.progress.ProgressBar`; ``progress``: also elsewhere, as lines; ``quiet``: never).
    ``command``: the command line, kept in the metadata. ``skip=False``: every render does all the work
    (no culling, empty-space skipping or early ray termination; ``--no-skip``), noted in the result."""

    pipes = load_pipelines(pipelines, device, quick=quick)  # unknown names fail before any work
    check_gpu(gpu)
    notes = [] if gpu is None else ([gpu_support(gpu)] if gpu_support(gpu) else [])
    if quick:
        notes.append(f"--quick: pre-integration table resolutions capped at {QUICK_TABLE_CAPS} (not the presets as shipped)")
    if not skip:
        notes.append("--no-skip: every render does all the work (no culling of invisible cells, no empty-space "
                     "skipping, no early ray termination)")
    meta = run_metadata(device, command)
    prov = provenance.start(command or "warpvol.tools.bench.run_bench (from Python)", timing=True)
    rows, images = [], {}
    done = done or {}
    # units: the reference, then per pipeline its warm-up and timed renders (audit renders added when known)
    per = 1 + repeats
    with ProgressBar(f"bench {scene.name}", 1 + len(pipes) * per, enabled=not quiet, force=progress) as prog:
        prog.describe("exact reference")
        ref, ref_s, hit = cached_reference(scene, cache_dir, quiet=quiet)
        prog.advance(1, "reference read from the cache" if hit else f"reference {ref_s:.2f} s")
        for pipe, key in zip(pipes, pipeline_keys(pipes)):
            start, extra = prog.done, [0]
            if key in done:
                row, img = done[key]
                rows.append(dict(row))
                if img is not None:
                    images[key] = img
                prog.set(start + per, f"{key}: saved row reused")
                continue
            calls = [0]

            def step(what: str, k: str = key) -> None:  # called before each render: what runs next
                prog.advance(1 if calls[0] else 0, f"{k}: {what}")
                calls[0] += 1

            def more(n: int) -> None:
                extra[0] += n
                prog.add_total(n)

            try:
                row = bench_pipeline(pipe, scene, ref, repeats=repeats, gpu=gpu, audit=audit, device=device,
                                     on_step=step, on_audit=more, skip=skip)
                images[key] = row.pop("_image")
            except KeyboardInterrupt:
                raise
            except Exception as e:  # noqa: BLE001 - one failing pipeline is a row, the others go on
                row = {"pipeline": key, "status": "failed", "message": f"{type(e).__name__}: {e}"}
            row["pipeline"] = key
            rows.append(row)
            if on_row is not None:
                on_row(key, row, images.get(key))
            prog.set(start + per + extra[0], f"{key}: {row['status']}")
    meta["load average at the end"] = load_average()
    mark_pareto(rows)
    return BenchResult(describe_scene(scene), rows, ref, ref_s, hit, images, gpu, notes, meta,
                       provenance.finish(prov))


def pipeline_keys(pipes: list[Any]) -> list[str]:
    """Each pipeline's row key: its name, ``name#2``, ``name#3``, ... for repeats."""
    keys: list[str] = []
    for pipe in pipes:
        key, n = pipe.name, 2
        while key in keys:
            key, n = f"{pipe.name}#{n}", n + 1
        keys.append(key)
    return keys


def pipeline_digest(name_or_path: str | Path) -> str:
    """SHA-256 (hex) of a preset's or pipeline file's TOML text: a resumed run reuses a pipeline's
    saved results only while this is unchanged."""

    return hashlib.sha256(_read_pipeline_text(name_or_path)[0].encode()).hexdigest()


ROW_DIR = "pipelines"  # per-pipeline rows and images under the output folder, written as each finishes
#: the files ``bench -o`` writes besides ROW_DIR (the ``pareto_modelled`` pair only with a GPU profile)
BENCH_FILES = ("table.csv", "table.json", "table.md", "pareto.svg", "pareto.png", "index.html")
BENCH_MODELLED_FILES = ("pareto_modelled.png", "pareto_modelled.svg")


def row_stem(key: str) -> str:
    """File name stem of a pipeline's row and image under ROW_DIR."""
    return key.replace("/", "_").replace("#", "_")


def row_store(outdir: str | Path, scene: Any, *, repeats: int, gpu: str | None, quick: bool, audit: bool,
              skip: bool = True, digests: dict[str, str] | None = None, owned: Any = None,
              note: Callable[[str], None] | None = None):
    """``(saved, save)`` for ``outdir/pipelines``: the rows and images saved there by an earlier bench of
    the same scene (content hash) with the same settings (another run's files are an error naming the
    difference), and a function saving one pipeline's row and image (each file whole or absent).

    ``digests``: row key -> :func:`pipeline_digest`; a row saved from other TOML text is benched
    again. ``owned`` (:class:`warpvol.io.OwnedFiles`): only the records warpvol wrote there are read.
    Temporary files (dot names) are never read; a record or image that cannot be read (cut short,
    edited) is benched again; ``note(text)`` is told about each saved row not reused."""

    note = note or (lambda _text: None)
    d = Path(outdir) / ROW_DIR
    key = {"scene": scene_hash(scene), "repeats": int(repeats), "gpu": gpu, "quick": bool(quick), "audit": bool(audit),
           "skip": bool(skip)}
    saved: dict[str, tuple[dict, np.ndarray | None]] = {}
    for f, rec in saved_records(outdir, ROW_DIR, owned):
        if rec is None or not isinstance(rec.get("key"), str) or not isinstance(rec.get("row"), dict):
            note(f"{f} cannot be read (cut short or edited): its pipeline is benched again")
            continue
        # a record saved before skip was recorded came from a bench with skipping on (the default)
        diff = [k for k in key if rec.get(k, True if k == "skip" else None) != key[k]]
        if diff:
            raise ConfigError(f"--resume: {f} is from another bench ({', '.join(f'{k} {rec.get(k)!r}' for k in diff)}; "
                              f"this one: {', '.join(f'{k} {key[k]!r}' for k in diff)})")
        if digests is not None and rec["key"] in digests and rec.get("pipeline_sha") != digests[rec["key"]]:
            note(f"{f}: pipeline {rec['key']} changed since its row was saved: it is benched again")
            continue
        img_f, img = f.with_suffix(".npy"), None
        if img_f.is_file():
            try:
                img = np.load(img_f)
            except (OSError, ValueError):
                note(f"{img_f} cannot be read (cut short or edited): its pipeline is benched again")
                continue
        saved[rec["key"]] = (rec["row"], img)

    def save(name: str, row: dict, image: np.ndarray | None) -> None:
        extra = {} if digests is None or name not in digests else {"pipeline_sha": digests[name]}
        save_result(d, row_stem(name), report_json({**key, **extra, "key": name, "row": row}),
                    None if image is None else np.asarray(image, np.float32), owned=owned)

    return saved, save


def write_bench(result: BenchResult, outdir: str | Path, *, plan: dict | None = None, owned: Any = None) -> list[Path]:
    """Write table.csv / table.json / table.md, the Pareto plot of the emulated times (pareto.svg with
    hover titles, pareto.png the same plot), with a GPU profile the one of the modelled times
    (pareto_modelled.svg / .png) and index.html into ``outdir``, all or none
    (:class:`warpvol.io.Outputs`; ``owned``: its :class:`warpvol.io.OwnedFiles`). Returns the paths."""

    out_dir = Path(outdir)
    files = {"table.csv": rh.table_csv(result.rows), "table.json": report_json(result.as_json()),
             "table.md": rh.table_markdown(result.rows) + "\n", "pareto.svg": rh.pareto_svg(result.rows)}
    paths = []
    with Outputs(owned) as out:
        for name, text in files.items():
            out.text(out_dir / name, text)
            paths.append(out_dir / name)
        out.bytes(out_dir / "pareto.png", rh.pareto_png(result.rows))
        paths.append(out_dir / "pareto.png")
        if any(r.get("modelled_s") for r in result.rows):
            out.bytes(out_dir / "pareto_modelled.png", rh.pareto_png(result.rows, tk="modelled_s", gpu=result.gpu))
            out.text(out_dir / "pareto_modelled.svg", rh.pareto_svg(result.rows, tk="modelled_s", gpu=result.gpu))
            paths += [out_dir / "pareto_modelled.png", out_dir / "pareto_modelled.svg"]
        out.text(out_dir / "index.html", rh.bench_page(result, plan=plan))
        paths.append(out_dir / "index.html")
    return paths
