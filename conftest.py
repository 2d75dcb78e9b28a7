"""Root pytest configuration: doctests in the package run with Warp's start-up and module-load
messages silenced (they go to stdout and would be read as doctest output); the suite's own options."""

from warpvol.pipeline import quiet_warp

quiet_warp()


def pytest_addoption(parser):
    parser.addoption("--ptx-archs", default=None, metavar="all|75,80,90",
                     help="tests/test_cuda.py: the architectures every kernel module is compiled for to PTX "
                          "(default: 75, whose PTX later GPUs JIT-compile; 'all': 75, 80 and 90)")
