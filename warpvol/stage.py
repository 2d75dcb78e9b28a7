"""The stage framework: :class:`Stage` (one hardware unit or host step), its parameters (:class:`Param`),
the render :class:`Context` the stages share, and the registry that :func:`register_stage` fills.

A stage validates its parameters when built, owns the buffers it creates (stored on the render
:class:`Context`), launches its own kernels in :meth:`Stage.run`, and may tell the planner through
:meth:`Stage.skip_reason` that the current scene does not need it. Pipelines (:mod:`warpvol.pipeline`)
chain stages; the built-in stages live with their families (:mod:`warpvol.stages` lists them).
"""

from __future__ import annotations

import sys
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, ClassVar, Iterator

import numpy as np

from warpvol.errors import ConfigError, check_choice, check_keys, check_number
from warpvol.timing import CompileClock

# ------------------------------------------------------------------------------------------------
# parameters
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Param:
    """One stage parameter: type, default, allowed values and a one-line doc."""

    name: str
    kind: type
    default: Any
    doc: str
    choices: tuple | None = None
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    #: old names of the parameter, still accepted in pipeline files (with a DeprecationWarning)
    aliases: tuple[str, ...] = ()

    def validate(self, where: str, value: Any) -> Any:
        key = f"{where}.{self.name}"
        if self.choices is not None:
            return check_choice(key, value, self.choices)
        if self.kind is bool:
            if not isinstance(value, bool):
                raise ConfigError(f"{key}: expected true or false, got {value!r}")
            return value
        if self.kind in (int, float):
            return check_number(key, value, lo=self.lo, hi=self.hi, lo_open=self.lo_open,
                                hi_open=self.hi_open, integer=self.kind is int)
        if not isinstance(value, self.kind):
            raise ConfigError(f"{key}: expected {self.kind.__name__}, got {value!r}")
        return value

    def describe(self) -> str:
        old = f" (old name: {', '.join(self.aliases)})" if self.aliases else ""
        return f"{self.name:<18} {self.kind.__name__:<6} {self.default!r:<12} {self.allowed():<22} {self.doc}{old}"

    def allowed(self) -> str:
        """The allowed values in words: the choices, or the range (empty: any value of the type)."""
        rng = ""
        if self.choices:
            rng = " | ".join(map(str, self.choices))
        elif self.lo is not None or self.hi is not None:
            lo = "-inf" if self.lo is None else self.lo
            hi = "inf" if self.hi is None else self.hi
            rng = f"{'(' if self.lo_open else '['}{lo}, {hi}{')' if self.hi_open else ']'}"
        return rng


def renamed_params(where: str, declared: tuple[Param, ...], params: dict[str, Any]) -> dict[str, Any]:
    """``params`` with every old parameter name (a :class:`Param`'s ``aliases``) moved to its current name,
    each with a DeprecationWarning naming both; both names given at once is an error.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True):
    ...     renamed_params("stage 'x'", (Param("early_termination", float, 0.0, "", aliases=("t_min",)),),
    ...                    {"t_min": 1e-6})
    {'early_termination': 1e-06}
    """
    out = dict(params)
    for p in declared:
        for old in p.aliases:
            if old not in out:
                continue
            if p.name in out:
                raise ConfigError(f"{where}: {p.name!r} and its old name {old!r} both given; keep {p.name!r}")
            warnings.warn(f"{where}: {old!r} is the old name of {p.name!r} (still accepted)", DeprecationWarning,
                          stacklevel=3)
            out[p.name] = out.pop(old)
    return out


# ------------------------------------------------------------------------------------------------
# registry
# ------------------------------------------------------------------------------------------------

STAGES: dict[str, type["Stage"]] = {}


def register_stage(cls: type["Stage"]) -> type["Stage"]:
    """Class decorator: make a stage available to pipeline configs under ``cls.name``."""
    if not getattr(cls, "name", None):
        raise TypeError(f"{cls.__name__} has no stage name")
    if cls.name in STAGES and STAGES[cls.name] is not cls:
        raise TypeError(f"stage name {cls.name!r} registered twice")
    STAGES[cls.name] = cls
    return cls


class Stage:
    """Base class of all stages.

    Subclasses set ``name``, ``summary`` and ``params`` (a tuple of :class:`Param`) and implement
    :meth:`run`. They may override :meth:`skip_reason` (planner hook).
    """

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    params: ClassVar[tuple[Param, ...]] = ()
    #: names of what the stage reads (``ctx.buffers`` keys; ``"image"`` for ``ctx.image``) and what it
    #: writes; a pipeline whose stages lack what they need is rejected when it is built. A name may
    #: refer to a parameter as ``"{param}"`` (e.g. a table stage's ``"{output}"`` key).
    needs: ClassVar[tuple[str, ...]] = ()
    provides: ClassVar[tuple[str, ...]] = ()
    #: a per-mesh / per-TF set-up step whose result is kept across renders (tables, cell data): its time
    #: is reported as ``setup_s``, apart from the frame (``render_s``); when it reuses what it built
    #: before it says so with ``ctx.stats[name]["cached"] = True`` (or is skipped by the planner)
    setup: ClassVar[bool] = False
    #: entries of the stage's ``ctx.stats[name]`` that were renamed: old name -> current name. The report
    #: still writes the old name (same value) and lists it under ``report["deprecated"]``
    #: (:func:`renamed_stats`), so readers of reports keep working.
    renamed_stats: ClassVar[dict[str, str]] = {}

    def __init__(self, device: str = "cpu", where: str | None = None, **params: Any):
        self.device = device
        self.where = where or f"stage {self.name!r}"
        allowed = {p.name: p for p in self.params}
        params = renamed_params(self.where, self.params, params)
        check_keys(self.where, params, list(allowed))
        self.config: dict[str, Any] = {}
        for p in self.params:
            self.config[p.name] = p.validate(self.where, params[p.name]) if p.name in params else p.default
        self.validate()

    def validate(self) -> None:
        """Cross-parameter checks (override)."""

    def __getattr__(self, item: str) -> Any:
        cfg = self.__dict__.get("config")
        if cfg is not None and item in cfg:
            return cfg[item]
        for p in type(self).params:  # an old name reads the current one
            if item in p.aliases and cfg is not None:
                return cfg[p.name]
        raise AttributeError(item)

    def requires_caps(self) -> dict[str, Any]:
        """Capabilities a modelled GPU must have for this stage (``render(gpu=...)``): ``{cap: True,
        a minimum number, or a value the profile's list holds}``; names in :mod:`warpvol.model`."""
        return {}

    def skip_reason(self, ctx: "Context") -> str | None:
        """Planner hook: return a reason if this scene does not need the stage, else ``None``."""
        return None

    def leaves_out(self, ctx: "Context") -> str | None:
        """Planner hook for a stage that runs: what it leaves out of its work when ``ctx.skip`` is on
        (invisible cells, empty space, depth behind an opaque front) and why, in words; ``None``:
        nothing. Called without buffers (by :meth:`warpvol.pipeline.Pipeline.plan`); what was left
        out in a render is counted through :meth:`Context.left_out`."""
        return None

    def run(self, ctx: "Context") -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    @classmethod
    def doc_table(cls) -> str:
        """Plain-text parameter table (used by ``warpvol pipelines --stages``)."""
        lines = [f"{cls.name}: {cls.summary}",
                 f"    needs: {', '.join(cls.needs) or '-'}; provides: {', '.join(cls.provides) or '-'}"]
        lines += ["    " + p.describe() for p in cls.params] or ["    (no parameters)"]
        return "\n".join(lines)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in self.config.items())})"


# ------------------------------------------------------------------------------------------------
# context and report
# ------------------------------------------------------------------------------------------------

class StatsSection(dict):
    """A stage's ``report["stats"]`` section that still carries the old names of renamed entries (``old``:
    old name -> current name), each with the current entry's value, so that readers written against the old
    names keep working (the JSON report holds both); reading an old name here warns (DeprecationWarning
    naming the current one).

    Examples
    --------
    >>> import warnings
    >>> s = StatsSection({"float64_rays": 3}, {"unresolved_rays": "float64_rays"})
    >>> dict(s)
    {'float64_rays': 3, 'unresolved_rays': 3}
    >>> with warnings.catch_warnings(record=True) as w:
    ...     warnings.simplefilter("always")
    ...     s["unresolved_rays"], str(w[0].message)
    (3, "stats name 'unresolved_rays' is the old name of 'float64_rays' (still written)")
    """

    def __init__(self, data: dict, old: dict[str, str]):
        super().__init__(data)
        self.old = {o: n for o, n in old.items() if n in data}
        for o, n in self.old.items():
            super().__setitem__(o, data[n])

    def _warn(self, key: Any) -> None:
        if key in self.old:
            warnings.warn(f"stats name {key!r} is the old name of {self.old[key]!r} (still written)",
                          DeprecationWarning, stacklevel=3)

    def __getitem__(self, key: Any) -> Any:
        self._warn(key)
        return super().__getitem__(key)

    def get(self, key: Any, default: Any = None) -> Any:
        self._warn(key)
        return super().get(key, default)


def renamed_stats(stats: dict, stages: list) -> dict[str, str]:
    """Give each stage's section of ``stats`` (``ctx.stats[stage.name]``) the old names its
    :attr:`Stage.renamed_stats` declares (a :class:`StatsSection`, in place); returns the deprecation note
    of the report: ``{"stats.<stage>.<old>": "stats.<stage>.<current>"}`` for each old name written."""
    note = {}
    for st in stages:
        section = stats.get(st.name)
        if st.renamed_stats and isinstance(section, dict) and not isinstance(section, StatsSection):
            stats[st.name] = section = StatsSection(section, st.renamed_stats)
            note.update({f"stats.{st.name}.{o}": f"stats.{st.name}.{n}" for o, n in section.old.items()})
    return note



@dataclass
class Context:
    """What the stages of one render share: the scene, the device, buffers and the output image."""

    scene: Any
    device: str = "cpu"
    buffers: dict[str, Any] = field(default_factory=dict)
    stats: dict[str, Any] = field(default_factory=dict)
    image: np.ndarray | None = None
    quiet: bool = False
    #: state that outlives one render and belongs to the pipeline (e.g. the table cache), so
    #: rendering again, or after a TF edit, rebuilds only what changed
    persistent: dict[str, Any] = field(default_factory=dict)
    #: counted work per stage (report key -> counter name -> integer), filled through :meth:`count`
    counters: dict[str, dict[str, int]] = field(default_factory=dict)
    #: report key of the stage now running (``None`` outside a stage)
    stage_key: str | None = None
    #: set by a stage that wrote the final image early (e.g. nothing in view): why the later stages
    #: are skipped
    finished: str | None = None
    #: leave out what the scene does not need (invisible cells, empty space, occluded depth); ``False``
    #: (``skip=False``, ``--no-skip``): every stage does all its work, for comparison. One setting under one
    #: name from the user to the stages: ``render(skip=...)``, ``--no-skip``, a sweep option's ``skip``,
    #: ``Pipeline.render``/``plan`` and this field (``report["skip"]`` says it); a stage reads ``ctx.skip``,
    #: and what it decided travels as a value (the ray casters' ``cells["confined"]``,
    #: :func:`warpvol.shared.visible.confined`), never as whether a buffer holds a key
    skip: bool = True
    #: what each stage left out (report key -> ``{"why": text, count name: integer}``), filled through
    #: :meth:`left_out`; the report's ``left_out`` section
    omitted: dict[str, dict] = field(default_factory=dict)
    #: when planning (:meth:`warpvol.pipeline.Pipeline.plan`, no buffers built): what the stages planned to
    #: run before this one will provide; empty in a render
    planned: set[str] = field(default_factory=set)

    #: per-mesh set-up a stage of the frame computed on first use in this render (``(what, seconds)``,
    #: kernel compilation excluded), filled through :meth:`setup_work`; the pipeline moves it to the
    #: stage's ``stage_timing`` row (``first_use_s``), reports it under set-up (``setup_s``) and lists
    #: it in the report's ``first_use`` section
    first_use: list[tuple[str, float]] = field(default_factory=list)

    @contextmanager
    def setup_work(self, what: str) -> Iterator[None]:
        """Time a block of per-mesh set-up that a frame stage computes on first use (e.g. on a cache
        miss: face planes, cell shapes) as set-up, not as frame time; enter it only when the work is
        done, so a warm render reports none."""

        t0 = time.perf_counter()
        with CompileClock() as clock:
            yield
        self.first_use.append((str(what), max(0.0, time.perf_counter() - t0 - clock.seconds)))

    def mesh_setup(self, mesh: Any, *names: str) -> None:
        """Compute the per-mesh properties ``names`` of ``mesh`` (``functools.cached_property`` ones, e.g.
        ``"face_planes"``) that are not computed yet, as set-up (:meth:`setup_work`)."""
        from functools import cached_property

        for n in names:  # a plain property is computed on every access: never set-up
            if not isinstance(getattr(type(mesh), n, None), cached_property):
                raise TypeError(f"mesh_setup: {type(mesh).__name__}.{n} is not a cached property")
        missing = [n for n in names if n not in vars(mesh)]
        if missing:
            with self.setup_work(f"mesh {', '.join(n.lstrip('_') for n in missing)}"):
                for n in missing:
                    getattr(mesh, n)

    def left_out(self, why: str | None = None, **amounts: int) -> None:
        """Record what the running stage left out, e.g. ``ctx.left_out(why="invisible under the
        transfer function", cells_culled=n)``; counts add up over calls, ``why`` replaces."""
        d = self.omitted.setdefault(self.stage_key or "_host", {})
        if why is not None:
            d["why"] = str(why)
        for k, v in amounts.items():
            d[k] = d.get(k, 0) + int(v)

    def count(self, **amounts: int) -> None:
        """Add to the running stage's counters, e.g. ``ctx.count(cell_steps=n, fragments=m)``."""
        d = self.counters.setdefault(self.stage_key or "_host", {})
        for k, v in amounts.items():
            d[k] = d.get(k, 0) + int(v)

    def progress(self, msg: str) -> None:
        if not self.quiet:
            print(f"[warpvol] {msg}", file=sys.stderr, flush=True)
