"""Which packages the distribution holds (everything else is in pyproject.toml).

Every folder under ``warpvol/`` is found by a scan (``find_namespace_packages``; the folders of data --
presets, profiles, templates -- too), so a new family's folder needs no line here. ``kernels/`` lives at
the top of the repository but is installed as ``warpvol.kernels``, so no top-level ``kernels`` package
leaks into site-packages: that mapping is the one name written out.
"""

from setuptools import find_namespace_packages, setup

setup(
    packages=find_namespace_packages(include=["warpvol", "warpvol.*"], exclude=["*.__pycache__"])
    + ["warpvol.kernels"],
    package_dir={"warpvol": "warpvol", "warpvol.kernels": "kernels"},
)
