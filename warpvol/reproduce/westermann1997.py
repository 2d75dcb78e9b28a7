"""Westermann & Ertl 1997, the VSBUFFER sweep (paper figures, data sets and the modelled times); the
command line is ``scripts/reproduce_westermann1997.py``."""

from __future__ import annotations

import os

import numpy as np


# Table 1 of the paper: tets, drawn tets, GrOps [s], Int [s], total [s]
PAPER = {
    "ell64": (44689, 954317, 9.2, 36.6, 46.9),
    "fedata": (99306, 1498032, 12.4, 42.1, 56.0),
    "bluntfin": (224874, 2102153, 16.3, 42.3, 61.6),
}


PAPER_ROW = {"bluntfin": "bluntfin", "fe": "fedata", "spx": None}


def fe_mesh():
    """Concave finite-element-like stand-in for ``fedata``: an annular sector (270 degrees) of
    6-tet hexes, 16,500 hexes = 99,000 tets, scalar = a smooth stress-like field in [0, 1]."""
    from warpvol.scene.grids import structured_to_tets
    from warpvol.scene.mesh import TetMesh

    nr, nt, nz = 11, 111, 16
    r = np.linspace(1.0, 2.0, nr)
    th = np.linspace(0.0, 1.5 * np.pi, nt)
    z = np.linspace(0.0, 1.0, nz)
    R, T, Z = np.meshgrid(r, th, z, indexing="ij")
    R, T, Z = (a.transpose(2, 1, 0).ravel() for a in (R, T, Z))  # i (r) fastest, as structured_to_tets
    pts = np.column_stack([R * np.cos(T), R * np.sin(T), Z])
    s = 0.5 + 0.35 * np.sin(2.0 * T) * (2.0 - R) + 0.15 * np.cos(3.0 * np.pi * Z) * (R - 1.0)
    return TetMesh(pts, structured_to_tets((nr, nt, nz)), s, name="fe-like annular sector")



def dataset(name: str, size: int):
    from warpvol.scene.camera import Camera
    from warpvol.scene.loaders import read_mesh_file
    from warpvol.scene.scene import Scene
    from warpvol.scene.scene_file import load_scene
    from warpvol.scene.transfer import TransferFunction

    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # the repository
    if name == "bluntfin":
        sc = load_scene(os.path.join(root, "scenes", "bluntfin.toml"))
        mesh, tf, view = sc.mesh, sc.transfer, sc.camera.eye - sc.camera.target
    elif name == "spx":
        mesh = read_mesh_file(os.path.join(root, "..", "shared", "data", "spx.vtk"), "scalars")
        tf = TransferFunction([[0.0, 0.1, 0.2, 0.9, 0.0], [0.6, 0.2, 0.6, 1.0, 0.6], [1.2, 1.0, 0.9, 0.3, 1.5],
                               [2.254, 1.0, 0.2, 0.1, 3.0]], "color_extinction")
        view = np.array([1.0, 0.7, 1.4])
    else:
        mesh = fe_mesh()
        tf = TransferFunction([[0.0, 0.1, 0.3, 1.0, 0.3], [0.5, 0.3, 1.0, 0.4, 1.0], [1.0, 1.0, 0.2, 0.1, 3.0]],
                              "color_extinction")
        view = np.array([0.8, -1.0, 1.3])
    lo, hi = mesh.bounds
    c, diag = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    view = view / np.linalg.norm(view)
    up = (0.0, 1.0, 0.0) if abs(view[1]) < 0.9 else (0.0, 0.0, 1.0)
    cam = Camera(projection="orthographic", eye=c + 2.0 * diag * view, target=c, up=up, ortho_height=diag,
                 width_px=size, height_px=size)
    return Scene(mesh=mesh, transfer=tf, camera=cam, name=name)
