"""The aided (velocity known) fit's candidates: the weighted, shrunk and plain scans' peaks,
each refined and graded on the plain scan."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal

from wavealt.altimetry.dispersion import TRUSTED_QUALITY, DispersionAltimeter, _wrap
from wavealt.altimetry.dispersion.constants import (
    AIDED_SCAN_ABOVE,
    AIDED_SCAN_BELOW,
    EDGE_FACTOR,
    MIN_SIGNIFICANCE,
)

FPS, FOCAL_PX, FRAMES, N_PSI = 30.0, 200.0, 10, 128


def _lattice(max_kappa: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One of each +-pair of a 64-px tile's modes between 0.04 and ``max_kappa`` rad/px."""
    k = np.arange(-32, 32) * (2.0 * math.pi / 64.0)
    kx, ky = (a.ravel() for a in np.meshgrid(k, k, indexing="ij"))
    kappa = np.hypot(kx, ky)
    keep = (kappa > 0.04) & (kappa < max_kappa) & ((kx > 0) | ((kx == 0) & (ky > 0)))
    return kx[keep], ky[keep], kappa[keep]


def _split_table(h_true: float, h_fast: float, slow_share: float = 0.9,
                 floor: float = 0.02, seed: int | None = None) -> tuple[dict, np.ndarray]:
    """A periodogram of a hovering camera at ``h_true`` m in which the modes that turn less
    than half a cycle over the clip hold the shell (a peak of width ``pi / T`` holding
    ``slow_share`` of their energy) and the others hold only faster content, at the shell
    of ``h_fast``; over a flat ``floor`` (``seed``: a gamma-distributed one of that mean
    over half its shape instead)."""
    est = DispersionAltimeter(dispersion="gravity")
    kx, ky, kappa = _lattice(0.8)
    psi = 2.0 * math.pi * np.arange(N_PSI) / N_PSI

    def peak(h: float) -> tuple[np.ndarray, np.ndarray]:
        step = est.omega(kappa * FOCAL_PX / h) / FPS
        return step, np.exp(-0.5 * (_wrap(psi[None, :] - step[:, None]) / (math.pi / FRAMES))
                            ** 2)

    step, shell = peak(h_true)
    fast = step * FRAMES / (2.0 * math.pi) >= 0.5
    q = slow_share * shell
    q[fast] = 0.3 * peak(h_fast)[1][fast]
    q += (floor if seed is None
          else np.random.default_rng(seed).gamma(0.5, floor, q.shape))
    return {"q": q.astype(np.float32), "kx": kx, "ky": ky, "kappa": kappa,
            "frames": FRAMES}, fast


def _grid(est: DispersionAltimeter) -> np.ndarray:
    lo, hi = (math.log(a) for a in est.altitude_range_m)
    step = (hi - lo) / (est.n_scan - 1)
    return np.arange(lo - math.log(AIDED_SCAN_BELOW), hi + math.log(AIDED_SCAN_ABOVE)
                     + step / 2, step)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_plain_scans_most_prominent_peak_is_always_refined(seed: int) -> None:
    """Whatever the table, one of the aided fits lies within four coarse steps of the plain
    scan's most prominent peak in the range (SciPy's prominences), and the result is the
    first fit's unless a later one is trusted and better graded, or significant where the
    first is not."""
    rng = np.random.default_rng(seed)
    kx, ky, kappa = _lattice(math.pi)
    q = rng.gamma(0.5, 0.05, (kappa.size, N_PSI)).astype(np.float32)
    p = {"q": q, "kx": kx, "ky": ky, "kappa": kappa, "frames": FRAMES}
    est = DispersionAltimeter(dispersion="gravity")
    velocity = tuple(rng.uniform(-0.5, 0.5, 2))
    fits = est._fit_aided(p, FPS, FOCAL_PX, velocity)
    grid, scan = _grid(est), fits[0]["scan"]
    step = grid[1] - grid[0]
    lo, hi = (math.log(a) for a in est.altitude_range_m)
    peaks, props = scipy.signal.find_peaks(scan, prominence=0)
    near = np.abs(grid[peaks] - 0.5 * (lo + hi)) <= 0.5 * (hi - lo) + step
    top = grid[peaks[near][np.argmax(props["prominences"][near])]]
    assert min(abs(f["logh"] - top) for f in fits) <= 4 * step + 1e-9
    graded = [est._result(p, f, FRAMES, FPS, FOCAL_PX) for f in fits]
    want = graded[0]
    for alt in graded[1:]:
        if ((alt.quality >= TRUSTED_QUALITY and alt.quality > want.quality)
                or alt.significance >= MIN_SIGNIFICANCE > want.significance):
            want = alt
    res = est._aided(p, FRAMES, FPS, FOCAL_PX, velocity)
    assert (res.altitude_m, res.quality) == (want.altitude_m, want.quality)


def test_a_shell_that_only_the_slow_modes_hold_is_kept_over_the_weighted_peak() -> None:
    """The turn weighting leaves out the modes that turn less than half a cycle; where
    they alone hold the shell and the turning modes hold faster content (a high camera,
    a short clip, the optics' sum products on the short modes), the weighted scan peaks
    low and ungraded, and the plain scan's peak, refined and trusted, is the result."""
    est = DispersionAltimeter(dispersion="gravity")
    h_true = 9.0
    p, fast = _split_table(h_true, 0.7 * h_true)
    assert 0.3 < fast.mean() < 0.9
    fits = est._fit_aided(p, FPS, FOCAL_PX, (0.0, 0.0))
    first = est._result(p, fits[0], FRAMES, FPS, FOCAL_PX)
    assert first.altitude_m < 0.8 * h_true and first.quality < TRUSTED_QUALITY
    res = est._aided(p, FRAMES, FPS, FOCAL_PX, (0.0, 0.0))
    # the plain scan blends in the faster content too, but reads far nearer the shell
    assert abs(math.log(res.altitude_m / h_true)) < 0.5 * abs(math.log(first.altitude_m
                                                                     / h_true))
    assert res.quality >= TRUSTED_QUALITY


def test_a_significant_candidate_replaces_a_first_fit_that_is_not() -> None:
    """A first fit no more significant than random phase steps (``MIN_SIGNIFICANCE``) tells
    nothing of where the shell is: a later candidate that is significant replaces it, though
    neither is graded high enough to be trusted; but not from within ``EDGE_FACTOR`` of an
    end of the range."""
    est = DispersionAltimeter(dispersion="gravity")
    p, _ = _split_table(12.0, 6.0, slow_share=0.6, seed=0)
    graded = [est._result(p, f, FRAMES, FPS, FOCAL_PX)
              for f in est._fit_aided(p, FPS, FOCAL_PX, (0.0, 0.0))]
    assert graded[0].significance < MIN_SIGNIFICANCE
    later = [r for r in graded[1:] if r.significance >= MIN_SIGNIFICANCE]
    assert later and all(r.quality < TRUSTED_QUALITY for r in later)
    res = est._aided(p, FRAMES, FPS, FOCAL_PX, (0.0, 0.0))
    assert res.significance >= MIN_SIGNIFICANCE
    assert res.altitude_m == later[0].altitude_m
    assert abs(math.log(res.altitude_m / 12.0)) < abs(math.log(graded[0].altitude_m / 12.0))
    # the same candidate within EDGE_FACTOR of the top of a narrower range: not taken
    top = DispersionAltimeter(dispersion="gravity", altitude_range_m=(0.5, 8.5))
    first, *rest = [top._result(p, f, FRAMES, FPS, FOCAL_PX)
                    for f in top._fit_aided(p, FPS, FOCAL_PX, (0.0, 0.0))]
    assert first.significance < MIN_SIGNIFICANCE
    assert any(r.significance >= MIN_SIGNIFICANCE and r.altitude_m > 8.5 / EDGE_FACTOR
               for r in rest)
    kept = top._aided(p, FRAMES, FPS, FOCAL_PX, (0.0, 0.0))
    assert kept.altitude_m == first.altitude_m
