"""The exact reference: the numpy renderer (:mod:`.numpy_render`), its exact predicates (:mod:`.exact`),
the ray-segment integration (:mod:`.integrate`) and the same renderer as Warp kernels (:mod:`.warp_render`).
"""

from warpvol.reference.numpy_render import REFERENCE_METHODS, render_reference

__all__ = ["REFERENCE_METHODS", "render_reference"]
