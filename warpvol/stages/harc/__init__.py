"""Hardware ray-casting stages (Weiler et al. 2003, Espinha & Celes 2005): ``harc_mesh``,
``harc_raster``, ``harc``, ``harc_peel``. A subpackage so ``warpvol/stages`` stays small; importing it
registers every module in it (``warpvol.stages`` imports its subpackages like its modules)."""

import importlib
import pkgutil

for _m in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_m.name}")
del _m
