"""Warp kernels, one module per hardware unit (installed as ``warpvol.kernels``).

With ``WARPVOL_LAUNCH_ORDER`` set (:func:`warpvol.parallel.apply_launch_order`, a debug mode) the CPU
kernels run their threads in another order; it is applied here, before any kernel compiles."""

from warpvol.parallel import apply_launch_order

apply_launch_order()


def kernel_modules() -> list:
    """Every Warp module (``warp`` ``Module`` objects) that defines kernels: one per file of this package
    that has kernels, one per HARC march configuration (:func:`warpvol.kernels.harc.march_kernel`,
    each a module of its own, and ``harc_best``'s with segments) and one per ``raycast`` march configuration
    (:func:`warpvol.kernels.raycast.march_kernel`), and the lane march of one lane, raycast's and harc_best's
    (:func:`warpvol.kernels.lanes_march.march_lanes_kernel`). Files that define only ``@wp.func`` s are compiled through the kernels that
    call them."""
    import importlib
    import pkgutil

    import warp as wp

    out = []
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        mod = importlib.import_module(f"{__name__}.{info.name}")
        wm = wp.get_module(mod.__name__)
        if wm.kernels:
            out.append(wm)
    from . import harc, raycast
    from .harc_integ import INTEG_EXACT, INTEG_FULL, INTEG_PARTIAL

    for walk in (harc.WALK_PLANES, harc.WALK_PLUCKER):
        for setup in (harc.SETUP_ROBUST, harc.SETUP_PAPER):
            for mode in (INTEG_EXACT, INTEG_FULL, INTEG_PARTIAL):
                if setup == harc.SETUP_PAPER and walk != harc.WALK_PLANES:
                    continue  # make_march refuses it: the paper's set-up walks the face planes
                out.append(harc.march_kernel(walk, setup, mode).module)
    out.append(harc.march_kernel(harc.WALK_PLUCKER, harc.SETUP_ROBUST, INTEG_EXACT, True).module)  # with segments
    from . import pt_span

    out.append(pt_span.span_kernel_cached(16).module)
    for segs in (False, True):
        out.append(raycast.march_kernel(segs).module)
    from . import lanes_march

    out.append(lanes_march.march_lanes_kernel(1).module)  # (the lane march as CUDA would build it: one ray per thread)
    out.append(lanes_march.march_lanes_kernel(1, harc=True).module)  # (harc_best's)
    return out
