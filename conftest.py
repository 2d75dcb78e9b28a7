"""Root pytest configuration: doctests in the package run with Warp's start-up and module-load
messages silenced (they go to stdout and would be read as doctest output)."""

from warpvol.pipeline import quiet_warp

quiet_warp()
