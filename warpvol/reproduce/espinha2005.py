"""Espinha & Celes 2005, hardware-assisted ray casting (paper figures, transfer functions, views, modelled
times); the command line is ``scripts/reproduce_espinha2005.py``."""

from __future__ import annotations

import numpy as np


def resampled_tf(tf, segments: int):
    """The TF sampled at ``segments + 1`` uniformly spaced control points over its range (piecewise
    linear with ``segments`` segments, as the paper approximates its TFs)."""
    from warpvol.scene.transfer import TransferFunction

    lo, hi = tf.srange
    s = np.linspace(lo, hi, segments + 1)
    return TransferFunction.from_table(tf.evaluate(s), (lo, hi), emission=tf.emission)
