"""The compiled (numba) forms of the searches' inner loops, each the same bits as its array
form (:mod:`.kernel` says which, and loads this module: importing numba costs about 0.25 s).

Every float operation is numpy's, in numpy's order and without fused multiply-adds (numba
compiles without fast-math): a mean over modes is numpy's pairwise sum
(:func:`pairwise_sum`), ``np.remainder`` is ``fmod`` turned positive, and a ``bincount``
adds in index order.  ``tests/test_dispersion.py`` holds each compiled loop to its array
form.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np


def _jit(fn: Any) -> Any:
    """``fn`` compiled once and cached on disk (numba's ``cache=True``), or compiled in each
    process where numba finds no writable cache directory."""
    try:
        return numba.njit(cache=True, nogil=True)(fn)
    except RuntimeError:
        return numba.njit(nogil=True)(fn)


@_jit
def _block_sum(a: np.ndarray, lo: int, n: int, zero: Any) -> Any:
    """The leaf of :func:`pairwise_sum`: ``n <= 128`` values, eight running sums."""
    if n < 8:
        res = zero
        for i in range(n):
            res += a[lo + i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    end = n - n % 8
    while i < end:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@_jit
def pairwise_sum(a: np.ndarray, lo: int, n: int, zero: Any) -> Any:
    """``a[lo:lo + n]`` summed as numpy sums a contiguous row (its pairwise summation: eight
    running sums over blocks of at most 128, the two halves summed above, the first half a
    multiple of 8 long), from ``zero`` (of ``a``'s type); ``zero + pairwise_sum(row)`` is
    ``row.sum()`` bit for bit.  The recursion is unrolled on a stack (numba's disk cache
    of a recursive function crashed on loading)."""
    if n <= 128:
        return _block_sum(a, lo, n, zero)
    # frames (start, length, stage): stage 0 sums the first half, 1 the second, 2 both
    s_lo = np.empty(64, dtype=np.int64)
    s_n = np.empty(64, dtype=np.int64)
    s_stage = np.empty(64, dtype=np.int64)
    s_left = np.full(64, zero)
    top = 0
    s_lo[0], s_n[0], s_stage[0] = lo, n, 0
    ret = zero
    while top >= 0:
        m = s_n[top]
        if m <= 128:
            ret = _block_sum(a, s_lo[top], m, zero)
            top -= 1
            continue
        n2 = m // 2
        n2 -= n2 % 8
        stage = s_stage[top]
        if stage == 2:
            ret = s_left[top] + ret
            top -= 1
            continue
        if stage == 1:
            s_left[top] = ret
        s_stage[top] = stage + 1
        top += 1
        s_lo[top] = s_lo[top - 1] + (n2 if stage == 1 else 0)
        s_n[top] = m - n2 if stage == 1 else n2
        s_stage[top] = 0
    return ret


@_jit
def shares_loop(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                ky: np.ndarray, pair: np.ndarray, frames: int, turns: bool,
                out: np.ndarray, wt: np.ndarray) -> None:
    """``out[c, m]``, in place: the table value of mode ``m`` at candidate ``c``'s phase step.

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


@_jit
def compass(om: np.ndarray, kx: np.ndarray, ky: np.ndarray, pair: np.ndarray, ux: float,
            uy: float, step: float, min_step: float, to_bins: float) -> tuple[float, float,
                                                                                float]:
    """The compass search of
    :meth:`~wavealt.altimetry.dispersion.profile._Profile._best_velocity` at one altitude
    (``om``: its one row of phase steps, table bins), from ``(ux, uy)`` px/frame: its best
    score (the mean share over the modes, float32) and velocity.

    A candidate whose float32 velocity in bins was scored before (the centre a move left,
    the neighbours it shares with the old centre) is not scored again: its score is the
    same bits.
    """
    n = kx.size
    off_x = np.array([-1.0, -1.0, -1.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    off_y = np.array([-1.0, 0.0, 1.0, -1.0, 1.0, -1.0, 0.0, 1.0])
    vals = np.empty((8, n), dtype=np.float32)
    wt = np.empty((0, 0), dtype=np.float32)
    vx = np.empty(8, dtype=np.float32)
    vy = np.empty(8, dtype=np.float32)
    seen_x = np.empty(64, dtype=np.float32)
    seen_y = np.empty(64, dtype=np.float32)
    seen_v = np.empty(64, dtype=np.float32)
    n_seen = 0
    zero = np.float32(0.0)
    count = np.float32(n)
    vx[0] = np.float32(ux * to_bins)
    vy[0] = np.float32(uy * to_bins)
    shares_loop(om, vx[:1], vy[:1], kx, ky, pair, 0, False, vals[:1], wt)
    best = (zero + pairwise_sum(vals[0], 0, n, zero)) / count
    seen_x[0], seen_y[0], seen_v[0] = vx[0], vy[0], best
    n_seen = 1
    cand_x = np.empty(8)
    cand_y = np.empty(8)
    score = np.empty(8, dtype=np.float32)
    known = np.empty(8, dtype=np.int64)
    while step >= min_step:
        k = 0
        for j in range(8):
            cand_x[j] = ux + step * off_x[j]
            cand_y[j] = uy + step * off_y[j]
            bx = np.float32(cand_x[j] * to_bins)
            by = np.float32(cand_y[j] * to_bins)
            known[j] = -1
            for s in range(n_seen):
                if seen_x[s] == bx and seen_y[s] == by:
                    known[j] = s
                    break
            if known[j] < 0:
                vx[k], vy[k] = bx, by
                k += 1
        shares_loop(om, vx[:k], vy[:k], kx, ky, pair, 0, False, vals[:k], wt)
        i = 0
        for j in range(8):
            if known[j] >= 0:
                score[j] = seen_v[known[j]]
                continue
            score[j] = (zero + pairwise_sum(vals[i], 0, n, zero)) / count
            if n_seen == seen_x.size:  # grow the record
                seen_x = np.concatenate((seen_x, seen_x))
                seen_y = np.concatenate((seen_y, seen_y))
                seen_v = np.concatenate((seen_v, seen_v))
            seen_x[n_seen], seen_y[n_seen], seen_v[n_seen] = vx[i], vy[i], score[j]
            n_seen += 1
            i += 1
        # numpy's argmax: the first maximum, a NaN before all
        jb = 0
        for j in range(1, 8):
            if np.isnan(score[jb]):
                break
            if np.isnan(score[j]) or score[j] > score[jb]:
                jb = j
        if score[jb] > best:
            best = score[jb]
            ux, uy = cand_x[jb], cand_y[jb]
        else:
            step *= 0.5
    return float(best), ux, uy


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
    a = np.empty(n_modes)
    s1 = np.empty(n_rings)
    v = np.empty(n_modes)
    for g in range(gx.size):
        s1[:] = 0.0
        for m in range(n_modes):
            a[m] = abs(_wrap(psi[m] - (gx[g] * kx[m] + gy[g] * ky[m])))
            s1[ring[m]] += a[m] * wt[m]
        for m in range(n_modes):
            mr = s1[ring[m]] / wsum[ring[m]]
            rel = (a[m] - mr) / (mr + 0.05)
            r2 = rel * rel
            v[m] = wt[m] * (1.0 if r2 > 1.0 else r2)
        out[g] = 0.0 + pairwise_sum(v, 0, n_modes, 0.0)
    return out


@_jit
def fmod_2pi(x: float) -> float:
    """``np.fmod(x, 2 pi)``, the same bits, without libm's bit-by-bit division: the
    quotient ``q`` from a product by ``1 / (2 pi)`` (off by at most one, then corrected) and
    the remainder ``|x| - q 2 pi`` exact, ``q 2 pi`` split into its rounded value and the
    rounding error (Dekker's product; ``|x|`` less the rounded value is exact by
    Sterbenz's lemma), which the exact remainder, a float, is once ``q`` is right."""
    two_pi = 2.0 * np.pi
    ax = abs(x)
    if not ax < 1e15:  # inf, nan, or a quotient past the split: libm
        return np.fmod(x, two_pi)
    # no branch on |x| < 2 pi (q = 0 gives |x| itself): the data make it unpredictable
    q = np.floor(ax * (1.0 / two_pi))
    # 2 pi split in two halves of 26 bits (Veltkamp)
    c = 134217729.0 * two_pi
    yh = c - (c - two_pi)
    yl = two_pi - yh
    for _ in range(3):
        c = 134217729.0 * q
        qh = c - (c - q)
        ql = q - qh
        p = q * two_pi
        err = ((qh * yh - p) + qh * yl + ql * yh) + ql * yl  # q 2 pi = p + err exactly
        r = (ax - p) - err
        if r < 0.0:
            q -= 1.0
        elif r >= two_pi:
            q += 1.0
        else:
            return math.copysign(r, x)
    return np.fmod(x, two_pi)


@_jit
def _wrap(x: float) -> float:
    """:func:`~wavealt.altimetry.dispersion.spectra._wrap` of one angle: ``np.remainder``
    (``fmod`` turned positive, +0 for 0) of ``x + pi`` by ``2 pi``, less ``pi``."""
    mod = fmod_2pi(x + np.pi)
    # selects, not branches (the sign is unpredictable): mod + 2 pi of a negative mod is
    # positive, and a zero, either sign, is +0
    mod = mod + 2.0 * np.pi if mod < 0.0 else mod
    mod = 0.0 if mod == 0.0 else mod
    return mod - np.pi


@_jit
def refine_terms(om: np.ndarray, dom: np.ndarray, kappa: np.ndarray, kx: np.ndarray,
                 ky: np.ndarray, psi: np.ndarray, w0: np.ndarray, ux: float, uy: float,
                 fps: float, kb: float, tukey_c: float) -> tuple[np.ndarray, ...]:
    """The per-mode terms of one Gauss-Newton step of
    :meth:`~wavealt.altimetry.dispersion.start._Start._refine` (``om, dom``: ``omega`` and
    its derivative by log altitude at the modes): the modes used, the better branch's
    wrapped residual ``r``, its Tukey weight ``tw`` and sign ``s``, and on the modes used
    the Jacobian ``jac`` ``(n, 3)``, ``jw = jac * (w0 tw)`` and the residual."""
    n = kappa.size
    use = np.empty(n, dtype=np.bool_)
    r = np.empty(n)
    tw = np.empty(n)
    s = np.empty(n)
    top = 0.9 * np.pi
    n_use = 0
    for m in range(n):
        step = om[m] / fps
        use[m] = (kappa[m] <= kb) and (step < top)
        n_use += use[m]
        dop = kx[m] * ux + ky[m] * uy
        rp = _wrap(psi[m] - (step + dop))
        rm = _wrap(psi[m] - (-om[m] / fps + dop))
        s[m] = 1.0 if abs(rp) <= abs(rm) else -1.0
        r[m] = rp if s[m] > 0 else rm
        if abs(r[m]) < tukey_c:
            q = r[m] / tukey_c
            t = 1.0 - q * q
            tw[m] = t * t
        else:
            tw[m] = 0.0
    jac = np.empty((n_use, 3))
    jw = np.empty((n_use, 3))
    res = np.empty(n_use)
    wt = np.empty(n_use)
    i = 0
    for m in range(n):
        if use[m]:
            w = w0[m] * tw[m]
            wt[i] = w
            jac[i, 0] = s[m] * dom[m] / fps
            jac[i, 1] = kx[m]
            jac[i, 2] = ky[m]
            jw[i, 0] = jac[i, 0] * w
            jw[i, 1] = jac[i, 1] * w
            jw[i, 2] = jac[i, 2] * w
            res[i] = r[m]
            i += 1
    return use, r, tw, s, jac, jw, res, 0.0 + pairwise_sum(wt, 0, n_use, 0.0)
