"""The scene data model: tetrahedral meshes, cameras, transfer functions, loaders, built-in scenes,
scene files and pyvista/VTK conversions. Imports nothing of warpvol above the base modules and kernels.
"""
