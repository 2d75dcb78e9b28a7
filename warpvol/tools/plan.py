"""``warpvol plan``: the planner's dry run for each preset and scene, then (unless ``--no-measure``) the
measured renders and the planner audit of :func:`warpvol.tools.bench.bench_pipeline`.

Without ``--pipeline`` only the default preset is planned; ``--pipeline all`` (or several names) plans
each in turn. A preset that declines the scene (e.g. Guthe's 2D tables need ``color_extinction``) is
listed with its reason and the others go on; with several presets the expected time is announced after
the first one is measured (the first one's time times the number left: presets that build
pre-integration tables or sweep planes take longer), refined from the mean after each, and the actual
total is printed at the end.
"""

from __future__ import annotations

import time
from typing import Any, Callable

from warpvol.errors import WarpvolError
from warpvol.tools.bench import bench_pipeline


def _duration(seconds: float) -> str:
    """``0.4 s`` / ``42 s`` / ``3.5 min`` / ``1.5 h``.

    Examples
    --------
    >>> _duration(0.42), _duration(42.4), _duration(210), _duration(5400)
    ('0.4 s', '42 s', '3.5 min', '1.5 h')
    """
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def print_plan(pipe: Any, scene: Any, skip: bool) -> None:
    """The planner's dry run of ``pipe`` on ``scene``: one line per stage (runs / skipped / decided at render
    time, with the reason and what it leaves out)."""
    for s in pipe.plan(scene, skip=skip):
        state = {True: "runs", False: "skipped", None: "decided at render time"}[s["run"]]
        print(f"  {s['stage']:<20} {state}" + (f": {s['reason']}" if s["reason"] else ""))
        if s.get("leaves_out"):
            print(f"  {'':<20} leaves out: {s['leaves_out']}")


def print_measured(row: dict) -> None:
    """The measured part of one preset's plan: the median render, what it left out, the planner audit."""
    print(f"  render: {row['total_s']:.4f} s (median of {row['repeats']})" + ("" if row["skip"] else ", skipping off"))
    for key, lo in row["left_out"].items():
        counts = ", ".join(f"{k} {v}" for k, v in lo.items() if k != "why")
        print(f"  {key} left out: {counts} ({lo.get('why', '')})")
    for a in row["planner"]:
        if a.get("saved_s") is None:
            print(f"  {a['stage']}: {a['note']}")
        else:
            warm = a.get("warmup_stage_s")
            print(f"  {a['stage']} forced on: render {a['forced_total_s']:.4f} s ({a['total_diff_s']:+.4f} s); "
                  f"leaving it out saves {a['saved_s']:.4f} s (its own time); images differ by max "
                  f"{a['diff_max_abs']:.2e}" + ("" if warm is None else f"; it ran in the warm-up render: {warm:.4f} s"))


def run_plan(pipes: list, scenes: list, *, repeats: int = 3, measure: bool = True, skip: bool = True,
             note: Callable[[str], None] | None = None, clock: Callable[[], float] = time.perf_counter) -> list[dict]:
    """Plan (and measure) every preset of ``pipes`` on every scene of ``scenes``, printing as it goes.

    A preset that declines a scene (a :class:`~warpvol.errors.WarpvolError` from its render; in a dry run,
    ``measure=False``, from the checks that need no rendering, ``Pipeline.check_scene``) is printed as
    declined with the reason and the run goes on (with a single pair the error propagates). ``note(text)`` gets the progress lines (the expected
    time, each preset's time, the declines at the end); ``None``: none. Returns one dict per (scene,
    preset): ``pipeline``, ``scene``, ``status`` (``ok`` / ``declined`` / ``planned``), ``message``, ``s``
    (seconds spent on it).
    """

    say = note or (lambda _text: None)
    jobs = [(sc, p) for sc in scenes for p in pipes]
    many = len(jobs) > 1
    if many and measure:
        say(f"plan: {len(jobs)} preset x scene pairs, each a warm-up render, {repeats} timed render(s) and the "
            "planner audit's renders; the expected time follows the first")
    t_all, rows = clock(), []
    for k, (scene, pipe) in enumerate(jobs):
        t0 = clock()
        print(f"{pipe.name} on {scene.name}:")
        print_plan(pipe, scene, skip)
        row = {"pipeline": pipe.name, "scene": scene.name, "status": "planned", "message": ""}
        if measure or hasattr(pipe, "check_scene"):
            try:
                if measure:
                    measured = bench_pipeline(pipe, scene, None, repeats=repeats, skip=skip)
                else:  # a dry run: the checks that need no rendering
                    pipe.check_scene(scene)
            except WarpvolError as e:  # the preset declines this scene, in words
                if not many:
                    raise  # one preset asked for: its refusal is the answer (exit 2)
                row.update(status="declined", message=str(e))
                print(f"  declined: {e}")
            else:
                if measure:
                    row["status"] = "ok"
                    print_measured(measured)
        row["s"] = clock() - t0
        rows.append(row)
        if many and measure:
            done, left = k + 1, len(jobs) - k - 1
            spent = clock() - t_all
            if k == 0 and left:
                say(f"plan: the first took {_duration(spent)}; the other {left} expected to take about "
                    f"{_duration(spent * left)} if each costs as much (those that build pre-integration tables "
                    "or sweep planes take longer)")
            else:
                say(f"plan: {done}/{len(jobs)} done, {pipe.name} {row['status']} in {_duration(row['s'])}; "
                    + (f"about {_duration(spent / done * left)} to go (the mean so far)" if left
                       else f"{_duration(spent)} in all"))
    declined = [r for r in rows if r["status"] == "declined"]
    if many and declined:
        say(f"plan: {len(declined)} declined: " + "; ".join(f"{r['pipeline']} on {r['scene']} ({r['message']})"
                                                            for r in declined))
    return rows

