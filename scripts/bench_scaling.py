"""Cost laws: time, peak memory and bytes per tet against mesh size and image size.

Renderers: warpvol's ``raycast``, ``harc_best`` and ``pt_best`` presets (warm: kernels compiled, per-mesh
data built; ``vsbuffer_best`` on request, ``--renderers vsbuffer_best``), the exact float64 reference (:func:`warpvol.reference.numpy_render.render_reference`, Warp
kernels; kernels compiled by a 16x16 warm-up, per-mesh set-up included in its time: it keeps none) and
VTK's ``vtkProjectedTetrahedraMapper`` (offscreen, set up as in ``scripts/bench_raycast.py``; warm).

Meshes: the cube [-1, 1]^3 as a refined structured grid (Kuhn split, 6 tets per cube) and as an
unstructured Delaunay mesh of uniform random points (VTK's ``vtkDelaunay3D`` through pyvista; its slivers dropped as zero-volume tets), of
about ``--tets`` tets each, with a smooth scalar field and a 4-point TF; the camera frames the cube
(:meth:`warpvol.scene.camera.Camera.fit`). Two sweeps:

* mesh size (``--tets``, default 1e4 1e5 1e6) at ``--mesh-size-px`` (default 256^2), both mesh kinds;
* image size (``--sizes``, default 128 256 512 1024) on the structured mesh of ``--image-tets`` (1e5).

Every (renderer, mesh, image) point runs in its own child process, one at a time: time is the median
of ``--repeat`` renders after a first render (which builds the per-mesh data; its time is reported as
``first``); peak memory is the child's peak resident set (``ru_maxrss``) minus its resident set once the
renderer has drawn a 48-tet mesh (kernels compiled and loaded, libraries imported) and the measured mesh
is built (so it counts what the renderer allocates for that mesh and image: per-mesh data, buffers,
images), and bytes per tet is that over the tets (also reported: the resident memory kept between frames, per tet). The fitted exponents
are least-squares slopes in log-log: time ~ tets^a (per mesh kind), time ~ pixels^b, memory ~ tets^c
(from the two largest meshes). The machine's load average is recorded with every point.
Writes ``docs/data/scaling.json`` (tables for the documentation's ``<!-- table: scaling/NAME -->``
markers) and ``docs/img/scaling.png`` (log-log plot), unless ``--no-docs``; meshes are cached in
``--cache``.

``--tf shell`` measures the cost law of what the renderers leave out instead: the mesh sweep only, with a
transfer function that shows one iso-like shell of the scalar (a hat around 0.5 whose half-width is
:data:`SHELL_CELLS` cell edges in scalar units), so the visible fraction of the cells shrinks as the mesh
grows (~tets^-1/3: a surface's cells over the volume's). A renderer whose frame grows with the visible
cells and covered pixels rather than the mesh shows time ~ tets^a with a well below 1. Writes
``docs/data/scaling_shell.json`` (tables ``points`` and ``exponents``, with the visible fraction).

Usage::

    ./run.sh python scripts/bench_scaling.py [--tets 1e4 1e5 1e6] [--sizes 128 256 512 1024] [--repeat 2]
        [--renderers raycast,harc_best,pt_best,reference,vtk_pt] [--timeout 300] [--no-docs]
    ./run.sh python scripts/bench_scaling.py --tf shell --kinds structured --renderers raycast,harc_best,pt_best,vtk_pt
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from warpvol.tools import provenance

ROOT = Path(__file__).resolve().parents[1]
RENDERERS = ("raycast", "harc_best", "pt_best", "reference", "vtk_pt", "vsbuffer_best")
#: the default run's renderers (``vsbuffer_best``, seconds per frame from 10^6 tets on, is run on request)
DEFAULT_RENDERERS = RENDERERS[:5]
TF_POINTS = [[0.0, 0.1, 0.2, 0.8, 0.0], [0.35, 0.2, 0.7, 0.9, 0.4], [0.6, 1.0, 0.8, 0.2, 1.5],
             [1.0, 1.0, 0.2, 0.1, 0.6]]
#: ``--tf shell``: the shell's half-width in cell edges (scalar units: the field's slope is about 1)
SHELL_CELLS = 0.75


def shell_points(n_tets: float) -> list:
    """The shell TF of ``--tf shell`` for a mesh of about ``n_tets`` tets: zero except a hat around
    0.5 whose half-width is :data:`SHELL_CELLS` edges of the structured grid of that many tets."""
    w = SHELL_CELLS * 2.0 / max(1.0, (n_tets / 6.0) ** (1.0 / 3.0))
    return [[0.0, 1.0, 0.8, 0.2, 0.0], [0.5 - w, 1.0, 0.8, 0.2, 0.0], [0.5, 1.0, 0.8, 0.2, 6.0],
            [0.5 + w, 1.0, 0.8, 0.2, 0.0], [1.0, 1.0, 0.8, 0.2, 0.0]]


# -- meshes ----------------------------------------------------------------------------------------
def make_mesh(kind: str, n_tets: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(points, tets, scalars)`` of about ``n_tets`` tets filling [-1, 1]^3: ``structured`` (a grid of
    n^3 cubes, 6 tets each) or ``delaunay`` (uniform random points plus the cube's corners)."""
    from warpvol.scene.grids import grid_points, structured_to_tets

    if kind == "structured":
        n = max(1, int(round((n_tets / 6.0) ** (1.0 / 3.0))))
        xs = np.linspace(-1.0, 1.0, n + 1)
        pts = grid_points(xs, xs, xs)
        tets = structured_to_tets((n + 1, n + 1, n + 1))
    elif kind == "delaunay":
        import pyvista as pv

        rng = np.random.default_rng(seed)
        n_pts = max(8, int(n_tets / 6.3))
        corners = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
        pts = np.concatenate([corners, rng.uniform(-1.0, 1.0, (n_pts, 3))])
        grid = pv.PolyData(pts).delaunay_3d()  # VTK's vtkDelaunay3D; point order kept
        pts = np.asarray(grid.points, dtype=np.float64)
        tets = np.asarray(grid.cells_dict[pv.CellType.TETRA])
    else:
        raise ValueError(f"kind: {kind!r}; allowed: structured, delaunay")
    x, y, z = pts.T
    s = 0.5 + 0.25 * np.sin(2.5 * x + 0.5) * np.cos(2.0 * y) + 0.25 * np.cos(3.0 * z - 0.3 * x)
    return pts, np.ascontiguousarray(tets, dtype=np.int64), np.clip(s, 0.0, 1.0)


def mesh_file(cache: Path, kind: str, n_tets: float) -> Path:
    """The mesh's ``.npz`` in ``cache`` (built on first use)."""
    path = cache / f"{kind}_{int(n_tets)}.npz"
    if not path.exists():
        cache.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        pts, tets, s = make_mesh(kind, n_tets)
        np.savez(path, points=pts, tets=tets, scalars=s)
        print(f"  built {kind} mesh, {len(tets):,} tets, in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return path


# -- one point, in a child process -----------------------------------------------------------------
def rss_bytes() -> int:
    """This process's resident set now."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    return 0


def child(spec: dict) -> dict:
    """Render one point (``spec``: renderer, mesh file, size, repeat) and measure it."""
    import resource
    import statistics
    import warnings

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from warpvol.pipeline import quiet_warp

    quiet_warp()
    from warpvol.scene.camera import Camera
    from warpvol.scene.mesh import TetMesh
    from warpvol.scene.scene import Scene
    from warpvol.scene.transfer import TransferFunction

    def scene_of(points, tets, scalars, name, size, tf_points=TF_POINTS):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # Delaunay slivers dropped as zero-volume tets
            mesh = TetMesh(points, tets, scalars, name=name)
        cam = Camera.fit(mesh, width_px=size, height_px=size)
        return Scene(mesh=mesh, transfer=TransferFunction(np.array(tf_points)), camera=cam, name=name)

    def renderer(name, scene):
        if name == "vtk_pt":
            from bench_raycast import vtk_renderer

            return vtk_renderer(scene, "projected_tetrahedra")[0]
        if name == "reference":
            from warpvol.reference.numpy_render import render_reference

            return lambda: render_reference(scene.mesh, scene.transfer, scene.camera)
        from warpvol.pipeline import Pipeline

        pipe = Pipeline.load(name)
        return lambda: pipe.render(scene, quiet=True)

    name = spec["renderer"]
    # kernels compiled and loaded, libraries imported, on a 48-tet mesh: not counted in the memory
    renderer(name, scene_of(*make_mesh("structured", 48), "tiny", 16))()
    data = np.load(spec["mesh"])
    tf_points = shell_points(len(data["tets"])) if spec.get("tf") == "shell" else TF_POINTS
    scene = scene_of(data["points"], data["tets"], data["scalars"], Path(spec["mesh"]).stem, int(spec["size"]),
                     tf_points)
    mesh, size = scene.mesh, int(spec["size"])
    base = rss_bytes()
    render = renderer(name, scene)
    warm = render  # the first render builds the per-mesh data (the reference keeps none)
    t0 = time.perf_counter()
    warm()
    first = time.perf_counter() - t0
    times = []
    for _ in range(max(1, int(spec["repeat"]))):
        t0 = time.perf_counter()
        render()
        times.append(time.perf_counter() - t0)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    kept = rss_bytes() - base  # what stays resident between frames (per-mesh data, buffers)
    return {"renderer": name, "mesh": mesh.name, "tets": int(mesh.n_tets), "points": int(mesh.n_points),
            "size": size, "pixels": size * size, "time_s": statistics.median(times), "times_s": times,
            "first_s": first, "peak_bytes": max(0, peak - base), "bytes_per_tet": max(0, peak - base) / mesh.n_tets,
            "kept_bytes": max(0, kept), "kept_bytes_per_tet": max(0, kept) / mesh.n_tets,
            "load": list(os.getloadavg()), "visible_fraction": visible_fraction(scene)}


def visible_fraction(scene) -> float:
    """The fraction of the cells the scene's transfer function can make visible."""
    from warpvol.conditioning.visibility import cell_visibility

    return float(cell_visibility(scene.mesh, scene.transfer).mean())


def run_point(spec: dict, timeout: float) -> dict:
    """:func:`child` in a fresh interpreter (its own peak memory); ``{"error": ...}`` when it fails."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", json.dumps(spec)]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=str(ROOT))
    except subprocess.TimeoutExpired:
        return {**spec, "error": f"over the {timeout:.0f} s timeout"}
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
    if p.returncode != 0 or not lines:
        return {**spec, "error": (p.stderr.strip().splitlines() or ["no output"])[-1][:300]}
    return json.loads(lines[-1])


# -- fits, tables, plot ----------------------------------------------------------------------------
def point_key(p: dict) -> tuple:
    """What identifies a measured point: sweep, mesh (file stem), pixels, renderer."""
    return p.get("sweep"), Path(p["mesh"]).stem, int(p.get("pixels", p["size"] ** 2)), p["renderer"]


def points_of_table(table: dict) -> list[dict]:
    """The point dicts of a written ``points`` table (the inverse of the table rows ``main`` writes)."""
    out = []
    for row in table["rows"]:
        r = dict(zip(table["columns"], row))
        p = {"sweep": r["sweep"], "mesh": r["mesh"], "kind": str(r["mesh"]).split("_")[0], "tets": r["tets"],
             "pixels": r["pixels"], "size": int(round(float(r["pixels"]) ** 0.5)), "renderer": r["renderer"]}
        if r["time [s]"] is None:
            p["error"] = "failed or timed out (earlier run)"
        else:
            p.update(time_s=r["time [s]"], first_s=r["first [s]"], peak_bytes=r["peak [MiB]"] * 2**20,
                     bytes_per_tet=r["peak bytes/tet"], load=[r["load (1 min)"]])
            if r.get("kept bytes/tet") is not None:
                p["kept_bytes_per_tet"] = r["kept bytes/tet"]
        if r.get("run"):
            p["run"] = r["run"]
        out.append(p)
    return out


def slope(x, y) -> float | None:
    """Least-squares slope of log y against log x (None with fewer than two points)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0)
    if ok.sum() < 2:
        return None
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def fits(points: list[dict], renderers, image_mesh: str) -> list[dict]:
    rows = []
    for r in renderers:
        row = {"renderer": r}
        for kind in ("structured", "delaunay"):
            pts = [p for p in points if p.get("sweep") == "mesh" and p["renderer"] == r and p["kind"] == kind
                   and "error" not in p]
            row[f"time ~ tets^a ({kind})"] = slope([p["tets"] for p in pts], [p["time_s"] for p in pts])
            top = sorted(pts, key=lambda p: p["tets"])[-2:]  # small meshes: a fixed ~0.1 GB dominates
            row[f"memory ~ tets^c ({kind})"] = slope([p["tets"] for p in top], [p["peak_bytes"] for p in top])
            big = max(pts, key=lambda p: p["tets"], default=None)
            row[f"largest mesh ({kind})"] = big["tets"] if big else None
            row[f"peak bytes/tet there ({kind})"] = round(big["bytes_per_tet"], 1) if big else None
            row[f"kept bytes/tet there ({kind})"] = round(big["kept_bytes_per_tet"], 1) \
                if big and "kept_bytes_per_tet" in big else None
        pts = [p for p in points if p.get("sweep") == "image" and p["renderer"] == r and "error" not in p]
        row["time ~ pixels^b"] = slope([p["pixels"] for p in pts], [p["time_s"] for p in pts])
        rows.append(row)
    return rows


#: the plot's design width in inches at 100 dpi (the documentation shows it at 900 px) and its text size
PLOT_WIDTH_IN = 9.0
PLOT_FONT = 10


def plot(points: list[dict], renderers, path: Path) -> None:
    """The three cost laws one under the other (time against tets, time against pixels, peak memory
    against tets), each log-log with its legend beside it; drawn for :data:`PLOT_WIDTH_IN` inches at
    100 dpi with :data:`PLOT_FONT`-point text, saved at twice that resolution."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(PLOT_WIDTH_IN, 11.5), dpi=100, layout="constrained")
    colours = dict(zip(RENDERERS, ("C0", "C1", "C2", "C3", "C4", "C5")))
    for r in renderers:
        for kind, ls in (("structured", "-"), ("delaunay", "--")):
            pts = sorted((p for p in points if p.get("sweep") == "mesh" and p["renderer"] == r and p["kind"] == kind
                          and "error" not in p), key=lambda p: p["tets"])
            if pts:
                x = [p["tets"] for p in pts]
                axes[0].loglog(x, [p["time_s"] for p in pts], ls, marker="o", color=colours[r], label=f"{r} ({kind})")
                axes[2].loglog(x, [max(p["peak_bytes"], 1) / 2**20 for p in pts], ls, marker="o", color=colours[r],
                               label=f"{r} ({kind})")
        pts = sorted((p for p in points if p.get("sweep") == "image" and p["renderer"] == r and "error" not in p),
                     key=lambda p: p["pixels"])
        if pts:
            axes[1].loglog([p["pixels"] for p in pts], [p["time_s"] for p in pts], "-", marker="o", color=colours[r],
                           label=r)
    axes[0].set_title("time against mesh size (solid: structured grid, dashed: Delaunay)", fontsize=PLOT_FONT + 1)
    axes[0].set_xlabel("tets", fontsize=PLOT_FONT)
    axes[0].set_ylabel("time per frame [s]", fontsize=PLOT_FONT)
    axes[1].set_title("time against image size", fontsize=PLOT_FONT + 1)
    axes[1].set_xlabel("pixels", fontsize=PLOT_FONT)
    axes[1].set_ylabel("time per frame [s]", fontsize=PLOT_FONT)
    axes[2].set_title("peak memory against mesh size", fontsize=PLOT_FONT + 1)
    axes[2].set_xlabel("tets", fontsize=PLOT_FONT)
    axes[2].set_ylabel("peak memory [MiB]", fontsize=PLOT_FONT)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
        ax.tick_params(labelsize=PLOT_FONT - 1)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=PLOT_FONT - 1, loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=200)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--tets", nargs="+", type=float, default=[1e4, 1e5, 1e6])
    ap.add_argument("--kinds", default="structured,delaunay")
    ap.add_argument("--mesh-size-px", type=int, default=256)
    ap.add_argument("--sizes", nargs="+", type=int, default=[128, 256, 512, 1024])
    ap.add_argument("--image-tets", type=float, default=1e5)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--renderers", default=",".join(DEFAULT_RENDERERS))
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds per point (child process)")
    ap.add_argument("--cache", default=str(ROOT / "out" / "bench_scaling"))
    ap.add_argument("--no-docs", action="store_true", help="do not write docs/data/scaling.json, docs/img/scaling.png")
    ap.add_argument("--tf", default="dense", choices=("dense", "shell"),
                    help="shell: the mesh sweep with a one-shell TF whose visible fraction shrinks as the mesh grows "
                         "(writes docs/data/scaling_shell.json)")
    ap.add_argument("--replot", action="store_true", help="redraw docs/img/scaling.png from docs/data/scaling.json "
                    "(no measurement)")
    ap.add_argument("--merge", action="store_true",
                    help="keep the points of docs/data/scaling.json that this run does not measure again (a run of "
                         "extra points, e.g. --sizes 2048 or --tets 1e7, adds them to the tables, fits and plot)")
    args = ap.parse_args(argv)
    if args.replot:  # the plot again from the points docs/data/scaling.json holds, nothing measured
        pts = points_of_table(json.loads((ROOT / "docs" / "data" / "scaling.json").read_text())["tables"]["points"])
        plot(pts, [r for r in RENDERERS if any(p["renderer"] == r for p in pts)], ROOT / "docs" / "img" / "scaling.png")
        return 0
    if args.child:
        print(json.dumps(child(json.loads(args.child))))
        return 0

    prov = provenance.start(provenance.command_line("scripts/bench_scaling.py", argv), timing=True)
    renderers = [r for r in args.renderers.split(",") if r]
    bad = [r for r in renderers if r not in RENDERERS]
    if bad:
        raise SystemExit(f"--renderers: unknown {bad}; allowed: {', '.join(RENDERERS)}")
    cache = Path(args.cache)
    specs = []
    for kind in [k for k in args.kinds.split(",") if k]:  # --kinds "": no mesh sweep
        for n in args.tets:
            specs += [{"sweep": "mesh", "kind": kind, "mesh": str(mesh_file(cache, kind, n)), "size": args.mesh_size_px,
                       "renderer": r, "repeat": args.repeat} for r in renderers]
    if args.tf == "shell":
        for s in specs:
            s["tf"] = "shell"
        return shell_sweep(specs, args, argv, prov)
    img_mesh = str(mesh_file(cache, "structured", args.image_tets))
    for size in args.sizes:
        specs += [{"sweep": "image", "kind": "structured", "mesh": img_mesh, "size": size, "renderer": r,
                   "repeat": args.repeat} for r in renderers]
    t_start = time.perf_counter()
    sources = ["python scripts/bench_scaling.py " + " ".join(argv if argv is not None else sys.argv[1:])]
    points = []
    print(f"{'sweep':<6}{'mesh':<20}{'tets':>10}{'size':>6}  {'renderer':<10}{'time [s]':>10}{'first [s]':>10}"
          f"{'peak [MiB]':>11}{'B/tet':>8}{'kept':>8}  load")
    for spec in specs:
        res = run_point({k: spec[k] for k in ("renderer", "mesh", "size", "repeat")}, args.timeout)
        res.update(sweep=spec["sweep"], kind=spec["kind"], run=sources[-1])
        points.append(res)
        mesh = Path(spec["mesh"]).stem
        if "error" in res:
            print(f"{spec['sweep']:<6}{mesh:<20}{'':>10}{spec['size']:>6}  {spec['renderer']:<10} failed: {res['error']}")
        else:
            print(f"{res['sweep']:<6}{mesh:<20}{res['tets']:>10,}{res['size']:>6}  {res['renderer']:<10}"
                  f"{res['time_s']:>10.3f}{res['first_s']:>10.3f}{res['peak_bytes'] / 2**20:>11.1f}"
                  f"{res['bytes_per_tet']:>8.0f}{res.get('kept_bytes_per_tet', float('nan')):>8.0f}  {res['load'][0]:.2f}",
                  flush=True)
    data = ROOT / "docs" / "data" / "scaling.json"
    prov = provenance.with_loads(prov, [p["load"][0] for p in points if "error" not in p])
    if args.merge and data.exists():
        old = json.loads(data.read_text())
        kept = [p for p in points_of_table(old["tables"]["points"]) if point_key(p) not in {point_key(q) for q in points}]
        print(f"kept {len(kept)} points of {data.name} not measured again")
        points = kept + points
        renderers = [r for r in RENDERERS if any(p["renderer"] == r for p in points)]
        # the runs whose points the tables hold (points of files written before points named their run:
        # that file's runs)
        runs = [p.get("run") for p in points]
        earlier = old.get("sources", [old.get("source", "")]) if None in runs else []
        sources = list(dict.fromkeys(earlier + [r for r in runs if r]))
        if len(sources) > 1:
            prov["note"] = ("This run merged its points with those of earlier runs (each point names its run and "
                            "its load in the points table); commit, date and load here are this run's.")
    fit_rows = fits(points, renderers, img_mesh)
    print("\nfitted exponents (least squares in log-log)")
    for row in fit_rows:
        print("  " + ", ".join(f"{k}: {v:.2f}" if isinstance(v, float) else f"{k}: {v}" for k, v in row.items()))
    total = time.perf_counter() - t_start
    print(f"total {total:.0f} s; load average now {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if args.no_docs:
        return 0
    cols = ["sweep", "mesh", "tets", "pixels", "renderer", "time [s]", "first [s]", "peak [MiB]", "peak bytes/tet",
            "kept bytes/tet", "load (1 min)", "run"]
    rows = [[p["sweep"], Path(p["mesh"]).stem, p.get("tets"), p.get("pixels", p["size"] ** 2), p["renderer"],
             None if "error" in p else round(p["time_s"], 4),
             None if "error" in p else round(p["first_s"], 3),
             None if "error" in p else round(p["peak_bytes"] / 2**20, 1),
             None if "error" in p else round(p["bytes_per_tet"], 1),
             None if "error" in p else round(p.get("kept_bytes_per_tet", float("nan")), 1),
             None if "error" in p else round(p["load"][0], 2), p.get("run", "")] for p in points]
    fit_cols = list(fit_rows[0].keys()) if fit_rows else []
    doc = {"source": " + ".join(sources), "sources": sources,
           "tables": {
               "exponents": {"title": "Fitted exponents and bytes per tet",
                             "columns": fit_cols,
                             "rows": [[None if v is None else (round(v, 2) if isinstance(v, float) else v)
                                       for v in r.values()] for r in fit_rows],
                             "notes": (f"time ~ tets^a at {args.mesh_size_px}^2 over all mesh sizes, time ~ pixels^b "
                                       f"on the structured {args.image_tets:.0e}-tet mesh, memory ~ tets^c from the two "
                                       "largest meshes (below ~1e5 tets a fixed ~0.1 GB of thread pools, allocator "
                                       "arenas and image buffers dominates); peak bytes/tet = peak resident memory the "
                                       "renderer adds (first render: per-mesh data built, with its temporaries) over "
                                       "the tets, kept bytes/tet = what stays resident between frames, at the largest "
                                       "mesh. "
                                       f"Runs on {os.cpu_count()} cores, shared machine (load in the points table): "
                                       + "; ".join(sources) + ".")},
               "points": {"title": "Every point (median of the warm renders)", "columns": cols, "rows": rows,
                          "notes": "Failed or timed-out points show '-'; run: the command that measured the point."}}}
    provenance.write_json(data, doc, prov)
    plot(points, renderers, ROOT / "docs" / "img" / "scaling.png")
    print(f"wrote {data} and {ROOT / 'docs' / 'img' / 'scaling.png'}")
    return 0


def shell_sweep(specs: list[dict], args, argv, prov: dict) -> int:
    """``--tf shell``: the mesh sweep with the shell TF; time ~ tets^a and visible ~ tets^v per renderer
    and mesh kind, written to ``docs/data/scaling_shell.json`` unless ``--no-docs``."""
    source = "python scripts/bench_scaling.py " + " ".join(argv if argv is not None else sys.argv[1:])
    points = []
    print(f"{'mesh':<22}{'tets':>10}{'visible':>9}  {'renderer':<14}{'time [s]':>10}{'first [s]':>10}  load")
    for spec in specs:
        res = run_point({k: spec[k] for k in ("renderer", "mesh", "size", "repeat", "tf")}, args.timeout)
        res.update(kind=spec["kind"])
        points.append(res)
        mesh = Path(spec["mesh"]).stem
        if "error" in res:
            print(f"{mesh:<22}{'':>19}  {spec['renderer']:<14} failed: {res['error']}")
            continue
        print(f"{mesh:<22}{res['tets']:>10,}{100 * res['visible_fraction']:>8.2f}%  {res['renderer']:<14}"
              f"{res['time_s']:>10.3f}{res['first_s']:>10.3f}  {res['load'][0]:.2f}", flush=True)
    ok = [p for p in points if "error" not in p]
    fit_rows = []
    for r in dict.fromkeys(p["renderer"] for p in ok):
        for kind in dict.fromkeys(p["kind"] for p in ok):
            pts = [p for p in ok if p["renderer"] == r and p["kind"] == kind]
            a = slope([p["tets"] for p in pts], [p["time_s"] for p in pts])
            v = slope([p["tets"] for p in pts], [p["visible_fraction"] * p["tets"] for p in pts])
            fit_rows.append([r, kind, None if a is None else round(a, 2), None if v is None else round(v, 2)])
            print(f"  {r} ({kind}): time ~ tets^{a:.2f}, visible cells ~ tets^{v:.2f}" if a is not None else
                  f"  {r} ({kind}): too few points")
    if args.no_docs:
        return 0
    doc = {"source": source, "sources": [source], "tables": {
        "exponents": {"title": "Cost law with a one-shell transfer function (visible fraction shrinking as the mesh grows)",
                      "columns": ["renderer", "mesh", "time ~ tets^a", "visible cells ~ tets^v"], "rows": fit_rows,
                      "notes": f"least-squares slopes in log-log over the mesh sweep at {args.mesh_size_px}^2; "
                               f"shell half-width {SHELL_CELLS} cell edges; {os.cpu_count()} cores, shared machine "
                               f"(load in the points table): {source}."},
        "points": {"title": "Every point (median of the warm renders)",
                   "columns": ["mesh", "tets", "visible cells [%]", "renderer", "time [s]", "first [s]", "load (1 min)"],
                   "rows": [[Path(p["mesh"]).stem, p.get("tets"),
                             None if "error" in p else round(100 * p["visible_fraction"], 2), p["renderer"],
                             None if "error" in p else round(p["time_s"], 4),
                             None if "error" in p else round(p["first_s"], 3),
                             None if "error" in p else round(p["load"][0], 2)] for p in points],
                   "notes": "Failed or timed-out points show '-'."}}}
    data = ROOT / "docs" / "data" / "scaling_shell.json"
    provenance.write_json(data, doc, provenance.with_loads(prov, [p["load"][0] for p in ok]))
    print(f"wrote {data}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
