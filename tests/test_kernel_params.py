"""No Warp kernel or function of :mod:`warpvol.kernels` takes more than 24 parameters: inputs that belong together
(camera, mesh, transfer function, walk options, entry lists) travel as Warp structs, as ``warp.fem`` bundles its
own. Covers every file's kernels and functions and the kernels and functions the factories make (the HARC and
``raycast`` march configurations and the cell walk they share)."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

MAX_PARAMS = 24


def warp_objects():
    """``(where, name, python function)`` of every Warp kernel and user function the kernels package defines."""
    import warp as wp

    import warpvol.kernels as K

    mods = {}
    for info in pkgutil.iter_modules(K.__path__):
        mod = importlib.import_module(f"{K.__name__}.{info.name}")
        mods[mod.__name__] = wp.get_module(mod.__name__)
    for m in K.kernel_modules():  # the factories' kernels (modules of their own), made here if not yet
        mods[m.name] = m
    out = []
    for name, wm in mods.items():
        for key, k in wm.kernels.items():
            out.append((name, key, k.func))
        for key, f in wm.functions.items():
            out.append((name, key, f.func))
            for ov in getattr(f, "user_overloads", {}).values():
                out.append((name, key, ov.func))
    return out


def test_no_kernel_or_function_takes_more_than_24_parameters():
    objs = warp_objects()
    names = {k for _, k, _ in objs}
    # the check sees the walk's kernels and functions (made by factories), not only module-level ones
    assert any("cell_walk" in k for k in names) and any("harc_march" in k for k in names)
    assert any(k.endswith("march_ray") for k in names) and "render_rows" in names
    over = sorted({(len(inspect.signature(f).parameters), f"{where}.{key}") for where, key, f in objs
                   if len(inspect.signature(f).parameters) > MAX_PARAMS})
    assert not over, over
