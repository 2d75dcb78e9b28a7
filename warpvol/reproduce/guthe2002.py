"""Guthe et al. 2002, pre-integration tables in hardware (transfer function and the model of its Table 4);
the command line is ``scripts/reproduce_guthe2002.py``."""

from __future__ import annotations

import numpy as np

from warpvol.reproduce.common import counted


def guthe_tf(m=128):
    """m entries, colour times extinction, with steep gradients (what the polynomial is for)."""
    from warpvol.scene.transfer import TransferFunction

    x = np.linspace(0, 1, m)
    r = 0.5 + 0.5 * np.sin(9 * x)
    g = np.clip(np.exp(-((x - 0.55) / 0.05) ** 2) + 0.2, 0, 1)
    b = np.clip(1 - x, 0, 1)
    rho = 0.5 + 6.0 * np.exp(-((x - 0.55) / 0.04) ** 2) + 2.0 * (x > 0.8)
    return TransferFunction.from_table(np.column_stack([r, g, b, rho]), (0.0, 1.0), "color_extinction")


GUTHE_T4 = {1: (4.4, 0.6), 2: (6.6, 1.0), 4: (11.0, 1.7)}


def guthe_t4_model(degree: int, device: str = "cpu", gpu: str = "radeon8500") -> float:
    """Modelled Table 4 hardware row (512^2, m = 128, ping-pong slices + host coefficient fit)."""
    from warpvol.model import load_profile, model_counters
    from warpvol.tables.guthe2d import build_guthe2d

    c = counted(build_guthe2d, guthe_tf(), n_s=512, degree=degree, lmax=1.0, slices="pingpong", m=128,
                emulate=False, device=device)
    return model_counters(c, load_profile(gpu))["s"]



def guthe_steps_per_pass_speedup(device: str = "cpu") -> float:
    """Radeon 8500: modelled GPU time of 1 over 4 integration steps per pass (one channel slice)."""
    from warpvol.model import load_profile, model_counters
    from warpvol.tables.pingpong import build_pingpong

    p = load_profile("radeon8500")
    t = [model_counters(counted(build_pingpong, guthe_tf(), n_s=512, lengths=(1.0,), m=128, per_pass=k,
                                emulate=False, device=device), p)["gpu_s"] for k in (1, 4)]
    return t[0] / t[1]
