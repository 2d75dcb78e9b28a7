"""Safety net: every faithful preset (the papers' presets and ``pt_vertex_color``; not ``raycast`` nor the
``*_best`` presets) draws the pinned image bits and counts the pinned counters on two small built-in scenes.

Faithful presets must never change because of a shared-code edit (an improvement is an option that a
``*_best`` preset turns on). Each preset renders ``concave`` (non-convex, disconnected: MPVONC / XMPVO)
and ``sphere`` (convex: MPVO) at 32 x 32; its float image's SHA-256 (shape, dtype and bytes) and every
integer counter of its report must equal ``tests/data/faithful_pins.json``, and a preset that declines a
scene (a ``ConfigError``: Guthe's tables need ``color_extinction``) must decline it with the same message.
Renders are deterministic run to run and in any thread order (``tests/test_launch_order.py`` requires
every preset's images bit-identical under ``WARPVOL_LAUNCH_ORDER=shuffled``), so the image pin is exact;
the per-channel sums are kept only to say how far an image moved.

When a faithful preset's output is meant to change (a fix of the preset itself, said in the commit),
re-pin and read what changed::

    ./run.sh python tests/test_faithful_pins.py --repin          # rewrites the JSON, prints the changes
    ./run.sh python tests/test_faithful_pins.py                  # prints the changes only
"""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

from helpers import pin_of

PINS = Path(__file__).resolve().parent / "data" / "faithful_pins.json"
SCENES = (("concave", 32), ("sphere", 32))


def faithful_presets() -> list[str]:
    """Every shipped preset but ``raycast`` and the ``*_best`` presets (improvements beyond the papers)."""
    from warpvol.pipeline import list_presets

    return [n for n, _ in list_presets() if n != "raycast" and not n.endswith("_best")]


def compute_pins() -> dict:
    """``{"scene/preset": pin or {"declined": message}}`` on the current code."""
    from warpvol.errors import ConfigError
    from warpvol.pipeline import Pipeline, quiet_warp
    from warpvol.scene.builtin import builtin_scene

    quiet_warp()
    out = {}
    for name, size in SCENES:
        sc = builtin_scene(name).with_camera(width_px=size, height_px=size)
        for preset in faithful_presets():
            key = f"{name}/{preset}"
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = Pipeline.load(preset).render(sc, quiet=True)
            except ConfigError as e:
                out[key] = {"declined": str(e)}
                continue
            out[key] = pin_of(res.image, res.report, sums=True)
    return out


def differences(pinned: dict, now: dict) -> list[str]:
    """What changed between two pin sets, one line per preset and scene."""
    lines = []
    for key in sorted(set(pinned) | set(now)):
        a, b = pinned.get(key), now.get(key)
        if a == b:
            continue
        if a is None or b is None:
            lines.append(f"{key}: {'new' if a is None else 'gone'}")
            continue
        if "declined" in a or "declined" in b:
            lines.append(f"{key}: declined {a.get('declined')!r} -> {b.get('declined')!r}")
            continue
        if a["sha256"] != b["sha256"]:
            lines.append(f"{key}: image bits differ (channel sums {a['sums']} -> {b['sums']})")
        ca, cb = a["counters"], b["counters"]
        for c in sorted(set(ca) | set(cb)):
            if ca.get(c) != cb.get(c):
                lines.append(f"{key}: counter {c} {ca.get(c)} -> {cb.get(c)}")
    return lines


def test_faithful_presets_draw_and_count_as_pinned():
    pinned = json.loads(PINS.read_text())["pins"]
    now = compute_pins()
    assert len([k for k, v in now.items() if "declined" not in v]) >= 20
    diff = differences(pinned, now)
    assert not diff, ("a faithful preset changed (re-pin only for a fix of the preset itself: "
                      "python tests/test_faithful_pins.py --repin):\n" + "\n".join(diff))


def main(argv: list[str]) -> int:
    now = compute_pins()
    pinned = json.loads(PINS.read_text())["pins"] if PINS.is_file() else {}
    diff = differences(pinned, now)
    print("\n".join(diff) if diff else "no change against the pins")
    if "--repin" in argv:
        PINS.parent.mkdir(parents=True, exist_ok=True)
        PINS.write_text(json.dumps({"about": "tests/test_faithful_pins.py: faithful presets' image digests and "
                                             "counters on built-in scenes at 32 x 32; re-pin with "
                                             "python tests/test_faithful_pins.py --repin",
                                    "pins": now}, indent=1, sort_keys=True) + "\n")
        print(f"wrote {PINS}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
