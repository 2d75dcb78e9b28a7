"""Small mesh builders shared by tests (no files, no randomness unless seeded)."""

import hashlib
from types import SimpleNamespace

import numpy as np
import warp as wp

from warpvol.scene.grids import grid_points, structured_to_tets
from warpvol.scene.mesh import TetMesh

# every test that launches kernels runs on each of these (CI has no GPU: CPU only there)
DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


def box_points(lo, hi, dims):
    """Points of a regular grid over the box [lo, hi] with ``dims`` points per axis."""
    return grid_points(*(np.linspace(lo[k], hi[k], dims[k]) for k in range(3)))


def box_mesh(lo=(-1, -1, -1), hi=(1, 1, 1), dims=(4, 4, 4), scalar=None, name="box"):
    pts = box_points(lo, hi, dims)
    s = np.ones(len(pts)) if scalar is None else scalar(pts)
    return TetMesh(pts, structured_to_tets(dims), s, name=name)


def merge(*meshes, name="merged"):
    pts, tets, sc, off = [], [], [], 0
    for m in meshes:
        pts.append(m.points)
        tets.append(m.tets + off)
        sc.append(m.scalars)
        off += m.n_points
    return TetMesh(np.vstack(pts), np.vstack(tets), np.concatenate(sc), name=name)


def scene(mesh, tf, camera, name="test"):
    return SimpleNamespace(mesh=mesh, transfer=tf, camera=camera, name=name)


def noisy_shell(seed: int, size: int = 96, **camera):
    """Long thin cells (4 x 24 x 24 points over [-1, 1]^3), a noisy field and a TF showing one shell of it,
    seen from a random direction (perspective, 40 degrees, ``size`` pixels square; ``camera`` overrides):
    rays leave and re-enter the visible cells many times, the visible boundary has slivers."""
    from warpvol.scene.camera import Camera
    from warpvol.scene.transfer import TransferFunction

    rng = np.random.default_rng(seed)
    dims = (4, 24, 24)
    pts = box_points((-1, -1, -1), (1, 1, 1), dims)
    s = np.sin(3 * pts[:, 0]) * np.cos(2 * pts[:, 1]) + 0.5 * pts[:, 2] + 0.3 * rng.standard_normal(len(pts))
    m = TetMesh(pts, structured_to_tets(dims), s)
    tf = TransferFunction([[-3, 0, 0, 0, 0], [0.2, 0, 0, 0, 0], [0.3, 1, 0.7, 0.3, 4.0], [0.4, 0, 0, 0, 0],
                           [3, 0, 0, 0, 0]])
    eye = rng.normal(size=3)
    args = dict(eye=list(3.5 * eye / np.linalg.norm(eye)), target=[0, 0, 0], fov_y_deg=40, width_px=size,
                height_px=size)
    args.update(camera)
    return scene(m, tf, Camera(**args))


def restore_sigint() -> None:
    """``preexec_fn`` of a child process that must see Ctrl-C: a suite started in the background of a
    non-interactive shell inherits SIGINT ignored, and Python then installs no KeyboardInterrupt
    handler; the default disposition brings it back."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


class python_sigint:
    """Context manager: Python's KeyboardInterrupt handler for SIGINT in this process (see
    :func:`restore_sigint`), the previous handler restored after."""

    def __enter__(self):
        import signal

        self.old = signal.signal(signal.SIGINT, signal.default_int_handler)
        return self

    def __exit__(self, *exc):
        import signal

        signal.signal(signal.SIGINT, self.old)
        return False


def pin_of(image, report: dict, sums: bool = False) -> dict:
    """A render's pin: the SHA-256 of its float image (shape and dtype included) and every integer counter
    of its report (``stage.name``); with ``sums`` also the image's per-channel sums (what a changed pin
    moved, at a glance)."""
    img = np.ascontiguousarray(image)
    h = hashlib.sha256(f"{img.shape}{img.dtype.str}".encode())
    h.update(img.tobytes())
    counters = {f"{stage}.{k}": int(v) for stage, cc in sorted(report["counters"].items())
                for k, v in sorted(cc.items()) if isinstance(v, (int, np.integer)) and not isinstance(v, bool)}
    pin = {"sha256": h.hexdigest()}
    if sums:
        pin["sums"] = [float(x) for x in img.astype(np.float64).sum(axis=(0, 1))]
    pin["counters"] = counters
    return pin
