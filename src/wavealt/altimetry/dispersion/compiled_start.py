"""The compiled (numba) forms of the blind start's inner loops (:mod:`.start`): the ring
cost of its velocity grid and the terms of its Gauss-Newton steps, on a wrap of the phase
steps that gives ``np.remainder``'s bits without libm's division; each the same bits as its
array form (:mod:`.compiled` says how; :mod:`.kernel` loads both).
"""

from __future__ import annotations

import math

import numpy as np

from wavealt.altimetry.dispersion.compiled import _jit, _pairwise, pairwise_sum


@_jit
def _remainder(ax: float, q: float) -> float:
    """``ax - q 2 pi`` for an integer ``q >= 0`` near ``ax / (2 pi)``: exact where that is
    a float (``q`` the quotient), else of the right sign or past ``2 pi``.  ``q 2 pi`` is
    split into its rounded value and the rounding error (Dekker's product, halves of 26
    bits), and ``ax`` less the rounded value is exact (Sterbenz's lemma)."""
    two_pi = 2.0 * np.pi
    c = 134217729.0 * two_pi
    yh = c - (c - two_pi)
    yl = two_pi - yh
    c = 134217729.0 * q
    qh = c - (c - q)
    ql = q - qh
    p = q * two_pi
    err = ((qh * yh - p) + qh * yl + ql * yh) + ql * yl  # q 2 pi = p + err exactly
    return (ax - p) - err


@_jit
def _fmod_fast(x: float) -> float:
    """``np.fmod(x, 2 pi)`` for finite ``|x| < 1e15`` (:func:`fmod_2pi`), without a branch:
    the quotient from a product by ``1 / (2 pi)`` is off by at most one there (relative
    error 2^-52), corrected once by selects, so that loops over it vectorise."""
    two_pi = 2.0 * np.pi
    ax = abs(x)
    q = np.floor(ax * (1.0 / two_pi))
    r = _remainder(ax, q)
    q = q - 1.0 if r < 0.0 else (q + 1.0 if r >= two_pi else q)
    return math.copysign(_remainder(ax, q), x)


@_jit
def fmod_2pi(x: float) -> float:
    """``np.fmod(x, 2 pi)``, the same bits, without libm's bit-by-bit division: the
    remainder ``|x| - q 2 pi`` formed exactly (:func:`_remainder`), which fmod's result,
    a float, is once the quotient ``q`` is right (:func:`_fmod_fast`); libm's for
    non-finite ``x`` and ``|x| >= 1e15``."""
    if not abs(x) < 1e15:
        return np.fmod(x, 2.0 * np.pi)
    return _fmod_fast(x)


@_jit
def _wrap_of(mod: float) -> float:
    """The wrap of an angle whose ``fmod(angle + pi, 2 pi)`` is ``mod``: ``np.remainder``
    (``mod`` turned positive, +0 for 0) less ``pi``, by selects (the sign follows the data
    unpredictably): ``mod + 2 pi`` of a negative ``mod`` is positive."""
    mod = mod + 2.0 * np.pi if mod < 0.0 else mod
    mod = 0.0 if mod == 0.0 else mod
    return mod - np.pi


@_jit
def _wrap(x: float) -> float:
    """:func:`~wavealt.altimetry.dispersion.spectra._wrap` of one angle: ``np.remainder``
    of ``x + pi`` by ``2 pi``, less ``pi``."""
    return _wrap_of(fmod_2pi(x + np.pi))


@_jit
def _wrap_fast(x: float) -> float:
    """:func:`_wrap` for ``|x + pi| < 1e15`` (no branch: loops over it vectorise); the
    callers check that bound over the loop and take :func:`_wrap` where it fails."""
    return _wrap_of(_fmod_fast(x + np.pi))


@_jit
def ring_costs(psi: np.ndarray, kx: np.ndarray, ky: np.ndarray, wt: np.ndarray,
               ring: np.ndarray, n_rings: int, gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
    """The ring cost of the velocity candidates ``(gx, gy)`` (px/frame)
    (:meth:`~wavealt.altimetry.dispersion.start._Start._ring_cost` of the wrapped
    Doppler-free phase steps of modes ``psi, kx, ky``, weights ``wt``, rings ``ring``)."""
    n_modes = psi.size
    wsum = np.zeros(n_rings)
    for m in range(n_modes):
        wsum[ring[m]] += wt[m]
    for k in range(n_rings):
        wsum[k] = max(wsum[k], 1e-30)
    out = np.empty(gx.size)
    x = np.empty(n_modes)
    a = np.empty(n_modes)
    s1 = np.empty(n_rings)
    mr = np.empty(n_modes)
    v = np.empty(n_modes)
    frames = np.empty((3, 64), dtype=np.int64)
    left = np.zeros(64)
    for g in range(gx.size):
        ok = True
        for m in range(n_modes):  # vectorised
            x[m] = psi[m] - (gx[g] * kx[m] + gy[g] * ky[m])
            ok &= abs(x[m] + np.pi) < 1e15
            a[m] = abs(_wrap_fast(x[m]))
        if not ok:
            for m in range(n_modes):
                a[m] = abs(_wrap(x[m]))
        s1[:] = 0.0
        for m in range(n_modes):  # bincount's order
            s1[ring[m]] += a[m] * wt[m]
        for k in range(n_rings):  # each ring's mean |r|
            s1[k] /= wsum[k]
        for m in range(n_modes):
            mr[m] = s1[ring[m]]
        for m in range(n_modes):  # vectorised
            rel = (a[m] - mr[m]) / (mr[m] + 0.05)
            r2 = rel * rel
            v[m] = wt[m] * (1.0 if r2 > 1.0 else r2)
        out[g] = 0.0 + _pairwise(v, 0, n_modes, 0.0, frames, left)
    return out


@_jit
def refine_terms(om: np.ndarray, dom: np.ndarray, kappa: np.ndarray, kx: np.ndarray,
                 ky: np.ndarray, psi: np.ndarray, w0: np.ndarray, ux: float, uy: float,
                 fps: float, kb: float, tukey_c: float) -> tuple[np.ndarray, ...]:
    """The per-mode terms of one Gauss-Newton step of
    :meth:`~wavealt.altimetry.dispersion.start._Start._refine` (``om, dom``: ``omega`` and
    its derivative by log altitude at the modes): the modes used, the better branch's
    wrapped residual ``r``, its Tukey weight ``tw`` and sign ``s``, and on the modes used
    the Jacobian ``jac`` ``(n, 3)``, ``jw = jac * (w0 tw)``, the residual and the sum of
    the weights ``w0 tw``."""
    n = kappa.size
    use = np.empty(n, dtype=np.bool_)
    r = np.empty(n)
    tw = np.empty(n)
    s = np.empty(n)
    xp = np.empty(n)
    xm = np.empty(n)
    top = 0.9 * np.pi
    # selects, not branches: which modes are used, the branch and the Tukey cut follow
    # the data unpredictably; the loop vectorises
    ok = True
    for m in range(n):
        step = om[m] / fps  # -om / fps is -(om / fps): division rounds symmetrically
        use[m] = (kappa[m] <= kb) & (step < top)
        dop = kx[m] * ux + ky[m] * uy
        xp[m] = psi[m] - (step + dop)
        xm[m] = psi[m] - (-step + dop)
        ok &= (abs(xp[m] + np.pi) < 1e15) & (abs(xm[m] + np.pi) < 1e15)
        rp = _wrap_fast(xp[m])
        rm = _wrap_fast(xm[m])
        first = abs(rp) <= abs(rm)
        s[m] = 1.0 if first else -1.0
        r[m] = rp if first else rm
    if not ok:
        for m in range(n):
            rp = _wrap(xp[m])
            rm = _wrap(xm[m])
            first = abs(rp) <= abs(rm)
            s[m] = 1.0 if first else -1.0
            r[m] = rp if first else rm
    for m in range(n):
        q = r[m] / tukey_c
        q = 1.0 - q * q
        tw[m] = q * q if abs(r[m]) < tukey_c else 0.0
    jac = np.empty((n, 3))
    jw = np.empty((n, 3))
    res = np.empty(n)
    wt = np.empty(n)
    n_use = 0
    for m in range(n):  # the used modes packed as they come
        w = w0[m] * tw[m]
        wt[n_use] = w
        jac[n_use, 0] = s[m] * dom[m] / fps
        jac[n_use, 1] = kx[m]
        jac[n_use, 2] = ky[m]
        jw[n_use, 0] = jac[n_use, 0] * w
        jw[n_use, 1] = jac[n_use, 1] * w
        jw[n_use, 2] = jac[n_use, 2] * w
        res[n_use] = r[m]
        n_use += 1 if use[m] else 0
    jac, jw, res = jac[:n_use], jw[:n_use], res[:n_use]
    return use, r, tw, s, jac, jw, res, 0.0 + pairwise_sum(wt, 0, n_use, 0.0)
