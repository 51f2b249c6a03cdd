"""Uncertainty and trust: the spread of the shell's peak over bands of wavenumber, the peak's
prominence and significance, and the decision whether a result may be used."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wavealt.altimetry.dispersion.attitude import (
    chi2_quantile,
    cochran_q,
    tile_centres,
    unlevelled_tilt_var_log,
    unmeasured_tilt_var_log,
)
from wavealt.altimetry.dispersion.constants import (
    BAND_CALIBRATED_MIN_FRAMES,
    BAND_SHORT_CLIP_POWER,
    BLIND_SD_FLOOR_LOG,
    EDGE_FACTOR,
    FULL_CLIP_FRAMES,
    GROUP_PEAK_WITHIN_LOG,
    MAX_TRUSTED_3SIGMA,
    MIN_PROMINENCE_Z,
    MIN_SIGNIFICANCE,
    PAIRED_BAND_SD_FRACTION,
    PROFILE_PROMINENCE,
    REFERENCE_FPS,
    RESOLUTION_FRACTION,
    RIGID_MAX_RATIO,
    SCAN_PROMINENCE,
    SD_FLOOR_LOG,
    TILE_AGREEMENT_SIGMAS,
    TILE_SCATTER_LEVEL,
    TRUSTED_QUALITY,
)
from wavealt.altimetry.dispersion.result import DispersionResult
from wavealt.altimetry.dispersion.search import _most_prominent, _parabolic_peak
from wavealt.altimetry.dispersion.search import significance, weighted_spread
from wavealt.altimetry.dispersion.spectra import _corner_shape, _corners, _windowed_modes
from wavealt.altimetry.dispersion.yaw import significant_turn


class _Trust:
    """Uncertainty and trust of :class:`DispersionAltimeter`'s results (uses
    ``altitude_range_m``, ``n_groups``)."""

    def _failed(self, frames: int) -> DispersionResult:
        lo, hi = self.altitude_range_m
        mid = math.sqrt(lo * hi)
        return DispersionResult(altitude_m=mid, altitude_std_m=hi - lo,
                                camera_velocity_mps=(0.0, 0.0), quality=0.0, trusted=False,
                                reason="no wave signal to fit (flat or frozen frames)",
                                mode="blind",
                                frames=int(frames), n_modes=0)

    def _group_labels(self, p: dict[str, np.ndarray], n: int) -> np.ndarray:
        """Mode group of each of the ``n`` modes: ``n_groups`` bands of wavenumber.  The
        shell of the true altitude is the same at every wavenumber, while the optics'
        products (sum frequencies faster than the shell, difference frequencies slower) pose
        as altitudes that change with it."""
        cache = p.setdefault("_group_labels", {})
        key = (n, self.n_groups)
        if key not in cache:  # one periodogram serves several fits
            labels = np.empty(n, dtype=np.int64)
            labels[np.argsort(p["kappa"], kind="stable")] = np.arange(n) * self.n_groups // n
            cache[key] = labels
        return cache[key]

    def _group_curves(self, labels: np.ndarray, vals: np.ndarray) -> np.ndarray:
        """Per-group sums of ``vals`` ``(grid, modes)``: ``(n_groups, grid)``."""
        # one bincount over (row, group) bins: the sums a bincount per row makes
        g = self.n_groups
        bins = (np.arange(vals.shape[0])[:, None] * g + labels[None, :]).ravel()
        sums = np.bincount(bins, weights=vals.ravel(), minlength=vals.shape[0] * g)
        return np.ascontiguousarray(sums.reshape(vals.shape[0], g).T)

    def _result(self, p: dict[str, np.ndarray], fit: dict[str, Any], t: int, fps: float,
                focal_px: float) -> DispersionResult:
        """Uncertainty from the spread of the peak over groups of modes, quality from the
        peak's prominence in the altitude scan (aided) or profile (blind).

        Aided, the groups' peaks are taken on the fine grid around the estimate.  Blind
        (``fit["ridge"]``), along the whole profile, the velocity re-fitted at every altitude
        (on the fine grid alone the spread is far too small), and each group counts
        by its peak's curvature, as it counts in the summed profile whose peak the estimate
        is (:func:`~.search.weighted_spread`): a flat group puts its peak far off and says
        little.  Where every group sees the same flat ridge the spread stays small; the
        ridge's paired band (:func:`~wavealt.altimetry.dispersion.profile.paired_band`) then
        sets the uncertainty (``PAIRED_BAND_SD_FRACTION``).  The groups' spread and the floor
        (the bias they share) are independent and add in quadrature; the band's term is
        calibrated as a whole standard deviation on its own (it covers the errors, bias
        and scatter, at the 68 % rate), so it replaces their sum where it is larger, on
        clips long enough for that calibration to hold (as many frames as
        ``BAND_CALIBRATED_MIN_FRAMES``, and as long at ``REFERENCE_FPS``); on shorter ones,
        the systematic term."""
        logh, u = fit["logh"], fit["u"]
        vals = fit["vals"]
        n = vals.shape[1]
        labels = self._group_labels(p, n)
        profile = "ridge" in fit
        if profile:
            grid, ridge = fit["ridge"]
            sums = self._group_curves(labels, ridge)
            ests, curv = [], []
            for row in sums:
                k = _most_prominent(row, grid, -np.inf, np.inf, near=logh,
                                   within=GROUP_PEAK_WITHIN_LOG)[0]
                lo_k = min(max(k - 1, 0), grid.size - 3)
                y = row[lo_k:lo_k + 3]
                ests.append(_parabolic_peak(grid[lo_k:lo_k + 3], y))
                curv.append(max(2.0 * y[1] - y[0] - y[2], 0.0))  # its peak's sharpness
            ests, curv = np.array(ests), np.array(curv)
        else:
            sums = self._group_curves(labels, vals)
            ests = np.array([_parabolic_peak(fit["local"], row) for row in sums])
        # the groups' spread, plus a floor: the bias the clip and the optics leave (measured
        # in ``docs/benchmarks.md``), short clips more
        floor = ((BLIND_SD_FLOOR_LOG if profile else SD_FLOOR_LOG)
                 * max(1.0, FULL_CLIP_FRAMES / t) ** 3)
        t_ref = t * min(1.0, REFERENCE_FPS / fps)  # as long, and as many frames (the band's)
        spread = weighted_spread(ests, curv if profile else None, logh)
        # the band's part of a standard deviation grows on shorter clips
        band = (PAIRED_BAND_SD_FRACTION
                * max(1.0, BAND_CALIBRATED_MIN_FRAMES / t_ref) ** BAND_SHORT_CLIP_POWER
                * fit["band_log"] if profile else 0.0)
        if t_ref >= BAND_CALIBRATED_MIN_FRAMES:
            # on a flat ridge a small bias moves the peak far: the paired band's width, a
            # whole uncertainty of its own (its fraction is set so that it alone covers
            # 68 % of the errors), where it is the larger
            sd_logh = max(math.hypot(spread, floor), band)
        else:
            # a shorter clip, where the band alone under-covers: it adds to the spread
            sd_logh = math.hypot(spread, max(floor, band))
        # significance of the peak against random phase steps: each mode's share averaged
        # over all phase steps (its mean and variance) gives the score's null distribution
        z = significance(p, vals)
        # The wave shell of a real sea stands out of the scan as a prominent peak; textures
        # without dispersion (noise, frozen or carried patterns) make at most small bumps on
        # a scan that rises toward the edge of the range.
        rel_prom = fit["prominence"] / max(float(np.max(fit["scan"])), 1e-30)
        start, span = PROFILE_PROMINENCE if profile else SCAN_PROMINENCE
        q = float(np.clip((rel_prom - start) / span, 0.0, 1.0))
        if not fit["interior"]:
            q = 0.0  # the most prominent peak lies outside the altitude range, or none
        if profile and fit["prominence_z"] < MIN_PROMINENCE_Z:
            q = 0.0  # a bump no higher above the profile's own floor than its noise
        q *= float(np.clip(1.0 - sd_logh / 0.1, 0.0, 1.0))
        if not profile:
            # the aided scan's fine-grid spread does not see a second peak: an ill-graded
            # fit must not look precise
            sd_logh = sd_logh + (1.0 - q) ** 3
            # and no more precise than the clip's resolution allows (after the grading,
            # which the statistical spread alone sets)
            sd_logh = math.hypot(sd_logh, RESOLUTION_FRACTION
                                 * self._resolution_log(p, logh, u, fps, focal_px))
        alt = math.exp(logh)
        # u is the camera's image velocity over the water (px/frame)
        vel = (float(u[0] * fps * alt / focal_px), float(u[1] * fps * alt / focal_px))
        return DispersionResult(altitude_m=float(alt), altitude_std_m=float(alt * sd_logh),
                                camera_velocity_mps=vel, quality=q, trusted=False, reason=None,
                                mode="blind", frames=int(t), n_modes=int(n),
                                significance=z)

    def _resolution_log(self, p: dict[str, Any], logh: float, u: np.ndarray, fps: float,
                        focal_px: float) -> float:
        """How far, in log altitude, shifting every mode's peak by one periodogram bin
        (``2 pi / T`` rad per frame) moves an aided estimate at ``(logh, u)``.

        Each mode's predicted phase step ``psi = s omega / fps - kappa . u`` (its better
        branch ``s``, :meth:`_branch_values`) moves with the altitude at the rate
        ``g = d psi / d log h = s (d omega / d log h) / fps + kappa . u`` (the velocity is
        fixed in m/s, so in px per frame it scales as ``1 / h``).  Weighted by the modes'
        explained shares ``w`` at the estimate, a shift ``delta`` of every peak along ``g``
        moves the least-squares altitude by ``delta sum(w |g|) / sum(w g^2)``.  The peaks
        of a short clip are ``2 pi / T`` wide, and whatever shares them (the optics'
        products, waves the other way, the temporal window's leakage) shifts them by a part
        of that which the mode groups share: a clip that turns its waves by less than a
        bin (high altitude, few frames) cannot place the shell to better than the
        corresponding part of the result, however well its groups agree.
        """
        t = int(p["frames"])
        kappa, kx, ky = p["kappa"], p["kx"], p["ky"]
        # once per distinct wavenumber (:meth:`_omega_modes`)
        distinct, inv = self._distinct_kappa(p, self._lookup(p, None))
        om, dom = (v[inv] for v in self._omega_and_dlog(distinct, focal_px, math.exp(logh)))
        dop = kx * float(u[0]) + ky * float(u[1])  # px/frame . rad/px
        q = p["q"]
        n_psi = q.shape[1]
        rows = np.arange(kappa.size)
        best = rate = None
        for s in (1.0, -1.0):
            pos = np.mod(s * om / fps - dop, 2.0 * np.pi) * (n_psi / (2.0 * np.pi))
            val = q[rows, np.rint(pos).astype(np.int64) % n_psi].astype(np.float64)
            g = np.abs(s * dom / fps + dop)
            rate = g if best is None else np.where(val > best, g, rate)
            best = val if best is None else np.maximum(best, val)
        den = float(np.sum(best * rate**2))
        if den <= 1e-30:
            return math.inf
        return (2.0 * np.pi / t) * float(np.sum(best * rate)) / den

    @staticmethod
    def _shell_seen(res: DispersionResult) -> tuple[bool, float]:
        """How well a fit shows a shell, for choosing between two: its peak significant
        against random phase steps (``MIN_SIGNIFICANCE``) first, then its quality."""
        return res.significance >= MIN_SIGNIFICANCE, res.quality

    def _off_the_edges(self, altitude_m: float) -> bool:
        """Whether an estimate lies farther than ``EDGE_FACTOR`` from both ends of the range."""
        lo, hi = self.altitude_range_m
        return lo * EDGE_FACTOR < altitude_m < hi / EDGE_FACTOR

    def _distrust(self, res: DispersionResult) -> str | None:
        """Why a finished fit may not be trusted, None when it may (:meth:`_judge`)."""
        rel3 = 3.0 * res.altitude_std_m / res.altitude_m
        if res.significance < MIN_SIGNIFICANCE:
            return res.reason or "no wave signal above the noise"
        if res.quality < TRUSTED_QUALITY:
            return res.reason or "no prominent wave-shell peak"
        if rel3 > math.log1p(MAX_TRUSTED_3SIGMA):
            # a reason that widened the interval (the tiles' scatter) says more
            return res.reason or f"3-sigma uncertainty {100 * rel3:.0f} % of the altitude"
        if not self._off_the_edges(res.altitude_m):
            return "at the edge of the altitude range searched"
        return res.reason

    def _rigid_verdict(self, p: dict[str, Any] | None, res: DispersionResult, fps: float,
                       focal_px: float) -> str | None:
        """Why a fit that passes the other trust tests may not be trusted because a pattern
        carried rigidly across the image (no dispersion) explains the clip's motion at least
        as well as the waves do; None where the waves explain more.

        The waves' evidence is the phase steps' dependence on the wavenumber through the
        dispersion relation; a still texture translated across the image (one frame moved
        by the camera, frozen waves, floating matter alone) puts every mode on a line of
        phase steps ``-kappa . u``, and with a velocity given, a shell that crosses that line
        makes a sharp, significant, prominent peak at an altitude the clip does not measure.
        The line's best score over the image velocity (:meth:`_best_line`, as
        :meth:`_carried_velocity` finds foam) against the score of the
        fit's own shell and velocity, on every mode of ``p``: at or above
        ``RIGID_MAX_RATIO`` of it, the clip shows no dispersion that the line does not
        explain as well.
        """
        if p is None:
            return None
        best = self._best_line(p, fps, focal_px)
        if best is None:
            return None
        scale = focal_px / (res.altitude_m * fps)  # m/s -> px/frame
        vx, vy = res.camera_velocity_mps
        shell = float(self._score(p, fps, focal_px, np.array([math.log(res.altitude_m)]),
                                  np.array([vx * scale]), np.array([vy * scale]))[0])
        ratio = float(best[0]) / max(shell, 1e-30)
        if ratio < RIGID_MAX_RATIO:
            return None
        return (f"a still pattern carried across the image explains the motion as well as "
                f"the waves ({ratio:.2f} of their score): no dispersion to measure")

    def _measured_turn(self, p: dict[str, Any] | None, signal: np.ndarray,
                       fps: float, with_sd: bool = False) -> Any:
        """The yaw rate, deg/s, at which the corner tiles of the fitted ``signal`` show the
        camera turning about its axis (:func:`.yaw.significant_turn`; their mode series
        taken from ``p`` where it holds them); None where they show no turn (``with_sd``:
        the rate and its standard error, deg/s).  A fit assumes
        one velocity over the frame; a turn gives each tile its own, and the shell the fit
        finds is smeared or moved, and may be trusted at an altitude the clip does not show
        (``docs/dispersion.md``, twenty-third session)."""
        tiles = _corners(signal, self._tile_fraction())
        shape = tiles[0].shape[1:]
        if min(shape) < 32:
            return None
        kx, ky, _, _, idx = self._plane(*shape)
        series = _corner_series(p, shape)
        if series is not None:
            idx = p["_series_modes"]
        else:
            series = _windowed_modes(tiles, idx)
            series -= series.mean(axis=1, keepdims=True)
        return significant_turn(series, kx[idx], ky[idx],
                                tile_centres(signal.shape[1:], shape), fps, with_sd)

    def _tile_verdict(self, fits: list[tuple[float, float, float, float]],
                      res: DispersionResult) -> str | None:
        """Why the corner tiles' fits ``fits`` (:meth:`_corner_fits`, the first list)
        contradict a fit that passes the other trust tests (:meth:`_distrust`), None where
        they do not.

        The model holds one image scale over the frame: a camera looking straight down at a
        level sea.  A tilted camera sees the sea farther away on one side of the frame than
        on the other, and its fit reads an average of the scales, high by up to twice the
        tilt's range factor, at an uncertainty far smaller than that error
        (``docs/dispersion.md``); :meth:`_level` takes out a tilt the
        tiles measure, and this judges what is left.  Where two tiles differ by more than
        ``TILE_AGREEMENT_SIGMAS`` of their combined uncertainty in log altitude, the frame's
        scale is not one, and the altitude is not trusted.  Where the tiles together scatter
        more than their uncertainties allow (:func:`tile_scatter`), the scatter joins the
        fit's uncertainty (in place, in ``res``), and a fit whose interval then fails the
        trust bar is not trusted.  And the fit must read what its tiles read: where it lies
        more than ``TILE_AGREEMENT_SIGMAS`` from the tiles' mean (random effects, with their
        scatter), its peak is not the one the tiles that hold the waves show, but one the
        others' content makes in their sum."""
        logs = [(lg, sd) for _, _, lg, sd in fits]
        tau = tile_scatter(logs)
        if logs:
            mean, sd_mean = pooled_mean(logs, tau)
            off = mean - math.log(res.altitude_m)
            z = abs(off) / math.hypot(res.altitude_std_m / res.altitude_m, sd_mean)
            if z > TILE_AGREEMENT_SIGMAS:
                return (f"the corner tiles that hold the waves read "
                        f"{100 * math.expm1(off):+.0f} % from the fit ({z:.1f} sigma): its "
                        f"peak is not theirs")
        if tau > 0.0:
            _widen(res, tau)
            if self._distrust(res) is not None:  # the wider interval fails the trust bar
                return (f"the corner tiles' altitudes scatter by {100 * tau:.0f} % beyond "
                        f"their uncertainty: the image scale is not one over the frame (a "
                        f"tilted camera: give its attitude)")
        worst, apart = 0.0, 0.0
        for i, (a, sa) in enumerate(logs):
            for b, sb in logs[i + 1:]:
                z = abs(a - b) / max(math.hypot(sa, sb), 1e-12)
                if z > worst:
                    worst, apart = z, abs(a - b)
        if worst <= TILE_AGREEMENT_SIGMAS:
            return None
        return (f"the corner tiles' altitudes differ by {100 * math.expm1(apart):.0f} % "
                f"({worst:.1f} sigma): the image scale is not one over the frame (a tilted "
                f"camera: give its attitude)")

    def _unmeasured_tilt(self, fits: list[tuple[float, float, float, float]],
                         res: DispersionResult, focal_px: float,
                         shape: tuple[int, int]) -> str | None:
        """Widen, in place, the uncertainty of a fit whose attitude is unknown and was not
        levelled by what a tilt its corner tiles ``fits`` (:meth:`_corner_fits`, the first
        list) do not rule out moves it (the prior ``attitude_sigma_deg``): from three tiles
        on, the tilt within their precision (:func:`.attitude.unlevelled_tilt_var_log`), else
        the part they cannot measure (:func:`.attitude.unmeasured_tilt_var_log`): a fit whose
        waves come from part of the frame reads that part's scale, off by the tilt's range
        factor at an uncertainty that does not show it.  Why the fit is no
        longer trusted where it passed the trust tests before and the wider interval fails
        the bar, else None."""
        # the corner tiles' places (:meth:`_corner_fits` cuts them so)
        tile = _corner_shape(*shape, self._tile_fraction())
        var = unlevelled_tilt_var_log(fits, focal_px, self._attitude_prior_sd, tile)
        if var is None:
            var = unmeasured_tilt_var_log(fits, focal_px, self._attitude_prior_sd,
                                          tile_centres(shape, tile))
        if var <= 0.0:
            return None
        passed = self._distrust(res) is None
        _widen(res, math.sqrt(var))
        if passed and self._distrust(res) is not None:
            if not fits:
                where = "none of the 4 corner tiles holds the waves alone"
            else:
                verb = "holds" if len(fits) == 1 else "hold"
                where = (f"{len(fits)} of the 4 corner tiles {verb} the waves, too few or too "
                         f"imprecise to measure the camera's tilt")
            return (f"{where}: an unknown tilt of the camera moves the altitude by "
                    f"{100 * math.sqrt(var):.0f} % (1 sigma; give its attitude)")
        return None

    def _standing(self, res: DispersionResult) -> tuple[bool, bool, float]:
        """Order of two fits of one window: trusted first, then significant, then graded."""
        return (self._distrust(res) is None, res.significance >= MIN_SIGNIFICANCE,
                res.quality)

    def _rate_uncertain(self, res: DispersionResult,
                        moved: DispersionResult) -> DispersionResult:
        """``res``, a trusted fit of frames turned back at a yaw rate the corner tiles
        measured, judged again with the change to ``moved`` (the same frames turned back at
        one standard error more of rate) in its uncertainty, in quadrature in log altitude.
        A rate a little off leaves a turn that moves the fit by more than the uncertainty of
        the turned-back frames alone (``docs/dispersion.md``, twenty-seventh session)."""
        _widen(res, abs(math.log(moved.altitude_m / res.altitude_m)))
        return self._judge(res)

    def _judge(self, res: DispersionResult) -> DispersionResult:
        """The trust decision of a finished fit, in place: a shell peak significant against
        random phase steps (``MIN_SIGNIFICANCE``) and prominent (``TRUSTED_QUALITY``), a
        3-sigma interval in log altitude that holds no altitude the estimate exceeds (or
        falls short of) by more than ``MAX_TRUSTED_3SIGMA`` of it (``3 sd_log <= log 1.1``),
        and an estimate inside the altitude range (not within ``EDGE_FACTOR`` of an end of
        it)."""
        lo, hi = self.altitude_range_m
        reason = self._distrust(res)
        res.trusted = reason is None
        res.reason = reason
        if not res.trusted:
            # a window that cannot be measured says so in its 3-sigma interval: the range
            res.altitude_std_m = max(res.altitude_std_m, (hi - lo) / 3.0)
        return res


def _widen(res: DispersionResult, sd_log: float) -> None:
    """``res``'s uncertainty with ``sd_log`` (log altitude) added in quadrature, in place."""
    res.altitude_std_m = res.altitude_m * math.hypot(res.altitude_std_m / res.altitude_m,
                                                     sd_log)


def _corner_series(p: dict[str, Any] | None, tile: tuple[int, int]) -> np.ndarray | None:
    """The corner tiles' mode series (``(4, T, modes)``, of the plane's modes
    ``p["_series_modes"]``) that periodogram ``p`` kept, where it was taken on corner tiles of
    shape ``tile`` and kept them (a carried pattern's removal or a rolling shutter's does
    not); else None."""
    if (p is not None and p["corners"] and p.get("_series") is not None
            and tuple(p["tile"]) == tuple(tile)):
        return p["_series"]
    return None


def pooled_mean(fits: list[tuple[float, float]], tau: float) -> tuple[float, float]:
    """The random-effects mean of estimates ``fits`` (each ``(log altitude, sd_log)``),
    each weighted ``1 / (sd^2 + tau^2)`` with ``tau`` their scatter beyond their noise
    (:func:`tile_scatter`), and its standard deviation."""
    w = np.array([1.0 / (sd * sd + tau * tau) for _, sd in fits])
    mean = float(w @ np.array([lg for lg, _ in fits])) / float(w.sum())
    return mean, 1.0 / math.sqrt(float(w.sum()))


def tile_scatter(fits: list[tuple[float, float]], level: float = TILE_SCATTER_LEVEL) -> float:
    """The scatter of estimates ``fits`` (each ``(log altitude, sd_log)``) beyond their own
    uncertainties, in log altitude; 0 where there is none at test level ``level``.

    Random-effects meta-analysis: Cochran's ``Q = sum w (x - xbar)^2`` (``w = 1 / sd^2``,
    ``xbar`` their weighted mean) is chi-square with ``k - 1`` degrees of freedom when the
    estimates share one value; where ``Q`` exceeds that distribution's ``1 - level``
    quantile, the between-estimate variance is DerSimonian and Laird's (Controlled Clinical
    Trials 7, 1986) ``tau^2 = (Q - (k - 1)) / (sum w - sum w^2 / sum w)``.
    """
    if len(fits) < 2:
        return 0.0
    q, _, w = cochran_q(fits)
    dof = len(fits) - 1
    if q <= chi2_quantile(dof, level):
        return 0.0
    sw = float(w.sum())
    return math.sqrt((q - dof) / (sw - float(np.sum(w * w)) / sw))
