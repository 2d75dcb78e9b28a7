"""The kernels on CUDA without a GPU: every module that defines Warp kernels compiles to PTX through NVRTC
(it ships with warp-lang, so no driver or GPU is needed); a kernel that uses a CPU-only construct turns
the check red, naming its module and kernel. With a CUDA device, every preset's pipeline is built on
``cuda:0`` and renders a small scene there within its tolerance row of the CPU image; without one that
test is skipped and says why.

By default each module is compiled once, for sm_75 (Turing; its PTX is JIT-compiled by the driver of
every later GPU); ``pytest --ptx-archs all`` (or a list such as
``--ptx-archs 75,90``) compiles for sm_75, sm_80 and sm_90, which a change to what the kernels call
(intrinsics, native snippets) should get. The PTX goes to a cache outside the repository
(``$WARPVOL_PTX_CACHE``, else ``~/.cache/warpvol/ptx``), keyed by each module's hash: a warm run only
re-compiles changed modules. Cold, about 40 s of CPU per architecture on a 2-core machine (the wall time
grows with the load: 48 / 95 / 115 s were seen with other jobs running), warm about a second each.
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
from pathlib import Path

import numpy as np
import pytest
import warp as wp

from tolerances import preset_tolerance

#: the architectures ``--ptx-archs all`` compiles for; the default run compiles for the first only
ARCHS = (75, 80, 90)


def ptx_archs(option: str | None) -> tuple[int, ...]:
    """The architectures of ``--ptx-archs``: ``None`` -> ``(75,)``, ``all`` -> :data:`ARCHS`, else a
    comma list of the numbers of :data:`ARCHS`.

    >>> ptx_archs(None), ptx_archs("all"), ptx_archs("90, 75")
    ((75,), (75, 80, 90), (90, 75))
    """
    if option is None:
        return ARCHS[:1]
    if option.strip() == "all":
        return ARCHS
    try:
        archs = tuple(int(a) for a in option.split(","))
    except ValueError:
        archs = ()
    if not archs or not set(archs) <= set(ARCHS):
        raise pytest.UsageError(f"--ptx-archs: expected 'all' or a comma list of {', '.join(map(str, ARCHS))}, "
                                f"got {option!r}")
    return archs


def pytest_generate_tests(metafunc):
    if "arch" in metafunc.fixturenames:
        metafunc.parametrize("arch", ptx_archs(metafunc.config.getoption("--ptx-archs")))


def ptx_cache() -> Path:
    d = os.environ.get("WARPVOL_PTX_CACHE") or Path.home() / ".cache" / "warpvol" / "ptx"
    Path(d).mkdir(parents=True, exist_ok=True)
    return Path(d)


@contextlib.contextmanager
def captured_fds():
    """What native code (NVRTC's log) writes to fds 1 and 2 while the block runs: ``out[0]`` after it."""
    out = [""]
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        saved = [os.dup(1), os.dup(2)]
        try:
            os.dup2(tmp.fileno(), 1)
            os.dup2(tmp.fileno(), 2)
            yield out
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            tmp.seek(0)
            out[0] = tmp.read().decode("utf-8", "replace")


def _errors(log: str, n: int = 3) -> str:
    lines = [ln.strip() for ln in log.splitlines() if re.search(r"\berror\b", ln)]
    return " | ".join(lines[:n]) or log.strip()[-400:]


def compile_ptx(module, arch: int, module_dir: Path) -> list[str]:
    """Compile the Warp ``module`` to PTX for ``sm_<arch>``; ``[]`` or one line per failing kernel
    (module, kernel, NVRTC's first errors). On a failure each kernel is compiled alone (a module of its
    own, same options) to name the ones that fail."""
    try:
        with captured_fds() as log:
            wp.compile_aot_module(module, arch=arch, module_dir=str(module_dir), use_ptx=True)
        return []
    except Exception as e:  # noqa: BLE001 - NVRTC's failure is a plain Exception
        first = f"{type(e).__name__}: {e}"
    failed = []
    for key, k in module.kernels.items():
        alone = wp.kernel(k.func, module="unique", module_options=dict(module.options), enable_backward=False)
        try:
            with captured_fds() as klog:
                wp.compile_aot_module(alone.module, arch=arch, module_dir=str(module_dir), use_ptx=True)
        except Exception:  # noqa: BLE001
            failed.append(f"{module.name}: kernel {key} does not compile for sm_{arch}: {_errors(klog[0])}")
    return failed or [f"{module.name}: does not compile for sm_{arch} ({first}): {_errors(log[0])}"]


@pytest.fixture(scope="module")
def kernel_modules():
    from warpvol.kernels import kernel_modules

    mods = kernel_modules()
    assert len(mods) >= 20 and all(m.kernels for m in mods)
    return mods


def test_every_kernel_compiles_to_ptx(kernel_modules, arch):
    failures = [f for m in kernel_modules for f in compile_ptx(m, arch, ptx_cache())]
    assert not failures, "\n".join(failures)


# ---- a deliberately broken kernel: valid on the CPU, not on CUDA --------------------------------

@wp.func_native(snippet="return _wp_isfinite((double)x) ? x : 0.0f;")  # the CPU runtime's helper
def cpu_only_isfinite(x: float) -> float: ...


@wp.kernel(enable_backward=False)
def k_cpu_only(a: wp.array(dtype=float)):
    i = wp.tid()
    a[i] = cpu_only_isfinite(a[i])


def test_a_cpu_only_construct_turns_the_check_red(tmp_path):
    a = wp.array(np.array([1.0, np.inf], np.float32), device="cpu")
    wp.launch(k_cpu_only, dim=2, inputs=[a], device="cpu")  # fine on the CPU ...
    assert a.numpy().tolist() == [1.0, 0.0]
    failures = compile_ptx(k_cpu_only.module, 75, tmp_path)  # ... not for the GPU
    assert len(failures) == 1, failures
    assert k_cpu_only.module.name in failures[0] and "kernel k_cpu_only" in failures[0]
    assert "_wp_isfinite" in failures[0]


# ---- every preset on cuda:0 -------------------------------------------------------------------

def _cuda() -> bool:
    try:
        return wp.is_cuda_available()
    except Exception:  # noqa: BLE001
        return False


@pytest.mark.skipif(not _cuda(), reason="no CUDA device here (Warp finds no driver or GPU): "
                                        "the presets' pipelines on cuda:0 are checked on a GPU machine only")
def test_every_preset_builds_and_renders_on_cuda():
    from warpvol.pipeline import Pipeline, list_presets
    from warpvol.scene.builtin import builtin_scene

    sc = builtin_scene("concave").with_camera(width_px=24, height_px=24)
    for name, _ in list_presets():
        p = Pipeline.load(name, device="cuda:0")
        assert all(st.device == "cuda:0" for st in p.stages), name
        gpu = p.render(sc, quiet=True)
        cpu = Pipeline.load(name, device="cpu").render(sc, quiet=True)
        assert gpu.report["device"] == "cuda:0"
        tol = preset_tolerance(name)
        assert np.abs(gpu.image - cpu.image).max() <= tol["max_abs"], name


# ---- bounds checks (Warp's debug mode: an out-of-bounds index aborts the process) ------------------

BOUNDS_SCRIPT = """
import sys
import warp as wp
wp.config.quiet = True
from warpvol.kernels import pt_draw, pt_span
wp.set_module_options({"mode": "debug"}, module=pt_draw)  # array indices checked in the fused draw
pt_span.span_kernel_cached(16).module.options["mode"] = "debug"  # and in its span form (the CPU's default)
from warpvol.pipeline import Pipeline
from warpvol.scene.builtin import builtin_scene
sc = builtin_scene("box").with_camera(width_px=12, height_px=12, projection=sys.argv[1])
r = Pipeline.load("pt_best").render(sc, quiet=True)
print("fragments", r.report["counters"]["pt_integrate"]["fragments"])
"""


def test_fused_pt_draw_reads_inside_its_arrays():
    """The fused draw reads the per-pixel ray factors only where the exact perspective thickness uses
    them: with an orthographic camera it gets a 1x1 array, and the bounds-checked kernels (one fragment at a
    time and in spans) run through."""
    import subprocess
    import sys

    p = subprocess.run([sys.executable, "-c", BOUNDS_SCRIPT, "orthographic"], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0 and "fragments" in p.stdout, (p.returncode, p.stdout[-500:], p.stderr[-1500:])
    assert int(p.stdout.split()[-1]) > 0


# ---- pt_best's fused draw: bins by device --------------------------------------------------------

def test_fused_pt_draw_bins_by_device_draw_the_same_image():
    """The fused draw runs one thread per bin: 64-px bins on the CPU, 8-px bins on CUDA (thousands of
    threads instead of 64 at 512^2). Bins own disjoint pixels and keep their triangles in submission
    order, so every bin size draws the same bits."""
    from warpvol.pipeline import Pipeline
    from warpvol.projection.pt import fused_tile
    from warpvol.scene.builtin import builtin_scene
    from warpvol.tools.sweep import pipeline_config

    assert (fused_tile("cpu"), fused_tile("cuda:0"), fused_tile("cuda:0", 16)) == (64, 8, 16)
    sc = builtin_scene("concave").with_camera(width_px=40, height_px=40)
    imgs = {t: Pipeline.from_config(pipeline_config("pt_best", (("pt_integrate.fused_tile", t),))).render(
        sc, quiet=True).image for t in (0, 4, 8, 64)}
    for t in (4, 8, 64):
        np.testing.assert_array_equal(imgs[t], imgs[0])
    assert imgs[0][..., 3].max() > 0.1


# ---- device syncs per frame ----------------------------------------------------------------------

def test_reads_back_to_the_host_are_counted_per_frame():
    """Every ``wp.array.numpy()`` of a render's stages is counted in ``report["device_reads"]`` (a sync
    on a GPU): per stage and in total, the same count for the same frame, and only the reads of arrays on
    the render's device."""
    import threading

    from warpvol.pipeline import Pipeline
    from warpvol.scene.builtin import builtin_scene
    from warpvol.timing import ReadCounter

    with ReadCounter("cpu") as reads:
        a = wp.zeros(4, dtype=float, device="cpu")
        a.numpy()
        th = threading.Thread(target=a.numpy)  # a host thread's read counts too
        th.start()
        th.join()
    assert reads.count == 2
    with ReadCounter("cuda:0") as none:
        a.numpy()
    assert none.count == 0
    sc = builtin_scene("concave").with_camera(width_px=16, height_px=16)
    p = Pipeline.load("raycast")
    r1, r2 = p.render(sc, quiet=True), p.render(sc, quiet=True)
    d = r1.report["device_reads"]
    assert d["total"] == sum(d["stages"].values()) > 0 and set(d["stages"]) <= set(r1.report["stages"])
    assert r2.report["device_reads"]["stages"]["raycast"] == d["stages"]["raycast"] > 0


def test_floating_point_contraction_is_off_where_presets_run(kernel_modules):
    """clang and NVRTC contract a*b+c into fused multiply-adds differently, so a module that allows it
    can round differently on each device: off in every kernel module but the float64 reference."""
    on = sorted(m.name for m in kernel_modules if m.options.get("fuse_fp", True))
    assert on == ["warpvol.kernels.reference"], on


# ---- device= everywhere ---------------------------------------------------------------------------

def test_every_launch_and_array_in_the_host_code_names_its_device():
    """Host code (``warpvol/``, and ``kernels/`` outside kernel signatures) passes ``device=`` to every
    ``wp.launch`` and array constructor, so nothing lands on Warp's default device (``cuda:0`` when a GPU
    is present) behind a render on another. ``wp.copy`` and ``wp.clone`` follow their arrays' devices."""
    import ast

    root = Path(__file__).resolve().parents[1]
    names = {"launch", "array", "zeros", "empty", "full", "ones", "zeros_like", "empty_like", "full_like",
             "ones_like", "from_numpy", "array2d", "array3d"}
    missing, checked = [], 0
    for p in sorted(root.glob("warpvol/**/*.py")) + sorted(root.glob("kernels/*.py")):
        tree = ast.parse(p.read_text())
        annotations = {id(n) for a in ast.walk(tree) for ann in (getattr(a, "annotation", None), getattr(a, "returns", None))
                       if ann is not None for n in ast.walk(ann)}
        for n in ast.walk(tree):
            if (isinstance(n, ast.Call) and id(n) not in annotations and isinstance(n.func, ast.Attribute)
                    and isinstance(n.func.value, ast.Name) and n.func.value.id == "wp" and n.func.attr in names):
                checked += 1
                if not {k.arg for k in n.keywords} & {"device", None}:
                    missing.append(f"{p.relative_to(root)}:{n.lineno}: wp.{n.func.attr}(...) without device=")
    assert checked > 100 and not missing, "\n".join(missing)
