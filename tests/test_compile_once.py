"""On a fresh Warp kernel cache every module compiles once, also where its first launches come from host
threads (:func:`warpvol.parallel.launch_blocks` loads the modules it is given on the calling thread
before any block starts; two threads launching an unloaded module would each compile it).

The render runs in a subprocess with its own temporary kernel cache, so the session's Warp and its cache
are untouched. ``westermann1997`` is the smallest preset whose modules are first launched from host
threads: its two ID passes per plane batch are rasteriser draws on two host threads, and the column walk
runs in plane blocks."""

import json
import subprocess
import sys

import pytest

from warpvol.parallel import cpu_threads

COUNT_SCRIPT = """
import collections, json, sys, threading
import warp as wp
wp.config.kernel_cache_dir = sys.argv[1]  # a fresh cache: every module compiles
wp.config.quiet = True
from warp._src import context as ctx

orig = ctx.Module._compile
compiles = collections.Counter()
lock = threading.Lock()

def counted(self, *args, **kwargs):
    compiled = orig(self, *args, **kwargs)
    if compiled:
        with lock:
            compiles[self.name] += 1
    return compiled

ctx.Module._compile = counted
wp.init()
import warpvol

if sys.argv[2] == "unnamed":  # launch_blocks given no modules: the loader lets one thread compile
    from warpvol.kernels import vertex
    from warpvol.parallel import launch_blocks

    pts = wp.zeros(64, dtype=wp.vec3, device="cpu")
    outs = [wp.zeros(64, dtype=wp.vec4, device="cpu") for _ in range(3)]
    m = wp.mat44(*[float(i % 5 == 0) for i in range(16)])
    launch_blocks("cpu", 8, lambda b: wp.launch(vertex.k_transform, dim=64, inputs=[pts, m, m, m, *outs],
                                                device="cpu"), threads=4)
else:
    scene = warpvol.builtin_scene("sphere").with_camera(width_px=32, height_px=32)
    warpvol.render(scene, pipeline=sys.argv[2], reference=False)
print(json.dumps(compiles))
"""


def count_compiles(tmp_path, what: str) -> dict[str, int]:
    """Compilations per module of ``what`` (a preset, or ``unnamed``) on a fresh kernel cache."""
    from warp._src import context as ctx

    if not hasattr(ctx.Module, "_compile"):
        pytest.skip("this Warp has no Module._compile to count compilations with")
    if cpu_threads() < 2:
        pytest.skip("one core: launch_blocks launches in order on the calling thread, nothing runs concurrently")
    script = tmp_path / "count_compiles.py"
    script.write_text(COUNT_SCRIPT)
    p = subprocess.run([sys.executable, str(script), str(tmp_path / "kernel-cache"), what],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_threaded_launches_compile_each_module_once(tmp_path):
    compiles = count_compiles(tmp_path, "westermann1997")
    # the modules the host threads launch were compiled in this process (a fresh cache) ...
    for m in ("warpvol.kernels.raster", "warpvol.kernels.raster_draw", "warpvol.kernels.vsbuffer"):
        assert m in compiles, compiles
    # ... and each exactly once
    assert {m: n for m, n in compiles.items() if n != 1} == {}, compiles


def test_unnamed_module_compiles_once(tmp_path):
    """Four host threads launch a module nobody loaded first (``launch_blocks`` without ``modules``):
    one compiles it, the others wait and load the result."""
    assert count_compiles(tmp_path, "unnamed") == {"warpvol.kernels.vertex": 1}
