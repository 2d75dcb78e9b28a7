"""Throughput model: what a stage's counted work would cost on one of the papers' GPUs.

GPU profiles are TOML files shipped in ``warpvol/profiles/`` (``warpvol gpus`` lists them). Every
number in them is a table ``{ value = ..., source = "..." }``; the source says whether it is the
vendor's specification (``vendor: ...``), derived from vendor numbers (``derived: ...``, the
derivation), an estimate (``estimate: ...``, why) or calibrated on a paper (``calibrated: paper,
figure, row``). A calibrated constant is never compared with the figure it was fitted to: ``scripts/validate_model.py`` marks
every row as calibration or prediction.

Model (per stage, from its counters, :mod:`warpvol.gpu.counters`)
-----------------------------------------------------------------
The stage's passes are alike (a stage whose passes differ counts them in sections ``name/...``,
each a group of its own). For a group of ``P`` passes::

    gpu  = max over units u of (work_u / rate_u)      # the slowest unit; summed over the P passes
         + P * pass_overhead_s
         + bytes_down / bus_down + bytes_up / bus_up    # read-backs and uploads stall the pipeline
    host = sum over host counters h of (work_h / host_rate_h)

which equals ``P * (max_u (work_u / P) / rate_u + pass_overhead_s) + transfers`` when the passes are
alike. Units and the counters they consume:

===========  =======================================================  =======================================
unit         work                                                     rate (profile ``[rates]``)
===========  =======================================================  =======================================
vertex       ``vertices``                                             ``vertex_rate``
raster       ``fragments``                                            ``pixel_fill``
texture      ``tex_<d>d_<fmt>_<filter>`` fetches                      ``tex_<d>d_<filter>_<fmt>`` if given,
                                                                      else ``tex_<d>d_<filter>``
shader       ``combiner_ops``                                         ``combiner_rate``
rop          ``blends_<fmt>``, ``writes_<fmt>``, ``clear_pixels``     ``blend_<fmt>`` (default ``pixel_fill``),
                                                                      ``pixel_fill``, ``clear_rate``
memory       frame-buffer bytes: (2 blends + writes + clears) x       ``memory_bandwidth`` (unit left out
             bytes per pixel of the format; ``tex_miss_bytes``        where a profile has no figure)
             (texture-cache misses, where counted:
             :mod:`warpvol.reproduce.texcache`)
===========  =======================================================  =======================================

Programmable fragment pipes whose texture fetches take an issue slot of the program (profile cap
``fragment_issue = "shared"``: the NV3x) add the texture unit's time to the shader's instead of
overlapping them. A group that runs a fragment-program loop (``cell_steps`` with ``combiner_ops``: the
HARC walks, whose instructions per iteration come from :mod:`warpvol.gpu.programs`) prices every
instruction and fetch of the loop as one issue slot at ``loop_issue_rate``, times the loop's lock-step
factor on a card whose fragment processor runs pixel batches in lock-step (cap ``fragment_batch_pixels``:
each batch runs until its longest ray is done; :func:`loop_lockstep`); ``cell_steps`` alone (the
exact walks) use ``cell_step_rate``. ``fb_texture_rebinds`` (colour buffer rebound as a texture with a
fence, Kraus' fp16 read-back path) cost ``fb_rebind_s`` each, serially.

Host counters: ``sw_samples`` (``sw_sample_rate``), ``host_texels`` (``host_texel_rate``),
``cells_sorted`` (``cell_sort_rate`` for the graph sorts MPVO / MPVONC / XMPVO, ``numeric_sort_rate``
when the sort built no graph: the numeric centroid sort), XMPVO's ``ray_constraints``
(``graph_edge_rate``) and ``boundary_fragments`` (sorted per pixel: ``fragment_sort_rate``),
``host_cell_steps`` (``host_cell_rate``: cells intersected and integrated by a host ray walk, the
VSBUFFER's). Where a profile's host has ``upload_rate``, ``bytes_up`` also cost the host ``bytes_up /
upload_rate`` (the CPU gathering the per-vertex data and issuing it to the driver), on top of the bus;
the other profiles price uploads on the bus alone (``quadro_fx3000``: the one measurement, Kraus et al.
2004 §5.1, is of the rows that card is compared with; the SGI hosts: no figure).
Counters that carry no time of their own (``fragments_passed``, ``primitives``, ``texels``,
``readbacks`` ...) are listed in :data:`INFORMATIONAL`. Work for which the profile has no rate makes
the stage *unmodelled* (``modelled_s`` None, the counters named), never a silent zero.

Capabilities (``[caps]``): a stage declares what it needs with :meth:`Stage.requires_caps
<warpvol.pipeline.Stage.requires_caps>` (``{cap: needed}``: True, a minimum number, or a value the
profile's list must hold); counted work is checked too (fp16 blends need ``fp16_blend``, 3D fetches
``tex3d``, filtered float fetches ``float_filter``, ray-walk cell steps ``fragment_loops``). A missing capability raises
:class:`~warpvol.errors.ConfigError` naming the stage and the capability.

Example
-------
>>> p = load_profile("geforce3")
>>> t = model_counters({"passes": 2, "fragments": 1_600_000, "tex_1d_rgba8_linear": 1_600_000,
...                     "blends_unorm8": 1_600_000}, p)
>>> round(t["gpu_s"] * 1e3, 3), t["bound"]   # 1.6 M fragments at 800 Mpix/s (2 ms) + 2 x 0.5 ms per pass
(3.0, 'raster')
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

from warpvol.errors import ConfigError

INFORMATIONAL = frozenset({"fragments_passed", "primitives", "primitives_culled", "texels", "texture_bytes",
                           "readbacks", "clears", "dependent_fetches", "rays", "entries", "passes",
                           # projected tetrahedra and sorting: what was classified / ordered, not unit work
                           # (the work is counted as vertices, bytes_up, fetches, combiner_ops, cells_sorted)
                           "tets_projected", "triangles", "thick_vertex_moved", "class_four_triangle",
                           "class_three_triangle", "class_flat", "class_culled", "class_vertex_on_edge",
                           "class_vertex_on_vertex", "batches", "attrs_clamped", "texture_lookups",
                           "dependent_lookups", "segment_integrals", "graph_edges", "cycles_broken",
                           
                           # VSBUFFER: the paper's "drawn tetra" (the work is counted as vertices)
                           "drawn_cells",
                           # a HARC loop's issue slots per pixel, as run and in lock-step batches (they scale
                           # the loop's instructions and fetches: loop_lockstep)
                           "loop_slots", "loop_slots_batch1024"})
HOST_RATES = {"sw_samples": "sw_sample_rate", "host_texels": "host_texel_rate", "cells_sorted": "cell_sort_rate",
              "host_cell_steps": "host_cell_rate"}
_TEX = re.compile(r"^tex_(\d)d_([a-z0-9]+)_(nearest|linear)$")
_ROP = re.compile(r"^(blends|writes)_([a-z0-9]+)$")


@dataclass
class Profile:
    """One GPU (and its host) as the papers timed it: rates, capabilities, host costs, with sources."""

    name: str
    title: str
    papers: list
    rates: dict = field(default_factory=dict)
    caps: dict = field(default_factory=dict)
    host: dict = field(default_factory=dict)
    host_title: str = ""

    def rate(self, key: str, default: str | None = None) -> float | None:
        e = self.rates.get(key)
        if e is None and default is not None:
            e = self.rates.get(default)
        return None if e is None else float(e["value"])

    def cap(self, key: str) -> Any:
        e = self.caps.get(key)
        return None if e is None else e["value"]

    def source(self, section: str, key: str) -> str:
        return getattr(self, section)[key]["source"]


def _profile_files() -> dict[str, Any]:
    root = resources.files("warpvol.profiles")
    return {p.name[:-5]: p for p in root.iterdir() if p.name.endswith(".toml")}


def _entries(where: str, d: dict) -> dict:
    for k, v in d.items():
        if not (isinstance(v, dict) and "value" in v and isinstance(v.get("source"), str) and v["source"]):
            raise ConfigError(f"{where}.{k}: every number needs {{ value = ..., source = \"...\" }}")
    return d


def load_profile(name: str) -> Profile:
    """A shipped GPU profile by name (``warpvol gpus`` lists them)."""
    files = _profile_files()
    if not isinstance(name, str) or name not in files:
        raise ConfigError(f"--gpu: unknown GPU profile {name!r}; available: {', '.join(sorted(files))}")
    cfg = tomllib.loads(files[name].read_text())
    host = dict(cfg.get("host", {}))
    host_title = str(host.pop("title", ""))
    return Profile(name=name, title=cfg["title"], papers=list(cfg.get("papers", [])),
                   rates=_entries(f"{name}.rates", cfg.get("rates", {})),
                   caps=_entries(f"{name}.caps", cfg.get("caps", {})),
                   host=_entries(f"{name}.host", host), host_title=host_title)


def list_profiles() -> list[tuple[str, str, str]]:
    """``(name, GPU title, host title)`` of every shipped profile, sorted by name."""
    out = []
    for n in sorted(_profile_files()):
        p = load_profile(n)
        out.append((n, p.title, p.host_title))
    return out


def _bpp(fmt: str) -> int:
    m = re.match(r"^(unorm|fp|rgb)(\d+)$", fmt)
    bits = int(m.group(2)) if m else 8
    if fmt.startswith("rgb"):
        return 3  # 24-bit ID colour
    return 4 * ((bits + 7) // 8)


def _group(counters: dict[str, int]) -> dict[str, dict[str, int]]:
    groups: dict[str, dict[str, int]] = {}
    for k, v in counters.items():
        g, _, name = k.rpartition("/")
        groups.setdefault(g, {})[name] = int(v)
    return groups


def loop_lockstep(c: dict[str, int], profile: Profile) -> float:
    """How much longer a fragment-program loop runs on a card whose fragment processor runs batches of
    pixels in lock-step (profile cap ``fragment_batch_pixels``) than its rays' own work: the counted
    ``loop_slots_batch<N>`` (each batch as long as its longest ray) over ``loop_slots``; 1 where the
    card or the counters give no batch."""
    n = profile.cap("fragment_batch_pixels")
    run, batched = c.get("loop_slots"), c.get(f"loop_slots_batch{n}") if n else None
    return batched / run if run and batched else 1.0


def model_counters(counters: dict[str, int], profile: Profile) -> dict[str, Any]:
    """Modelled seconds of one stage's counters: ``{"s", "gpu_s", "host_s", "bound", "units", "unmodelled"}``.

    ``s`` is None when some counted work has no rate in the profile (``unmodelled`` names it).
    """
    gpu = host = 0.0
    unmodelled: list[str] = []
    units_all: dict[str, float] = {}
    for gname, c in _group(counters).items():
        units = {"vertex": 0.0, "raster": 0.0, "texture": 0.0, "shader": 0.0, "rop": 0.0, "memory": 0.0}
        serial = 0.0

        def use(unit: str, work: float, rate_key: str, default: str | None = None, key: str = "") -> None:
            if unit == "memory" and "memory_bandwidth" not in profile.rates:
                return
            r = profile.rate(rate_key, default)
            if r is None or r <= 0:
                unmodelled.append(f"{gname + '/' if gname else ''}{key or rate_key} (no rate {rate_key!r})")
            else:
                units[unit] += work / r

        loop = bool(c.get("cell_steps")) and bool(c.get("combiner_ops"))  # a fragment-program loop (HARC)
        lockstep = loop_lockstep(c, profile) if loop else 1.0
        for k, v in c.items():
            if not v or k in INFORMATIONAL:
                continue
            if loop and (k == "combiner_ops" or _TEX.match(k)):
                # every instruction and fetch of the loop body takes an issue slot of the looping fragment,
                # for as long as the longest ray of its lock-step batch runs
                use("shader", v * lockstep, "loop_issue_rate", key=k)
                continue
            if loop and k == "cell_steps":
                continue  # priced by the body's instructions
            if k == "vertices":
                use("vertex", v, "vertex_rate", key=k)
            elif k == "fragments":
                use("raster", v, "pixel_fill", key=k)
            elif k == "combiner_ops":
                use("shader", v, "combiner_rate", key=k)
            elif k == "tex_miss_bytes":  # table texels the texture cache did not hold, read from memory
                use("memory", v, "memory_bandwidth", key=k)
            elif k == "clear_pixels":
                use("rop", v, "clear_rate", "pixel_fill", key=k)
                use("memory", v * 4, "memory_bandwidth", key=k)
            elif (m := _TEX.match(k)):
                d, fmt, flt = m.groups()
                use("texture", v, f"tex_{d}d_{flt}_{fmt}", f"tex_{d}d_{flt}", key=k)
            elif (m := _ROP.match(k)):
                kind, fmt = m.groups()
                if kind == "blends":
                    use("rop", v, f"blend_{fmt}", "pixel_fill", key=k)
                else:
                    use("rop", v, "pixel_fill", key=k)
                use("memory", v * _bpp(fmt) * (2 if kind == "blends" else 1), "memory_bandwidth", key=k)
            elif k in ("bytes_down", "bytes_up"):
                r = profile.rate("bus_down" if k == "bytes_down" else "bus_up")
                if r is None:
                    unmodelled.append(f"{k} (no rate 'bus_{k[6:]}')")
                else:
                    serial += v / r
                if k == "bytes_up" and "upload_rate" in profile.host:  # the CPU issuing the data to the driver
                    host += v / float(profile.host["upload_rate"]["value"])
            elif k == "cell_steps":
                r = profile.rate("cell_step_rate")
                if r is None:
                    unmodelled.append("cell_steps (no rate 'cell_step_rate')")
                else:
                    units["shader"] += v / r
            elif k == "fb_texture_rebinds":
                r = profile.rate("fb_rebind_s")
                if r is None:
                    unmodelled.append("fb_texture_rebinds (no rate 'fb_rebind_s')")
                else:
                    serial += v * r
            elif k == "cells_sorted" and not c.get("graph_edges"):  # numeric (centroid) sort: no cell graph
                e = profile.host.get("numeric_sort_rate")
                if e is None:
                    unmodelled.append("cells_sorted (numeric sort: no host rate 'numeric_sort_rate')")
                else:
                    host += v / float(e["value"])
            elif k == "ray_constraints":  # XMPVO: extra graph edges from the rasterised boundary
                e = profile.host.get("graph_edge_rate")
                if e is None:
                    unmodelled.append("ray_constraints (no host rate 'graph_edge_rate')")
                else:
                    host += v / float(e["value"])
            elif k == "boundary_fragments":  # XMPVO: boundary fragments read back and sorted per pixel
                e = profile.host.get("fragment_sort_rate")
                if e is None:
                    unmodelled.append("boundary_fragments (no host rate 'fragment_sort_rate')")
                else:
                    host += v / float(e["value"])
            elif k in HOST_RATES:
                e = profile.host.get(HOST_RATES[k])
                if e is None:
                    unmodelled.append(f"{k} (no host rate {HOST_RATES[k]!r})")
                else:
                    host += v / float(e["value"])
            else:
                unmodelled.append(f"{k} (unknown counter)")
        passes = c.get("passes", 0)
        if passes:
            o = profile.rate("pass_overhead_s")
            if o is None:
                unmodelled.append("passes (no 'pass_overhead_s')")
            else:
                serial += passes * o
        if profile.cap("fragment_issue") == "shared":  # TEX and ALU instructions share the fragment pipe's issue
            units["shader"] += units["texture"]
            units["texture"] = 0.0
        top = max(units, key=units.get)
        for u, t in units.items():
            units_all[u] = units_all.get(u, 0.0) + t
        gpu += units[top] + serial
    busy = {u: t for u, t in units_all.items() if t > 0}
    bound = max(busy, key=busy.get) if busy else None  # the unit with the most time over all groups
    return {"s": None if unmodelled else gpu + host, "gpu_s": gpu, "host_s": host, "bound": bound,
            "units": {u: t for u, t in units_all.items() if t}, "unmodelled": unmodelled}


def model_report(counters: dict[str, dict[str, int]], profile: Profile) -> dict[str, Any]:
    """``modelled_s`` of a render report: seconds per stage, ``total`` (None if any stage is unmodelled),
    the bounding unit per stage, what could not be modelled and the stages that counted nothing."""
    stages, bound, unmod = {}, {}, {}
    uncounted = [k for k, c in counters.items() if not c]
    for key, c in counters.items():
        r = model_counters(c, profile)
        stages[key] = r["s"]
        bound[key] = r["bound"] if r["gpu_s"] >= r["host_s"] else "host"
        if r["unmodelled"]:
            unmod[key] = r["unmodelled"]
    total = None if unmod else sum(stages.values())
    return {"stages": stages, "total": total, "bound": bound, "unmodelled": unmod,
            "uncounted": uncounted}  # stages that counted no work (modelled as 0 s)


# ------------------------------------------------------------------------------------------------
# capabilities
# ------------------------------------------------------------------------------------------------

CAP_DOCS = {"fb_formats": "frame-buffer format", "tex3d": "3D textures", "max_tex3d": "3D texture size",
            "max_tex2d": "2D texture size", "texture_units": "texture units", "combiner_stages": "combiner stages",
            "fp16_blend": "fp16 blending", "float_textures": "float textures",
            "float_filter": "filtering of float textures", "hilo": "HILO textures",
            "fb_overflow": "frame-buffer overflow behaviour", "fragment_program": "fragment-program instructions",
            "fragment_loops": "dynamic loops in fragment programs"}


def check_caps(profile: Profile, where: str, needs: dict[str, Any] | list[tuple[str, Any]]) -> None:
    """Raise ConfigError naming ``where`` (the stage) and the first capability ``profile`` lacks."""
    for cap, need in (needs.items() if isinstance(needs, dict) else needs):
        have = profile.cap(cap)
        what = CAP_DOCS.get(cap, cap)
        if isinstance(need, bool):
            ok = bool(have) if need else True
            msg = f"needs {what}"
        elif isinstance(need, (int, float)):
            ok = have is not None and not isinstance(have, bool) and have >= need
            msg = f"needs {what} >= {need}"
        else:
            ok = have is not None and (need in have if isinstance(have, list) else have == need)
            msg = f"needs {what} {need!r}"
        if not ok:
            raise ConfigError(f"{where}: {msg}, which the {profile.title} ({profile.name}) lacks "
                              f"(it has {cap} = {have!r})")


def counter_needs(counters: dict[str, int]) -> list[tuple[str, Any]]:
    """Capabilities implied by counted work, ``[(cap, needed)]`` (checked after a stage ran)."""
    needs: list[tuple[str, Any]] = []
    for k, v in counters.items():
        if not v:
            continue
        k = k.rpartition("/")[2]
        if k == "blends_fp16":
            needs.append(("fp16_blend", True))
        elif k == "cell_steps":  # GPU ray casting (HARC) walks cells in a fragment-program loop
            needs.append(("fragment_loops", True))
        elif (m := _ROP.match(k)) and m.group(2).startswith("unorm"):
            needs.append(("fb_formats", m.group(2)))
        elif (m := _TEX.match(k)):
            d, fmt, flt = m.groups()
            if d == "3":
                needs.append(("tex3d", True))
            if fmt.endswith("f"):
                needs.append(("float_textures", True))
                if flt == "linear":
                    needs.append(("float_filter", True))
            if fmt == "hilo16":
                needs.append(("hilo", True))
    return needs


def modelled_time(seconds: float | None) -> str:
    """Seconds as printed by the scripts (``-`` for unmodelled)."""
    if seconds is None or not math.isfinite(seconds):
        return "-"
    return f"{seconds:.3f}s" if seconds >= 0.01 else f"{seconds * 1e3:.2f}ms"
