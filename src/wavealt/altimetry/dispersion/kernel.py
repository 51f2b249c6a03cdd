"""The score's inner loop, compiled: every candidate's explained share of every mode, read
from the periodogram's phase-step table by linear interpolation, the better of the two
directions of travel (:meth:`~wavealt.altimetry.dispersion.search._Search._branch_values`).

One fused pass per (candidate, mode) instead of a dozen array passes; the float32 operations
are numpy's, in numpy's order and without fused multiply-adds, so the values are the same
bits as the array form's (``tests/test_dispersion.py``).  Compiled on first use and cached
on disk beside this module (numba's ``cache=True``).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def explained_shares(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                     ky: np.ndarray, pair: np.ndarray, frames: int, turns: bool,
                     out: np.ndarray, wt: np.ndarray) -> None:
    """``out[c, m]``: the table value of mode ``m`` at candidate ``c``'s phase step.

    ``om[c, m]``: the wave's phase step in table bins (one row: the same for every
    candidate); ``vx, vy``: the candidate's image
    velocity in bins per unit wavenumber; ``pair[m, j]``: the table ``q[m, j]`` (real part)
    and the step to ``q[m, j + 1]`` (imaginary part).  The two directions predict the steps
    ``om - k.v`` and ``-(om + k.v)``; the larger value is kept (the first on a tie).  With
    ``turns``, ``wt[c, m]`` gets the kept branch's turn weight: the cycles its phase step
    turns over ``frames`` frames, minus half a cycle, clipped to [0, 1].
    """
    n_cand, n_modes = out.shape
    one_row = om.shape[0] == 1
    n_psi = pair.shape[1]
    pow2 = n_psi & (n_psi - 1) == 0
    mask = n_psi - 1
    period = np.float32(n_psi)
    per_bin = np.float32(frames / n_psi)
    half = np.float32(0.5)
    for c in range(n_cand):
        ux = vx[c]
        uy = vy[c]
        for m in range(n_modes):
            d = ux * kx[m]
            d += uy * ky[m]
            o = om[0 if one_row else c, m]
            pos1 = o - d
            pos2 = -(o + d)
            f1 = np.floor(pos1)
            f2 = np.floor(pos2)
            frac1 = pos1 - f1
            frac2 = pos2 - f2
            if pow2:
                j1 = np.int64(f1) & mask
                j2 = np.int64(f2) & mask
            else:
                j1 = np.int64(f1) % n_psi
                j2 = np.int64(f2) % n_psi
            g1 = pair[m, j1]
            g2 = pair[m, j2]
            v1 = g1.imag * frac1
            v1 += g1.real
            v2 = g2.imag * frac2
            v2 += g2.real
            second = v2 > v1
            out[c, m] = v2 if second else v1
            if turns:
                w = np.float32(j2) + frac2 if second else np.float32(j1) + frac1
                w = min(w, period - w)
                w *= per_bin
                w -= half
                wt[c, m] = min(max(w, np.float32(0.0)), np.float32(1.0))
