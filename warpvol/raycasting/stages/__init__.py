"""Ray-casting stages: the consistent float32 walk (`raycast`, `peel`) and hardware ray casting (HARC).

Importing this package registers every stage module in it.
"""

import importlib
import pkgutil

for _m in pkgutil.walk_packages(__path__, prefix=f"{__name__}."):
    importlib.import_module(_m.name)
del _m
