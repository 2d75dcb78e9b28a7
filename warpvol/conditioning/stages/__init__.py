"""The ``condition`` stage. Importing this package registers it."""

import importlib
import pkgutil

for _m in pkgutil.walk_packages(__path__, prefix=f"{__name__}."):
    importlib.import_module(_m.name)
del _m
