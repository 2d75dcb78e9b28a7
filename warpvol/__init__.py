"""warpvol: a simulator of classic GPU pipelines for volume rendering of tetrahedral meshes.

Stages emulate the hardware units (rasteriser, texture units, blending into fixed-point frame
buffers, ray propagation through cell adjacency, ...) as NVIDIA Warp kernels; pipelines chain them.
Every render can be compared with an exact float64 reference.

Nothing is initialised at import time: Warp is initialised on first use.
"""

__version__ = "0.1.0"

from .camera import Camera
from .errors import ConfigError, MeshError, WarpvolError
from .mesh import TetMesh
from .pipeline import Pipeline, Stage, list_presets, register_stage
from .transfer import TransferFunction

__all__ = ["Camera", "ConfigError", "MeshError", "Pipeline", "Stage", "TetMesh", "TransferFunction",
           "WarpvolError", "list_presets", "register_stage"]
