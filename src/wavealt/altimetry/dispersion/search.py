"""The searches: the periodogram's score of a candidate (altitude, velocity), the aided and
prior fits over altitude (velocity known or known to a sigma), and the peak helpers and
score statistics that they and the blind profile (:mod:`.profile`) share."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wavealt.altimetry.dispersion.constants import (
    AIDED_SCAN_ABOVE,
    AIDED_SCAN_BELOW,
    AIDED_SHRINK_FRACTION,
    MIN_SIGNIFICANCE,
    TRUSTED_QUALITY,
)
from wavealt.altimetry.dispersion.kernel import explained_shares
from wavealt.altimetry.dispersion.result import DispersionResult
from wavealt.sim.sea.spectrum import GRAVITY_MPS2


class _Search:
    """The searches of :class:`DispersionAltimeter`: periodogram score lookups, the aided
    (velocity known) and prior fits (uses ``altitude_range_m``, ``n_scan`` and the
    dispersion relation)."""

    @staticmethod
    def _lookup(p: dict[str, Any], modes: np.ndarray | None) -> dict[str, np.ndarray]:
        """Per-mode arrays for the table lookups of :meth:`_branch_values` (cached in ``p``;
        float32 but for ``kappa``, which the general dispersion relation takes), of all modes
        or of ``modes``.  ``pair[m, j]`` holds ``q[m, j]`` and the
        step to ``q[m, j + 1]`` as one complex number, so that one gather serves the linear
        interpolation."""
        if "_lookup" not in p:
            q = p["q"]  # (modes, n_psi), periodic in the phase step
            pair = np.empty(q.shape, dtype=np.complex64)
            pair.real = q
            step = pair.imag
            np.subtract(q[:, 1:], q[:, :-1], out=step[:, :-1])
            np.subtract(q[:, :1], q[:, -1:], out=step[:, -1:])
            p["_lookup"] = {"pair": pair, "kx": p["kx"].astype(np.float32),
                            "ky": p["ky"].astype(np.float32), "kappa": p["kappa"],
                            "sqrt_kappa": np.sqrt(p["kappa"]).astype(np.float32)}
        arrays = p["_lookup"]
        if modes is None:
            return arrays
        # the searches ask for the same few subsets many times: gathered once each; an
        # array asked for before is known by identity (it is held, so its id is not
        # reused) before its bytes are hashed
        held = p.setdefault("_lookup_held", {})
        seen = held.get(id(modes))
        if seen is not None:
            return seen[1]
        n = arrays["kappa"].size
        if modes.size == n and np.array_equal(modes, np.arange(n)):
            held[id(modes)] = (modes, arrays)  # every mode, in order: the arrays themselves
            return arrays
        subsets = p.setdefault("_lookup_subsets", {})
        key = modes.tobytes()
        if key not in subsets:
            subsets[key] = {k: v[modes] for k, v in arrays.items()}
        held[id(modes)] = (modes, subsets[key])
        return subsets[key]

    def _branch_values(self, p: dict[str, Any], fps: float, focal_px: float,
                       logh: np.ndarray, ux: np.ndarray, uy: np.ndarray,
                       modes: np.ndarray | None = None,
                       turns: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
        """Explained share of every mode for candidates ``(log h, ux, uy)`` (same shape),
        ``(candidates, modes)`` float32, and with ``turns`` the turn weight of the branch
        each value took (:meth:`_mode_values`), else None.

        A candidate predicts each mode's phase step ``s omega(kappa f / h) / fps - kappa.u``
        (eq. (1)); each mode takes the better of the two directions ``s = +-1``.
        """
        a = self._lookup(p, modes)
        pair = a["pair"]
        n_modes, n_psi = pair.shape
        to_bins = n_psi / (2.0 * np.pi)
        logh = np.atleast_1d(logh)
        if self.dispersion == "gravity" and self.water_depth_m is None:
            om = self._gravity_bins(a, logh, fps, focal_px, to_bins)
        elif logh.size and bool(np.all(logh == logh[0])):
            om = self._omega_row(p, a, logh, fps, focal_px, to_bins)
        elif logh.ndim == 1 and bool(np.all(logh[1:] > logh[:-1])):
            om = self._omega_modes(p, a, logh, fps, focal_px, to_bins)  # a grid: distinct
        else:
            uniq, inv = np.unique(logh, return_inverse=True)
            om = self._omega_modes(p, a, uniq, fps, focal_px, to_bins)
            if uniq.size < logh.size or not np.array_equal(uniq, logh):
                om = om[inv.ravel()]
        vx = (np.atleast_1d(ux) * to_bins).astype(np.float32)
        vy = (np.atleast_1d(uy) * to_bins).astype(np.float32)
        shape = (logh.size, n_modes)
        best = np.empty(shape, dtype=np.float32)
        wt = np.empty(shape if turns else (0, 0), dtype=np.float32)
        explained_shares(np.ascontiguousarray(om), vx, vy, a["kx"], a["ky"], pair,
                         int(p["frames"]) if turns else 0, turns, best, wt)
        return best, (wt if turns else None)

    @staticmethod
    def _gravity_bins(a: dict[str, np.ndarray], logh: np.ndarray, fps: float,
                      focal_px: float, to_bins: float) -> np.ndarray:
        """The gravity waves' phase step ``omega(kappa f / h) / fps`` of the modes of lookup
        arrays ``a`` (:meth:`_lookup`) at each altitude ``exp(logh)``, in table bins,
        ``(altitudes, modes)`` float32: ``omega = sqrt(g kappa f / h)``, one outer product
        instead of a matrix of sqrt."""
        scale = np.sqrt(GRAVITY_MPS2 * focal_px / np.exp(logh)) * (to_bins / fps)
        return scale.astype(np.float32)[:, None] * a["sqrt_kappa"][None, :]

    def _omega_row(self, p: dict[str, Any], a: dict[str, np.ndarray], logh: np.ndarray,
                   fps: float, focal_px: float, to_bins: float) -> np.ndarray:
        """The one row ``(1, modes)`` of :meth:`_omega_bins` of the modes of lookup arrays
        ``a`` at the altitude ``exp(logh[0])``.  The velocity searches ask for one altitude
        many times: each row is computed once per mode subset (whose lookup arrays ``p``
        holds for its life)."""
        if self.dispersion == "gravity" and self.water_depth_m is None:
            return self._gravity_bins(a, logh[:1], fps, focal_px, to_bins)
        rows = p.setdefault("_omega_rows", {}).setdefault(id(a), {})
        key = (float(logh[0]), float(fps), float(focal_px))
        if key not in rows:
            rows[key] = self._omega_modes(p, a, logh[:1], fps, focal_px, to_bins)
        return rows[key]

    def _omega_modes(self, p: dict[str, Any], a: dict[str, np.ndarray], logh: np.ndarray,
                     fps: float, focal_px: float, to_bins: float) -> np.ndarray:
        """:meth:`_omega_bins` of the modes of lookup arrays ``a`` at each altitude
        ``exp(logh)``, taken once per distinct wavenumber (a square tile's modes come in
        fours of one ``|kappa|``; its distinct values, cached per mode subset, which ``p``
        holds)."""
        kappa, inv = self._distinct_kappa(p, a)
        return self._omega_bins(kappa, logh, fps, focal_px, to_bins)[:, inv]

    @staticmethod
    def _distinct_kappa(p: dict[str, Any], a: dict[str, np.ndarray]
                        ) -> tuple[np.ndarray, np.ndarray]:
        """The distinct wavenumbers of the modes of lookup arrays ``a`` (:meth:`_lookup`)
        and each mode's place among them (``np.unique``), cached in ``p``, which holds
        ``a``."""
        distinct = p.setdefault("_kappa_distinct", {})
        if id(a) not in distinct:
            distinct[id(a)] = np.unique(a["kappa"], return_inverse=True)
        return distinct[id(a)]

    def _omega_bins(self, kappa: np.ndarray, logh: np.ndarray, fps: float, focal_px: float,
                    to_bins: float) -> np.ndarray:
        """The wave phase step ``omega(kappa f / h) / fps`` of every mode at each altitude
        ``exp(logh)``, in table bins, ``(altitudes, modes)`` float32."""
        return (self.omega(kappa[None, :] * focal_px / np.exp(logh)[:, None])
                * (to_bins / fps)).astype(np.float32)

    def _mode_values(self, p: dict[str, Any], fps: float, focal_px: float,
                     logh: np.ndarray, ux: np.ndarray, uy: np.ndarray,
                     modes: np.ndarray | None = None, weighted: bool = False) -> np.ndarray:
        """Explained share of every mode for candidates ``(log h, ux, uy)`` (same shape):
        ``(candidates, modes)`` float32 (:meth:`_branch_values`).

        ``weighted``: each value is weighted by how far the predicted phase step turns over
        the clip, ``clip(cycles - 0.5, 0, 1)``, and a candidate's row is rescaled so that its
        mean over the modes is the weighted mean.  A mode the candidate predicts to
        (nearly) stand still in the image cannot tell the wave from the optics' slow
        products, which fill the inside of the dispersion shell (:meth:`_fit_aided`).
        """
        best, wt = self._branch_values(p, fps, focal_px, logh, ux, uy, modes, turns=weighted)
        if wt is None:
            return best
        best *= wt
        best *= (wt.shape[1] / np.maximum(wt.sum(axis=1, keepdims=True), 1e-9)).astype(
            np.float32)
        return best

    def _score(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
               logh: np.ndarray, ux: np.ndarray, uy: np.ndarray,
               modes: np.ndarray | None = None, weighted: bool = False) -> np.ndarray:
        """Mean explained share over modes for candidates ``(log h, ux, uy)`` (same shape)."""
        return self._mode_values(p, fps, focal_px, logh, ux, uy, modes, weighted).mean(axis=1)

    def _prior(self, p: dict[str, Any], t: int, fps: float, focal_px: float,
               prior: tuple[float, float, float]) -> DispersionResult:
        """The camera's velocity over the water known to ``sigma`` m/s (``prior = (vx, vy,
        sigma)``), propagated: exact fits at the prior's mean and at the eight points
        ``sigma`` away along and between the image axes.

        The estimate is the fit at the mean; the spread of the nine altitudes adds to its
        uncertainty, so an altitude that depends on the unknown drift (a short clip, waves
        one way, a wide prior) is not trusted, while one that does not (a narrow prior, or
        waves both ways pinning the drift) keeps the exact fit's precision.  Where it is not
        trusted the blind search takes over (:meth:`DispersionAltimeter._fit_path`).
        """
        vx, vy, sigma = prior
        offs = [(0.0, 0.0)] + [(sigma * math.cos(a), sigma * math.sin(a))
                               for a in np.arange(8) * (np.pi / 4)]
        fits = [self._aided(p, t, fps, focal_px, (vx + dx, vy + dy)) for dx, dy in offs]
        res = fits[0]
        logs = np.log([r.altitude_m for r in fits])
        spread = float(np.std(logs))
        sd_logh = math.hypot(res.altitude_std_m / res.altitude_m, spread)
        res.altitude_std_m = float(res.altitude_m * sd_logh)
        return res

    def _aided(self, p: dict[str, Any], t: int, fps: float, focal_px: float,
               velocity_mps: tuple[float, float]) -> DispersionResult:
        """The aided result of periodogram ``p``: the fit at the weighted scan's peak, or the
        one at the shrunk or the plain scan's peak (:meth:`_fit_aided`) where that one is
        trusted and better graded, or significant (``MIN_SIGNIFICANCE``) where the fit it
        would replace is not: a peak that scores no better than random phase steps tells
        nothing of where the shell is (on a calm sea high up, in a short clip, the weighted
        scan can peak, insignificantly, far below the shell where the plain scan's peak is
        significant and holds it; ``docs/dispersion.md``, twenty-ninth session).  A
        significant peak within ``EDGE_FACTOR`` of an end of the range does not replace it:
        that is where slow content makes the scan rise to the end (the estimate there is
        never trusted, and a corner fit pinned to the top, made significant, would not give
        way to a whole-frame fit that reads the shell)."""
        fits = self._fit_aided(p, fps, focal_px, velocity_mps)
        res = self._result(p, fits[0], t, fps, focal_px)
        for fit in fits[1:]:
            alt = self._result(p, fit, t, fps, focal_px)
            if ((alt.quality >= TRUSTED_QUALITY and alt.quality > res.quality)
                    or (alt.significance >= MIN_SIGNIFICANCE > res.significance
                        and self._off_the_edges(alt.altitude_m))):
                res = alt
        return res

    def _fit_aided(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                   velocity_mps: tuple[float, float]) -> list[dict[str, Any]]:
        """Known camera velocity over the water: a 1-D search over the altitude alone.

        A coarse scan over log altitude picks its most *prominent* peak in the range (not
        the highest: slow content makes the scan rise toward high altitudes, and a bump on
        that rise is no wave shell).  The scan weights each mode by how far the candidate
        makes it turn over the clip (:meth:`_mode_values`): when the camera drifts downwind,
        the Doppler shift cancels the waves' own motion on a band of modes, which then stand
        nearly still in the image and hold only the optics' slow products; unweighted, those
        make the scan rise with no peak near the truth (``docs/dispersion.md``).  The fine
        stage, on every mode and unweighted, takes the highest point within +-4 coarse steps
        and refines it with a parabola; the mode groups' spread there gives the uncertainty
        (:meth:`_result`).  Where the unweighted values rise through those steps with no
        peak (the nearly still modes again), the fine stage is weighted too
        (``docs/dispersion.md``); such estimates are flagged by the quality below.  The
        quality is the prominence of the *unweighted* scan's peak at the estimate (none
        within two steps: no quality), so an estimate that only the weighting found is not
        trusted.

        Returns the fit at the weighted scan's peak and, where a shrunk weighted scan (see
        below) or the plain scan peaks elsewhere, the fits there too; :meth:`_aided` grades
        them all on the plain scan.  The plain scan's own peak is a candidate because the
        weighting moves the peak on a sea whose long modes turn little in a short clip (a
        camera at 8-15 m, 10 frames): it rests on the short modes that do turn, where the
        optics' square puts its sum products just faster than the shell, and reads low
        (``docs/dispersion.md``, twenty-second and twenty-ninth sessions).
        """
        vx, vy = (float(v) for v in velocity_mps)
        lo, hi = (math.log(a) for a in self.altitude_range_m)

        def u_of(logh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            scale = focal_px / (np.exp(logh) * fps)  # m/s -> px/frame at this altitude
            return vx * scale, vy * scale

        # The scan reaches past the altitude range (x1.5 below, x4 above, same step) so that
        # a peak near an end of the range has the fall on both of its sides measured: at
        # high altitudes the shell's peak is broad (the waves move little in a short clip).
        step = (hi - lo) / (self.n_scan - 1)
        grid = np.arange(lo - math.log(AIDED_SCAN_BELOW),
                         hi + math.log(AIDED_SCAN_ABOVE) + step / 2, step)
        # the coarse scans need no more than a fixed subsample of the modes
        sub = np.arange(0, p["kappa"].size, max(1, p["kappa"].size // 300))
        ux, uy = u_of(grid)
        # both coarse scans from one pass: weighted (picks the peak) and plain (grades it)
        vals, wt = self._branch_values(p, fps, focal_px, grid, ux, uy, modes=sub, turns=True)
        scan = vals.mean(axis=1)
        wsum, wtot = np.sum(vals * wt, axis=1), wt.sum(axis=1)
        # The peak is the most prominent within the range (the scan reaches past it only to
        # measure the fall beside a peak near an end): with a fast drift, slow content that
        # rides with the water raises a hump beyond it that can hide the shell.
        inr = {"near": 0.5 * (lo + hi), "within": 0.5 * (hi - lo) + step}
        i = _most_prominent(wsum / np.maximum(wtot, 1e-9), grid, lo - step, hi + step, **inr)[0]
        fits = [self._fine_aided(p, fps, focal_px, grid[i], step, u_of, scan, grid)]
        # The weighted mean of a candidate at which few modes turn rests on few modes: on
        # small frames (128 px, 1-5 m) it makes spurious peaks at several times the altitude,
        # read with confidence.  Pulled toward the plain scan's median by a tenth
        # of the modes, the true peak stands out there; where that peak lies elsewhere it is
        # refined too, and kept when trusted and more so (:meth:`_aided`).
        n0 = AIDED_SHRINK_FRACTION * wt.shape[1]
        shrunk = (wsum + n0 * float(np.median(scan))) / (wtot + n0)
        k = _most_prominent(shrunk, grid, lo - step, hi + step, **inr)[0]
        if abs(k - i) > 4:
            fits.append(self._fine_aided(p, fps, focal_px, grid[k], step, u_of, scan, grid))
        # the plain scan's own most prominent peak, where no fit so far has reached it
        j = _most_prominent(scan, grid, lo - step, hi + step, **inr)[0]
        if all(abs(grid[j] - fit["logh"]) > 4 * step for fit in fits):
            fits.append(self._fine_aided(p, fps, focal_px, grid[j], step, u_of, scan, grid))
        return fits

    def _fine_aided(self, p: dict[str, Any], fps: float, focal_px: float, center: float,
                    step: float, u_of: Any, scan: np.ndarray, grid: np.ndarray) -> dict[str, Any]:
        """The aided fit's fine stage around the coarse peak ``center`` (:meth:`_fit_aided`)."""
        lo, hi = (math.log(a) for a in self.altitude_range_m)
        local = center + np.linspace(-4.0, 4.0, 17) * step
        vals = self._mode_values(p, fps, focal_px, local, *u_of(local))
        mean = vals.mean(axis=1)
        if int(np.argmax(mean)) in (0, local.size - 1):
            # no peak within reach, the plain values rising through the window (nearly
            # still modes pulling it up): the weighted values' peak
            vals = self._mode_values(p, fps, focal_px, local, *u_of(local), weighted=True)
            mean = vals.mean(axis=1)
        logh = float(np.clip(_parabolic_peak(local, mean), lo, hi))
        # the spread over mode groups is measured on the points around the peak
        j = int(np.clip(np.argmax(mean), 5, local.size - 6))
        local, vals = local[j - 5:j + 6], vals[j - 5:j + 6]
        _, prominence, interior = _most_prominent(scan, grid, lo - step, hi + step, near=logh,
                                                  within=2.0 * step)
        ux, uy = u_of(np.array([logh]))
        return {"logh": logh, "u": np.array([ux[0], uy[0]]), "scan": scan,
                "interior": interior, "prominence": prominence, "local": local, "vals": vals}


def significance(p: dict[str, Any], vals: np.ndarray) -> float:
    """How far the best row of per-mode values ``vals`` ``(candidates, modes)`` scores above
    random phase steps, in standard deviations of the score (:func:`null_score`)."""
    null_mean, null_spread = null_score(p)
    return (float(np.max(vals.mean(axis=1))) - null_mean) / max(null_spread, 1e-30)


def null_score(p: dict[str, Any]) -> tuple[float, float]:
    """Mean and standard deviation of the score (the mean share over all modes) under
    random phase steps: each mode's share averaged over all phase steps gives its mean and
    variance (cached in ``p``: one periodogram serves several fits)."""
    if "_null" not in p:
        p["_null"] = (float(p["q"].mean()), null_sd(p, np.arange(p["q"].shape[0])))
    return p["_null"]


def null_sd(p: dict[str, Any], modes: np.ndarray) -> float:
    """Standard deviation under random phase steps of the mean share over ``modes``
    (:func:`null_score`; the modes' variances over the phase steps cached in ``p``)."""
    if "_mode_var" not in p:
        p["_mode_var"] = p["q"].var(axis=1)
    return float(np.sqrt(np.sum(p["_mode_var"][modes]))) / max(len(modes), 1)


def peak_prominences(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The local maxima of ``y`` (a plateau counts once, at its middle, as SciPy does) and
    their topographic prominences: the height above the higher of the two lowest points
    between the peak and the nearest strictly higher sample (or the end) on either side.

    The same peaks and prominences as ``scipy.signal.find_peaks(y, prominence=0)`` (a test
    holds it to that), written out because importing ``scipy.signal`` costs the command
    line about 0.4 s of its 1-s start-up budget; the scans are a few hundred points.
    """
    y = np.asarray(y, np.float64)
    v = y.tolist()  # the walks compare Python floats (the same IEEE comparisons, faster)
    n = len(v)
    peaks = []
    i = 1
    while i < n - 1:
        if v[i - 1] < v[i]:
            j = i
            while j + 1 < n and v[j + 1] == v[i]:
                j += 1
            if j + 1 < n and v[j + 1] < v[i]:
                peaks.append((i + j) // 2)
            i = j + 1
        else:
            i += 1
    prom = np.empty(len(peaks))
    for k, p in enumerate(peaks):
        top = v[p]
        left = p
        while left > 0 and v[left - 1] <= top:
            left -= 1
        right = p
        while right < n - 1 and v[right + 1] <= top:
            right += 1
        prom[k] = top - max(min(v[left:p + 1]), min(v[p:right + 1]))
    return np.asarray(peaks, dtype=np.intp), prom


def _most_prominent(scan: np.ndarray, grid: np.ndarray, lo: float, hi: float,
                    near: float | None = None, within: float = 0.0) -> tuple[int, float, bool]:
    """Index of the most prominent peak of ``scan`` over ``grid`` (with ``near``: among the
    peaks within ``within`` of it), its prominence, and whether it lies within ``[lo, hi]``;
    ``(argmax, 0, False)`` when there is no such peak (the scan rises to an end: nothing
    there pins the altitude)."""
    peaks, prom = peak_prominences(scan)
    if near is not None:
        keep = np.abs(grid[peaks] - near) <= within
        peaks, prom = peaks[keep], prom[keep]
    if not peaks.size:
        return int(np.argmax(scan)), 0.0, False
    k = int(np.argmax(prom))
    i = int(peaks[k])
    return i, float(prom[k]), bool(lo <= grid[i] <= hi)


def _parabolic_peak(x: np.ndarray, y: np.ndarray) -> float:
    """Abscissa of the maximum of ``y`` over the even grid ``x``, refined by a parabola
    through the best point and its neighbours."""
    # np.clip's minimum(maximum()) on scalars (NaN kept), without its call overhead
    j = min(max(int(np.argmax(y)), 1), y.size - 2)
    den = y[j - 1] - 2.0 * y[j] + y[j + 1]
    off = 0.5 * (y[j - 1] - y[j + 1]) / den if den < 0 else 0.0
    return float(x[j] + float(min(max(off, -1.0), 1.0)) * (x[1] - x[0]))


def weighted_spread(ests: np.ndarray, weights: np.ndarray | None, centre: float) -> float:
    """Standard error of ``centre``, an estimate that combines the mode groups' estimates
    ``ests`` with ``weights`` (each group's peak curvature: a sum of the groups' curves
    peaks at their curvature-weighted mean), from the groups' scatter about it: the
    sandwich (robust) variance ``sum w^2 (x - centre)^2`` with the weights normalised, times
    ``n_eff / (n_eff - 1)``, ``n_eff = 1 / sum w^2`` (Kish's effective number of groups).
    Without weights, or where fewer than two groups carry them (``n_eff < 2``: their
    agreement says nothing), the plain standard error of the mean over all groups."""
    total = 0.0 if weights is None else float(np.sum(weights))
    w = weights / total if total > 0 else None
    n_eff = 1.0 / float(np.sum(w * w)) if w is not None else 0.0
    if n_eff < 2.0:
        return float(np.std(ests, ddof=1) / math.sqrt(len(ests)))
    return math.sqrt(float(np.sum(w * w * (ests - centre) ** 2)) * n_eff / (n_eff - 1.0))
