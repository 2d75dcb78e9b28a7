"""What the reproduction modules share."""

from __future__ import annotations


def counted(fn, *a, **kw) -> dict:
    from warpvol.gpu.counters import Counters

    with Counters() as c:
        fn(*a, **kw)
    return c.as_dict()
