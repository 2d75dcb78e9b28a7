"""Safety net for the shared cell walk: the faithful HARC presets (``espinha2005_full``, ``espinha2005_partial``)
and ``raycast`` draw the pinned image bits and count the pinned counters on small built-in scenes and on the
stress classes that drive the walk's rare paths (a TF jump, slivers, a far eye, a face seen edge-on, rays along
shared edges, an eye inside the mesh).

Renders are deterministic run to run and in any thread order (``tests/test_launch_order.py``), so the pins are
exact: a shared-code edit of the walk must leave these bits alone (``harc_best`` may move within its tolerance
row and is not pinned here). When a pinned preset is meant to change (said in the commit), re-pin::

    ./run.sh python tests/test_walk_pins.py --repin
"""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import pytest

from helpers import pin_of

PINS = Path(__file__).resolve().parent / "data" / "walk_pins.json"
PRESETS = ("espinha2005_full", "espinha2005_partial", "raycast")
BUILTIN = (("concave", 32), ("sphere", 24))
STRESS = ("tf_jump", "slivers", "camera_far", "face_edge_on", "ray_along_shared_edge", "camera_inside")


def scene_of(name: str):
    from warpvol.scene.builtin import builtin_scene
    from warpvol.tools.stress import build_case

    for b, size in BUILTIN:
        if b == name:
            return builtin_scene(b).with_camera(width_px=size, height_px=size)
    return build_case(name, quick=True).scene


def render_pin(scene: str, preset: str) -> dict:
    from warpvol.errors import ConfigError
    from warpvol.pipeline import Pipeline

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = Pipeline.load(preset).render(scene_of(scene), quiet=True)
    except ConfigError as e:
        return {"declined": str(e)}
    return pin_of(res.image, res.report)


def keys() -> list[tuple[str, str]]:
    return [(s, p) for s in [b for b, _ in BUILTIN] + list(STRESS) for p in PRESETS]


@pytest.mark.parametrize("scene,preset", keys())
def test_walk_pins(scene, preset):
    pinned = json.loads(PINS.read_text())[f"{scene}/{preset}"]
    assert render_pin(scene, preset) == pinned


if __name__ == "__main__":
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    now = {f"{s}/{p}": render_pin(s, p) for s, p in keys()}
    if "--repin" in sys.argv:
        PINS.write_text(json.dumps(now, indent=1, sort_keys=True) + "\n")
    old = json.loads(PINS.read_text()) if PINS.exists() else {}
    for k in now:
        print(k, "same" if old.get(k) == now[k] else "CHANGED")
