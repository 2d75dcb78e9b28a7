"""One-call notebook API: :func:`render`, :func:`compare`, :func:`presets`.

Inputs follow pyvista's habits: a mesh may be a :class:`~warpvol.TetMesh`, a pyvista data set
(with ``scalars=`` naming the point array) or a mesh file, a camera may be a pyvista plotter, a
transfer function may be a colour-map name, a ParaView preset or a VTK function pair. Left out, the
transfer function is a colour map over the point scalars' range with ParaView's opacity ramp and the
camera frames the whole mesh (:mod:`warpvol.scene.defaults`). Every argument is validated and an
error names it.
"""

from __future__ import annotations

import base64
import html
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from time import perf_counter
from typing import Any

import numpy as np

from warpvol import cache
from warpvol.errors import ConfigError, WarpvolError
from warpvol.figures import comparison_figure, draw_pair
from warpvol.io import write_exr, write_png
from warpvol.pipeline import DEFAULT_PIPELINE, Pipeline, RenderResult, check_device, list_presets, quiet_warp
from warpvol.scene.camera import Camera
from warpvol.scene.defaults import colormap_transfer, default_extinction, default_transfer, pixel_size, scalar_window
from warpvol.scene.loaders import mesh_from_pyvista
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.scene.scene_file import scene_from_config
from warpvol.scene.spec import scene_from_spec
from warpvol.scene.transfer import TransferFunction
from warpvol.timing import CompileClock, announce_compile, time_summary, wall_fields

IMAGE_EXTENSIONS = (".exr", ".png")


def gpu_profile(gpu: Any) -> str | None:
    """The ``gpu=`` argument checked: ``None`` or the name of a GPU profile (``warpvol gpus``,
    :func:`warpvol.model.list_profiles`), as ``--gpu`` on the command line."""
    if gpu is None:
        return None
    from warpvol import model

    try:
        model.load_profile(gpu)
    except ConfigError as e:
        raise ConfigError(str(e).replace("--gpu:", "gpu:", 1)) from None
    return gpu


# -- argument coercion ----------------------------------------------------------------------------
def as_mesh(mesh: Any, scalars: str | None = None, split: int | None = None) -> TetMesh:
    """``mesh`` as a :class:`TetMesh` (a TetMesh as it is; a pyvista data set converted)."""
    if isinstance(mesh, TetMesh):
        if scalars is not None or split is not None:
            raise ConfigError("scalars/split: only used when mesh is a pyvista data set; a TetMesh has its scalars")
        return mesh
    return mesh_from_pyvista(mesh, scalars, split, arg="mesh")


def as_transfer(transfer: Any, mesh: TetMesh | None = None) -> TransferFunction:
    """``transfer`` as a :class:`TransferFunction`: one already; ``None`` (with ``mesh``) the default
    (:func:`~warpvol.scene.defaults.default_transfer`); a colour-map name (matplotlib's or a
    ParaView preset's, with ``mesh``: over its scalar range with the default opacity ramp); a
    ParaView preset (``.json`` file or parsed dict), a scene file's ``[transfer]`` table as a dict, a
    ``(vtkColorTransferFunction, vtkPiecewiseFunction)`` pair (opacity per unit
    length), a ``vtkVolumeProperty`` (pyvista's ``add_volume(...).prop``: its scalar-opacity unit
    distance is used), or ``[s, r, g, b, extinction]`` rows."""
    if isinstance(transfer, TransferFunction):
        return transfer
    if transfer is None and mesh is not None:
        return default_transfer(mesh, where="transfer")
    if isinstance(transfer, str) and mesh is not None and not transfer.lower().endswith(".json") \
            and not Path(transfer).is_file():
        return colormap_transfer(transfer, scalar_window(mesh), default_extinction(mesh), where="transfer")
    if isinstance(transfer, dict) and any(k in transfer for k in ("points", "table", "paraview")):
        return TransferFunction.from_config(transfer, where="transfer")  # a scene file's [transfer] table
    if isinstance(transfer, (str, Path, dict)):
        return TransferFunction.from_paraview(transfer, where="transfer")
    if isinstance(transfer, (tuple, list)) and len(transfer) == 2 and not np.isscalar(transfer[0]) \
            and type(transfer[0]).__module__.startswith("vtkmodules"):
        return TransferFunction.from_vtk(*transfer, where="transfer")
    if hasattr(transfer, "GetScalarOpacityUnitDistance"):  # vtkVolumeProperty, e.g. add_volume(...).prop
        return TransferFunction.from_vtk(transfer.GetRGBTransferFunction(0), transfer.GetScalarOpacity(0),
                                         unit_distance=transfer.GetScalarOpacityUnitDistance(0), where="transfer")
    if isinstance(transfer, (list, tuple, np.ndarray)):
        return TransferFunction(transfer, where="transfer")
    raise ConfigError("transfer: expected a TransferFunction, a colour-map name, a ParaView preset (.json file or dict), a "
                      f"(vtkColorTransferFunction, vtkPiecewiseFunction) pair or [s, r, g, b, extinction] rows; "
                      f"got {type(transfer).__name__}")


def as_camera(camera: Any, mesh: TetMesh | None = None, size: Any = None) -> Camera:
    """``camera`` as a :class:`Camera`: one already, a pyvista plotter, or a dict of Camera fields;
    ``None`` (with ``mesh``) :meth:`Camera.fit` of the mesh. ``size`` (pixels, or ``(width_px,
    height_px)``) replaces the image size."""
    if camera is None and mesh is not None:
        w, h = pixel_size(size)
        return Camera.fit(mesh, width_px=w, height_px=h)
    cam = _as_camera(camera)
    if size is not None:
        w, h = pixel_size(size)
        cam = cam.replace(width_px=w, height_px=h)
    return cam


def _as_camera(camera: Any) -> Camera:
    if isinstance(camera, Camera):
        return camera
    if isinstance(camera, dict):
        return Camera.from_config(camera, where="camera")
    if hasattr(camera, "renderer") and hasattr(camera, "window_size"):
        return Camera.from_pyvista(camera)
    if type(camera).__module__.startswith(("vtkmodules", "pyvista")):
        raise ConfigError("camera: a bare pyvista/VTK camera has no image size; pass "
                          "Camera.from_pyvista(camera, window_size=(width, height)) or the plotter")
    raise ConfigError(f"camera: expected a warpvol Camera, a pyvista Plotter or a dict of Camera fields; "
                      f"got {type(camera).__name__}")


def as_scene(mesh: Any, transfer: Any = None, camera: Any = None, *, scalars: str | None = None,
             split: int | None = None, size: Any = None, step: int | None = None, time: float | None = None) -> Scene:
    """A :class:`Scene` from parts. ``mesh`` may also be a whole Scene, ``"builtin:NAME"``, a scene
    ``.toml`` file or a mesh file pyvista reads (:func:`~warpvol.scene.spec.scene_from_spec`);
    ``transfer`` and ``camera``, when given, replace the scene's own. Left out for a bare mesh, the
    transfer function is the default colour map over its scalars and the camera frames it
    (:mod:`warpvol.scene.defaults`). ``size`` replaces the image size in pixels; ``step`` or ``time``
    picks the step of a time-series mesh file (``.pvd``, ...; default its first)."""
    if isinstance(mesh, (str, Path)):
        mesh = scene_from_spec(mesh, scalars=scalars, split=split, where="mesh", step=step, time=time)
    elif step is not None or time is not None:
        raise ConfigError("step/time: only used when mesh is a mesh file (a time series such as a .pvd)")
    elif isinstance(mesh, Scene) and (scalars is not None or split is not None):
        raise ConfigError("scalars/split: only used when mesh is a pyvista data set or a mesh file, not a Scene")
    if isinstance(mesh, Scene):
        cam = mesh.camera if camera is None else as_camera(camera, mesh.mesh)
        if size is not None:
            w, h = pixel_size(size)
            cam = cam.replace(width_px=w, height_px=h)
        return Scene(mesh=mesh.mesh, transfer=mesh.transfer if transfer is None else as_transfer(transfer, mesh.mesh),
                     camera=cam, name=mesh.name, source=mesh.source)
    m = as_mesh(mesh, scalars, split)
    return Scene(mesh=m, transfer=as_transfer(transfer, m), camera=as_camera(camera, m, size), name=m.name)


def _scene_of(scene_or_parts: Any, scalars: str | None) -> Scene:
    if isinstance(scene_or_parts, dict):
        return scene_from_config(scene_or_parts, where="scene_or_parts")
    if isinstance(scene_or_parts, (tuple, list)) and len(scene_or_parts) == 3:
        return as_scene(*scene_or_parts, scalars=scalars)
    if isinstance(scene_or_parts, (tuple, list)):
        raise ConfigError("scene_or_parts: expected a Scene, a scene file, 'builtin:NAME', a mesh file, a mesh, a "
                          f"scene dict or a (mesh, transfer, camera) tuple; got a {type(scene_or_parts).__name__} "
                          f"of {len(scene_or_parts)}")
    try:
        return as_scene(scene_or_parts, scalars=scalars)
    except ConfigError as e:
        if str(e).startswith("mesh: expected"):
            raise ConfigError("scene_or_parts: expected a Scene, a scene file, 'builtin:NAME', a mesh file, a mesh, "
                              "a scene dict or a (mesh, transfer, camera) tuple; got "
                              f"{type(scene_or_parts).__name__}") from None
        raise


def _pipeline(pipeline: Any, device: str, arg: str = "pipeline") -> tuple[Pipeline, Any]:
    """``(pipeline, cache key)``: a preset or file's pipeline from the session's cache (built on a miss,
    :mod:`warpvol.cache`); a :class:`Pipeline` object as it is (key ``None``)."""
    if isinstance(pipeline, Pipeline):
        return pipeline, None
    if not isinstance(pipeline, (str, Path)):
        raise ConfigError(f"{arg}: expected a preset name, a pipeline .toml file or a Pipeline; "
                          f"got {type(pipeline).__name__}")

    def load() -> Pipeline:
        try:
            return Pipeline.load(pipeline, device=device)
        except ConfigError as e:
            msg = str(e)
            raise ConfigError(msg.replace("--pipeline:", f"{arg}:", 1) if msg.startswith("--pipeline") else msg) \
                from None

    try:
        return cache.pipeline(pipeline, device, load)
    except OSError as e:
        raise ConfigError(f"{arg}: cannot read {str(pipeline)!r}: {e.strerror or e}") from None


def _interned(scene: Scene) -> Scene:
    """The scene with the session's mesh object for its mesh's content (so per-mesh caches hit)."""
    mesh = cache.canonical_mesh(scene.mesh)
    return scene if mesh is scene.mesh else Scene(mesh=mesh, transfer=scene.transfer, camera=scene.camera,
                                                  name=scene.name, source=scene.source)


def _quiet(quiet: Any, device: Any) -> None:
    """Before anything touches Warp: with ``quiet``, Warp initialised without its banner and
    module-load lines (nothing of it on stdout from the first call on)."""
    if not isinstance(quiet, bool):
        raise ConfigError(f"quiet: expected True or False, got {quiet!r}")
    if quiet:
        quiet_warp(cuda=isinstance(device, str) and device.startswith("cuda"))


def _device(device: Any) -> str:
    if not isinstance(device, str):
        raise ConfigError(f"device: expected a device name such as 'cpu' or 'cuda:0', got {device!r}")
    return check_device(device, "device")


def _reference(reference: Any, scene: Scene, fn: str = "render",
               quiet: bool = True) -> tuple[np.ndarray | None, float | None]:
    """``(image, seconds)``: False -> none; True -> the exact reference, computed or from the session's
    cache (seconds ``0.0``: see :mod:`warpvol.cache`; unless ``quiet``, a progress bar on stderr when
    it is a terminal); an array or an EXR file name -> it. Errors name ``fn(reference)`` and what is
    accepted."""
    if reference is False or reference is None:
        return None, None
    if reference is True:
        from warpvol.progress import ProgressBar
        from warpvol.reference.numpy_render import render_reference

        t0 = perf_counter()
        # stderr only; none with quiet. Its kernels compile on first use: said before the wait
        with ProgressBar("exact reference", enabled=not quiet) as bar, \
                CompileClock(None if quiet else announce_compile):
            img, hit = cache.reference(scene, lambda: render_reference(scene.mesh, scene.transfer, scene.camera,
                                                                       progress=bar.fraction))
        return img, (0.0 if hit else perf_counter() - t0)
    arg = f"{fn}(reference)"
    accepted = ("expected True (compute the exact reference), False or None (no reference), the name of an "
                "existing EXR image file or an (H, W, 4) image array")
    if isinstance(reference, (str, Path)):
        from warpvol.io import read_exr

        if not Path(reference).is_file():
            raise ConfigError(f"{arg}: {str(reference)!r} is no image file (file not found); {accepted}")
        try:
            reference = read_exr(reference)
        except ConfigError as e:
            raise ConfigError(f"{arg}: {e}") from None
    elif isinstance(reference, np.bool_) or np.isscalar(reference):
        raise ConfigError(f"{arg}: got {reference!r}; {accepted}")
    try:
        ref = np.array(reference, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"{arg}: got a {type(reference).__name__}; {accepted}") from None
    want = (scene.camera.height_px, scene.camera.width_px, 4)
    if ref.shape != want:
        raise ConfigError(f"reference: shape {ref.shape} does not match the image {want} (height_px, width_px, RGBA)")
    return ref, None


# -- results --------------------------------------------------------------------------------------
@dataclass
class Rendering(RenderResult):
    """What :func:`render` returns: ``image`` (premultiplied RGBA float32, row 0 at the top),
    ``report`` (the render report of Contract 3), ``error`` against the reference when one was asked
    for, and ways to look at it: :meth:`save`, :meth:`show` / :meth:`plot`, and a PNG for Jupyter."""

    scene: Scene | None = None
    reference: np.ndarray | None = field(default=None, repr=False)

    @property
    def error(self) -> dict | None:
        """``{"rmse", "max_abs", "psnr"}`` over the RGBA image, or ``None`` without a reference."""
        return self.report.get("error")

    @property
    def error_image(self) -> np.ndarray | None:
        """Per-pixel max absolute error over RGBA, (H, W), or ``None`` without a reference."""
        if self.reference is None:
            return None
        from warpvol.metrics import error_image

        return error_image(self.image, self.reference)

    def save(self, path: str | Path, *, background=(0.0, 0.0, 0.0)) -> Path:
        """Write the image: ``.exr`` (float32 RGBA, as ``warpvol render -o``) or ``.png`` (8-bit,
        composited over ``background``), chosen by the extension. Returns the path."""

        p = Path(path)
        ext = p.suffix.lower()
        if ext not in IMAGE_EXTENSIONS:
            raise ConfigError(f"path: {str(path)!r} has extension {p.suffix or '(none)'!r}; "
                              f"supported: {', '.join(IMAGE_EXTENSIONS)}")
        if ext == ".exr":
            write_exr(p, self.image)
        else:
            write_png(p, self.image, background=background)
        return p

    def plot(self):
        """A matplotlib figure of the image (over black; title: pipeline, time, RMSE) and, when there
        is a reference, its error map on a logarithmic colour scale with a colour bar."""
        from matplotlib.figure import Figure

        return self._fill(Figure(figsize=self._figsize(), layout="constrained"))

    def show(self) -> None:
        """Show :meth:`plot`'s figure with matplotlib (inline in Jupyter, a window elsewhere)."""
        import matplotlib.pyplot as plt

        self._fill(plt.figure(figsize=self._figsize(), layout="constrained"))
        with warnings.catch_warnings():  # a non-interactive backend (scripts, tests) just keeps the figure
            warnings.filterwarnings("ignore", message=".*non-interactive.*")
            plt.show()

    def _figsize(self) -> tuple[float, float]:
        return (4.2 if self.reference is None else 8.4), 4.2

    def _fill(self, fig):
        axes = fig.subplots(1, 1 if self.reference is None else 2, squeeze=False)
        draw_pair(axes[0, 0], axes[0, 1] if self.reference is not None else None, self, self.report.get("pipeline", ""))
        return fig

    def _repr_png_(self) -> bytes:
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "image.png"
            write_png(path, self.image)
            return path.read_bytes()

    def __repr__(self) -> str:
        h, w = self.image.shape[:2]
        e = self.error
        err = f", rmse={e['rmse']:.3e}, max_abs={e['max_abs']:.3e}" if e else ""
        wall = f", wall {self.report['wall_s']:.3f} s" if self.report.get("wall_s") is not None else ""
        return f"Rendering({self.report.get('pipeline')!r}, {w}x{h}, {time_summary(self.report)}{wall}{err})"


def render(mesh: Any, transfer: Any = None, camera: Any = None, pipeline: Any = DEFAULT_PIPELINE,
           reference: Any = False, device: str = "cpu", gpu: Any = None, *, scalars: str | None = None,
           split: int | None = None, size: Any = None, quiet: bool = True, skip: bool = True,
           step: int | None = None, time: float | None = None) -> Rendering:
    """Render a mesh in one call.

    Parameters
    ----------
    mesh : TetMesh, pyvista data set, Scene or str / path
        A pyvista ``UnstructuredGrid``, ``StructuredGrid``, ``ImageData`` or ``RectilinearGrid`` is
        converted as a scene file would be (:meth:`TetMesh.from_pyvista`); a :class:`Scene`,
        ``"builtin:NAME"`` or a scene ``.toml`` file brings its own transfer function and camera (the
        arguments, when given, replace them); any other file name is a mesh file pyvista reads
        (``.vtu``, ``.vtk``, ...).
    transfer : None, colour-map name, TransferFunction, ParaView preset, VTK functions or vtkVolumeProperty
        ``None``: the ``"viridis"`` colour map over the point scalars' range with ParaView's opacity
        ramp (extinction rising linearly, scaled so an average ray gathers an optical depth of about
        6); a name: any matplotlib
        colour map or ParaView preset name the same way (:mod:`warpvol.scene.defaults`; an unknown
        name is an error listing the closest). A preset is a ``.json`` file or its dict
        (:meth:`TransferFunction.from_paraview`); a ``(vtkColorTransferFunction,
        vtkPiecewiseFunction)`` pair is read with unit distance 1 and a volume property
        (``plotter.add_volume(...).prop``) with its own (:meth:`TransferFunction.from_vtk` states
        the conversion).
    camera : None, Camera, pyvista.Plotter or dict
        ``None``: :meth:`Camera.fit`, pyvista's default view of the whole mesh. A plotter gives its
        current view and window size (:meth:`Camera.from_pyvista`).
    pipeline : str, path or Pipeline
        A preset name (see :func:`presets`), a pipeline ``.toml`` file or a built pipeline.
    reference : bool, array or path
        ``True`` computes the exact float64 reference and reports the error against it; an
        ``(H, W, 4)`` array or an EXR file is used as the reference.
    device : str
        Warp device: ``"cpu"`` or ``"cuda:0"``, ...
    gpu : str, optional
        A GPU profile (``warpvol gpus``), as ``--gpu`` on the command line: every stage's
        capabilities are checked against the card and the report gains ``gpu`` and ``modelled_s``.
    scalars : str, optional
        Point-data array of a pyvista ``mesh`` or mesh file (default: its active scalars).
    split : {None, 6, 5}, optional
        Tets per hex cell of a structured pyvista ``mesh``.
    step : int, optional
        The step of a time-series mesh file (``.pvd``, ...) to render, counted from 0 (default: the
        first; the report's ``mesh_notes`` says which of how many).
    time : float, optional
        Instead of ``step``: the time value of the step to render.
    size : int or (int, int), optional
        Image size in pixels, ``(width_px, height_px)``; replaces the camera's (default 512 x 512
        for a fitted camera).
    quiet : bool
        Keep per-stage progress lines and Warp's start-up and module-load messages off the output:
        Warp is initialised quietly before anything else, so nothing reaches stdout.
    skip : bool
        Leave out what the scene does not need: cells the transfer function makes invisible, empty
        space, depth behind an opaque front (``report["left_out"]`` counts it per stage). ``False``
        does all the work, for comparison (``--no-skip`` on the command line).

    Returns
    -------
    Rendering
        ``image``, ``report``, ``error`` (with a reference), ``save(path)``, ``show()``.

    Examples
    --------
    >>> import warpvol
    >>> scene = warpvol.builtin_scene("box").with_camera(width_px=16, height_px=16)
    >>> r = warpvol.render(scene, reference=True)
    >>> r.image.shape, r.error["max_abs"] < 1e-4
    ((16, 16, 4), True)
    >>> round(float(r.image[8, 8, 3]), 5)  # alpha through thickness 2 at extinction 1.5: 1 - exp(-3)
    0.95021
    >>> warpvol.render(scene.mesh, size=16).image.shape  # default transfer function and camera
    (16, 16, 4)
    """
    t_call = perf_counter()
    _quiet(quiet, device)
    device = _device(device)  # Warp starts here at the latest
    gpu = gpu_profile(gpu)
    t_scene = perf_counter()
    scene = _interned(as_scene(mesh, transfer, camera, scalars=scalars, split=split, size=size, step=step,
                               time=time))
    t_pipe = perf_counter()
    pipe, key = _pipeline(pipeline, device)  # unknown pipelines fail before the reference spends time
    if reference is True:  # what the pipeline declines is declined before the reference spends time
        pipe.check_scene(scene)
    t_ref = perf_counter()
    ref, ref_s = _reference(reference, scene, quiet=quiet)
    t_render = perf_counter()
    res = pipe.render(scene, reference=ref, quiet=quiet, device=device, gpu=gpu, skip=skip)
    if key is not None:
        cache.pipeline_used(key)
    if ref_s is not None:
        res.report["reference_s"] = ref_s
        res.report["reference_cached"] = reference is True and ref_s == 0.0
    # a reference read from a file or given as an array, or found in the cache, counts as input conversion
    wall_fields(res.report, startup_s=(t_scene - t_call) + (t_ref - t_pipe),
                conversion_s=(t_pipe - t_scene) + max(0.0, t_render - t_ref - (ref_s or 0.0)),
                wall_s=perf_counter() - t_call)
    return Rendering(res.image, res.report, scene=scene, reference=ref)


# -- comparison -----------------------------------------------------------------------------------
TABLE_COLUMNS = ("pipeline", "status", "time_s", "cold_s", "rmse", "max_abs", "psnr", "reason")


@dataclass
class Comparison:
    """What :func:`compare` returns: a matplotlib ``figure`` (one image + error-map pair per
    pipeline that rendered, a labelled empty panel with the reason for one that declined or failed), the same data as a ``table`` (one dict per pipeline, :data:`TABLE_COLUMNS`;
    a pipeline that declined the scene or failed is a row with ``status`` and ``reason``), each
    pipeline's :class:`Rendering` in ``results`` and the ``reference`` image. Unpacks as
    ``figure, table``; shows as figure and table in Jupyter.

    ``time_s`` is the median of the warm renders (kernels compiled, per-mesh data and tables built);
    ``cold_s`` the first render's time, compilation and set-up included."""

    figure: Any
    table: list[dict]
    results: dict[str, Rendering]
    reference: np.ndarray
    reference_s: float | None = None

    def __iter__(self):
        return iter((self.figure, self.table))

    @staticmethod
    def _cells(r: dict) -> list[str]:
        def f(v, fmt):
            return "-" if v is None else format(v, fmt)

        return [str(r["pipeline"]), str(r["status"]), f(r["time_s"], ".3f"), f(r["cold_s"], ".3f"),
                f(r["rmse"], ".3e"), f(r["max_abs"], ".3e"), f(r["psnr"], ".1f"), str(r["reason"] or "")]

    def markdown(self) -> str:
        """The table as Markdown text."""
        rows = ["| " + " | ".join(TABLE_COLUMNS) + " |", "|" + " --- |" * len(TABLE_COLUMNS)]
        rows += ["| " + " | ".join(self._cells(r)) + " |" for r in self.table]
        return "\n".join(rows)

    __str__ = markdown

    def _repr_html_(self) -> str:
        import io

        img = ""
        if self.figure is not None:
            buf = io.BytesIO()
            self.figure.savefig(buf, format="png", dpi=80, bbox_inches="tight")
            img = f'<img src="data:image/png;base64,{base64.b64encode(buf.getvalue()).decode()}"/>'
        head = "".join(f"<th>{c}</th>" for c in TABLE_COLUMNS)
        body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in self._cells(r)) + "</tr>"
                       for r in self.table)
        return f"{img}<table><tr>{head}</tr>{body}</table>"


def _timed_renders(pipe: Pipeline, scene: Scene, ref, repeats: int, quiet: bool, device: str,
                   gpu: str | None = None, skip: bool = True) -> tuple[Any, float, float]:
    """``(last result, cold seconds, median warm seconds)``: one render that may compile kernels and
    build the set-up, then ``repeats`` warm ones."""
    import statistics

    kw = {"reference": ref, "quiet": quiet, "device": device, "gpu": gpu, "skip": skip}
    first = pipe.render(scene, **kw)
    warm = [pipe.render(scene, **kw) for _ in range(repeats)]
    last = warm[-1] if warm else first
    times = [r.report["total_s"] for r in warm] or [first.report["total_s"]]
    return last, float(first.report["total_s"]), float(statistics.median(times))


def compare(scene_or_parts: Any, pipelines: Any = (DEFAULT_PIPELINE,), *, reference: Any = True,
            repeats: int = 3, device: str = "cpu", gpu: Any = None, scalars: str | None = None,
            quiet: bool = True, skip: bool = True) -> Comparison:
    """Render one scene with several pipelines against one exact reference.

    Each pipeline renders once cold (kernel compilation, tables, per-mesh data: ``cold_s``) and then
    ``repeats`` times warm; ``time_s`` is the median warm time. A pipeline that declines the scene (a
    configuration it cannot render, e.g. cell projection with the eye inside the mesh) or fails is a row
    with its ``status`` and ``reason``; the others are kept.

    Parameters
    ----------
    scene_or_parts : Scene, str, path, mesh, dict or (mesh, transfer, camera)
        A scene, a scene file, ``"builtin:NAME"`` or a mesh file, a mesh (TetMesh or pyvista data
        set, with the default transfer function and camera), a scene table, or the parts
        :func:`render` takes (``None`` for a default).
    pipelines : str or sequence
        Preset names (any of :func:`presets`), pipeline ``.toml`` files or :class:`Pipeline` objects;
        all are loaded (and checked) before anything is rendered.
    reference : True, array or path
        ``True`` computes the exact reference once (or takes it from the session's cache); an image or
        EXR file is used as given.
    repeats : int
        Warm renders per pipeline after the first (0: report the first render's time).
    device : str
        Warp device, as in :func:`render`.
    gpu : str, optional
        A GPU profile, as in :func:`render`: the table's times stay the emulation's, each result's
        report gains ``modelled_s``.
    scalars : str, optional
        Point-data array of a mesh given as ``scene_or_parts``, as in :func:`render`.
    quiet : bool
        As in :func:`render`.
    skip : bool
        As in :func:`render`: ``False`` renders every pipeline doing all the work (no culling, empty-space
        skipping or early ray termination); each result's ``report["left_out"]`` says what was left out.

    Returns
    -------
    Comparison
        ``figure`` (titles give each pipeline's warm time and RMSE; the error maps share one
        logarithmic colour scale), ``table`` (rows of
        :data:`TABLE_COLUMNS`), ``results``; ``fig, table = compare(...)``.

    Examples
    --------
    >>> import warpvol
    >>> scene = warpvol.builtin_scene("linear_box").with_camera(width_px=12, height_px=12)
    >>> fig, table = warpvol.compare(scene, ["raycast"], repeats=1)
    >>> [r["pipeline"] for r in table], table[0]["rmse"] < 1e-5, len([a for a in fig.axes if a.images])
    (['raycast'], True, 2)
    """

    _quiet(quiet, device)
    device = _device(device)
    gpu = gpu_profile(gpu)
    if reference is False or reference is None:
        raise ConfigError("reference: compare needs a reference (True to compute it, or an image)")
    if not isinstance(repeats, (int, np.integer)) or isinstance(repeats, bool) or repeats < 0:
        raise ConfigError(f"repeats: expected an integer >= 0, got {repeats!r}")
    names = [pipelines] if isinstance(pipelines, (str, Path, Pipeline)) else list(pipelines) \
        if isinstance(pipelines, (list, tuple)) else None
    if not names:
        raise ConfigError(f"pipelines: expected one or more preset names, files or Pipelines; got {pipelines!r}")
    pipes = [_pipeline(p, device, arg=f"pipelines[{k}]") for k, p in enumerate(names)]
    scene = _interned(_scene_of(scene_or_parts, scalars))
    ref, ref_s = _reference(reference, scene, "compare", quiet)
    results: dict[str, Rendering] = {}
    table: list[dict] = []
    for pipe, pkey in pipes:
        key, n = pipe.name, 2
        while key in results or any(r["pipeline"] == key for r in table):
            key, n = f"{pipe.name}#{n}", n + 1
        row: dict[str, Any] = dict.fromkeys(TABLE_COLUMNS)
        row["pipeline"] = key
        try:
            r, cold, warm = _timed_renders(pipe, scene, ref, int(repeats), quiet, device, gpu, bool(skip))
        except WarpvolError as e:  # the pipeline declines this scene, in words
            table.append({**row, "status": "declined", "reason": str(e)})
            continue
        except Exception as e:  # noqa: BLE001 - one failing pipeline must not lose the others' results
            table.append({**row, "status": "failed", "reason": f"{type(e).__name__}: {e}"})
            continue
        if pkey is not None:
            cache.pipeline_used(pkey)
        r.report["cold_s"] = cold
        r.report["median_s"] = warm
        results[key] = Rendering(r.image, r.report, scene=scene, reference=ref)
        err = r.report["error"]
        table.append({**row, "status": "ok", "time_s": warm, "cold_s": cold, "rmse": err["rmse"],
                      "max_abs": err["max_abs"], "psnr": err["psnr"], "reason": ""})
    # every pipeline has its row: a declined or failed one as an empty panel with the reason
    fig = comparison_figure(results, table, None if ref_s is None else f"{scene.name}: exact reference {ref_s:.2f} s")
    return Comparison(fig, table, results, ref, ref_s)


def presets() -> dict[str, str]:
    """The shipped pipeline presets: name -> one-line description (``warpvol pipelines``).

    Examples
    --------
    >>> import warpvol
    >>> "raycast" in warpvol.presets()
    True
    """
    return dict(list_presets())
