"""``warpvol stress``: a named suite of stiff and extreme scenes, each rendered with every pipeline.

Each case builds a scene (at full size, or at the reduced size of ``--quick`` that CI runs, which
also caps the pre-integration tables' resolution, :data:`warpvol.tools.bench.QUICK_TABLE_CAPS`) and is rendered with every
preset (:func:`warpvol.pipeline.list_presets`). Per case and pipeline the suite
records whether the output is finite, its error against the exact reference (or a closed form where
the exact reference would take minutes), the run time and a status:

``ok``
    rendered, finite.
``declined``
    the pipeline (or the reference) refused the case with a :class:`~warpvol.WarpvolError` naming why
    (it cannot handle it and says so); not a failure.
``failed``
    any other exception (its message is kept) or a non-finite pixel; the command exits 1.

Cases (see :data:`CASES`): extinction from 1e-6 to 1e6 per unit length, a TF jump (control points
1e-7 apart), edge ratio 1e6, Delaunay slivers of jittered grids, degenerate projections (a face seen
edge-on, vertices on pixel centres with rays inside shared faces, a ray along an edge shared by six
tets), the camera inside the mesh, far away, looking away, the near plane cutting cells, constant
scalars, one tet and 600k tets, 1x1 and 4096x4096 images, cells smaller than the rasteriser's snapping
on pixel rays, slabs and sheets too thin for float32, a silhouette on pixel centres.

Examples
--------
>>> from warpvol.tools.stress import CASES, build_case
>>> s = build_case("one_tet", quick=True)
>>> s.scene.mesh.n_tets, sorted(CASES)[:3]
(1, ['camera_far', 'camera_inside', 'camera_looking_away'])
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from warpvol.errors import ConfigError, WarpvolError
from warpvol.io import save_result, saved_records
from warpvol.metrics import image_error
from warpvol.pipeline import report_json
from warpvol.progress import ProgressBar, detail
from warpvol.reference.numpy_render import render_reference
from warpvol.scene.builtin import builtin_mesh
from warpvol.scene.camera import Camera
from warpvol.scene.grids import grid_points
from warpvol.scene.mesh import TetMesh
from warpvol.scene.scene import Scene
from warpvol.scene.transfer import TransferFunction
from warpvol.tools.bench import load_pipelines
from warpvol.tools.report_html import _fmt, html_table, page
from warpvol.tools.stress_meshes import _box, _tf
from warpvol.tools.stress_range import range_cases
from warpvol.tools.stress_real import add_real_data_cases
from warpvol.tools.stress_subpixel import add_subpixel_cases


@dataclass
class Case:
    """A built stress case: the scene, a closed-form reference where one replaces the exact one, and
    what it tests."""

    name: str
    scene: Scene
    doc: str
    analytic: Callable[[], np.ndarray] | None = None


def _ortho(px: int = 32, height: float = 3.0, eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0)) -> Camera:
    return Camera(projection="orthographic", eye=eye, target=target, up=up, ortho_height=height, width_px=px, height_px=px)


def _persp(px: int = 32, eye=(3.0, 2.0, 4.0), target=(0, 0, 0), fov=30.0) -> Camera:
    return Camera(eye=eye, target=target, up=(0, 1, 0), fov_y_deg=fov, width_px=px, height_px=px)


TF_LINEAR = TransferFunction([[-1.0, 1.0, 0.2, 0.1, 0.5], [1.0, 0.1, 0.3, 1.0, 2.0]])


def _box_closed_form(cam: Camera, rho: float = 1.5, c=(0.8, 0.6, 0.4)) -> Callable[[], np.ndarray]:
    """Builtin ``box`` seen down -z orthographically: thickness 2 inside |x|, |y| < 1, else nothing."""
    def ref() -> np.ndarray:
        h, w = cam.height_px, cam.width_px
        pix = cam.ortho_height / h
        xs = (np.arange(w) + 0.5 - w / 2) * pix
        ys = (h / 2 - np.arange(h) - 0.5) * pix
        inside = (np.abs(ys)[:, None] < 1) & (np.abs(xs)[None, :] < 1)
        a = 1.0 - np.exp(-2.0 * rho)
        img = np.zeros((h, w, 4))
        img[inside] = [c[0] * a, c[1] * a, c[2] * a, a]
        return img
    return ref


def _slivers(n: int, seed: int = 7) -> TetMesh:
    import pyvista as pv

    rng = np.random.default_rng(seed)
    x = np.linspace(-1.0, 1.0, n)
    pts = grid_points(x, x, x)
    pts[:, :] += rng.normal(scale=1e-4 * (x[1] - x[0]), size=pts.shape)  # nearly co-spherical: slivers
    grid = pv.PolyData(pts).delaunay_3d()
    tets = grid.cells_dict[10] if hasattr(grid, "cells_dict") else grid.cells.reshape(-1, 5)[:, 1:]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zero-volume tets are dropped with a warning: expected here
        return TetMesh(np.asarray(grid.points, float), tets, np.asarray(grid.points)[:, 2].copy(), name="slivers")


def _many(quick: bool) -> TetMesh:
    n = 11 if quick else 48  # 6 tets per cell: 6,000 / 622,938 tets
    return _box(n, name="many_tets")


def _cases() -> dict[str, tuple[str, Callable[[bool], Case]]]:
    c: dict[str, tuple[str, Callable[[bool], Case]]] = {}

    def sc(mesh, tf, cam, name):
        return Scene(mesh=mesh, transfer=tf, camera=cam, name=name)

    def simple(name, doc, build):
        c[name] = (doc, lambda quick: Case(name, build(quick), doc))

    def with_ref(name, doc, build):
        def make(quick):
            scene, ref = build(quick)
            return Case(name, scene, doc, ref)
        c[name] = (doc, make)

    for ext in (1e-6, 1e-2, 1e2, 1e6):
        simple(f"extinction_{ext:.0e}", f"constant extinction {ext:g} per unit length (optical depth {2 * ext:g} "
               "through the box)", lambda q, ext=ext: sc(_box(), _tf(ext), _persp(24 if q else 128), f"extinction_{ext:.0e}"))
    simple("tf_jump", "transfer function jumps at s = 0: control points 1e-7 apart (extinction 0.1 -> 5)",
           lambda q: sc(_box(), TransferFunction([[-1, 0.2, 0.4, 1.0, 0.1], [-5e-8, 0.2, 0.4, 1.0, 0.1],
                                                  [5e-8, 1.0, 0.5, 0.1, 5.0], [1, 1.0, 0.5, 0.1, 5.0]]),
                        _persp(24 if q else 128), "tf_jump"))
    simple("edge_ratio_1e6", "layer of thickness 2e-6 in a box of size 2: longest / shortest edge ~1.4e6",
           lambda q: sc(_box(5, zs=[-1.0, -1.0 + 2e-6, -0.5, 0.0, 1.0], name="edge_ratio"), TF_LINEAR,
                        _persp(24 if q else 128), "edge_ratio_1e6"))
    simple("slivers", "Delaunay tetrahedralisation of a grid jittered by 1e-4 of its spacing: slivers of near-zero volume",
           lambda q: sc(_slivers(5 if q else 16), TF_LINEAR, _persp(24 if q else 128), "slivers"))
    simple("face_edge_on", "perspective eye in the plane of the boundary face x = 1: that face is seen edge-on",
           lambda q: sc(_box(), TF_LINEAR, _persp(24 if q else 128, eye=(1.0, 0.3, 5.0), target=(1.0, 0.0, 0.0),
                                                  fov=40.0), "face_edge_on"))
    # orthographic down -z, pixel size = grid spacing / k, image inside the box: every interior grid
    # vertex in view on a pixel centre, the rays through them inside the shared faces x, y = const
    # (the boundary planes |x| = 1 stay off the pixel centres: a ray inside a boundary face is a
    # tie between in and out)
    simple("vertex_on_pixel_centre", "orthographic view down -z, interior grid vertices exactly on pixel centres; "
           "rays run inside shared interior faces",
           lambda q: sc(_box(), TF_LINEAR, _ortho(7 if q else 63, height=(7 if q else 63) * 0.5 / (2 if q else 16)),
                        "vertex_on_pixel_centre"))
    simple("ray_along_shared_edge", "orthographic view along the cube diagonal: the centre ray runs along the edge "
           "shared by the six tets of each cube",
           lambda q: sc(_box(3), TF_LINEAR, _ortho(9 if q else 65, eye=(5, 5, 5), height=3.0), "ray_along_shared_edge"))
    simple("camera_inside", "perspective eye at the centre of the mesh (rays start in the eye's cell)",
           lambda q: sc(_box(), TF_LINEAR, _persp(24 if q else 128, eye=(0.01, 0.02, 0.03), target=(1, 0.5, -2),
                                                  fov=90.0), "camera_inside"))
    simple("camera_far", "eye 1e6 away with a field of view of ~2e-4 degrees (mesh fills the image)",
           lambda q: sc(_box(), TF_LINEAR, _persp(24 if q else 128, eye=(3e5, 4e5, 8.66e5), fov=1.6e-4),
                        "camera_far"))
    simple("camera_looking_away", "the mesh is behind the eye: an empty image",
           lambda q: sc(_box(), TF_LINEAR, _persp(24 if q else 128, eye=(0, 0, 5), target=(0, 0, 10)),
                        "camera_looking_away"))
    simple("near_plane_cuts_cells", "eye 1e-4 outside the boundary with a 120 degree field of view: the near "
           "region cuts the boundary cells",
           lambda q: sc(_box(), TF_LINEAR, _persp(24 if q else 128, eye=(0.1, 0.2, 1.0001), target=(0, 0, 0),
                                                  fov=120.0), "near_plane_cuts_cells"))
    simple("ortho_eye_inside", "orthographic eye plane through the middle of the mesh",
           lambda q: sc(_box(), TF_LINEAR, _ortho(24 if q else 128, eye=(0, 0, 0.05)), "ortho_eye_inside"))
    simple("constant_scalars", "every scalar 1.0, on a TF control point",
           lambda q: sc(_box(scalar=lambda p: np.ones(len(p))),
                        TransferFunction([[0, 0, 0, 1, 0.1], [1, 1, 0.5, 0, 3.0], [2, 0, 1, 0, 0.2]]),
                        _persp(24 if q else 128), "constant_scalars"))
    simple("one_tet", "a mesh of one tet",
           lambda q: sc(TetMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]], [0.0, 1.0, -1.0, 0.5],
                                name="one_tet"), TF_LINEAR, _persp(24 if q else 128, eye=(2, 1.5, 2.5), target=(0.25,) * 3),
                        "one_tet"))
    simple("many_tets", "a 47^3-cell grid, 622,938 tets (--quick: 6,000)",
           lambda q: sc(_many(q), TF_LINEAR, _persp(32 if q else 256), "many_tets"))
    for px in (1, 4096):
        def boxed(q, px=px):
            size = px if px == 1 else (512 if q else px)
            cam = _ortho(size)
            s = builtin_mesh("box")
            tf = TransferFunction([[0.0, 0.8, 0.6, 0.4, 1.5], [2.0, 0.8, 0.6, 0.4, 1.5]])
            return sc(s, tf, cam, f"image_{px}"), _box_closed_form(cam)
        with_ref(f"image_{px}x{px}", f"a {px}x{px} image (--quick: {'1x1' if px == 1 else '512x512'}) of the built-in "
                 "box; reference: its closed form", boxed)
    add_real_data_cases(simple, with_ref, sc)
    range_cases(simple, with_ref, sc)
    add_subpixel_cases(simple, sc)
    return c


def case_names() -> list[str]:
    return sorted(_cases())


CASES = {k: v[0] for k, v in sorted(_cases().items())}
"""case name -> what it tests"""


def build_case(name: str, quick: bool = False) -> Case:
    cases = _cases()
    if name not in cases:
        from warpvol.errors import ConfigError

        raise ConfigError(f"--cases: unknown stress case {name!r}; available: {', '.join(sorted(cases))}")
    return cases[name][1](quick)


# ------------------------------------------------------------------------------------------------
def report_warnings(report: dict) -> list[str]:
    """The warnings of a render report: ``stats.warning`` and each stage section's (``stats.KEY.warning``,
    prefixed with the key), so a pipeline that flags its own losses says so in the stress table."""
    stats = report.get("stats", {}) or {}
    out = [str(stats["warning"])] if stats.get("warning") else []
    out += [f"{k}: {v['warning']}" for k, v in stats.items() if isinstance(v, dict) and v.get("warning")]
    return out


def run_case(case: Case, pipes: list[Any], device: str = "cpu",
             on_step: Callable[[str], None] | None = None, skip: bool = True) -> list[dict]:
    """Rows for one case: the reference's row, then one per pipeline (never raises, but for Ctrl-C).
    ``on_step(what)`` is told what starts next (the reference, each pipeline): progress. ``skip=False``:
    every render does all the work (``--no-skip``); a row's ``left_out`` says what a render left out."""
    step = on_step or (lambda _what: None)

    rows = []
    t0 = time.perf_counter()
    ref = None
    step("reference")
    try:
        if case.analytic is not None:
            ref, kind = case.analytic(), "closed form"
        else:
            sc = case.scene
            # its share done goes to the open progress bar (none: nothing shown)
            ref = render_reference(sc.mesh, sc.transfer, sc.camera, progress=lambda f: detail("reference", f))
            kind = "exact float64"
        finite = bool(np.isfinite(ref).all())
        rows.append({"case": case.name, "pipeline": f"reference ({kind})", "status": "ok" if finite else "failed",
                     "finite": finite, "time_s": time.perf_counter() - t0, "rmse": None, "max_abs": None,
                     "message": "" if finite else "non-finite reference pixels"})
        if not finite:
            ref = None
    except KeyboardInterrupt:
        raise
    except WarpvolError as e:  # a scene no reading renders (e.g. parts overlapping in space): declined in words
        rows.append({"case": case.name, "pipeline": "reference", "status": "declined", "finite": None,
                     "time_s": time.perf_counter() - t0, "rmse": None, "max_abs": None, "message": str(e)})
    except Exception as e:  # noqa: BLE001 - reported as the case's failure, the pipelines still run
        rows.append({"case": case.name, "pipeline": "reference", "status": "failed", "finite": None,
                     "time_s": time.perf_counter() - t0, "rmse": None, "max_abs": None,
                     "message": f"{type(e).__name__}: {e}"})
    for pipe in pipes:
        step(pipe.name)
        row = {"case": case.name, "pipeline": pipe.name, "finite": None, "rmse": None, "max_abs": None, "message": ""}
        t0 = time.perf_counter()
        try:
            res = pipe.render(case.scene, quiet=True, device=device, **({} if skip else {"skip": False}))
            row["time_s"] = res.report["total_s"]
            row["left_out"] = "; ".join(f"{k}: " + ", ".join(f"{c} {n}" for c, n in v.items() if c != "why")
                                        for k, v in res.report.get("left_out", {}).items())
            row.update({k: res.report.get(k) for k in ("render_s", "setup_s", "compile_s")})
            row["finite"] = bool(np.isfinite(res.image).all())
            row["status"] = "ok" if row["finite"] else "failed"
            if ref is not None and row["finite"]:
                e = image_error(res.image, ref)
                row.update(rmse=e["rmse"], max_abs=e["max_abs"])
            row["message"] = "; ".join(report_warnings(res.report)) if row["finite"] else "non-finite pixels"
        except KeyboardInterrupt:
            raise
        except WarpvolError as e:
            row.update(status="declined", time_s=time.perf_counter() - t0, message=str(e))
        except Exception as e:  # noqa: BLE001 - a crash is this case's failure; the suite goes on
            finite = False if "NaN/Inf" in str(e) else None
            row.update(status="failed", finite=finite, time_s=time.perf_counter() - t0,
                       message=f"{type(e).__name__}: {e}")
        rows.append(row)
    return rows


def run_stress(quick: bool = False, cases: list[str] | None = None, pipelines: Any = "all", device: str = "cpu",
               quiet: bool = True, done: dict[str, list[dict]] | None = None,
               on_case: Callable[[str, list[dict]], None] | None = None, progress: bool = False,
               skip: bool = True) -> list[dict]:
    """Every case x every pipeline; a case that cannot even be built is a failed row. ``quick``: the
    reduced sizes of each case and :func:`warpvol.tools.bench.quick_pipeline`. ``done``: rows of cases
    already run (a resumed suite: they are not run again); ``on_case(name, rows)`` is called after
    each case that runs (e.g. to save it at once). Progress (a unit per reference and per render, with the
    time left) goes to stderr on a terminal (``progress``: also elsewhere, as lines; ``quiet``: never).
    ``skip=False``: every render does all the work (``--no-skip``)."""

    names = check_case_names(cases)
    pipes = load_pipelines(pipelines, device, quick=quick)
    per = 1 + len(pipes)  # units of a case: its reference and one render per pipeline
    rows: list[dict] = []
    done = done or {}
    with ProgressBar("stress" + (" --quick" if quick else ""), len(names) * per, enabled=not quiet,
                     force=progress) as prog:
        for k, n in enumerate(names):
            if n in done:
                rows += done[n]
                prog.set((k + 1) * per, f"{n}: saved rows reused")
                continue
            start = len(rows)
            prog.describe(f"{n}: building the case")
            try:
                case = build_case(n, quick)
            except KeyboardInterrupt:
                raise
            except Exception as e:  # noqa: BLE001
                rows.append({"case": n, "pipeline": "(scene)", "status": "failed", "finite": None, "time_s": None,
                             "rmse": None, "max_abs": None, "message": f"building the case: {type(e).__name__}: {e}"})
                prog.set((k + 1) * per, f"{n}: failed")
                continue
            steps = [0]

            def step(what: str, n: str = n) -> None:  # called before each item: what runs next
                prog.advance(1 if steps[0] else 0, f"{n}: {what}")
                steps[0] += 1

            rows += run_case(case, pipes, device, on_step=step, **({} if skip else {"skip": False}))
            if on_case is not None:
                on_case(n, rows[start:])
            prog.set((k + 1) * per, f"{n}: done")
    return rows


def check_case_names(cases: list[str] | None) -> list[str]:
    """The case names to run (all when ``cases`` is empty); an unknown name is a ConfigError naming it
    (before any work or file is touched)."""
    names = list(cases or case_names())
    for n in names:
        if n not in CASES:
            build_case(n)  # raises the ConfigError naming the case
    return names


CASE_DIR = "cases"  # per-case rows under the output folder, written as each case finishes
#: the summary files ``stress -o`` writes
STRESS_FILES = ("stress.json", "stress.csv", "stress.md", "stress.html")


def case_store(outdir, quick: bool, pipelines: list[str], *, skip: bool = True, digests: dict[str, str] | None = None,
               owned: Any = None, note: Callable[[str], None] | None = None):
    """``(saved, save)`` for ``outdir/cases``: the rows of the cases saved there by an earlier run with
    the same ``quick`` flag and pipeline names (a different run's files are an error naming the
    difference), and a function saving one case's rows.

    ``digests``: pipeline name -> content hash of its TOML (:func:`warpvol.tools.bench.pipeline_digest`):
    a case saved with other pipeline contents is run again. ``owned``
    (:class:`warpvol.io.OwnedFiles`): only the records warpvol wrote there are read. Temporary files
    (dot names) are never read; a record that cannot be read (cut short, edited) is run again;
    ``note(text)`` is told about each record not reused."""
    from pathlib import Path


    note = note or (lambda _text: None)
    d = Path(outdir) / CASE_DIR
    key = {"quick": bool(quick), "pipelines": sorted(pipelines), "skip": bool(skip)}
    saved: dict[str, list[dict]] = {}
    for f, rec in saved_records(outdir, CASE_DIR, owned):
        if rec is None or not isinstance(rec.get("case"), str) or not isinstance(rec.get("rows"), list):
            note(f"{f} cannot be read (cut short or edited): its case runs again")
            continue
        # a record saved before skip was recorded came from a run with skipping on (the default)
        if {k: rec.get(k, True if k == "skip" else None) for k in key} != key:
            raise ConfigError(f"--resume: {f} is from a run with quick={rec.get('quick')}, skip={rec.get('skip', True)} "
                              f"and pipelines {rec.get('pipelines')}, this one has quick={key['quick']}, "
                              f"skip={key['skip']} and {key['pipelines']}")
        if digests is not None and rec.get("pipeline_sha") != digests:
            old = rec.get("pipeline_sha") if isinstance(rec.get("pipeline_sha"), dict) else {}
            changed = [n for n in sorted(digests) if old.get(n) != digests[n]]
            note(f"{f}: pipeline {', '.join(changed)} changed since the case was saved: it runs again")
            continue
        saved[rec["case"]] = rec["rows"]

    def save(name: str, rows: list[dict]) -> None:
        extra = {} if digests is None else {"pipeline_sha": digests}
        save_result(d, name, report_json({**key, **extra, "case": name, "rows": rows}), owned=owned)

    return saved, save


STRESS_HEAD = ("case", "pipeline", "status", "finite", "time [s]", "RMSE", "max abs", "note")


def stress_markdown(rows: list[dict]) -> str:
    lines = ["| " + " | ".join(STRESS_HEAD) + " |", "|" + " --- |" * len(STRESS_HEAD)]
    for r in rows:
        cells = [r["case"], r["pipeline"], r["status"], _fmt(r.get("finite")), _fmt(r.get("time_s")),
                 _fmt(r.get("rmse")), _fmt(r.get("max_abs")), (r.get("message") or "").replace("|", "/")[:160]]
        lines.append("| " + " | ".join(cells) + " |")
    fails = sum(r["status"] == "failed" for r in rows)
    declined = sum(r["status"] == "declined" for r in rows)
    ok = sum(r["status"] == "ok" for r in rows)
    lines.append(f"\n{len({r['case'] for r in rows})} cases: {ok} ok, {declined} declined, {fails} failed")
    return "\n".join(lines)


def stress_matrix(rows: list[dict]) -> str:
    """Cases x pipelines as Markdown: ``RMSE / max abs (time)`` per cell, or the status in words.

    Examples
    --------
    >>> print(stress_matrix([{"case": "c", "pipeline": "p", "status": "ok", "rmse": 1e-7, "max_abs": 2e-6,
    ...                       "time_s": 0.5}, {"case": "d", "pipeline": "p", "status": "declined"}]))
    | case | p |
    | --- | --- |
    | c | 1.0e-07 / 2e-06 (0.5 s) |
    | d | declined |
    """
    pipes = list(dict.fromkeys(r["pipeline"] for r in rows if not r["pipeline"].startswith(("reference", "("))))
    lines = ["| case | " + " | ".join(pipes) + " |", "|" + " --- |" * (len(pipes) + 1)]
    for case in dict.fromkeys(r["case"] for r in rows):
        cells = []
        for p in pipes:
            r = next((r for r in rows if r["case"] == case and r["pipeline"] == p), None)
            if r is None:
                cells.append("-")
            elif r["status"] == "ok" and r.get("rmse") is not None:
                cells.append(f"{r['rmse']:.1e} / {r['max_abs']:.2g} ({r['time_s']:.2g} s)")
            else:
                cells.append(r["status"] + ("" if r["status"] != "ok" else " (no reference)"))
        lines.append(f"| {case} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def stress_page(rows: list[dict], quick: bool) -> str:
    """The summary as a self-contained HTML page: one table, failed rows in red, case descriptions."""

    body = [[r["case"], r["pipeline"], r["status"], _fmt(r.get("finite")), _fmt(r.get("time_s")), _fmt(r.get("rmse")),
             _fmt(r.get("max_abs")), r.get("message") or ""] for r in rows]
    table = html_table(list(STRESS_HEAD), body).replace("<td>failed</td>", '<td class="fail">failed</td>')
    cases = html_table(["case", "what it tests"], [[k, v] for k, v in CASES.items()])
    summary = stress_markdown(rows).rsplit("\n", 1)[-1]
    matrix = [ln.strip("|").split(" | ") for ln in stress_matrix(rows).splitlines()]
    grid = html_table([c.strip() for c in matrix[0]], [[c.strip() for c in ln] for ln in matrix[2:]])
    return page("warpvol stress" + (" --quick" if quick else ""),
                [f"<p>{summary}</p>", "<h2>RMSE / max abs (time) per case and pipeline</h2>", grid,
                 "<h2>All rows</h2>", table, "<h2>Cases</h2>", cases])
