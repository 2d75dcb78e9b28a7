"""Scene option ``[mesh] split = 5 | 6`` for structured grids (Kraus 2004's Blunt Fin has 187,318 tets)."""

import numpy as np
import pytest

from warpvol.errors import ConfigError
from warpvol.scene.loaders import load_mesh


def _raw(tmp_path, dims=(4, 3, 3)):
    p = tmp_path / "v.raw"
    np.arange(np.prod(dims), dtype=np.uint8).tofile(p)
    return {"path": str(p), "dims": list(dims), "dtype": "uint8", "spacing": [1, 1, 1]}


@pytest.mark.parametrize("split", [5, 6])
def test_split_counts_and_conformity(tmp_path, split):
    m = load_mesh({"raw": _raw(tmp_path), "split": split})
    assert m.n_tets == split * 3 * 2 * 2
    # conforming: every interior triangle is shared by exactly two tets, boundary ones by one,
    # and the boundary is the box's 2 * (3*2 + 3*2 + 2*2) quads * 2 triangles
    faces = np.sort(m.tets[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]].reshape(-1, 3), axis=1)
    _, counts = np.unique(faces, axis=0, return_counts=True)
    assert counts.max() == 2
    assert (counts == 1).sum() == 2 * 2 * (6 + 6 + 4)
    p = m.points[m.tets]
    vol = np.abs(np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]))) / 6
    assert np.isclose(vol.sum(), 3 * 2 * 2)


def test_split_errors(tmp_path):
    with pytest.raises(ConfigError, match=r"mesh\.split: expected 6"):
        load_mesh({"raw": _raw(tmp_path), "split": 4})
    with pytest.raises(ConfigError, match=r"mesh\.split: not used with 'builtin'"):
        load_mesh({"builtin": "box", "split": 5})
