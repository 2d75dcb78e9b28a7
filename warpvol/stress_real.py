"""Stress cases of the inputs real data has every day: scalars with a large offset, georeferenced
coordinates, cells that meet without sharing faces, non-planar hexahedra, thin layers and the ranges of
float32 itself.

Each group is one function taking the registration helpers of :func:`warpvol.stress._cases`:
``simple(name, doc, build)`` registers a case whose reference is warpvol's exact float64 reference,
``with_ref(name, doc, build)`` one that returns ``(scene, reference_fn)``; ``sc(mesh, tf, camera, name)``
builds the scene. ``build(quick)`` takes the ``--quick`` flag (smaller images for CI).
"""

from __future__ import annotations


def conditioning_cases(simple, with_ref, sc) -> None:
    """Scalar offsets, georeferenced coordinates, meshes at extreme scales."""


def topology_cases(simple, with_ref, sc) -> None:
    """Cells that meet without sharing faces: glued blocks, split hexahedra / wedges / pyramids."""


def thin_layer_cases(simple, with_ref, sc) -> None:
    """Thin layers that carry the image, huge on-screen extents, edge-on slabs."""


def sweep_cases(simple, with_ref, sc) -> None:
    """VSBUFFER-specific: non-planar hexahedra, pixel centres on boundary faces."""


def add_real_data_cases(simple, with_ref, sc) -> None:
    for group in (conditioning_cases, topology_cases, thin_layer_cases, sweep_cases):
        group(simple, with_ref, sc)
