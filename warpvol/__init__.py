"""warpvol: a simulator of classic GPU pipelines for volume rendering of tetrahedral meshes.

Stages emulate the hardware units (rasteriser, texture units, blending into fixed-point frame
buffers, ray propagation through cell adjacency, ...) as NVIDIA Warp kernels; pipelines chain them.
Every render can be compared with an exact float64 reference.

In a notebook::

    import warpvol
    scene = warpvol.builtin_scene("sphere")
    r = warpvol.render(scene, reference=True)      # or render(pyvista_grid, preset_json, plotter, scalars=...)
    r.error, r.save("sphere.png")
    fig, table = warpvol.compare(scene, list(warpvol.presets()))

Nothing is initialised at import time: Warp is initialised on first use.
"""

__version__ = "0.1.0"

# the preset folder is a subpackage named like the presets() function below: import it first, so
# later imports of ``warpvol.presets`` (by importlib.resources) find it loaded and leave the name alone
from warpvol import presets as _presets_package  # noqa: F401
from warpvol.api import Comparison, Rendering, compare, presets, render
from warpvol.cache import cache_info, clear_cache, set_cache_budget
from warpvol.errors import ConfigError, MeshError, WarpvolError
from warpvol.pieces import render_in_pieces
from warpvol.pipeline import Pipeline, list_presets
from warpvol.scene.builtin import builtin_scene
from warpvol.scene.camera import Camera
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.scene.scene_file import load_scene
from warpvol.scene.transfer import TransferFunction
from warpvol.stage import Stage, register_stage

__all__ = ["Camera", "Comparison", "ConfigError", "MeshError", "Pipeline", "Rendering", "Scene", "Stage",
           "TetMesh", "TransferFunction", "WarpvolError", "builtin_scene", "cache_info", "clear_cache", "compare",
           "list_presets", "load_scene", "presets", "register_stage", "render", "render_in_pieces", "set_cache_budget"]
