"""Stages, one module per stage, grouped by family; importing this package registers every stage.

==============  ==================================================================================
subpackage      stages
==============  ==================================================================================
(top level)     ``condition``: the scene centred, scaled to unit size and its scalars mapped by the
                transfer function's range, in float64 (first in the exact presets)
``tables``      pre-integration tables (``table_*``: exact, Roettger software/hardware, Guthe
                ping-pong and 2D tables, incremental/log axis, cylindrical planes, psi, iso-crossing)
``projection``  cell projection: ``vertex``, ``sort`` (centroid/MPVO/MPVONC/XMPVO), ``pt_*``
                (classification, fragment programs of Roettger, Guthe, Kraus, ``pt_best``)
``raycasting``  ray casting: ``cell_setup``, ``entry_bins``, ``raycast``, ``peel`` (consistent
                float32 walk) and ``harc_*`` (hardware ray casting, Espinha & Celes 2005)
``sweep``       sweep planes: ``vsb_*`` (VSBUFFER, Westermann & Ertl 1997)
==============  ==================================================================================
"""

import importlib
import pkgutil

for _m in pkgutil.walk_packages(__path__, prefix=f"{__name__}."):
    importlib.import_module(_m.name)
del _m
