"""The compiled (numba) forms of the searches' inner loops and of the optics' continuum's lag
sums (:func:`lag_sums`), each the same bits as its array form (:mod:`.kernel` says which,
and loads this module: importing numba costs about 0.25 s); the blind start's are in
:mod:`.compiled_start`.

Every float operation is numpy's, in numpy's order and without fused multiply-adds (numba
compiles without fast-math): a mean over modes is numpy's pairwise sum
(:func:`pairwise_sum`), ``np.remainder`` is ``fmod`` turned positive, and a ``bincount``
adds in index order.  ``tests/test_dispersion.py`` holds each compiled loop to its array
form.
"""

from __future__ import annotations

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
    ``row.sum()`` bit for bit."""
    if n <= 128:
        return _block_sum(a, lo, n, zero)
    return _pairwise(a, lo, n, zero, np.empty((3, 64), dtype=np.int64), np.full(64, zero))


@_jit
def _pairwise(a: np.ndarray, lo: int, n: int, zero: Any, frames: np.ndarray,
              left: np.ndarray) -> Any:
    """:func:`pairwise_sum` with its recursion unrolled on a stack held in ``frames``
    ``(3, 64)`` int64 and ``left`` ``(64,)`` (a caller in a loop allocates them once;
    numba's disk cache of a recursive function crashed on loading)."""
    if n <= 128:
        return _block_sum(a, lo, n, zero)
    # frames (start, length, stage): stage 0 sums the first half, 1 the second, 2 both
    s_lo, s_n, s_stage = frames[0], frames[1], frames[2]
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
            ret = left[top] + ret
            top -= 1
            continue
        if stage == 1:
            left[top] = ret
        s_stage[top] = stage + 1
        top += 1
        s_lo[top] = s_lo[top - 1] + (n2 if stage == 1 else 0)
        s_n[top] = m - n2 if stage == 1 else n2
        s_stage[top] = 0
    return ret


@_jit
def _two_branches(o: Any, d: Any, pair: np.ndarray, m: int, pow2: bool, mask: int,
                  n_psi: int) -> tuple[Any, Any, int, int, Any, Any]:
    """Mode ``m``'s table values at the two directions' phase steps ``o - d`` and
    ``-(o + d)`` (table bins; linear interpolation from ``pair``, :func:`shares_loop`), and
    their table positions and fractions: ``(v1, v2, j1, j2, frac1, frac2)``."""
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
    return v1, v2, j1, j2, frac1, frac2


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
            v1, v2, j1, j2, frac1, frac2 = _two_branches(om[0 if one_row else c, m], d,
                                                         pair, m, pow2, mask, n_psi)
            second = v2 > v1
            out[c, m] = v2 if second else v1
            if turns:
                w = np.float32(j2) + frac2 if second else np.float32(j1) + frac1
                w = min(w, period - w)
                w *= per_bin
                w -= half
                wt[c, m] = min(max(w, np.float32(0.0)), np.float32(1.0))


@_jit
def _shares_by_mode(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                    ky: np.ndarray, pair: np.ndarray, out: np.ndarray) -> None:
    """:func:`shares_loop` of one row of ``om``, without turn weights, mode by mode (the
    candidates inner: a mode's table row stays in cache for all of them; 10 % faster)."""
    n_cand, n_modes = out.shape
    n_psi = pair.shape[1]
    pow2 = n_psi & (n_psi - 1) == 0
    mask = n_psi - 1
    for m in range(n_modes):
        o = om[0, m]
        kxm = kx[m]
        kym = ky[m]
        for c in range(n_cand):
            d = vx[c] * kxm
            d += vy[c] * kym
            v1, v2 = _two_branches(o, d, pair, m, pow2, mask, n_psi)[:2]
            out[c, m] = v2 if v2 > v1 else v1


@_jit
def _shares_rows(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                 ky: np.ndarray, pair: np.ndarray, out: np.ndarray, j1: np.ndarray,
                 j2: np.ndarray, fr1: np.ndarray, fr2: np.ndarray, om_max: float,
                 k_max: float) -> bool:
    """:func:`_shares_by_mode`, candidate by candidate in two passes over the modes: the
    table positions (``j1, j2`` int32, ``fr1, fr2``: workspaces of the modes' length),
    which vectorises, then the gathers.  ``om_max``, ``k_max``: bounds of ``|om|`` and of
    ``|kx|, |ky|`` (inf where not finite).  False, ``out`` unfinished, where a candidate's
    positions might lie beyond int32 (the caller takes :func:`_shares_by_mode`)."""
    n_cand, n_modes = out.shape
    n_psi = pair.shape[1]
    pow2 = n_psi & (n_psi - 1) == 0
    mask = np.int32(n_psi - 1)
    o_ = om[0]
    for c in range(n_cand):
        ux = vx[c]
        uy = vy[c]
        # |position| <= |om| + |u| |k|: checked once, so that the loop has no test
        if not om_max + (abs(ux) + abs(uy)) * k_max < 2.0**29:
            return False
        for m in range(n_modes):
            d = ux * kx[m]
            d += uy * ky[m]
            o = o_[m]
            pos1 = o - d
            pos2 = -(o + d)
            f1 = np.floor(pos1)
            f2 = np.floor(pos2)
            fr1[m] = pos1 - f1
            fr2[m] = pos2 - f2
            if pow2:
                j1[m] = np.int32(f1) & mask
                j2[m] = np.int32(f2) & mask
            else:
                j1[m] = np.int32(f1) % n_psi
                j2[m] = np.int32(f2) % n_psi
        row = out[c]
        for m in range(n_modes):
            g1 = pair[m, j1[m]]
            g2 = pair[m, j2[m]]
            v1 = g1.imag * fr1[m]
            v1 += g1.real
            v2 = g2.imag * fr2[m]
            v2 += g2.real
            row[m] = v2 if v2 > v1 else v1
    return True


@_jit
def _abs_bound(arr: np.ndarray) -> float:
    """The largest ``|x|`` of ``arr``; inf where one is not finite."""
    big = 0.0
    finite = True
    for x in arr.ravel():
        a = abs(float(x))
        finite &= a < np.inf
        big = max(big, a)
    return big if finite else np.inf


@_jit
def _candidate_shares(om: np.ndarray, vx: np.ndarray, vy: np.ndarray, kx: np.ndarray,
                      ky: np.ndarray, pair: np.ndarray, vals: np.ndarray, j1: np.ndarray,
                      j2: np.ndarray, fr1: np.ndarray, fr2: np.ndarray, om_max: float,
                      k_max: float) -> None:
    """``vals`` (candidates, modes), in place: :func:`_shares_rows` of the candidates
    ``(vx, vy)`` (bins per unit wavenumber), or :func:`_shares_by_mode` where it declines."""
    if not _shares_rows(om, vx, vy, kx, ky, pair, vals, j1, j2, fr1, fr2, om_max, k_max):
        _shares_by_mode(om, vx, vy, kx, ky, pair, vals)


@_jit
def _row_mean(row: np.ndarray, frames: np.ndarray, left: np.ndarray) -> Any:
    """The float32 mean of ``row`` as numpy takes it (its pairwise sum from +0, over the
    count); ``frames``, ``left``: :func:`_pairwise`'s workspaces."""
    zero = np.float32(0.0)
    return (zero + _pairwise(row, 0, row.size, zero, frames, left)) / np.float32(row.size)


@_jit
def _first_argmax(score: np.ndarray) -> int:
    """numpy's argmax of ``score``: the first maximum, a NaN before all."""
    jb = 0
    for j in range(1, score.size):
        if np.isnan(score[jb]):
            break
        if np.isnan(score[j]) or score[j] > score[jb]:
            jb = j
    return jb


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
    j1 = np.empty(n, dtype=np.int32)
    j2 = np.empty(n, dtype=np.int32)
    fr1 = np.empty(n, dtype=np.float32)
    fr2 = np.empty(n, dtype=np.float32)
    om_max = _abs_bound(om)
    k_max = max(_abs_bound(kx), _abs_bound(ky))
    vx = np.empty(8, dtype=np.float32)
    vy = np.empty(8, dtype=np.float32)
    seen_x = np.empty(64, dtype=np.float32)
    seen_y = np.empty(64, dtype=np.float32)
    seen_v = np.empty(64, dtype=np.float32)
    n_seen = 0
    frames = np.empty((3, 64), dtype=np.int64)
    left = np.full(64, np.float32(0.0))
    vx[0] = np.float32(ux * to_bins)
    vy[0] = np.float32(uy * to_bins)
    _candidate_shares(om, vx[:1], vy[:1], kx, ky, pair, vals[:1], j1, j2, fr1, fr2, om_max,
                      k_max)
    best = _row_mean(vals[0], frames, left)
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
        _candidate_shares(om, vx[:k], vy[:k], kx, ky, pair, vals[:k], j1, j2, fr1, fr2,
                          om_max, k_max)
        i = 0
        for j in range(8):
            if known[j] >= 0:
                score[j] = seen_v[known[j]]
                continue
            score[j] = _row_mean(vals[i], frames, left)
            if n_seen == seen_x.size:  # grow the record
                seen_x = np.concatenate((seen_x, seen_x))
                seen_y = np.concatenate((seen_y, seen_y))
                seen_v = np.concatenate((seen_v, seen_v))
            seen_x[n_seen], seen_y[n_seen], seen_v[n_seen] = vx[i], vy[i], score[j]
            n_seen += 1
            i += 1
        jb = _first_argmax(score)
        if score[jb] > best:
            best = score[jb]
            ux, uy = cand_x[jb], cand_y[jb]
        else:
            step *= 0.5
    return float(best), ux, uy


@_jit
def best_start(om: np.ndarray, kx: np.ndarray, ky: np.ndarray, pair: np.ndarray,
               cand_x: np.ndarray, cand_y: np.ndarray, to_bins: float) -> int:
    """Which of the candidates ``(cand_x, cand_y)`` px/frame scores highest at one altitude
    (``om`` as :func:`compass`'s), numpy's argmax of the score (the first maximum, a NaN
    before all): the start of the compass search from the velocity map's peaks
    (:meth:`~wavealt.altimetry.dispersion.velocity_map._VelocityMap._map_best_velocity`)."""
    n = kx.size
    k = cand_x.size
    vals = np.empty((k, n), dtype=np.float32)
    j1 = np.empty(n, dtype=np.int32)
    j2 = np.empty(n, dtype=np.int32)
    fr1 = np.empty(n, dtype=np.float32)
    fr2 = np.empty(n, dtype=np.float32)
    vx = np.empty(k, dtype=np.float32)
    vy = np.empty(k, dtype=np.float32)
    for c in range(k):
        vx[c] = np.float32(cand_x[c] * to_bins)
        vy[c] = np.float32(cand_y[c] * to_bins)
    _candidate_shares(om, vx, vy, kx, ky, pair, vals, j1, j2, fr1, fr2, _abs_bound(om),
                      max(_abs_bound(kx), _abs_bound(ky)))
    frames = np.empty((3, 64), dtype=np.int64)
    left = np.full(64, np.float32(0.0))
    score = np.empty(k, dtype=np.float32)
    for c in range(k):
        score[c] = _row_mean(vals[c], frames, left)
    return _first_argmax(score)


@_jit
def scatter_products(coef: np.ndarray, cos: np.ndarray, rows: np.ndarray, slot: np.ndarray,
                     cells: np.ndarray, out: np.ndarray) -> None:
    """``out`` (complex64, zeros on entry), in place: at each lattice cell, the sum of the
    products ``coef[m, j] * (2 cos[rows[m], j])`` (complex64 times float64) of the
    coefficients that fall on it (``cells[slot[m n_psi + j]]``), real and imaginary parts
    apart, in index order from +0: ``np.bincount`` of numpy's complex128 product, whose
    parts are the rounded ``re * turn`` and ``im * turn`` (the product's terms in 0 change
    at most a zero's sign, and a sum from +0 drops that), each rounded to float32 at the
    end.  The sums run over the occupied cells alone (``slot``, ``cells``: ``np.unique`` of
    the cell indices), and ``cos`` holds one row per distinct wavenumber (``rows``)."""
    n_psi = cos.shape[1]
    re = np.zeros(cells.size)
    im = np.zeros(cells.size)
    for m in range(rows.size):
        r = rows[m]
        for j in range(n_psi):
            i = m * n_psi + j
            z = coef[m, j]
            t = 2.0 * cos[r, j]
            re[slot[i]] += np.float64(z.real) * t
            im[slot[i]] += np.float64(z.imag) * t
    for s in range(cells.size):
        out[cells[s]] = np.complex64(complex(np.float32(re[s]), np.float32(im[s])))


@_jit
def map_peaks(score: np.ndarray, n_keep: int) -> np.ndarray:
    """The flat indices of the ``n_keep`` highest local maxima of ``score`` (2-D float64):
    finite points at least as high as each of their eight neighbours (a NaN neighbour
    forbids one), highest first, ties in index order, as
    :func:`~wavealt.altimetry.dispersion.velocity_map._map_peaks_arrays`."""
    ny, nx = score.shape
    top = np.empty(max(n_keep, 0), dtype=np.int64)
    top_v = np.empty(max(n_keep, 0))
    n = 0
    for y in range(ny):
        # a neighbour beyond the edge is the point itself, which a finite point is at
        # least as high as (numpy's pad of -inf); no branch per neighbour
        up = score[max(y - 1, 0)]
        mid = score[y]
        down = score[min(y + 1, ny - 1)]
        for x in range(nx):
            xl = max(x - 1, 0)
            xr = min(x + 1, nx - 1)
            s = mid[x]
            peak = ((s >= up[xl]) & (s >= up[x]) & (s >= up[xr]) & (s >= mid[xl])
                    & (s >= mid[xr]) & (s >= down[xl]) & (s >= down[x]) & (s >= down[xr])
                    & (abs(s) < np.inf))
            if not peak:
                continue
            # insertion after every kept peak at least as high (a stable sort)
            k = n
            while k > 0 and top_v[k - 1] < s:
                k -= 1
            if k >= n_keep:
                continue
            for i in range(min(n, n_keep - 1), k, -1):
                top[i] = top[i - 1]
                top_v[i] = top_v[i - 1]
            top[k] = y * nx + x
            top_v[k] = s
            n = min(n + 1, n_keep)
    return top[:n]


@_jit
def lag_sums(re: np.ndarray, im: np.ndarray, out_re: np.ndarray, out_im: np.ndarray) -> None:
    """``out_re + i out_im`` ``(T, P)``, in place: ``sum_s X_{s+l} conj(X_s)`` per lag ``l``
    and column of ``X = re + i im`` ``(T, P)`` float32, the pairs ``s`` added in ascending
    order as :func:`~wavealt.altimetry.dispersion.continuum.lag_sums_arrays` adds them."""
    t, n = re.shape
    out_re[:] = 0.0
    out_im[:] = 0.0
    for s in range(t):
        yr = re[s]
        yi = im[s]
        for lag in range(t - s):
            xr = re[s + lag]
            xi = im[s + lag]
            ar = out_re[lag]
            ai = out_im[lag]
            for q in range(n):
                ar[q] += xr[q] * yr[q] + xi[q] * yi[q]
                ai[q] += xi[q] * yr[q] - xr[q] * yi[q]
