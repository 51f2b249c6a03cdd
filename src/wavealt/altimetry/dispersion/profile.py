"""The blind profile: the periodogram score over log altitude with the velocity fitted again
at every altitude, its peak, and the velocity searches that follow it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wavealt.altimetry.dispersion.constants import (
    ALIAS_MODE_FRACTION,
    BLIND_PEAK_CANDIDATES,
    BLIND_PROFILE_ABOVE_LOG,
    BLIND_PROFILE_STEP_LOG,
    MIN_SIGNIFICANCE,
)
from wavealt.altimetry.dispersion.search import (
    _most_prominent,
    _parabolic_peak,
    null_score,
    null_sd,
    peak_prominences,
)


class _Profile:
    """The blind and prior-disk fits of :class:`DispersionAltimeter` (uses the score of
    :class:`~wavealt.altimetry.dispersion.search._Search`, ``altitude_range_m`` and the
    dispersion relation)."""

    def _best_velocity(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                       logh: float, u: np.ndarray, modes: np.ndarray | None, step: float,
                       min_step: float = 0.0015) -> tuple[float, np.ndarray]:
        """Image velocity (px/frame) of highest score at altitude ``exp(logh)``: a compass
        (pattern) search from ``u``, nine candidates per call, halving ``step`` to
        ``min_step``."""
        off = np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)], dtype=np.float64)
        lg = np.full(9, logh)
        best = float(self._score(p, fps, focal_px, lg[:1], u[:1], u[1:], modes)[0])
        while step >= min_step:
            cand = u[None, :] + step * off
            val = self._score(p, fps, focal_px, lg, cand[:, 0], cand[:, 1], modes)
            j = int(np.argmax(val))
            if j != 4 and val[j] > best:
                best, u = float(val[j]), cand[j]
            else:
                step *= 0.5
        return best, u

    def _alias_floor_log(self, p: dict[str, Any], fps: float, focal_px: float) -> float:
        """Log of the lowest altitude at which ``ALIAS_MODE_FRACTION`` of the periodogram's
        modes have a wave phase step ``omega(kappa focal_px / h) / fps`` below half a cycle.

        ``omega`` grows with ``k``, so that altitude is ``focal_px kappa_q / k_pi``, with
        ``kappa_q`` the modes' ``ALIAS_MODE_FRACTION`` quantile and ``omega(k_pi) = pi fps``
        (bisection in log ``k``; gravity alone: ``k_pi = (pi fps)^2 / g``).
        """
        target = math.pi * fps
        lo_k, hi_k = math.log(1e-6), math.log(1e9)
        for _ in range(60):
            mid = 0.5 * (lo_k + hi_k)
            if float(self.omega(np.array([math.exp(mid)]))[0]) < target:
                lo_k = mid
            else:
                hi_k = mid
        kappa_q = float(np.quantile(p["kappa"], ALIAS_MODE_FRACTION))
        return math.log(focal_px * kappa_q) - 0.5 * (lo_k + hi_k)

    def _fit_blind(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                   logh0: float, u0: np.ndarray,
                   prior: tuple[float, float, float] | None = None) -> dict[str, Any]:
        """Velocity unknown (or known to a disk, ``prior``): the profile of the periodogram
        score over log altitude, the velocity re-fitted at every altitude.

        The per-mode phase steps of the cross-spectra are biased on rendered frames: the
        difference-frequency products of the non-linear optics (wave groups, which move at
        the drift plus half the phase speed) pull every measured step toward a slower shell,
        and a slower shell plus more drift fits them (+10 to +40 % in altitude on the paper
        renderer).  The periodogram separates the shell from those products once the clip
        resolves them (about 1 s); along the profile, a drift that trades against altitude
        leaves a flat profile, which the quality and the mode groups' spread along it report
        (:meth:`_result`).  The profile follows the ridge from the phase-step fit
        ``(logh0, u0)`` (``u0`` in the periodogram's convention) up to x1.5 of its altitude
        (its bias is mostly upward) and down to the lowest altitude the frame rate can test
        (:meth:`_alias_floor_log`): a start may be many times too high, up to the top of
        the range where short, nearly non-dispersive waves pass for a frozen pattern in
        translation.  Of its most prominent peaks, the most prominent one that is
        significant on every mode is refined on all modes like the aided fit.

        ``prior = (vx, vy, radius)``, m/s: the camera's velocity over the water lies within
        ``radius`` of ``(vx, vy)``.  The profile is the blind one; the prior chooses among its
        peaks (:meth:`_significant_peak`).  Keeping every velocity searched inside the disk
        was tried and was worse than no prior at all (realistic preset, 10 frames, tuning
        seed 202: relative MAE 58 / 48 % against 35 / 30 % blind): the ridge, pinned to the
        disk's rim, led the continuation away from the shell.
        """
        lo, hi = (math.log(a) for a in self.altitude_range_m)
        step = BLIND_PROFILE_STEP_LOG
        low = max(lo, self._alias_floor_log(p, fps, focal_px))
        top = max(logh0 + BLIND_PROFILE_ABOVE_LOG, low + 4.0 * step)
        # the grid passes through the start, which is where the continuation begins
        # (a hair of tolerance keeps ends that are whole steps away on the grid)
        if logh0 > low:
            grid = logh0 + np.arange(-math.floor((logh0 - low) / step + 1e-9),
                                     math.floor((top - logh0) / step + 1e-9) + 1) * step
        else:
            grid = low + np.arange(0, math.floor((top - low) / step + 1e-9) + 1) * step
        n = p["kappa"].size
        sub = np.arange(0, n, max(1, n // 1500))
        scan = np.empty(grid.size)
        path = np.empty((grid.size, 2))
        j0 = int(np.argmin(np.abs(grid - logh0)))
        for order in (range(j0, grid.size), range(j0 - 1, -1, -1)):
            u = np.asarray(u0, dtype=np.float64)
            for j in order:  # continuation along the ridge
                scan[j], u = self._best_velocity(p, fps, focal_px, float(grid[j]), u, sub, 0.02)
                path[j] = u
        self._fill_dips(p, fps, focal_px, grid, scan, path, sub)
        i, prominence, interior = self._significant_peak(p, fps, focal_px, scan, grid, path,
                                                          prior)
        local = grid[i] + np.linspace(-1.0, 1.0, 5) * step
        us = np.empty((local.size, 2))
        for j, lg in enumerate(local):
            us[j] = self._best_velocity(p, fps, focal_px, float(lg), path[i], None, 0.005)[1]
        # per-mode values along the ridge: the group spread then includes the drift's trade
        vals = self._mode_values(p, fps, focal_px, local, us[:, 0], us[:, 1])
        mean = vals.mean(axis=1)
        logh = float(np.clip(_parabolic_peak(local, mean), lo, hi))
        u = np.array([np.interp(logh, local, us[:, 0]), np.interp(logh, local, us[:, 1])])
        # every mode along the whole ridge: the mode groups' peaks there give the uncertainty
        ridge = self._mode_values(p, fps, focal_px, grid, path[:, 0], path[:, 1])
        # the profile's noise: the sd of its score under random phase steps
        noise = null_sd(p, sub)
        return {"logh": logh, "u": u, "scan": scan, "interior": interior,
                "prominence": prominence, "prominence_z": prominence / max(noise, 1e-30),
                "local": local, "vals": vals, "ridge": (grid, ridge)}

    def _fill_dips(self, p: dict[str, Any], fps: float, focal_px: float, grid: np.ndarray,
                   scan: np.ndarray, path: np.ndarray, modes: np.ndarray) -> None:
        """Raise, in place, the points of the blind profile that lie below both neighbours
        by searching their velocity again from each neighbour's.

        The profile is the score maximised over the velocity at every altitude; the
        continuation finds a local maximum, and where it starts (from the phase-step
        start's velocity, which may lie far off) one point can hold a poor one, making a
        prominent false peak beside it (a trusted 14 m for 5 m; ``docs/dispersion.md``).
        Searched again from a neighbour's velocity, a point's score can only rise.
        """
        for _ in range(len(grid)):
            inner = scan[1:-1]
            dips = np.flatnonzero((inner < scan[:-2]) & (inner < scan[2:])) + 1
            raised = False
            for j in dips:
                for nb in (j - 1, j + 1):
                    val, u = self._best_velocity(p, fps, focal_px, float(grid[j]),
                                                 path[nb].copy(), modes, 0.02)
                    if val > scan[j] * (1.0 + 1e-6):
                        scan[j], path[j] = val, u
                        raised = True
            if not raised:
                return

    def _significant_peak(self, p: dict[str, Any], fps: float, focal_px: float,
                          scan: np.ndarray, grid: np.ndarray, path: np.ndarray,
                          prior: tuple[float, float, float] | None = None
                          ) -> tuple[int, float, bool]:
        """The blind profile's peak (index, prominence, inside the range): of the
        ``BLIND_PEAK_CANDIDATES`` most prominent, the first whose score on every mode is
        significant (:func:`null_score`), else the most prominent (:func:`_most_prominent`).
        With a ``prior`` (:meth:`_fit_blind`), the first significant one whose velocity
        along the ridge lies in the prior's disk comes before the others."""
        lo, hi = (math.log(a) for a in self.altitude_range_m)
        step = grid[1] - grid[0]
        peaks, prom = peak_prominences(scan)
        null_mean, null_sd = null_score(p)
        significant = []
        for k in np.argsort(-prom, kind="stable")[:BLIND_PEAK_CANDIDATES]:
            j = int(peaks[k])
            score = float(self._score(p, fps, focal_px, grid[j:j + 1], path[j:j + 1, 0],
                                      path[j:j + 1, 1])[0])
            if (score - null_mean) / max(null_sd, 1e-30) >= MIN_SIGNIFICANCE:
                significant.append((j, float(prom[k]), bool(lo - step <= grid[j] <= hi + step)))
        if prior is not None:
            for peak in significant:
                j = peak[0]
                v = path[j] * fps * math.exp(grid[j]) / focal_px  # px/frame -> m/s
                if math.hypot(v[0] - prior[0], v[1] - prior[1]) <= prior[2]:
                    return peak
        if significant:
            return significant[0]
        return _most_prominent(scan, grid, lo - step, hi + step)
