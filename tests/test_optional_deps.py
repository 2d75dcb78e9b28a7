"""``import warpvol`` and a built-in render work where pyvista, VTK and OpenImageIO cannot be imported.

Those libraries read mesh files and write images; a scene built in Python and rendered to an array needs
neither, and the package keeps them out of its import-time path (the rule in ``test_architecture``: heavy
optional dependencies are imported where they are used). The check runs in a fresh interpreter whose
import system refuses the three packages.
"""

from __future__ import annotations

import json
import subprocess
import sys

from tolerances import preset_tolerance

BLOCKED = ("pyvista", "vtk", "vtkmodules", "OpenImageIO")

SCRIPT = r"""
import importlib.abc, json, sys
BLOCKED = %r
class Refuse(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError("refused by the test: " + name)
        return None
sys.meta_path.insert(0, Refuse())
import numpy as np
import warpvol
scene = warpvol.builtin_scene("sphere").with_camera(width_px=12, height_px=12)
r = warpvol.render(scene, pipeline="raycast", reference=True)
print(json.dumps({"finite": bool(np.isfinite(r.image).all()), "covered": float(r.image[..., 3].max()),
                  "rmse": r.error["rmse"],
                  "loaded": sorted({m.split(".")[0] for m in sys.modules} & set(BLOCKED))}))
"""


def test_import_and_builtin_render_without_pyvista_vtk_or_openimageio():
    out = subprocess.run([sys.executable, "-c", SCRIPT % (BLOCKED,)], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    row = json.loads(out.stdout.strip().splitlines()[-1])
    assert row["loaded"] == []
    assert row["finite"] and row["covered"] > 0.1  # the sphere is drawn, not an empty frame
    assert row["rmse"] <= preset_tolerance("raycast")["rmse"]
