"""Pre-integration table builders of the five papers (plain functions; stages in ``warpvol.tables.stages.table_*``).

Every builder returns a :class:`~warpvol.tables.base.Table` (decoded float32 ``data`` in texture order,
``axes``, ``channels``, stored ``format`` with ``raw`` texels, cache ``key``, ``meta``) and takes
``device=`` so it runs unchanged on ``"cuda:0"``.

===================  ==========================================  =====================================
builder              paper                                       module
===================  ==========================================  =====================================
build_exact3d        piecewise-linear TF integrated exactly      :mod:`.exact`
build_roettger_sw    Roettger & Ertl 2002 eqs. 5-7 (software)    :mod:`.roettger_sw`
build_roettger_hw    Roettger & Ertl 2002 §3 (emulated blending)  :mod:`.roettger_hw`
build_pingpong       Guthe et al. 2002 §4 (ping-pong, 12 bit)    :mod:`.pingpong`
build_incremental    Weiler 2003 / Kraus et al. 2004 (log axis)  :mod:`.incremental`
build_cylindrical    Roettger & Ertl 2002 §4 (alpha-planes)      :mod:`.cylindrical`
build_guthe2d        Guthe et al. 2002 §3 (2D + dependent 1D)    :mod:`.guthe2d`
build_psi            Moreland & Angel 2004 (TF-free psi)         :mod:`.psi`
build_isocross       Espinha & Celes 2005 §4.2                   :mod:`.isocross`
===================  ==========================================  =====================================

Caching: :class:`~warpvol.tables.cache.TableCache` keys tables by the TF hash (iso table: control-point
positions only; psi: nothing) and parameters. Tolerances of every builder/format are stated in one
table, ``TABLE_TOLERANCES`` in ``tests/tolerances.py``.
"""

#: the family's declaration (warpvol.family): a renderer family imports no other family
FAMILY = {"title": "pre-integration tables", "renderer": False}
from warpvol.tables.base import Axis, Table, sample3d  # noqa: F401


def __getattr__(name):
    mods = {"build_exact3d": "exact", "build_roettger_sw": "roettger_sw", "build_roettger_hw": "roettger_hw",
            "build_pingpong": "pingpong", "build_incremental": "incremental", "build_cylindrical": "cylindrical",
            "build_guthe2d": "guthe2d", "build_psi": "psi", "build_isocross": "isocross", "TableCache": "cache"}
    if name in mods:
        import importlib

        return getattr(importlib.import_module(f"{__name__}.{mods[name]}"), name)
    raise AttributeError(name)


__all__ = ["Axis", "Table", "sample3d", "build_exact3d", "build_roettger_sw", "build_roettger_hw", "build_pingpong",
           "build_incremental", "build_cylindrical", "build_guthe2d", "build_psi", "build_isocross", "TableCache"]
