"""The stress class of sub-pixel, thin and disconnected cells (``warpvol stress``, :mod:`warpvol.tools.stress_subpixel`):
at the ``--quick`` sizes every exact preset renders each case within its tolerance row, warns, or declines --
no row is silently wrong."""

from tolerances import EXACT_PRESETS, preset_tolerance
from warpvol.pipeline import Pipeline
from warpvol.tools.stress import CASES, build_case, run_case

NAMES = ["subpixel_needles", "subpixel_specks", "thin_slabs_edge_on", "thin_slab_1e-9_edge_on", "thin_sheet_1e-8",
         "silhouette_on_pixel_centres"]


def test_subpixel_class_has_no_silent_wrong_rows():
    assert set(NAMES) <= set(CASES)
    pipes = [Pipeline.load(n) for n in EXACT_PRESETS]
    silent, seen = [], 0
    for name in NAMES:
        rows = run_case(build_case(name, quick=True), pipes)
        assert rows[0]["status"] == "ok", rows[0]  # the reference
        for r in rows[1:]:
            assert r["status"] in ("ok", "declined"), r
            if r["status"] == "ok" and not r["message"]:
                seen += 1
                if r["max_abs"] > preset_tolerance(r["pipeline"])["max_abs"]:
                    silent.append((name, r["pipeline"], r["max_abs"]))
    assert not silent
    assert seen == len(NAMES) * len(EXACT_PRESETS)  # every preset renders every case, none warned
