"""The compiled loops made ready before they are needed (:func:`warm_up`)."""

from __future__ import annotations

import math

import numpy as np

from wavealt.altimetry.dispersion.altimeter import DispersionAltimeter
from wavealt.altimetry.dispersion.kernel import compiled_module, use_compiled
from wavealt.sim.sea.spectrum import GRAVITY_MPS2


def warm_up() -> bool:
    """Load the compiled forms of the searches' inner loops and compile each of them, by a
    blind fit of a small synthetic clip (24 deep-water waves drifting, 30 frames of 128^2);
    False where numba cannot be imported (the array forms serve, nothing to compile).

    numba compiles a loop at its first call: about 10 s for all of them on a cold cache,
    which would fall on the first blind or prior window, or stall a live stream's first
    estimate.  It stores them in its disk cache (numba's ``cache=True``), from which later
    processes load them in about 0.5 s; ``make install`` calls this once.
    """
    if not use_compiled():
        return False
    n, t, h, f, fps = 128, 30, 4.0, 110.0, 30.0
    rng = np.random.default_rng(0)
    y, x = np.mgrid[0:n, 0:n].astype(np.float64)
    u = np.array([0.3, -0.2]) * f / (h * fps)  # the camera's drift, px/frame
    frames = np.zeros((t, n, n))
    for _ in range(24):
        kappa, heading = rng.uniform(0.15, 1.5), rng.uniform(0.0, 2.0 * math.pi)
        kx, ky = kappa * math.cos(heading), kappa * math.sin(heading)
        step = math.sqrt(GRAVITY_MPS2 * kappa * f / h) / fps  # rad per frame
        phase, amp = rng.uniform(0.0, 2.0 * math.pi), rng.uniform(0.5, 1.0) / kappa
        for i in range(t):
            frames[i] += amp * np.cos(kx * (x + u[0] * i) + ky * (y + u[1] * i) - step * i
                                      + phase)
    frames = (frames - frames.min()) / (frames.max() - frames.min())
    DispersionAltimeter().estimate(frames.astype(np.float32), fps=fps, focal_px=f)
    return compiled_module() is not None
