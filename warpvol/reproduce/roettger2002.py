"""Roettger & Ertl 2002, cell projection with pre-integration (tables of the paper, its transfer functions
and the model of its Table 2); the command line is ``scripts/reproduce_roettger2002.py``."""

from __future__ import annotations

import numpy as np

from warpvol.model import load_profile, model_counters
from warpvol.reproduce.common import counted
from warpvol.scene.transfer import TransferFunction
from warpvol.tables.roettger_hw import build_roettger_hw
from warpvol.tables.roettger_sw import sw_samples


def fig9_tf():
    """Four interleaved orange and blue regions over the distance range, constant opacity."""

    orange, blue, w = (1.0, 0.55, 0.1), (0.15, 0.35, 1.0), 0.01
    pts = []
    for k in range(4):
        c = orange if k % 2 == 0 else blue
        lo, hi = 0.45 * k, 0.45 * (k + 1)
        pts += [[lo + (w if k else 0.0), *c, 2.0], [hi - (w if k < 3 else 0.0), *c, 2.0]]
    return TransferFunction(pts, "emission_density")



def fig4_tf(rho_scale: float = 1.0):
    """64 entries, emission density: smooth colour ramps with bumps, extinction with a few peaks
    (times ``rho_scale``: the one number calibrated on Table 1)."""

    x = np.linspace(0, 1, 64)
    r = np.clip(0.2 + 0.8 * np.exp(-((x - 0.7) / 0.12) ** 2) + 0.3 * x, 0, 1)
    g = np.clip(0.6 * np.exp(-((x - 0.4) / 0.1) ** 2) + 0.2 * np.sin(6 * x) ** 2, 0, 1)
    b = np.clip(0.9 * np.exp(-((x - 0.15) / 0.1) ** 2) + 0.1, 0, 1)
    rho = 0.2 + 2.0 * np.exp(-((x - 0.7) / 0.05) ** 2) + 1.0 * np.exp(-((x - 0.3) / 0.08) ** 2)
    return TransferFunction.from_table(np.column_stack([r, g, b, rho_scale * rho]), (0.0, 1.0), "emission_density")


ROETTGER_T2 = {64: (13.499, 0.188, 71.80), 128: (216.204, 2.859, 75.62), 256: (3413.444, 35.550, 96.01)}


def roettger_t2_model(N: int, device: str = "cpu") -> dict:
    """Modelled Table 2 row N (N x N x N/2, N/2 steps): Octane MXI hardware build and R10K software."""

    p = load_profile("octane_mxi")
    hw = counted(build_roettger_hw, fig4_tf(), n_s=N, n_l=N // 2, steps=N // 2, bits=12, emulate=False,
                 device=device)
    x = (np.arange(N) + 0.5) / N
    sw = {"sw_samples": sw_samples(x, x, N // 2, 2.0, 1) * (N // 2)}
    return {"hw": model_counters(hw, p)["s"], "sw": model_counters(sw, p)["s"], "hw_counters": hw}



def roettger_combiner_speedup(N: int = 256, device: str = "cpu") -> float:
    """GeForce3: modelled time of plain 8-bit blending over the 4-steps-per-pass register-combiner build."""

    p = load_profile("geforce3")
    kw = dict(n_s=N, n_l=N // 2, steps=N // 2, bits=8, passes="one", emulate=False, device=device)
    plain = counted(build_roettger_hw, fig4_tf(), **kw)
    comb = counted(build_roettger_hw, fig4_tf(), variant="geforce3", **kw)
    return model_counters(plain, p)["s"] / model_counters(comb, p)["s"]
