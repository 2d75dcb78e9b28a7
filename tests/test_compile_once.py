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

scene = warpvol.builtin_scene("sphere").with_camera(width_px=32, height_px=32)
warpvol.render(scene, pipeline=sys.argv[2], reference=False)
print(json.dumps(compiles))
"""


def test_threaded_launches_compile_each_module_once(tmp_path):
    from warp._src import context as ctx

    if not hasattr(ctx.Module, "_compile"):
        pytest.skip("this Warp has no Module._compile to count compilations with")
    if cpu_threads() < 2:
        pytest.skip("one core: launch_blocks launches in order on the calling thread, nothing runs concurrently")
    script = tmp_path / "count_compiles.py"
    script.write_text(COUNT_SCRIPT)
    p = subprocess.run([sys.executable, str(script), str(tmp_path / "kernel-cache"), "westermann1997"],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    compiles = json.loads(p.stdout.strip().splitlines()[-1])
    # the modules the host threads launch were compiled in this process (a fresh cache) ...
    for m in ("warpvol.kernels.raster", "warpvol.kernels.raster_draw", "warpvol.kernels.vsbuffer"):
        assert m in compiles, compiles
    # ... and each exactly once
    assert {m: n for m, n in compiles.items() if n != 1} == {}, compiles
