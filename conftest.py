"""Root pytest configuration: doctests in the package run with Warp's start-up and module-load
messages silenced (they go to stdout and would be read as doctest output)."""

import warp as wp

wp.config.quiet = True
if hasattr(wp, "LOG_WARNING"):
    wp.config.log_level = wp.LOG_WARNING
