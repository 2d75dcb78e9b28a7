"""pyvista / VTK in and out: meshes and cameras.

The mesh conversion itself lives in :func:`warpvol.loaders.mesh_from_dataset` (scene files use the
same code, so a data set renders identically from memory and from a file). Cameras map one to one:

==========================  =====================================  ==============================
warpvol :class:`Camera`      VTK ``vtkCamera`` / ``pyvista.Camera``   note
==========================  =====================================  ==============================
``eye``                      ``position``
``target``                   ``focal_point``
``up``                       ``up`` (``ViewUp``)                    VTK keeps it orthogonal
``fov_y_deg``                ``view_angle``                         vertical unless
                                                                    ``UseHorizontalViewAngle``
``projection``               ``parallel_projection``
``height``                   ``2 * parallel_scale``                 orthographic image height
``width_px, height_px``      the plotter's ``window_size``          (times the renderer viewport)
==========================  =====================================  ==============================

VTK's window centre, view shear, off-axis projection, explicit projection matrix and model transform
have no warpvol counterpart; a camera that uses them is refused with the setting named.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import ConfigError

_DATASET_TYPES = "pyvista.UnstructuredGrid, StructuredGrid, ImageData or RectilinearGrid"


def as_pyvista_dataset(obj: Any, arg: str = "dataset"):
    """``obj`` as a pyvista data set (raw VTK data sets are wrapped; a one-block MultiBlock is
    unwrapped); anything else is an error naming ``arg``."""
    import pyvista as pv

    if isinstance(obj, pv.MultiBlock):
        blocks = [b for b in obj if b is not None]
        if len(blocks) != 1:
            raise ConfigError(f"{arg}: a MultiBlock with {len(blocks)} blocks; pass a single data set "
                              f"({_DATASET_TYPES}), e.g. multiblock.combine()")
        obj = blocks[0]
    if not isinstance(obj, pv.DataSet):
        try:
            from vtkmodules.vtkCommonDataModel import vtkDataSet
        except ImportError:  # pragma: no cover - VTK ships with pyvista
            vtkDataSet = ()
        if not isinstance(obj, vtkDataSet):
            raise ConfigError(f"{arg}: expected a {_DATASET_TYPES} (or a TetMesh), got {type(obj).__name__}")
        obj = pv.wrap(obj)
    if not isinstance(obj, (pv.UnstructuredGrid, pv.StructuredGrid, pv.ImageData, pv.RectilinearGrid)):
        raise ConfigError(f"{arg}: expected a {_DATASET_TYPES}, got {type(obj).__name__}, which has no volume cells")
    return obj


def mesh_from_pyvista(dataset: Any, scalars: str | None = None, split: int | None = None, *,
                      strict: bool = False, name: str | None = None, arg: str = "dataset"):
    """See :meth:`warpvol.TetMesh.from_pyvista`."""
    from .loaders import mesh_from_dataset

    ds = as_pyvista_dataset(dataset, arg)
    if scalars is None:
        scalars = ds.point_data.active_scalars_name
        if scalars is None and len(ds.point_data.keys()) == 1:
            scalars = ds.point_data.keys()[0]
    return mesh_from_dataset(ds, scalars, strict=strict, split=split, name=name or f"pyvista {type(ds).__name__}",
                             scalars_key="scalars", dataset_key=arg)


def mesh_to_pyvista(mesh, scalars_name: str = "scalars"):
    """See :meth:`warpvol.TetMesh.to_pyvista`."""
    import pyvista as pv

    if not isinstance(scalars_name, str) or not scalars_name:
        raise ConfigError(f"scalars_name: expected a non-empty string, got {scalars_name!r}")
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: np.array(mesh.tets, dtype=np.int64)},
                               np.array(mesh.points, dtype=np.float64))
    grid.point_data[scalars_name] = np.array(mesh.scalars, dtype=np.float64)
    grid.point_data.active_scalars_name = scalars_name
    return grid


# -- cameras ---------------------------------------------------------------------------------------
def _window_size(value: Any, arg: str = "window_size") -> tuple[int, int]:
    try:
        w, h = value
        ok = all(not isinstance(v, bool) and float(v).is_integer() and v >= 1 for v in (w, h))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ConfigError(f"{arg}: expected (width, height) in whole pixels >= 1, got {value!r}")
    return int(w), int(h)


def _check_plain_vtk_camera(cam, arg: str) -> None:
    """Refuse VTK camera settings warpvol's camera model cannot express."""
    checks = [
        ("GetWindowCenter", (0.0, 0.0), "window centre"),
        ("GetViewShear", (0.0, 0.0, 1.0), "view shear"),
        ("GetUseOffAxisProjection", 0, "off-axis projection"),
        ("GetUseExplicitProjectionTransformMatrix", 0, "explicit projection matrix"),
        ("GetUseExplicitAspectRatio", 0, "explicit aspect ratio"),
    ]
    for getter, plain, what in checks:
        if hasattr(cam, getter):
            v = getattr(cam, getter)()
            if not np.allclose(np.atleast_1d(np.asarray(v, dtype=float)), np.atleast_1d(plain), rtol=0, atol=0):
                raise ConfigError(f"{arg}: the VTK camera uses a {what} ({getter[3:]} = {v}), which warpvol's "
                                  "camera cannot express")
    m = cam.GetModelTransformMatrix()
    if not np.array_equal([[m.GetElement(i, j) for j in range(4)] for i in range(4)], np.eye(4)):
        raise ConfigError(f"{arg}: the VTK camera has a model transform, which warpvol's camera cannot express")


def camera_from_pyvista(source: Any, window_size: Any = None, *, arg: str = "plotter_or_camera"):
    """See :meth:`warpvol.Camera.from_pyvista`."""
    from vtkmodules.vtkRenderingCore import vtkCamera

    from .camera import Camera

    size = None
    if hasattr(source, "renderer") and hasattr(source, "window_size"):  # a pyvista Plotter
        cam = source.camera  # pyvista sets its default view here when none was set yet (as show() does)
        vp = source.renderer.GetViewport()
        ws = source.window_size
        size = (max(1, round(ws[0] * (vp[2] - vp[0]))), max(1, round(ws[1] * (vp[3] - vp[1]))))
    elif isinstance(source, vtkCamera):  # pyvista.Camera is a vtkCamera
        cam = source
    else:
        raise ConfigError(f"{arg}: expected a pyvista Plotter or a pyvista/VTK camera, got {type(source).__name__}")
    if window_size is not None:
        size = _window_size(window_size)
    if size is None:
        raise ConfigError("window_size: required with a camera (a camera has no image size); give "
                          "(width, height) in pixels, e.g. plotter.window_size")
    _check_plain_vtk_camera(cam, arg)
    w, h = size
    fov = float(cam.GetViewAngle())
    if cam.GetUseHorizontalViewAngle():
        fov = float(np.degrees(2.0 * np.arctan(np.tan(np.radians(fov) / 2.0) * h / w)))
    return Camera(projection="orthographic" if cam.GetParallelProjection() else "perspective",
                  eye=cam.GetPosition(), target=cam.GetFocalPoint(), up=cam.GetViewUp(), fov_y_deg=fov,
                  height=2.0 * float(cam.GetParallelScale()), width_px=w, height_px=h, where=arg)


def camera_to_pyvista(camera, plotter: Any = None):
    """See :meth:`warpvol.Camera.to_pyvista`."""
    import pyvista as pv

    cam = pv.Camera()
    cam.position = tuple(camera.eye)
    cam.focal_point = tuple(camera.target)
    cam.up = tuple(camera.true_up)
    cam.view_angle = float(camera.fov_y_deg)
    cam.parallel_projection = camera.projection == "orthographic"
    cam.parallel_scale = float(camera.height) / 2.0
    if plotter is not None:
        if not (hasattr(plotter, "renderer") and hasattr(plotter, "window_size")):
            raise ConfigError(f"plotter: expected a pyvista Plotter, got {type(plotter).__name__}")
        plotter.window_size = [int(camera.width_px), int(camera.height_px)]
        plotter.camera = cam
    return cam
