"""GPU profiles (TOML data files) of the machines the papers timed; read by :mod:`warpvol.model`."""
