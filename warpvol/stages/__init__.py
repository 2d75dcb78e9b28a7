"""Stages, one module per stage; importing this package registers every module in it."""

import importlib
import pkgutil

for _m in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_m.name}")
del _m
