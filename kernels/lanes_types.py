"""The configuration of :func:`warpvol.kernels.lanes_march.make_march_lanes`'s kernel: its ray start and
write-back functions, the types of its inputs that depend on them, and its lane matrices.

No Warp code of its own: the types it builds are Python-level Warp types, and the functions it picks
(:func:`~warpvol.kernels.lanes.make_lane_io`, :func:`~warpvol.kernels.harc_lanes.make_harc_lane_io`) are compiled
into the lane kernel's module.
"""

import threading
from typing import NamedTuple

import warp as wp

from .lanes import make_lane_io


class LaneIO(NamedTuple):
    """A lane kernel's ray start ``lane_next`` and write-back ``lane_done``, and the types of its ``starts``,
    ``col``, ``aux`` and ``more`` inputs (those of ``lane_done``'s arguments in those places): ``starts`` (raycast:
    the :class:`~warpvol.kernels.raycast.EntryBins`; harc: the :class:`~warpvol.kernels.harc.FragLists`), ``col``
    (the rays' colour: ``vec3`` radiance; ``vec4`` RGBA), ``aux`` (transmittance; each pixel's loop work
    ``px_work``), ``more`` (the re-entries a ray makes in the pass; the frame buffer's
    :class:`~warpvol.kernels.formats.NumFmt`)."""

    lane_next: object
    lane_done: object
    StartsT: object
    ColT: object
    AuxT: object
    MoreT: object


def lane_io(lanes: int, segs: bool, harc: bool) -> LaneIO:
    """The ray start and write-back of a lane kernel of ``lanes`` rays per thread (``harc``: those of
    :func:`~warpvol.kernels.harc_lanes.make_harc_lane_io`, else :func:`~warpvol.kernels.lanes.make_lane_io`)."""
    if harc:
        from .harc_lanes import make_harc_lane_io

        lane_next, lane_done = make_harc_lane_io(segs, lanes)
    else:
        lane_next, lane_done = make_lane_io(segs, lanes)
    io_types = list(lane_done.input_types.values())
    return LaneIO(lane_next, lane_done, *(io_types[i] for i in (4, 7, 8, 12)))


class LaneMats(NamedTuple):
    """The lane kernel's matrix and vector types (a row per state variable, a column per lane)."""

    FFm: object  # each lane's Face: pa, pb, pc, h, ma, mb, mc, s, w; 27..32 its lengths
    FGm: object  # each lane's Face.g
    SFm: object  # see the kernel's put block; 27..36: the lane's TF piece, 37 its density slope
    SIm: object  # cell, gn, cells, stall, k_in, thin is_short, walking
    RVv: object  # the lanes whose step is rare; whose piece is optically thick
    TFm: object  # a thick piece's length, entry TF value; crossing's ds, s, t
    TIm: object  # a thick piece: the next cell and its new vertex
    GIm: object  # each lane's cell's tets record; exit face, its nbr, nbr_vertex
    FLm: object  # the step taken; its commit kind (see the kernel's exit loop)
    GVm: object  # each lane's new vertex record


def lane_mats(lanes: int) -> LaneMats:
    """:class:`LaneMats` for ``lanes`` lanes."""
    return LaneMats(
        FFm=wp.types.matrix(shape=(33, lanes), dtype=float),
        FGm=wp.types.matrix(shape=(3, lanes), dtype=int),
        SFm=wp.types.matrix(shape=(38, lanes), dtype=float),
        SIm=wp.types.matrix(shape=(7, lanes), dtype=int),
        RVv=wp.types.vector(length=lanes, dtype=int),
        TFm=wp.types.matrix(shape=(8, lanes), dtype=float),
        TIm=wp.types.matrix(shape=(2, lanes), dtype=int),
        GIm=wp.types.matrix(shape=(7, lanes), dtype=int),
        FLm=wp.types.matrix(shape=(3, lanes), dtype=int),
        GVm=wp.types.matrix(shape=(4, lanes), dtype=float),
    )


_MADE: dict = {}
_MADE_LOCK = threading.Lock()


def made_once(key: tuple, make):
    """``make(*key)``, made once per ``(make, key)`` (a lane kernel per configuration: each is a Warp module of its
    own)."""
    with _MADE_LOCK:
        if (make, key) not in _MADE:
            _MADE[make, key] = make(*key)
        return _MADE[make, key]
