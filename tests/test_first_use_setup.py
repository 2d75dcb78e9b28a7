"""Per-mesh work a stage of the frame computes on first use (face planes, cell shapes, the float64
redo's mesh data, convexity) is reported as set-up, not frame time: the first render lists it under
``first_use`` and counts it in ``setup_s``; a second render of the same mesh has none. Structure only
(no timing values are asserted)."""

import pytest

from test_visibility import _scene
from warpvol.pipeline import Pipeline
from warpvol.timing import split_times

#: a stage of each exact preset whose first-use set-up is always there
FIRST_USE_STAGE = {"raycast": "entry_bins", "harc_best": "harc_raster", "pt_best": "pt_integrate",
                   "vsbuffer_best": "vsb_sweep"}


def _split_matches(report):
    """The report's split is the one its stage rows give (first-use set-up included in setup_s)."""
    want = split_times(report["stage_timing"], report["total_s"])
    return all(report[k] == pytest.approx(want[k], abs=1e-12) for k in ("compile_s", "setup_s", "render_s"))


@pytest.mark.parametrize("preset", sorted(FIRST_USE_STAGE))
def test_first_use_setup_is_set_up_not_frame(preset):
    sc = _scene(px=12)  # a fresh mesh: nothing computed on it yet
    pipe = Pipeline.load(preset)
    first, second = pipe.render(sc, quiet=True), pipe.render(sc, quiet=True)
    fu = first.report.get("first_use", {})
    key = FIRST_USE_STAGE[preset]
    assert key in fu and fu[key], fu
    rows = first.report["stage_timing"]
    for k, what in fu.items():
        assert not rows[k]["setup"]  # a stage of the frame ...
        assert rows[k]["first_use_s"] == pytest.approx(sum(what.values()))  # ... its first-use part apart
    assert _split_matches(first.report)
    # the second render finds it all computed: its frame is the warm frame
    assert "first_use" not in second.report, second.report.get("first_use")
    assert not any("first_use_s" in r for r in second.report["stage_timing"].values())
    assert _split_matches(second.report)


def test_split_times_counts_first_use_as_set_up():
    rows = {"cell_setup": {"s": 0.5, "compile_s": 0.25, "setup": True},
            "raycast": {"s": 2.0, "compile_s": 0.5, "setup": False, "first_use_s": 1.0}}
    assert split_times(rows, 2.5) == {"compile_s": 0.75, "setup_s": 1.25, "render_s": 0.5, "total_s": 2.5}
    # never more than the stage's own time less its compilation
    rows["raycast"]["first_use_s"] = 5.0
    assert split_times(rows, 2.5)["setup_s"] == 1.75


def test_mesh_setup_only_for_cached_properties():
    from warpvol.stage import Context

    sc = _scene(px=8)
    ctx = Context(scene=sc)
    ctx.mesh_setup(sc.mesh, "face_planes")
    assert [w for w, _ in ctx.first_use] == ["mesh face_planes"]
    ctx.mesh_setup(sc.mesh, "face_planes")  # computed: nothing more
    assert len(ctx.first_use) == 1
    with pytest.raises(TypeError, match="not a cached property"):
        ctx.mesh_setup(sc.mesh, "lmax")  # a plain property: computed on every access, never set-up
