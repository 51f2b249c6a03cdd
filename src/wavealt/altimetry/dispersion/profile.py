"""The blind profile: the periodogram score over log altitude with the velocity fitted again
at every altitude, its peak, and the velocity searches that follow it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wavealt.altimetry.dispersion.constants import (
    ALIAS_MODE_FRACTION,
    BLIND_MAX_SPEED_MPS,
    BLIND_PEAK_CANDIDATES,
    BLIND_PROFILE_ABOVE_LOG,
    BLIND_PROFILE_STEP_LOG,
    BLIND_REFINE_MIN_KAPPA,
    BLIND_SEED_EVERY,
    BLIND_SEED_MIN_Z,
    BLIND_SEED_PEAKS,
    CARRIED_MAP_PEAKS,
    MIN_PROMINENCE_Z,
    MIN_REFINE_MODES,
    MIN_SIGNIFICANCE,
)
from wavealt.altimetry.dispersion.kernel import compiled_module
from wavealt.altimetry.dispersion.search import (
    _most_prominent,
    _parabolic_peak,
    null_score,
    null_sd,
    peak_prominences,
    significance,
)
from wavealt.altimetry.dispersion.velocity_map import _VelocityMap


class _Profile(_VelocityMap):
    """The blind and prior-disk fits of :class:`DispersionAltimeter` (uses the score of
    :class:`~wavealt.altimetry.dispersion.search._Search`, ``altitude_range_m`` and the
    dispersion relation)."""

    def _best_velocity(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                       logh: float, u: np.ndarray, modes: np.ndarray | None, step: float,
                       min_step: float = 0.0015) -> tuple[float, np.ndarray]:
        """Image velocity (px/frame) of highest score at altitude ``exp(logh)``: a compass
        (pattern) search from ``u``, the eight neighbours ``step`` away per call (the
        centre's score is known), halving ``step`` to ``min_step``.  The compiled form
        (:func:`~wavealt.altimetry.dispersion.compiled.compass`) gives the same bits.

        A search is a function of its arguments: the profile's passes repeat some (a dip
        searched again from the same neighbour), and each is made once per periodogram
        (``p["_searched"]``, keyed by the lookup arrays of ``modes``, which ``p`` holds)."""
        key = (id(self._lookup(p, modes)), float(fps), float(focal_px), float(logh),
               float(u[0]), float(u[1]), float(step), float(min_step))
        searched = p.setdefault("_searched", {})
        if key not in searched:
            searched[key] = self._compass_search(p, fps, focal_px, logh, u, modes, step,
                                                 min_step)
        best, found = searched[key]
        return best, found.copy()

    def _compass_search(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                        logh: float, u: np.ndarray, modes: np.ndarray | None, step: float,
                        min_step: float) -> tuple[float, np.ndarray]:
        """The compass search of :meth:`_best_velocity`, made."""
        ck = compiled_module()
        if ck is not None:
            om, a, to_bins = self._compass_row(p, fps, focal_px, logh, modes)
            best, ux, uy = ck.compass(om, a["kx"], a["ky"], a["pair"], float(u[0]),
                                      float(u[1]), float(step), float(min_step), to_bins)
            return best, np.array([ux, uy])
        off = np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy],
                       dtype=np.float64)
        lg = np.full(off.shape[0], logh)
        best = float(self._score(p, fps, focal_px, lg[:1], u[:1], u[1:], modes)[0])
        while step >= min_step:
            cand = u[None, :] + step * off
            val = self._score(p, fps, focal_px, lg, cand[:, 0], cand[:, 1], modes)
            j = int(np.argmax(val))
            if val[j] > best:
                best, u = float(val[j]), cand[j]
            else:
                step *= 0.5
        return best, u

    def _compass_row(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                     logh: float, modes: np.ndarray | None
                     ) -> tuple[np.ndarray, dict[str, np.ndarray], float]:
        """What the compiled compass search takes at altitude ``exp(logh)``: the modes'
        phase steps (table bins, one contiguous row), their lookup arrays and the bins per
        radian."""
        a = self._lookup(p, modes)
        to_bins = a["pair"].shape[1] / (2.0 * np.pi)
        om = self._omega_row(p, a, np.array([logh]), fps, focal_px, to_bins)
        return np.ascontiguousarray(om), a, to_bins

    def _alias_floor_log(self, p: dict[str, Any], fps: float, focal_px: float) -> float:
        """Log of the lowest altitude at which ``ALIAS_MODE_FRACTION`` of the periodogram's
        modes have a wave phase step ``omega(kappa focal_px / h) / fps`` below half a cycle.

        ``omega`` grows with ``k``, so that altitude is ``focal_px kappa_q / k_pi``, with
        ``kappa_q`` the modes' ``ALIAS_MODE_FRACTION`` quantile and ``omega(k_pi) = pi fps``
        (bisection in log ``k``; gravity alone: ``k_pi = (pi fps)^2 / g``; cached per
        dispersion relation, water depth and frame rate).
        """
        log_k_pi = self.__dict__.setdefault("_log_k_pi", {})
        key = (self.dispersion, self.water_depth_m, float(fps))
        if key not in log_k_pi:
            target = math.pi * fps
            lo_k, hi_k = math.log(1e-6), math.log(1e9)
            for _ in range(60):
                mid = 0.5 * (lo_k + hi_k)
                if float(self.omega(np.array([math.exp(mid)]))[0]) < target:
                    lo_k = mid
                else:
                    hi_k = mid
            log_k_pi[key] = 0.5 * (lo_k + hi_k)
        kappa_q = float(np.quantile(p["kappa"], ALIAS_MODE_FRACTION))
        return math.log(focal_px * kappa_q) - log_k_pi[key]

    def _fit_blind(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                   logh0: float, u0: np.ndarray,
                   prior: tuple[float, float, float] | None = None) -> dict[str, Any]:
        """The blind profile fit (:meth:`_profile_fit`) from the phase-step start
        ``(logh0, u0)``, and again over the whole range from the velocity map where the
        start's profile holds no significant peak and that one holds a shell's.

        The profile from a start covers the altitudes a start may be wrong by (x1.5 above
        it, down to the frame rate's floor).  On a faint sea (texture a fraction of the
        noise) the phase-step start may be several times off, and the shell then lies beyond
        that profile: the peak it keeps scores no better than random phase steps
        (``MIN_SIGNIFICANCE``), which is no evidence of where the shell is.  The profile
        over the whole range, its velocity searched from the map as for a start that ran
        off the range (:meth:`_seed_profile`), replaces it where its own peak is both
        significant and prominent above the profile's noise (``MIN_PROMINENCE_Z``): the
        higher of two peaks that both fail the significance is noise, and a significant
        peak without prominence is the top of a ridge that rises toward an end of the
        range (``docs/dispersion.md``, fifteenth session).
        """
        fit = self._profile_fit(p, fps, focal_px, logh0, u0, prior)
        lo = math.log(self.altitude_range_m[0])
        if fit["z"] >= MIN_SIGNIFICANCE or logh0 <= lo + BLIND_PROFILE_ABOVE_LOG:
            return fit  # significant, or already the whole range from the map
        wide = self._profile_fit(p, fps, focal_px, lo, u0, prior)
        shell = wide["z"] >= MIN_SIGNIFICANCE and wide["prominence_z"] >= MIN_PROMINENCE_Z
        return wide if shell else fit

    def _profile_fit(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                     logh0: float, u0: np.ndarray,
                     prior: tuple[float, float, float] | None = None) -> dict[str, Any]:
        """Velocity unknown (or known to a disk, ``prior``): the profile of the periodogram
        score over log altitude, the velocity re-fitted at every altitude.

        The per-mode phase steps of the cross-spectra are biased on rendered frames: the
        difference-frequency products of the non-linear optics (wave groups, which move at
        the drift plus half the phase speed) pull every measured step toward a slower shell,
        and a slower shell plus more drift fits them (by tens of per cent in altitude on
        rendered frames).  The periodogram separates the shell from those products once the clip
        resolves them (about 1 s); along the profile, a drift that trades against altitude
        leaves a flat profile, which the quality and the mode groups' spread along it report
        (:meth:`_result`).  The profile follows the ridge from the phase-step fit
        ``(logh0, u0)`` (``u0`` in the periodogram's convention) up to x1.5 of its altitude
        (its bias is mostly upward) and down to the lowest altitude the frame rate can test
        (:meth:`_alias_floor_log`): a start may be many times too high, up to the top of
        the range where short, nearly non-dispersive waves pass for a frozen pattern in
        translation.  A start within a profile step of the top of the range, or less than
        x1.5 above its bottom (a failed Gauss-Newton start ends near a bound), ran off the
        range and tells nothing, of the altitude nor of the velocity: from the bottom, the
        profile runs to the top of the range, and from either end it is also searched from
        a global map of the velocity (:meth:`_seed_profile`).  Of its most prominent peaks,
        the most prominent one that is significant on every mode is refined like the aided
        fit, on the modes above the bottom of the band (``BLIND_REFINE_MIN_KAPPA``): the
        bottom holds the optics' slow difference products as well as the waves.

        ``prior = (vx, vy, radius)``, m/s: the camera's velocity over the water lies within
        ``radius`` of ``(vx, vy)``.  The profile is the blind one; the prior chooses among its
        peaks (:meth:`_significant_peak`).  Keeping every velocity searched inside the disk
        does worse than no prior at all: the ridge, pinned to the disk's rim, leads the
        continuation away from the shell (``docs/dispersion.md``, seventh session).
        """
        lo, hi = (math.log(a) for a in self.altitude_range_m)
        step = BLIND_PROFILE_STEP_LOG
        low = max(lo, self._alias_floor_log(p, fps, focal_px))
        # a start that ran off the range (see above)
        bottom = logh0 <= lo + BLIND_PROFILE_ABOVE_LOG
        pinned = bottom or logh0 >= hi - step
        top = hi if bottom else max(logh0 + BLIND_PROFILE_ABOVE_LOG, low + 4.0 * step)
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
        if pinned:
            self._seed_profile(p, fps, focal_px, grid, scan, path, sub)
        self._fill_dips(p, fps, focal_px, grid, scan, path, sub)
        # the highest point's velocity, followed both ways while it raises the profile by
        # more than its noise: the continuation from the start can hold a poor velocity over
        # a stretch of altitudes, and the profile then steps up where it finds the shell's
        # instead of peaking (a raise within the noise is another local maximum of the same
        # ridge, and following it would search the whole profile again)
        noise = null_sd(p, sub)  # the profile's noise: its score's sd under random steps
        top = int(np.argmax(scan))
        self._carry_outward(p, fps, focal_px, grid, scan, path, sub, [(top, -1), (top, 1)],
                            noise)
        i, prominence, interior = self._significant_peak(p, fps, focal_px, scan, grid, path,
                                                          noise, prior)
        local = grid[i] + np.linspace(-1.0, 1.0, 5) * step
        # refined on the shorter modes (BLIND_REFINE_MIN_KAPPA: the optics' slow products
        # fill the bottom of the band)
        fine = np.flatnonzero(p["kappa"] >= BLIND_REFINE_MIN_KAPPA)
        fine = fine if fine.size >= MIN_REFINE_MODES else None
        us = np.empty((local.size, 2))
        for j, lg in enumerate(local):
            us[j] = self._best_velocity(p, fps, focal_px, float(lg), path[i], fine, 0.005)[1]
        # per-mode values along the ridge: the group spread then includes the drift's trade
        vals = self._mode_values(p, fps, focal_px, local, us[:, 0], us[:, 1])
        mean = (vals if fine is None else vals[:, fine]).mean(axis=1)
        logh = float(np.clip(_parabolic_peak(local, mean), lo, hi))
        u = np.array([np.interp(logh, local, us[:, 0]), np.interp(logh, local, us[:, 1])])
        # every mode along the whole ridge: the mode groups' peaks there give the uncertainty
        ridge = self._mode_values(p, fps, focal_px, grid, path[:, 0], path[:, 1])
        return {"logh": logh, "u": u, "z": significance(p, vals), "scan": scan,
                "interior": interior, "prominence": prominence,
                "prominence_z": prominence / max(noise, 1e-30),
                "local": local, "vals": vals, "ridge": (grid, ridge),
                "band_log": paired_band(grid, ridge, i)}

    def _seed_profile(self, p: dict[str, Any], fps: float, focal_px: float, grid: np.ndarray,
                      scan: np.ndarray, path: np.ndarray, modes: np.ndarray) -> None:
        """Raise, in place, the blind profile where a global search of the velocity finds a
        far better one than the continuation, and carry the better velocity along the ridge
        (:meth:`_fit_blind` calls it where the phase-step start is pinned to an end of the
        range: a start that ran off the range carries no velocity).

        The continuation follows the local maximum of the score over the velocity nearest
        the start, and from a velocity far off it never reaches the shell's ridge.  Every
        ``BLIND_SEED_EVERY``-th altitude of the profile, the best of the few best velocities
        of a coarse map (:meth:`_velocity_map_peaks`), scored on the profile's modes, is
        refined; where its score beats the profile by ``BLIND_SEED_MIN_Z`` of the profile's
        noise it replaces it (the best of many velocities on noise beats the continuation
        by a few sigma, most at low altitudes, where the velocity range searched is widest)
        and is carried outward along the profile while it raises it.
        """
        noise = null_sd(p, modes)
        raised = []
        for j in range(0, grid.size, BLIND_SEED_EVERY):
            best = self._map_best_velocity(p, fps, focal_px, float(grid[j]), modes,
                                           BLIND_SEED_PEAKS)
            if best is None:
                continue
            val, u = best
            if val > scan[j] + BLIND_SEED_MIN_Z * noise:
                scan[j], path[j] = val, u
                raised += [(j, -1), (j, 1)]
        self._carry_outward(p, fps, focal_px, grid, scan, path, modes, raised)

    def _carry_outward(self, p: dict[str, Any], fps: float, focal_px: float,
                       grid: np.ndarray, scan: np.ndarray, path: np.ndarray,
                       modes: np.ndarray | None, starts: list[tuple[int, int]],
                       margin: float = 0.0) -> None:
        """Carry, in place, the velocity of each profile point ``j`` of ``starts`` (``(j,
        way)``, ``way`` -1 or +1) outward along the profile in that direction, searched again
        at each next point from it (the same velocity in m/s), while it raises the profile
        (by more than ``margin`` of the score, where given)."""
        raised = list(starts)
        while raised:
            j, way = raised.pop()
            nb = j + way
            # the same velocity in m/s: px/frame scales as 1 / altitude
            if 0 <= nb < grid.size and self._search_again(
                    p, fps, focal_px, grid, scan, path, modes, nb,
                    path[j] * math.exp(grid[j] - grid[nb]), margin):
                raised.append((nb, way))

    def _search_again(self, p: dict[str, Any], fps: float, focal_px: float,
                      grid: np.ndarray, scan: np.ndarray, path: np.ndarray,
                      modes: np.ndarray | None, j: int, u0: np.ndarray,
                      margin: float = 0.0) -> bool:
        """Search the velocity of profile point ``j`` again from ``u0`` and keep it, in
        place, where it scores more than the point holds (by more than ``margin``); whether
        it did."""
        val, u = self._best_velocity(p, fps, focal_px, float(grid[j]), u0, modes, 0.02)
        if val > scan[j] * (1.0 + 1e-6) + margin:
            scan[j], path[j] = val, u
            return True
        return False

    def _best_line(self, p: dict[str, Any], fps: float,
                   focal_px: float) -> tuple[float, np.ndarray] | None:
        """The score and image velocity (px/frame) of the best line of phase steps
        ``-kappa . u`` (no wave term: a pattern carried without dispersion) on every mode of
        ``p``, the velocity map's ``CARRIED_MAP_PEAKS`` best peaks refined; None where the
        map has none.  Cached in ``p``: the foam's removal and the trust test share it."""
        if "_line" not in p:
            lo = self.altitude_range_m[0]
            p["_line"] = self._map_best_velocity(p, fps, focal_px, math.inf, None,
                                                 CARRIED_MAP_PEAKS,
                                                 BLIND_MAX_SPEED_MPS * focal_px / (lo * fps),
                                                 0.005)
        return p["_line"]

    def _carried_velocity(self, p: dict[str, Any], fps: float,
                          focal_px: float) -> tuple[np.ndarray, float]:
        """The image velocity (px/frame, the table's convention) of the strongest pattern
        the clip carries across the image without dispersion, and how broadly it is
        carried: the median over the modes of each mode's share at the pattern's phase step
        ``-kappa . u`` over its mean share.

        The velocity maximises the score with no wave term (``omega = 0``): the best of the
        velocity map's few best peaks (:meth:`_velocity_map_peaks`), scored on every mode,
        refined.  Foam and floating matter ride with the water and fill every mode; the
        score's maximum alone does not tell them apart from a velocity whose line of phase
        steps crosses the wave shell, where a band of modes that the waves fill wholly
        makes a high score while most modes hold nothing there (``CARRIED_MIN_RATIO``).
        """
        best = self._best_line(p, fps, focal_px)
        if best is None:
            return np.zeros(2), 0.0
        u = best[1]
        vals = self._mode_values(p, fps, focal_px, np.array([math.inf]), u[:1], u[1:])[0]
        if "_qbar" not in p:
            p["_qbar"] = p["q"].mean(axis=1)
        return u, float(np.median(vals / np.maximum(p["_qbar"], 1e-30)))

    def _fill_dips(self, p: dict[str, Any], fps: float, focal_px: float, grid: np.ndarray,
                   scan: np.ndarray, path: np.ndarray, modes: np.ndarray) -> None:
        """Raise, in place, the points of the blind profile that lie below both neighbours
        by searching their velocity again from each neighbour's.

        The profile is the score maximised over the velocity at every altitude; the
        continuation finds a local maximum, and where it starts (from the phase-step
        start's velocity, which may lie far off) one point can hold a poor one, making a
        prominent false peak beside it, which can be trusted (``docs/dispersion.md``).
        Searched again from a neighbour's velocity, a point's score can only rise.
        """
        for _ in range(len(grid)):
            inner = scan[1:-1]
            dips = np.flatnonzero((inner < scan[:-2]) & (inner < scan[2:])) + 1
            raised = False
            for j in dips:
                for nb in (j - 1, j + 1):
                    if self._search_again(p, fps, focal_px, grid, scan, path, modes, j,
                                          path[nb].copy()):
                        raised = True
            if not raised:
                return

    def _significant_peak(self, p: dict[str, Any], fps: float, focal_px: float,
                          scan: np.ndarray, grid: np.ndarray, path: np.ndarray,
                          noise: float, prior: tuple[float, float, float] | None = None
                          ) -> tuple[int, float, bool]:
        """The blind profile's peak (index, prominence, inside the range): of the
        ``BLIND_PEAK_CANDIDATES`` most prominent, those whose score on every mode is
        significant (:func:`null_score`) in the order of :func:`rank_peaks`, else the most
        prominent (:func:`_most_prominent`); ``noise``: the profile's standard deviation
        under random phase steps.  With a ``prior`` (:meth:`_fit_blind`), the first
        significant one whose velocity along the ridge lies in the prior's disk comes
        before the others."""
        lo, hi = (math.log(a) for a in self.altitude_range_m)
        step = grid[1] - grid[0]
        peaks, prom = peak_prominences(scan)
        null_mean, null_spread = null_score(p)
        significant = []
        for k in np.argsort(-prom, kind="stable")[:BLIND_PEAK_CANDIDATES]:
            j = int(peaks[k])
            score = float(self._score(p, fps, focal_px, grid[j:j + 1], path[j:j + 1, 0],
                                      path[j:j + 1, 1])[0])
            if (score - null_mean) / max(null_spread, 1e-30) >= MIN_SIGNIFICANCE:
                significant.append((j, float(prom[k]), bool(lo - step <= grid[j] <= hi + step)))
        significant = rank_peaks(significant, scan, MIN_PROMINENCE_Z * noise)
        if prior is not None:
            for peak in significant:
                j = peak[0]
                v = path[j] * fps * math.exp(grid[j]) / focal_px  # px/frame -> m/s
                if math.hypot(v[0] - prior[0], v[1] - prior[1]) <= prior[2]:
                    return peak
        if significant:
            return significant[0]
        return _most_prominent(scan, grid, lo - step, hi + step)


def rank_peaks(peaks: list[tuple[int, float, bool]], scan: np.ndarray, bar: float
               ) -> list[tuple[int, float, bool]]:
    """Profile peaks ``(index, prominence, inside the range)``, given most prominent first,
    in the order the blind fit takes them: those inside the altitude range that stand out of
    the profile by ``bar`` (its noise times ``MIN_PROMINENCE_Z``), highest first, then the
    others as given.

    The profile is the score, the clip's share that the shell explains, maximised over the
    velocity at each altitude: of two peaks that each stand out of its noise, the higher is
    the better fit.  Prominence measures how a peak stands out, not how much it explains:
    ranked by it, the shell of a high sea, whose profile falls only a few per cent (yet
    several sigma) from it to the top of the range, loses to a small bump near the bottom
    of the range that explains far less but stands out more (a reading far below the truth;
    ``docs/dispersion.md``, fifty-first session).  A ridge that rises to an end of the range
    makes no peak there, a bump on it within the noise is not ranked by its height, and a
    peak beyond the range (the profile reaches past it to measure a peak's fall) is no
    answer however high.
    """
    strong = sorted((pk for pk in peaks if pk[1] >= bar and pk[2]),
                    key=lambda pk: -scan[pk[0]])
    return strong + [pk for pk in peaks if pk not in strong]


def paired_band(grid: np.ndarray, ridge: np.ndarray, i: int, t_max: float = 1.0) -> float:
    """Half-width, in log altitude, of the stretch of the blind ridge around its point ``i``
    that point ``i`` does not beat by ``t_max`` standard errors: at each point ``j`` the
    per-mode differences ``ridge[i] - ridge[j]`` (``ridge``: ``(grid, modes)`` explained
    shares along the ridge) give a paired t statistic, mean over standard error.  Where the
    stretch reaches an end of the grid it counts a step beyond it.  A flat ridge (drift
    trading against altitude) makes a wide band however well the mode groups agree
    (``PAIRED_BAND_SD_FRACTION``)."""
    diff = ridge[i][None, :].astype(np.float64) - ridge
    se = diff.std(axis=1) / math.sqrt(max(ridge.shape[1], 1))
    t = diff.mean(axis=1) / np.maximum(se, 1e-30)
    t[i] = 0.0
    step = float(grid[1] - grid[0]) if grid.size > 1 else 0.0
    ends = []
    for way in (-1, 1):
        j = i
        while 0 <= j + way < grid.size and t[j + way] < t_max:
            j += way
        nb = j + way
        if 0 <= nb < grid.size:  # where t crosses t_max, between j and nb
            ends.append(grid[j] + (t_max - t[j]) / (t[nb] - t[j]) * (grid[nb] - grid[j]))
        else:
            ends.append(grid[j] + way * step)
    return float(0.5 * (ends[1] - ends[0]))
