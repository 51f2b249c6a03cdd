"""The score's inner loop: every candidate's explained share of every mode, read from the
periodogram's phase-step table by linear interpolation, the better of the two directions of
travel (:meth:`~wavealt.altimetry.dispersion.search._Search._branch_values`).

Two forms give the same float32 bits (``tests/test_dispersion.py``): numpy array passes, and
the same loop compiled by numba, one fused pass per (candidate, mode), in numpy's order of
operations and without fused multiply-adds.  The compiled form is 2-3x faster; importing
numba costs about 0.25 s, so it is loaded (:func:`use_compiled`) where many calls follow,
the blind and prior searches, and not for the few calls of an exact fit, whose command line
starts in 0.4 s.  It is compiled once and cached on disk (numba's ``cache=True``); without
numba the array form serves.
"""

from __future__ import annotations

from typing import Any

import numpy as np

_compiled: Any = None


def use_compiled() -> bool:
    """Load the compiled form for the calls that follow in this process (once); False where
    numba cannot be imported."""
    global _compiled
    if _compiled is None:
        try:
            import numba
        except ImportError:
            _compiled = False
        else:
            try:
                _compiled = numba.njit(cache=True, nogil=True)(_shares_loop)
            except RuntimeError:  # no writable cache directory: compiled in each process
                _compiled = numba.njit(nogil=True)(_shares_loop)
    return _compiled is not False


def explained_shares(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                     ky: np.ndarray, pair: np.ndarray, frames: int, turns: bool,
                     out: np.ndarray, wt: np.ndarray) -> None:
    """``out[c, m]`` (and ``wt`` with ``turns``), in place: the compiled form once
    :func:`use_compiled` has loaded it, else the array form (:func:`_shares_loop` says what
    is computed)."""
    (_compiled or _shares_arrays)(om, vx, vy, kx, ky, pair, frames, turns, out, wt)


def _shares_arrays(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                   ky: np.ndarray, pair: np.ndarray, frames: int, turns: bool,
                   out: np.ndarray, wt: np.ndarray) -> None:
    """:func:`_shares_loop` in numpy array passes."""
    n_modes, n_psi = pair.shape
    dop = vx[:, None] * kx[None, :]
    dop += vy[:, None] * ky[None, :]
    base = np.arange(n_modes, dtype=np.int64)[None, :] * n_psi
    flat = pair.ravel()
    pos2 = np.add(om, dop)
    np.negative(pos2, out=pos2)
    best = w_best = None
    for pos in (om - dop, pos2):
        jf = np.floor(pos)
        frac = pos - jf
        j = jf.astype(np.int64)
        if n_psi & (n_psi - 1) == 0:
            j &= n_psi - 1  # the table's period, also for negative steps
        else:
            j %= n_psi
        w = None
        if turns:
            w = j.astype(np.float32)
            w += frac
            np.minimum(w, np.float32(n_psi) - w, out=w)
            w *= np.float32(frames / n_psi)
            w -= np.float32(0.5)
            np.clip(w, 0.0, 1.0, out=w)
        j += base
        g = flat[j]
        val = g.imag * frac
        val += g.real
        if best is None:
            best, w_best = val, w
        else:
            if turns:
                w_best = np.where(val > best, w, w_best)
            best = np.maximum(best, val)
    out[...] = best
    if turns:
        wt[...] = w_best


def _shares_loop(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                 ky: np.ndarray, pair: np.ndarray, frames: int, turns: bool,
                 out: np.ndarray, wt: np.ndarray) -> None:
    """``out[c, m]``, in place: the table value of mode ``m`` at candidate ``c``'s phase step
    (the loop that :func:`use_compiled` compiles).

    ``om[c, m]``: the wave's phase step in table bins (one row: the same for every
    candidate); ``vx, vy``: the candidate's image velocity in bins per unit wavenumber;
    ``pair[m, j]``: the table ``q[m, j]`` (real part) and the step to ``q[m, j + 1]``
    (imaginary part).  The two directions predict the steps
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
