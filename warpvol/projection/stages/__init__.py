"""Cell-projection stages: vertex stage, visibility sorting, projected-tetrahedra classification and fragment programs.

Importing this package registers every stage module in it.
"""

import importlib
import pkgutil

for _m in pkgutil.walk_packages(__path__, prefix=f"{__name__}."):
    importlib.import_module(_m.name)
del _m
