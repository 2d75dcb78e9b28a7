"""scripts/bench_scaling.py: the points table it writes reads back into the points it was written from (what
``--merge`` relies on), so the fits of the read-back points are the exponents table written beside them."""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def load_script():
    spec = importlib.util.spec_from_file_location("bench_scaling", ROOT / "scripts" / "bench_scaling.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_points_table_reads_back_into_the_written_fits():
    bs = load_script()
    doc = json.loads((ROOT / "docs" / "data" / "scaling.json").read_text())
    points = bs.points_of_table(doc["tables"]["points"])
    assert len(points) == len(doc["tables"]["points"]["rows"])
    renderers = [r for r in bs.RENDERERS if any(p["renderer"] == r for p in points)]
    ex = doc["tables"]["exponents"]
    written = {row[0]: dict(zip(ex["columns"], row)) for row in ex["rows"]}
    for row in bs.fits(points, renderers, ""):
        for col, v in row.items():
            want = written[row["renderer"]][col]
            if isinstance(v, float):
                assert want == pytest.approx(v, abs=0.006), (row["renderer"], col)
            else:
                assert want == v, (row["renderer"], col)
    # one key per measured point: a re-measured point replaces its earlier row
    assert len({bs.point_key(p) for p in points}) == len(points)
    # every point names the run that measured it, and the runs listed are exactly those
    runs = [p.get("run") for p in points]
    assert all(runs) and set(runs) == set(doc["sources"])
