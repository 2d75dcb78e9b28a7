"""Pipelines: stages chained from a preset or a config, the planner, timing and the render report.

A *stage* (the framework: :mod:`warpvol.stage`) is one hardware unit or host step. It validates its
parameters when built, owns the buffers it creates (stored on the render :class:`Context`), launches its
own kernels in :meth:`Stage.run`, and may tell the planner through :meth:`Stage.skip_reason` that the
current scene does not need it.

A *pipeline* is an ordered list of stages built from a plain config (TOML or dict)::

    name = "raycast"
    description = "..."
    [[stages]]
    stage = "cell_setup"
    [[stages]]
    stage = "raycast"
    max_steps = 100000

Unknown stage names, unknown keys and bad values are errors that name them and list what is allowed;
so is a stage that needs a buffer no stage before it provides, or a pipeline that writes no image.
"""

from __future__ import annotations

import json
import sys
import time
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from warpvol.errors import ConfigError, check_keys
from warpvol.stage import (  # noqa: F401  (the framework's names)
    STAGES,
    Context,
    Param,
    Stage,
    register_stage,
    renamed_stats,
)
from warpvol.timing import CompileClock, ReadCounter, announce_compile, split_times


def _load_builtin_stages() -> None:
    # importing the catalog registers every family's stage modules (loaded on first use); a family found
    # since (a package put on the path) is loaded too
    from warpvol import stages

    stages.load_family_stages()


def get_stage_class(name: str, where: str = "stage") -> type["Stage"]:
    _load_builtin_stages()
    if name not in STAGES:
        raise ConfigError(f"{where}: unknown stage {name!r}; allowed: {', '.join(sorted(STAGES))}")
    return STAGES[name]


@dataclass
class RenderResult:
    image: np.ndarray
    report: dict

    def write_report(self, path: str | Path) -> None:
        from warpvol.io import atomic_write_text

        atomic_write_text(path, report_json(self.report))


def report_json(report: dict) -> str:
    """The report as strict JSON (RFC 8259: no ``Infinity``/``NaN``).

    Non-finite numbers have no JSON form: the PSNR of an exact match is already ``None`` (see
    :func:`warpvol.metrics.image_error`); any other non-finite float becomes ``null`` and its key path
    is listed under ``"non_finite"``, so nothing is dropped silently.

    Examples
    --------
    >>> print(report_json({"a": 1.5, "b": [float("inf")]}), end="")
    {
      "a": 1.5,
      "b": [
        null
      ],
      "non_finite": [
        "b[0]"
      ]
    }
    """
    bad: list[str] = []

    def clean(v: Any, where: str) -> Any:
        if isinstance(v, dict):
            return {k: clean(x, f"{where}.{k}" if where else str(k)) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x, f"{where}[{i}]") for i, x in enumerate(v)]
        if isinstance(v, (float, np.floating)):
            if not np.isfinite(v):
                bad.append(where)
                return None
            return float(v)
        if isinstance(v, np.integer):
            return int(v)
        return v

    out = clean(report, "")
    if bad:
        out["non_finite"] = bad
    return json.dumps(out, indent=2, allow_nan=False) + "\n"


def _sync(device: str) -> None:
    try:
        import warp as wp

        wp.synchronize_device(device)
    except Exception:  # pragma: no cover - warp absent/uninitialised: nothing to wait for
        pass


def quiet_warp(cuda: bool = False) -> None:
    """Keep Warp's start-up banner and module-load lines off stdout (CLI, scripts, doctests).

    Unless ``cuda`` is asked for, Warp is also initialised here with its native "Could not find or
    load the NVIDIA CUDA driver" line (printed by the C library on a machine without a GPU, before any
    Python-level option applies) filtered out of stderr; anything else Warp prints there passes.
    """
    import warp as wp

    wp.config.quiet = True
    if hasattr(wp, "LOG_WARNING"):
        wp.config.log_level = wp.LOG_WARNING
    if cuda:
        return
    import os
    import tempfile

    sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:  # no stderr file descriptor: nothing reaches a terminal anyway
        wp.init()
        return
    with tempfile.TemporaryFile() as captured:
        os.dup2(captured.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        captured.seek(0)
        lines = captured.read().decode(errors="replace").splitlines(keepends=True)
    sys.stderr.write("".join(ln for ln in lines if "load the NVIDIA CUDA driver" not in ln))


def check_device(device: str, where: str = "device") -> str:
    """Validate a Warp device name (``cpu``, ``cuda:0``, ...) against the devices present."""
    import warp as wp

    names = [d.alias for d in wp.get_devices()]
    if str(device) not in names:
        try:
            return str(wp.get_device(device))
        except (ValueError, RuntimeError):
            raise ConfigError(f"{where}: device {device!r} is not available here; available: "
                              f"{', '.join(names)}") from None
    return str(device)


def _names(names: tuple[str, ...], config: dict) -> list[str]:
    return [n.format(**config) for n in names]


def check_stage_order(stages: list[Stage], where: str = "pipeline") -> None:
    """Reject stages that need what no earlier stage provides, and a pipeline that writes no image.

    Examples
    --------
    >>> check_stage_order([get_stage_class("raycast")()])
    Traceback (most recent call last):
    ...
    warpvol.errors.ConfigError: pipeline: stage 'raycast' needs 'cells', 'entry_bins', which no stage before it provides (stages that provide it: 'cell_setup', 'entry_bins')
    """
    have: set[str] = set()
    for st in stages:
        missing = [n for n in _names(st.needs, st.config) if n not in have]
        if missing:
            raise ConfigError(f"{where}: {st.where} needs {', '.join(map(repr, missing))}, which no stage before it "
                              f"provides ({_providers(missing)})")
        have.update(_names(st.provides, st.config))
    if "image" not in have:
        raise ConfigError(f"{where}: no stage writes the image ({_providers(['image'])})")


def _providers(names: list[str]) -> str:
    _load_builtin_stages()
    found = sorted(c.name for c in STAGES.values()
                   if set(names) & set(_names(c.provides, {p.name: p.default for p in c.params})))
    return f"stages that provide it: {', '.join(map(repr, found))}" if found else "no registered stage provides it"


class Pipeline:
    """Ordered stages plus a name; :meth:`render` runs the planner, the stages and the report."""

    def __init__(self, stages: list[Stage], name: str = "custom", description: str = ""):
        if not stages:
            raise ConfigError(f"pipeline {name!r}: no stages")
        check_stage_order(stages, f"pipeline {name!r}")
        self.stages, self.name, self.description = stages, name, description
        #: a faithful preset's known losses (its ``known_losses`` key): in every report as a warning
        self.known_losses = ""
        self.persistent: dict[str, Any] = {}

    @classmethod
    def from_config(cls, cfg: dict, device: str = "cpu", where: str = "pipeline") -> "Pipeline":
        check_keys(where, cfg, ["name", "description", "known_losses", "stages"])
        device = check_device(device, "--device" if where.startswith("preset") else f"{where}: device")
        stages_cfg = cfg.get("stages")
        if not isinstance(stages_cfg, list) or not stages_cfg:
            raise ConfigError(f"{where}.stages: expected a non-empty list of [[stages]] tables")
        stages = []
        for k, sc in enumerate(stages_cfg):
            w = f"{where}.stages[{k}]"
            if not isinstance(sc, dict) or "stage" not in sc:
                raise ConfigError(f"{w}: expected a table with a 'stage' key")
            sc = dict(sc)
            scls = get_stage_class(sc.pop("stage"), where=f"{w}.stage")
            stages.append(scls(device=device, where=f"{w} ({scls.name})", **sc))
        pipe = cls(stages, name=str(cfg.get("name", where)), description=str(cfg.get("description", "")))
        pipe.known_losses = str(cfg.get("known_losses", "")).strip()
        return pipe

    @classmethod
    def load(cls, name_or_path: str | Path, device: str = "cpu") -> "Pipeline":
        """A shipped preset by name, or a pipeline TOML file."""
        text, where = _read_pipeline_text(name_or_path)
        try:
            cfg = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise ConfigError(f"{where}: invalid TOML: {e}") from None
        except RecursionError:
            from warpvol.io import toml_nesting

            raise ConfigError(f"{where}: invalid TOML: nested too deeply {toml_nesting(text)}") from None
        cfg.setdefault("name", Path(str(name_or_path)).stem)
        return cls.from_config(cfg, device=device, where=where)

    def stage_keys(self) -> list[str]:
        """Report key of each stage: its name, ``name#2``, ``name#3``, ... for repeats."""
        keys: list[str] = []
        for st in self.stages:
            key, n = st.name, 2
            while key in keys:
                key, n = f"{st.name}#{n}", n + 1
            keys.append(key)
        return keys

    def plan(self, scene: Any, skip: bool = True) -> list[dict]:
        """Dry run of the planner: ``{"stage", "run", "reason", "leaves_out"}`` per stage, nothing rendered.

        Asks each stage's :meth:`Stage.skip_reason` with an empty context (no buffers); a hook that
        needs what an earlier stage builds is reported as decided at render time, with its error.
        ``leaves_out``: what a stage that runs leaves out of its work and why (:meth:`Stage.leaves_out`),
        ``None`` when nothing or with ``skip=False``.

        Examples
        --------
        >>> from warpvol.scene.builtin import builtin_scene
        >>> [(p["stage"], p["run"]) for p in Pipeline.load("raycast").plan(builtin_scene("box"))]
        [('condition', True), ('visibility', True), ('cell_setup', True), ('entry_bins', True), ('raycast', True), ('peel', False)]
        """
        ctx = Context(scene=scene, device=self.stages[0].device, quiet=True, skip=bool(skip))
        out = []
        for key, st in zip(self.stage_keys(), self.stages):
            try:
                reason = st.skip_reason(ctx)
            except Exception as e:  # noqa: BLE001 - the hook needs buffers of earlier stages
                reason = f"decided at render time ({type(e).__name__}: {e})"
                out.append({"stage": key, "run": None, "reason": reason, "leaves_out": None})
                continue
            what = None
            if not reason and ctx.skip:
                try:
                    what = st.leaves_out(ctx)
                except Exception as e:  # noqa: BLE001 - the hook needs buffers of earlier stages
                    what = f"decided at render time ({type(e).__name__}: {e})"
            out.append({"stage": key, "run": not reason, "reason": reason or None, "leaves_out": what})
            if not reason:
                ctx.planned.update(st.provides)
        return out

    def check_scene(self, scene: Any) -> None:
        """The checks of a scene that need no rendering, made before any costly work (a command calls it
        before the reference of ``--compute-reference``, :meth:`render` first of all): parts of the mesh
        that overlap in space (:meth:`warpvol.scene.mesh.TetMesh.check_overlap`, cached per mesh) and inputs
        this pipeline's float32 formats cannot hold (what the ``condition`` stage refuses, or, without
        it, :func:`warpvol.conditioning.conditioning.check_float32_ranges`). Raises a
        :class:`~warpvol.errors.WarpvolError` naming the field."""
        from warpvol.conditioning.conditioning import check_conditionable, check_float32_ranges

        mesh = getattr(scene.mesh, "pieces", scene.mesh)
        if hasattr(mesh, "check_overlap"):
            mesh.check_overlap()
        if any(st.name == "condition" for st in self.stages):
            check_conditionable(scene)
        else:
            check_float32_ranges(scene)

    def render(self, scene: Any, *, reference: np.ndarray | None = None, quiet: bool = False,
               device: str | None = None, gpu: str | None = None, force: Any = (), skip: bool = True) -> RenderResult:
        """Run the stages; ``gpu``: a GPU profile name (:mod:`warpvol.model`): checks every stage's
        capabilities first and adds ``gpu`` and ``modelled_s`` to the report. ``force``: stage names
        or report keys that run even when their :meth:`Stage.skip_reason` says the scene does not need
        them (the planner audit's "with the skipped stage" render); they are listed under
        ``report["forced"]`` with the reason. ``skip``: stages leave out what the scene does not need
        (invisible cells, empty space, occluded depth); ``False`` does all the work, for comparison.
        What was left out is under ``report["left_out"]`` (per stage: ``why`` and counts)."""
        from warpvol.gpu.counters import Counters

        force = {force} if isinstance(force, str) else set(force)
        if device is not None and not isinstance(device, str):
            raise ConfigError(f"render(device): expected a device name such as 'cpu' or 'cuda:0', got {device!r}")
        device = self.stages[0].device if device is None else check_device(device, "render(device)")
        if reference is not None:
            want = (int(scene.camera.height_px), int(scene.camera.width_px), 4)
            try:
                shape = np.shape(reference)
            except ValueError:
                shape = "ragged"
            if shape != want:
                raise ConfigError(f"render(reference): shape {shape} does not match the image {want} "
                                  "(height_px, width_px, RGBA)")
        model = None
        if gpu is not None:
            from warpvol import model

            profile = model.load_profile(gpu)
            for st in self.stages:
                model.check_caps(profile, st.where, st.requires_caps())
        ctx = Context(scene=scene, device=device, quiet=quiet, persistent=self.persistent, skip=bool(skip))
        t_checks = time.perf_counter()
        mesh = getattr(scene.mesh, "pieces", scene.mesh)
        if "overlapping_parts" in vars(mesh) or not hasattr(mesh, "check_overlap"):
            self.check_scene(scene)
        else:  # the mesh's parts searched for overlaps once per mesh: set-up of the first stage
            with ctx.setup_work("mesh parts overlap"):
                self.check_scene(scene)
        if not any(st.name == "condition" for st in self.stages):  # input cast to float32 as it is: say what it loses
            from warpvol.conditioning.conditioning import precision_warnings

            if (precision := precision_warnings(scene)) is not None:
                ctx.stats["precision"] = precision
        if self.known_losses:  # what the emulated hardware loses by design, stated in every report
            ctx.stats["known_losses"] = {"warning": self.known_losses}
        report: dict[str, Any] = {"pipeline": self.name, "device": device, "scene": getattr(scene, "name", None),
                                  "image": [scene.camera.height_px, scene.camera.width_px],
                                  "stages": {}, "skipped": [], "skip": bool(skip)}
        if getattr(getattr(scene, "mesh", None), "load_notes", None):  # what the reader left out, counted
            report["mesh_notes"] = dict(scene.mesh.load_notes)
        rows: dict[str, dict] = {}  # per stage: seconds, of which kernel compilation, set-up or frame, reused
        reads: dict[str, int] = {}  # per stage: wp.array.numpy() calls (timing.ReadCounter)
        t_all = t_checks
        for key, st in zip(self.stage_keys(), self.stages):
            if ctx.finished:
                report["skipped"].append({"stage": key, "reason": ctx.finished})
                continue
            if t_checks is not None and st.setup:  # a set-up stage's row is set-up as a whole, the checks with it
                ctx.first_use.clear()
            t0, t_checks = (time.perf_counter() if t_checks is None else t_checks), None  # checks: the first row's
            with CompileClock(None if quiet else announce_compile) as clock:
                reason = st.skip_reason(ctx)  # a reused table is fetched here
            if reason and (key in force or st.name in force):
                report.setdefault("forced", []).append({"stage": key, "reason": reason})
                reason = None
            if reason:
                report["skipped"].append({"stage": key, "reason": reason})
                ctx.progress(f"{key}: skipped ({reason})")
                dt = time.perf_counter() - t0
                rows[key] = {"s": dt, "compile_s": min(clock.seconds, dt), "setup": st.setup, "cached": st.setup}
                _first_use(ctx, rows[key], report, key)
                continue
            ctx.progress(f"{key} ...")
            ctx.stage_key = key
            with Counters(ctx.counters.setdefault(key, {})), ReadCounter(device) as stage_reads, \
                    CompileClock(None if quiet else announce_compile) as run_clock:  # units count into its entry
                st.run(ctx)
            if stage_reads.count:
                reads[key] = stage_reads.count
            ctx.stage_key = None
            if model is not None:  # work the card cannot do (e.g. fp16 blends) is an error naming the stage
                model.check_caps(profile, st.where, model.counter_needs(ctx.counters[key]))
            _sync(device)
            dt = time.perf_counter() - t0
            report["stages"][key] = dt
            stat = ctx.stats.get(st.name)
            rows[key] = {"s": dt, "compile_s": min(clock.seconds + run_clock.seconds, dt), "setup": st.setup,
                         "cached": bool(isinstance(stat, dict) and stat.get("cached"))}
            _first_use(ctx, rows[key], report, key)
            ctx.progress(f"{key}: {dt:.3f} s" + (f" (compiling kernels {rows[key]['compile_s']:.3f} s)"
                                                  if rows[key]["compile_s"] >= 0.05 else ""))
        report["total_s"] = time.perf_counter() - t_all
        # array reads back to the host (wp.array.numpy()) in the stages' runs: each a device sync on a GPU
        report["device_reads"] = {"total": sum(reads.values()), "stages": reads}
        report.update(split_times(rows, report["total_s"]))
        report["stage_timing"] = rows
        report["cached"] = [k for k, r in rows.items() if r["cached"]]
        if ctx.image is None:
            raise RuntimeError(f"pipeline {self.name!r} produced no image (no stage wrote ctx.image)")
        img = np.asarray(ctx.image, dtype=np.float32)
        if not np.isfinite(img).all():
            raise RuntimeError(f"pipeline {self.name!r} produced NaN/Inf pixels")
        report["counters"] = ctx.counters
        if ctx.omitted:
            report["left_out"] = ctx.omitted
        if model is not None:
            report["gpu"] = gpu
            report["modelled_s"] = model.model_report(ctx.counters, profile)
        if ctx.stats:
            report["stats"] = ctx.stats
            old_names = renamed_stats(ctx.stats, self.stages)  # old names beside the current ones
            if old_names:
                report["deprecated"] = old_names
        if reference is not None:
            from warpvol.metrics import image_error

            report["error"] = image_error(img, reference)
        return RenderResult(img, report)


def _first_use(ctx: Context, row: dict, report: dict, key: str) -> None:
    """Move the per-mesh set-up the stage ``key`` computed on first use (:meth:`Context.setup_work`) to
    its timing row (``first_use_s``, counted as set-up) and the report's ``first_use`` section."""
    if ctx.first_use:
        row["first_use_s"] = sum(s for _, s in ctx.first_use)
        sec = report.setdefault("first_use", {}).setdefault(key, {})
        for what, s in ctx.first_use:
            sec[what] = sec.get(what, 0.0) + s
        ctx.first_use.clear()


# ------------------------------------------------------------------------------------------------
# presets
# ------------------------------------------------------------------------------------------------


def _preset_files() -> dict[str, Any]:
    """Preset name -> TOML file: the families' own ``presets`` folders, then ``warpvol/presets/``."""
    from warpvol.family import family_preset_files  # (family discovery reads the path; on first use)

    root = resources.files("warpvol.presets")
    return {**family_preset_files(), **{p.name[:-5]: p for p in root.iterdir() if p.name.endswith(".toml")}}


def _read_pipeline_text(name_or_path: str | Path) -> tuple[str, str]:
    presets = _preset_files()
    s = str(name_or_path)
    if s in presets:
        return presets[s].read_text(), f"preset {s!r}"
    p = Path(s)
    if p.suffix == ".toml" or p.exists():
        if not p.is_file():
            raise ConfigError(f"--pipeline: file not found: {p}")
        return p.read_text(), str(p)
    import difflib

    close = difflib.get_close_matches(s, list(presets), n=3, cutoff=0.6)
    hint = f"did you mean {' or '.join(map(repr, close))}? " if close else ""
    raise ConfigError(f"--pipeline: {s!r} is neither a preset nor a file; {hint}presets: {', '.join(sorted(presets))}")


def list_presets() -> list[tuple[str, str]]:
    """``(name, one-line description)`` of every shipped preset, sorted by name."""
    out = []
    for name, p in sorted(_preset_files().items()):
        cfg = tomllib.loads(p.read_text())
        out.append((name, str(cfg.get("description", "")).strip().splitlines()[0] if cfg.get("description") else ""))
    return out


DEFAULT_PIPELINE = "raycast"
