"""scripts/bench_skip.py's transfer functions: the sparse one shows 5-10 % of the cells, the opaque one
makes every covered pixel of a view through the mesh opaque."""

import importlib.util
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def load_script():
    spec = importlib.util.spec_from_file_location("bench_skip", ROOT / "scripts" / "bench_skip.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_sparse_and_opaque_transfer_functions():
    from warpvol.conditioning.visibility import cell_visibility
    from warpvol.scene.builtin import builtin_scene

    bs = load_script()
    sc = builtin_scene("stiff")
    sparse, frac = bs.variant(sc, "sparse")
    assert 0.05 <= frac <= 0.10 and frac == float(cell_visibility(sc.mesh, sparse.transfer).mean())
    assert sparse.name == "stiff_sparse"
    opaque, frac = bs.variant(sc, "opaque")
    lo, hi = (np.asarray(b) for b in sc.mesh.bounds)
    assert frac == 1.0 and np.allclose(opaque.transfer.extinction, 100.0 / np.linalg.norm(hi - lo))
