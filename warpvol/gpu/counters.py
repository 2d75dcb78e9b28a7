"""Hardware counters: the work each emulated unit does, per stage (cf. D3D/GL pipeline-statistics queries).

A :class:`Counters` is a dict of integer counts. Units add to the *active* one — the one given
explicitly, else the one opened by ``with Counters() as c:`` on this thread (a context variable), else
none (then counting costs one lookup). The pipeline opens one per stage bound to
``ctx.counters[stage]``, so everything a stage does through the units, including table builders it
calls, lands in the report's ``counters`` without the stage passing anything around. Builders and
tests outside a pipeline open their own::

    >>> from warpvol.gpu.blend import BlendUnit, FrameBuffer
    >>> import numpy as np
    >>> with Counters() as c:
    ...     fb = FrameBuffer(4, 2, "unorm8"); fb.clear((0, 0, 0, 0))
    ...     BlendUnit.over().blend_layers(fb, np.zeros((3, 2, 4, 4), np.float32))
    >>> c["blends_unorm8"], c["clears"], c["clear_pixels"]
    (24, 1, 8)

Counter names (all integers; a stage reports only those it touched)
------------------------------------------------------------------
==========================  ===================================================================
name                        meaning
==========================  ===================================================================
``vertices``                vertices transformed (vertex unit)
``primitives``              triangles set up (rasteriser); ``primitives_culled`` culled or empty
``fragments``               fragments generated (pixel centres covered, before the depth test)
``fragments_passed``        fragments that passed the depth test
``tex_<d>d_<fmt>_<filter>`` texture fetches by dimension (1/2/3), texel format and effective filter,
                            e.g. ``tex_1d_rgba12_linear``; ``texels`` = texels read (nearest 1,
                            linear 2 / 4 / 8 for 1D / 2D / 3D)
``dependent_fetches``       fetches whose coordinate came from another fetch
``combiner_ops``            register-combiner / fragment-program operations (one per combiner
                            stage or shader step and fragment)
``blends_<fmt>``            blends into a frame buffer of format ``fmt`` (``unorm8``, ``unorm12``, ``fp16`` ...)
``writes_<fmt>``            frame-buffer writes without blending
``clears``, ``clear_pixels`` buffer clears and the pixels they fill
``passes``                  render passes: a render-target bind ending in a read-back or a copy
                            to a texture (what carries the per-pass overhead of the model)
``readbacks``               read-backs to host memory; ``bytes_down`` their bytes over the bus
``bytes_up``                bytes sent to the card (texture and vertex uploads, frame-buffer writes)
``texture_bytes``           texture memory made resident (sum of the textures created)
``rays``, ``entries``,      host-side or ray-walk work: rays started, boundary entries, cell
``cell_steps``              steps of ray walks
``cells_sorted``            cells put in visibility order on the host
``sw_samples``              samples taken by software integrators (host)
==========================  ===================================================================

How a stage feeds the throughput model (:mod:`warpvol.model`): it counts ``passes`` (the model adds
the profile's per-pass overhead for each) and the unit work above; the model turns each unit's work
into time with the GPU profile's rate for it and takes the slowest unit, assuming the stage's passes
are alike (true of every builder here: a table's slices are drawn the same way). A stage whose passes
differ counts them in sections: ``with counters.section("name"):`` (keys ``name/...``), each modelled as
its own group of passes. Host counters (``cell_steps``, ``cells_sorted``, ``sw_samples``) are timed
with the profile's host rates. Future stages (projected tetrahedra, HARC, VSBUFFER) only need to draw
through the units (or call :meth:`Counters.tex` / :meth:`Counters.blend` for work done inside their
own kernels) and count their passes.
"""

from __future__ import annotations

import contextvars
from contextlib import contextmanager
from typing import Any, Iterator

_ACTIVE: contextvars.ContextVar["Counters | None"] = contextvars.ContextVar("warpvol_counters", default=None)

#: texels read by one fetch, by (dimension, filter)
TEXELS_PER_FETCH = {(1, "nearest"): 1, (2, "nearest"): 1, (3, "nearest"): 1,
                    (1, "linear"): 2, (2, "linear"): 4, (3, "linear"): 8}


class Counters:
    """Integer work counts by name (module docstring lists the names).

    ``store``: the dict to count into (the pipeline passes ``ctx.counters[stage]``); a new one if
    omitted. Use as a context manager to make it the active counters of this thread.
    """

    def __init__(self, store: dict[str, int] | None = None):
        self.store: dict[str, int] = {} if store is None else store
        self._prefix = ""
        self._token: Any = None

    # -- dict-like ------------------------------------------------------------------------------
    def __getitem__(self, key: str) -> int:
        return self.store.get(key, 0)

    def get(self, key: str, default: int = 0) -> int:
        return self.store.get(key, default)

    def items(self):
        return self.store.items()

    def as_dict(self) -> dict[str, int]:
        return dict(self.store)

    def __repr__(self) -> str:
        return f"Counters({self.store!r})"

    # -- activation -----------------------------------------------------------------------------
    def __enter__(self) -> "Counters":
        self._token = _ACTIVE.set(self)
        return self

    def __exit__(self, *exc) -> None:
        _ACTIVE.reset(self._token)
        self._token = None

    @contextmanager
    def section(self, name: str) -> Iterator["Counters"]:
        """Count under ``name/`` (a group of passes unlike the stage's others; see the model)."""
        old = self._prefix
        self._prefix = f"{name}/"
        try:
            yield self
        finally:
            self._prefix = old

    # -- counting -------------------------------------------------------------------------------
    def add(self, **amounts: int) -> None:
        """Add integer amounts, e.g. ``c.add(fragments=16, passes=1)``."""
        s, p = self.store, self._prefix
        for k, v in amounts.items():
            k = p + k
            s[k] = s.get(k, 0) + int(v)

    def merge(self, other: "Counters | dict[str, int]") -> None:
        """Add every count of ``other``."""
        for k, v in (other.store if isinstance(other, Counters) else other).items():
            self.store[k] = self.store.get(k, 0) + int(v)

    def tex(self, texture: Any, fetches: int, dependent: bool = False) -> None:
        """``fetches`` lookups of ``texture`` (a Texture1D/2D/3D or TextureAtlas): fetch kind + texels."""
        t = getattr(texture, "texture", texture)  # an atlas samples its big 2D texture
        flt = t.effective_filter
        n = int(fetches)
        self.add(**{f"tex_{t.ndim}d_{t.fmt}_{flt}": n, "texels": n * TEXELS_PER_FETCH[t.ndim, flt]})
        if dependent:
            self.add(dependent_fetches=n)

    def blend(self, fmt: Any, n: int, blending: bool = True) -> None:
        """``n`` fragments written to a frame buffer of format ``fmt`` (a name or NumberFormat)."""
        name = getattr(fmt, "name", fmt)
        self.add(**{f"{'blends' if blending else 'writes'}_{name}": int(n)})


def active(explicit: Counters | None = None) -> Counters | None:
    """The counters a unit should count into: ``explicit`` if given, else the active ones (or None)."""
    return explicit if explicit is not None else _ACTIVE.get()


def count(**amounts: int) -> None:
    """Add to the active counters, if any (no-op otherwise)."""
    c = _ACTIVE.get()
    if c is not None:
        c.add(**amounts)


def bytes_per_pixel(fmt: Any) -> int:
    """Bytes of one RGBA pixel of frame-buffer format ``fmt`` read back (channels padded to bytes)."""
    return 4 * ((int(getattr(fmt, "bits", 8)) + 7) // 8)
