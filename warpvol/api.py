"""One-call notebook API: :func:`render`, :func:`compare`, :func:`presets`.

Inputs follow pyvista's habits: a mesh may be a :class:`~warpvol.TetMesh` or a pyvista data set
(with ``scalars=`` naming the point array), a camera may be a pyvista plotter, a transfer function
may be a ParaView preset or a VTK function pair. Every argument is validated and an error names it.
"""

from __future__ import annotations

import base64
import html
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from warpvol import cache
from warpvol.errors import ConfigError
from warpvol.pipeline import DEFAULT_PIPELINE, Pipeline, RenderResult, check_device, list_presets, quiet_warp
from warpvol.scene.camera import Camera
from warpvol.scene.loaders import mesh_from_pyvista
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.scene.scene_file import load_scene, scene_from_config
from warpvol.scene.transfer import TransferFunction
from warpvol.timing import time_summary

IMAGE_EXTENSIONS = (".exr", ".png")


def gpu_profile(gpu: Any) -> None:
    """The one place the ``gpu=`` argument is handled.

    GPU timing models (``--gpu`` profiles) are not part of this build, so only ``None`` is
    accepted; anything else is a :class:`~warpvol.ConfigError` saying so.
    """
    if gpu is None:
        return None
    raise ConfigError(f"gpu: GPU profiles are not available in this build (got {gpu!r}); use gpu=None")


# -- argument coercion ----------------------------------------------------------------------------
def as_mesh(mesh: Any, scalars: str | None = None, split: int | None = None) -> TetMesh:
    """``mesh`` as a :class:`TetMesh` (a TetMesh as it is; a pyvista data set converted)."""
    if isinstance(mesh, TetMesh):
        if scalars is not None or split is not None:
            raise ConfigError("scalars/split: only used when mesh is a pyvista data set; a TetMesh has its scalars")
        return mesh
    return mesh_from_pyvista(mesh, scalars, split, arg="mesh")


def as_transfer(transfer: Any) -> TransferFunction:
    """``transfer`` as a :class:`TransferFunction`: one already, a ParaView preset (``.json`` file or
    parsed dict), a scene file's ``[transfer]`` table as a dict, a
    ``(vtkColorTransferFunction, vtkPiecewiseFunction)`` pair (opacity per unit
    length), a ``vtkVolumeProperty`` (pyvista's ``add_volume(...).prop``: its scalar-opacity unit
    distance is used), or ``[s, r, g, b, extinction]`` rows."""
    if isinstance(transfer, TransferFunction):
        return transfer
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
    raise ConfigError("transfer: expected a TransferFunction, a ParaView preset (.json file or dict), a "
                      f"(vtkColorTransferFunction, vtkPiecewiseFunction) pair or [s, r, g, b, extinction] rows; "
                      f"got {type(transfer).__name__}")


def as_camera(camera: Any) -> Camera:
    """``camera`` as a :class:`Camera`: one already, a pyvista plotter, or a dict of Camera fields."""
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
             split: int | None = None) -> Scene:
    """A :class:`Scene` from parts; ``mesh`` may also be a whole Scene (``transfer`` and ``camera``,
    when given, replace its own)."""
    if isinstance(mesh, Scene):
        if scalars is not None or split is not None:
            raise ConfigError("scalars/split: only used when mesh is a pyvista data set, not a Scene")
        return Scene(mesh=mesh.mesh, transfer=mesh.transfer if transfer is None else as_transfer(transfer),
                     camera=mesh.camera if camera is None else as_camera(camera), name=mesh.name, source=mesh.source)
    m = as_mesh(mesh, scalars, split)
    if transfer is None:
        raise ConfigError("transfer: required (a TransferFunction, ParaView preset or VTK function pair)")
    if camera is None:
        raise ConfigError("camera: required (a Camera, a pyvista Plotter or a dict of Camera fields)")
    return Scene(mesh=m, transfer=as_transfer(transfer), camera=as_camera(camera), name=m.name)


def _scene_of(scene_or_parts: Any, scalars: str | None) -> Scene:
    if isinstance(scene_or_parts, Scene):
        return as_scene(scene_or_parts)
    if isinstance(scene_or_parts, (str, Path)):
        return load_scene(scene_or_parts)
    if isinstance(scene_or_parts, dict):
        return scene_from_config(scene_or_parts, where="scene_or_parts")
    if isinstance(scene_or_parts, (tuple, list)) and len(scene_or_parts) == 3:
        return as_scene(*scene_or_parts, scalars=scalars)
    raise ConfigError("scene_or_parts: expected a Scene, a scene file, 'builtin:NAME', a scene dict or a "
                      f"(mesh, transfer, camera) tuple; got {type(scene_or_parts).__name__}")


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


def _quiet(quiet: Any) -> None:
    if not isinstance(quiet, bool):
        raise ConfigError(f"quiet: expected True or False, got {quiet!r}")
    if quiet:
        quiet_warp()


def _device(device: Any) -> str:
    if not isinstance(device, str):
        raise ConfigError(f"device: expected a device name such as 'cpu' or 'cuda:0', got {device!r}")
    return check_device(device, "device")


def _reference(reference: Any, scene: Scene, fn: str = "render") -> tuple[np.ndarray | None, float | None]:
    """``(image, seconds)``: False -> none; True -> the exact reference, computed or from the session's
    cache (seconds ``0.0``: see :mod:`warpvol.cache`); an array or an EXR file name -> it. Errors name
    ``fn(reference)`` and what is accepted."""
    if reference is False or reference is None:
        return None, None
    if reference is True:
        from warpvol.reference.numpy_render import render_reference

        t0 = time.perf_counter()
        img, hit = cache.reference(scene, lambda: render_reference(scene.mesh, scene.transfer, scene.camera))
        return img, (0.0 if hit else time.perf_counter() - t0)
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
def _rgb(image: np.ndarray, background=(0.0, 0.0, 0.0)) -> np.ndarray:
    from warpvol.io import composite_over

    return np.clip(composite_over(np.asarray(image, np.float64), background), 0.0, 1.0)


def _draw(ax_img, ax_err, res: "Rendering", title: str) -> None:
    """One panel pair: the image (title: time and RMSE) and its error map against the reference."""
    ax_img.imshow(_rgb(res.image), interpolation="nearest")
    t = res.report.get("median_s", res.report.get("render_s", res.report["total_s"]))
    err = res.error
    ax_img.set_title(f"{title}\n{t:.3f} s" + (f", RMSE {err['rmse']:.2e}" if err else ""), fontsize=9)
    ax_img.set_axis_off()
    if ax_err is not None:
        im = ax_err.imshow(res.error_image, cmap="magma", interpolation="nearest", vmin=0.0)
        ax_err.set_title(f"|error| (max {err['max_abs']:.2e})", fontsize=9)
        ax_err.set_axis_off()
        ax_err.figure.colorbar(im, ax=ax_err, fraction=0.046, pad=0.04)


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
        from warpvol.io import write_exr, write_png

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
        is a reference, its error map."""
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
        _draw(axes[0, 0], axes[0, 1] if self.reference is not None else None, self, self.report.get("pipeline", ""))
        return fig

    def _repr_png_(self) -> bytes:
        from warpvol.io import write_png

        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "image.png"
            write_png(path, self.image)
            return path.read_bytes()

    def __repr__(self) -> str:
        h, w = self.image.shape[:2]
        e = self.error
        err = f", rmse={e['rmse']:.3e}, max_abs={e['max_abs']:.3e}" if e else ""
        return f"Rendering({self.report.get('pipeline')!r}, {w}x{h}, {time_summary(self.report)}{err})"


def render(mesh: Any, transfer: Any = None, camera: Any = None, pipeline: Any = DEFAULT_PIPELINE,
           reference: Any = False, device: str = "cpu", gpu: Any = None, *, scalars: str | None = None,
           split: int | None = None, quiet: bool = True) -> Rendering:
    """Render a mesh in one call.

    Parameters
    ----------
    mesh : TetMesh, pyvista data set or Scene
        A pyvista ``UnstructuredGrid``, ``StructuredGrid``, ``ImageData`` or ``RectilinearGrid`` is
        converted as a scene file would be (:meth:`TetMesh.from_pyvista`); a :class:`Scene` brings
        its own transfer function and camera (the arguments, when given, replace them).
    transfer : TransferFunction, ParaView preset, VTK functions or vtkVolumeProperty
        A preset is a ``.json`` file or its dict (:meth:`TransferFunction.from_paraview`); a
        ``(vtkColorTransferFunction, vtkPiecewiseFunction)`` pair is read with unit distance 1
        and a volume property (``plotter.add_volume(...).prop``) with its own
        (:meth:`TransferFunction.from_vtk` states the conversion).
    camera : Camera, pyvista.Plotter or dict
        A plotter gives its current view and window size (:meth:`Camera.from_pyvista`).
    pipeline : str, path or Pipeline
        A preset name (see :func:`presets`), a pipeline ``.toml`` file or a built pipeline.
    reference : bool, array or path
        ``True`` computes the exact float64 reference and reports the error against it; an
        ``(H, W, 4)`` array or an EXR file is used as the reference.
    device : str
        Warp device: ``"cpu"`` or ``"cuda:0"``, ...
    gpu : None
        GPU timing profile; not available in this build (anything but ``None`` is an error).
    scalars : str, optional
        Point-data array of a pyvista ``mesh`` (default: its active scalars).
    split : {None, 6, 5}, optional
        Tets per hex cell of a structured pyvista ``mesh``.
    quiet : bool
        Keep per-stage progress lines and Warp's start-up and module-load messages off the output
        (the latter through ``warp.config``, as the command line does).

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
    """
    gpu_profile(gpu)
    device = _device(device)
    _quiet(quiet)
    scene = _interned(as_scene(mesh, transfer, camera, scalars=scalars, split=split))
    pipe, key = _pipeline(pipeline, device)  # unknown pipelines fail before the reference spends time
    ref, ref_s = _reference(reference, scene)
    res = pipe.render(scene, reference=ref, quiet=quiet, device=device)
    if key is not None:
        cache.pipeline_used(key)
    if ref_s is not None:
        res.report["reference_s"] = ref_s
        res.report["reference_cached"] = reference is True and ref_s == 0.0
    return Rendering(res.image, res.report, scene=scene, reference=ref)


# -- comparison -----------------------------------------------------------------------------------
TABLE_COLUMNS = ("pipeline", "status", "time_s", "cold_s", "rmse", "max_abs", "psnr", "reason")


@dataclass
class Comparison:
    """What :func:`compare` returns: a matplotlib ``figure`` (one image + error-map pair per
    pipeline that rendered), the same data as a ``table`` (one dict per pipeline, :data:`TABLE_COLUMNS`;
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


def _timed_renders(pipe: Pipeline, scene: Scene, ref, repeats: int, quiet: bool, device: str) -> tuple[Any, float, float]:
    """``(last result, cold seconds, median warm seconds)``: one render that may compile kernels and
    build the set-up, then ``repeats`` warm ones."""
    import statistics

    first = pipe.render(scene, reference=ref, quiet=quiet, device=device)
    warm = [pipe.render(scene, reference=ref, quiet=quiet, device=device) for _ in range(repeats)]
    last = warm[-1] if warm else first
    times = [r.report["total_s"] for r in warm] or [first.report["total_s"]]
    return last, float(first.report["total_s"]), float(statistics.median(times))


def compare(scene_or_parts: Any, pipelines: Any = (DEFAULT_PIPELINE,), *, reference: Any = True,
            repeats: int = 3, device: str = "cpu", gpu: Any = None, scalars: str | None = None,
            quiet: bool = True) -> Comparison:
    """Render one scene with several pipelines against one exact reference.

    Each pipeline renders once cold (kernel compilation, tables, per-mesh data: ``cold_s``) and then
    ``repeats`` times warm; ``time_s`` is the median warm time. A pipeline that declines the scene (a
    configuration it cannot render, e.g. cell projection with the eye inside the mesh) or fails is a row
    with its ``status`` and ``reason``; the others are kept.

    Parameters
    ----------
    scene_or_parts : Scene, str, path, dict or (mesh, transfer, camera)
        A scene, a scene file or ``"builtin:NAME"``, a scene table, or the parts :func:`render`
        takes.
    pipelines : str or sequence
        Preset names (any of :func:`presets`), pipeline ``.toml`` files or :class:`Pipeline` objects;
        all are loaded (and checked) before anything is rendered.
    reference : True, array or path
        ``True`` computes the exact reference once (or takes it from the session's cache); an image or
        EXR file is used as given.
    repeats : int
        Warm renders per pipeline after the first (0: report the first render's time).
    device, gpu, scalars, quiet
        As in :func:`render`.

    Returns
    -------
    Comparison
        ``figure`` (titles give each pipeline's warm time and RMSE), ``table`` (rows of
        :data:`TABLE_COLUMNS`), ``results``; ``fig, table = compare(...)``.

    Examples
    --------
    >>> import warpvol
    >>> scene = warpvol.builtin_scene("linear_box").with_camera(width_px=12, height_px=12)
    >>> fig, table = warpvol.compare(scene, ["raycast"], repeats=1)
    >>> [r["pipeline"] for r in table], table[0]["rmse"] < 1e-5, len([a for a in fig.axes if a.images])
    (['raycast'], True, 2)
    """
    from matplotlib.figure import Figure

    from warpvol.errors import WarpvolError

    gpu_profile(gpu)
    device = _device(device)
    _quiet(quiet)
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
    ref, ref_s = _reference(reference, scene, "compare")
    results: dict[str, Rendering] = {}
    table: list[dict] = []
    for pipe, pkey in pipes:
        key, n = pipe.name, 2
        while key in results or any(r["pipeline"] == key for r in table):
            key, n = f"{pipe.name}#{n}", n + 1
        row: dict[str, Any] = dict.fromkeys(TABLE_COLUMNS)
        row["pipeline"] = key
        try:
            r, cold, warm = _timed_renders(pipe, scene, ref, int(repeats), quiet, device)
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
    fig = None
    if results:
        fig = Figure(figsize=(8.4, 4.0 * len(results)), layout="constrained")
        axes = fig.subplots(len(results), 2, squeeze=False)
        for row_axes, (k, r) in zip(axes, results.items()):
            _draw(row_axes[0], row_axes[1], r, k)
        if ref_s is not None:
            fig.suptitle(f"{scene.name}: exact reference {ref_s:.2f} s", fontsize=10)
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
