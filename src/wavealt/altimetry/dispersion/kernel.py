"""The score's inner loop: every candidate's explained share of every mode, read from the
periodogram's phase-step table by linear interpolation, the better of the two directions of
travel (:meth:`~wavealt.altimetry.dispersion.search._Search._branch_values`).

Two forms give the same float32 bits (``tests/test_dispersion.py``): numpy array passes, and
the same loop compiled by numba (:mod:`.compiled`), one fused pass per (candidate, mode), in
numpy's order of operations and without fused multiply-adds.  The compiled form is 2-3x
faster; importing numba costs about 0.25 s, so it is loaded (:func:`use_compiled`) where
many calls follow, the blind and prior searches, and not for the few calls of an exact fit,
whose command line starts in 0.4 s.  It is compiled once and cached on disk (numba's
``cache=True``); without numba the array form serves.  The same module holds the compiled
forms of the blind searches' other inner loops (the compass search of the velocity, the
start's velocity grid and Gauss-Newton terms), which their callers take where
:func:`compiled_module` offers them, each the same bits as the caller's array form.  A
window's matrix products run with NumPy's BLAS on one thread (:func:`_one_blas_thread`).
"""

from __future__ import annotations

from typing import Any

import numpy as np


def _one_blas_thread() -> Any:
    """Context in which NumPy's BLAS runs on one thread.

    The matrix products of one window are small; threaded, OpenBLAS's workers keep
    spinning after each product and fight other threads for the cores, which slows a
    window, the slowest windows most.
    """
    from threadpoolctl import ThreadpoolController

    global _BLAS_CONTROLLER
    if _BLAS_CONTROLLER is None:
        _BLAS_CONTROLLER = ThreadpoolController()
    return _BLAS_CONTROLLER.limit(limits=1, user_api="blas")


_BLAS_CONTROLLER: Any = None
_compiled: Any = None
_module: Any = None
_start_module: Any = None


def use_compiled() -> bool:
    """Load the compiled forms (:mod:`.compiled`, :mod:`.compiled_start`) for the calls that
    follow in this process (once); False where numba cannot be imported."""
    global _compiled, _module, _start_module
    if _compiled is None:
        try:
            import wavealt.altimetry.dispersion.compiled as compiled
            import wavealt.altimetry.dispersion.compiled_start as compiled_start
        except ImportError:
            _compiled = False
        else:
            _module, _start_module = compiled, compiled_start
            _compiled = compiled.shares_loop
    return _compiled is not False


def compiled_module() -> Any:
    """The compiled forms of the searches (:mod:`.compiled`) once :func:`use_compiled` has
    loaded them (and the score's loop is not switched to its array form), else None: the
    caller's array form serves."""
    return _module if _compiled else None


def compiled_start_module() -> Any:
    """The compiled forms of the blind start (:mod:`.compiled_start`), as
    :func:`compiled_module`."""
    return _start_module if _compiled else None


def explained_shares(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                     ky: np.ndarray, pair: np.ndarray, frames: int, turns: bool,
                     out: np.ndarray, wt: np.ndarray) -> None:
    """``out[c, m]`` (and ``wt`` with ``turns``), in place: the compiled form once
    :func:`use_compiled` has loaded it, else the array form
    (:func:`~wavealt.altimetry.dispersion.compiled.shares_loop` says what is computed)."""
    (_compiled or _shares_arrays)(om, vx, vy, kx, ky, pair, frames, turns, out, wt)


def _shares_arrays(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                   ky: np.ndarray, pair: np.ndarray, frames: int, turns: bool,
                   out: np.ndarray, wt: np.ndarray) -> None:
    """:func:`~wavealt.altimetry.dispersion.compiled.shares_loop` in numpy array passes."""
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
        g = np.take(flat, j)
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
