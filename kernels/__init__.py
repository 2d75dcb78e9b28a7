"""Warp kernels, one module per hardware unit (installed as ``warpvol.kernels``)."""
