"""Ctrl-C and terminal hygiene: queued blocks cancelled, one line, exit 130, no traceback; no CUDA
warning on the terminal unless CUDA was asked for."""

import signal
import subprocess
import sys
import threading
import time

import pytest

from helpers import python_sigint, restore_sigint
from warpvol.parallel import launch_blocks


def test_ctrl_c_cancels_the_queued_blocks():
    started = []
    main = threading.main_thread().ident

    def launch(b):
        started.append(b)
        if b == 4:  # all 200 are queued by now (submitting takes well under one block's 10 ms)
            signal.pthread_kill(main, signal.SIGINT)  # Ctrl-C while the main thread waits on the pool
        time.sleep(0.01)

    with python_sigint(), pytest.raises(KeyboardInterrupt):
        launch_blocks("cpu", 200, launch, threads=2)
    n = len(started)
    time.sleep(0.05)
    assert len(started) == n  # nothing starts after launch_blocks has returned
    assert n < 100  # the queued blocks were dropped (without cancelling, all 200 run)


def _cli(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "warpvol.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=restore_sigint, **kw)


def test_ctrl_c_during_a_render_prints_one_line_and_exits_130(tmp_path):
    out = tmp_path / "o.exr"
    p = _cli("render", "builtin:sphere", "--pipeline", "raycast", "-o", str(out), "--width", "2000",
             "--height", "2000", "--png", str(tmp_path / "p.png"), "--report", str(tmp_path / "r.json"))
    seen = []
    for line in p.stderr:  # progress lines up to the start of the ray casting stage
        seen.append(line)
        if line.startswith("[warpvol] raycast ..."):
            break
    assert seen and seen[-1].startswith("[warpvol] raycast ..."), seen
    p.send_signal(signal.SIGINT)
    stdout, rest = p.communicate(timeout=120)
    assert p.returncode == 130, (stdout, rest)
    assert rest == "warpvol: interrupted\n"  # one line, no traceback
    assert stdout == "" and list(tmp_path.iterdir()) == []


def test_no_cuda_driver_warning_unless_cuda_is_asked_for(tmp_path):
    import warp as wp

    p = _cli("render", "builtin:box", "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"), "--width", "8",
             "--height", "8", "--quiet")
    stdout, err = p.communicate(timeout=120)
    assert p.returncode == 0 and err == "" and stdout.startswith("raycast: ")
    if not wp.is_cuda_available():
        p = _cli("render", "builtin:box", "--pipeline", "raycast", "-o", str(tmp_path / "o.exr"),
                 "--device", "cuda:0", "--quiet")
        _, err = p.communicate(timeout=120)
        assert p.returncode == 2 and "device 'cuda:0' is not available here" in err
