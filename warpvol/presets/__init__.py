"""Shipped pipeline presets (TOML). ``warpvol pipelines`` lists them."""
