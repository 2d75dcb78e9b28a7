"""warpvol.parallel.launch_blocks keeps its host threads between calls, and blocks that launch blocks
themselves never wait on the pool they run in."""

import threading
import time

from warpvol.parallel import launch_blocks


def test_the_host_threads_are_kept_between_calls():
    names = []

    def launch(b):
        names.append(threading.current_thread().name)
        time.sleep(0.002)

    for _ in range(3):
        launch_blocks("cpu", 8, launch, threads=2)
    assert len(names) == 24 and len(set(names)) <= 2  # a pool per call: new threads (names) every call


def test_blocks_launching_blocks_finish():
    done = []

    def inner(b):
        time.sleep(0.001)

    def outer(b):
        launch_blocks("cpu", 4, inner, threads=2)  # from a pool thread: a pool of its own
        done.append(b)

    t = threading.Thread(target=lambda: launch_blocks("cpu", 6, outer, threads=2), daemon=True)
    t.start()
    t.join(timeout=30)
    assert not t.is_alive() and sorted(done) == list(range(6))
