"""The blind fit's start: the water's image velocity from the wavenumber rings, then a
Gauss–Newton phase-step fit of (log altitude, velocity) on the frame cross-spectra."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wavealt.altimetry.dispersion.constants import TUKEY_C_RAD
from wavealt.altimetry.dispersion.kernel import compiled_start_module
from wavealt.altimetry.dispersion.spectra import _wrap
from wavealt.altimetry.dispersion.velocity_map import _map_peaks_arrays
from wavealt.sim.sea.spectrum import GRAVITY_MPS2

# the Gauss-Newton normal matrix's floor (_refine)
_HESS_FLOOR = np.diag([1e-9, 1e-9, 1e-9])
_HESS_FLOOR.flags.writeable = False


def _band_modes(m: dict[str, Any], kb: float) -> tuple[np.ndarray, ...]:
    """``kappa, kx, ky, psi, weight`` of the modes of ``m`` (:meth:`_Spectra._modes`) with
    ``kappa <= kb``, in their order (cached in ``m``: every start refines on the same
    bands)."""
    cache = m.setdefault("_bands", {})
    if kb not in cache:
        sel = np.flatnonzero(m["kappa"] <= kb)
        cache[kb] = tuple(m[k][sel] for k in ("kappa", "kx", "ky", "psi", "weight"))
    return cache[kb]


class _Start:
    """The blind fit's start of :class:`DispersionAltimeter`: velocity candidates and a
    per-mode phase-step fit of ``(log altitude, u)`` (uses ``max_shift_px``,
    ``altitude_range_m`` and the dispersion relation)."""

    @staticmethod
    def _ring_cost(r: np.ndarray, ring: np.ndarray, wt: np.ndarray, n_rings: int) -> np.ndarray:
        """Weighted spread of ``|r|`` within each wavenumber ring, summed; rows of ``r`` are
        velocity candidates.  Eq. (1): after removing the Doppler term the wave phase step
        ``|s omega / fps|`` depends on ``|kappa|`` alone."""
        a = np.abs(r)
        g = r.shape[0]
        idx = (np.arange(g)[:, None] * n_rings + ring[None, :]).ravel()
        wsum = np.bincount(ring, weights=wt, minlength=n_rings)
        s1 = np.bincount(idx, weights=(a * wt[None, :]).ravel(), minlength=g * n_rings)
        mean = s1.reshape(g, n_rings) / np.maximum(wsum, 1e-30)[None, :]
        mr = np.take_along_axis(mean, np.broadcast_to(ring, r.shape), axis=1)
        # relative spread: a velocity that freezes every wave (|r| ~ 0) is no better
        rel = (a - mr) / (mr + 0.05)
        return np.sum(wt[None, :] * np.minimum(rel**2, 1.0), axis=1)

    def _velocity_candidates(self, m: dict[str, np.ndarray], n_best: int = 4) -> list[np.ndarray]:
        """Image velocities of the water (px/frame) worth refining, found without the altitude.

        Eq. (1): once the Doppler term ``kappa . u`` is removed, the phase step of every mode
        on a wavenumber ring has the same magnitude ``omega(|kappa|) / fps``.  A grid over
        ``u`` scores the relative spread of ``|r|`` within rings on the low modes; the best
        few local minima are polished on wider bands, coarse to fine.
        """
        kappa, kx, ky, psi, w0 = m["kappa"], m["kx"], m["ky"], m["psi"], m["weight"]
        dk = float(m["bin_kappa"])
        ring_all = np.rint(kappa / dk).astype(np.int64)

        def search(center: np.ndarray, band: float, half: float, step: float,
                   keep: int) -> list[np.ndarray]:
            sel = np.flatnonzero(kappa <= band)
            if sel.size > 160:
                sel = sel[np.argsort(-w0[sel] * m["energy"][sel])[:160]]
            n = max(2, math.ceil(half / step))
            g = np.arange(-n, n + 1) * step
            gx, gy = np.meshgrid(center[0] + g, center[1] + g, indexing="ij")
            ring = ring_all[sel] - ring_all[sel].min()
            ck = compiled_start_module()
            if ck is not None:  # the same bits, without the (grid, modes) passes
                cost = ck.ring_costs(psi[sel], kx[sel], ky[sel], w0[sel], ring,
                                     int(ring.max()) + 1, gx.ravel(), gy.ravel())
            else:
                r = _wrap(psi[sel][None, :] - (gx.ravel()[:, None] * kx[sel][None, :]
                                               + gy.ravel()[:, None] * ky[sel][None, :]))
                cost = self._ring_cost(r, ring, w0[sel], int(ring.max()) + 1)
            cost = cost.reshape(gx.shape)
            # local minima of the grid, best first: the negated cost's local maxima
            mins = _map_peaks_arrays(-cost, keep)
            return [np.array([gx.ravel()[i], gy.ravel()[i]]) for i in mins]

        band0 = max(0.25, 6.0 * dk)
        starts = search(np.zeros(2), band0, self.max_shift_px, 0.4, n_best)
        out = []
        for u in starts:
            band, step = band0, 0.4
            while band < 1.5:
                band, half = band * 2.0, 2.0 * step
                step = step / 2.0
                u = search(u, band, half, step, 1)[0]
            out.append(u)
        return out

    def _initial(self, m: dict[str, np.ndarray], fps: float, focal_px: float,
                 u: np.ndarray) -> float | None:
        """Altitude from each mode's Doppler-free phase step (gravity regime), weighted
        median: ``altitude = g focal_px kappa / omega^2`` with ``omega = fps |r|``."""
        kappa, kx, ky, psi, w0 = m["kappa"], m["kx"], m["ky"], m["psi"], m["weight"]
        r = np.abs(_wrap(psi - (kx * u[0] + ky * u[1])))
        ok = (r > 0.02) & (kappa <= 1.5)
        if np.count_nonzero(ok) < 8:
            return None
        logh = np.log(GRAVITY_MPS2 * focal_px * kappa[ok] / (fps * r[ok]) ** 2)
        # d log h = -2 d r / r: a larger phase step pins the altitude down better
        wt = w0[ok] * r[ok] ** 2
        order = np.argsort(logh)
        cw = np.cumsum(wt[order])
        med = float(logh[order][np.searchsorted(cw, 0.5 * cw[-1])])
        lo, hi = self.altitude_range_m
        return float(np.clip(math.exp(med), lo, hi))

    def _refine(self, m: dict[str, np.ndarray], fps: float, focal_px: float, alt: float,
                u: np.ndarray) -> dict[str, Any]:
        """Gauss–Newton with Tukey weights on (log altitude, u), widening the band."""
        kappa, kx, ky, psi, w0 = m["kappa"], m["kx"], m["ky"], m["psi"], m["weight"]
        bands = []
        kb = 1.0
        while kb < np.pi:
            bands.append(kb)
            kb *= 1.5
        bands.append(np.pi)
        logh = math.log(alt)
        lo, hi = (math.log(a) for a in self.altitude_range_m)
        out: dict[str, Any] = {}
        hess = None
        ck = compiled_start_module()
        for i, kb in enumerate(bands):
            # compiled, a band's steps take its modes alone (kappa <= kb, in order: the
            # same modes used, packed in the same order); the last band's terms, of every
            # mode, are the ones kept
            sub = (kappa, kx, ky, psi, w0)
            if ck is not None and i < len(bands) - 1:
                sub = _band_modes(m, kb)
            for _ in range(6):
                h = math.exp(logh)
                om, dom = self._omega_and_dlog(sub[0], focal_px, h)
                if ck is not None:  # the same bits in one pass over the modes
                    terms = ck.refine_terms(om, dom, *sub, float(u[0]), float(u[1]),
                                            float(fps), float(kb), TUKEY_C_RAD)
                    use, r, tw, s, jac, jw, r_use, wt_sum = terms
                    if r_use.size < 6 or wt_sum <= 0:  # six modes used, some weight
                        break
                else:
                    # keep modes whose own wave phase step does not wrap (unambiguous s)
                    use = (kappa <= kb) & (om / fps < 0.9 * np.pi)
                    if np.count_nonzero(use) < 6:
                        break
                    dop = kx * u[0] + ky * u[1]
                    rp = _wrap(psi - (om / fps + dop))
                    rm = _wrap(psi - (-om / fps + dop))
                    s = np.where(np.abs(rp) <= np.abs(rm), 1.0, -1.0)
                    r = np.where(s > 0, rp, rm)
                    tw = np.where(np.abs(r) < TUKEY_C_RAD,
                                  (1.0 - (r / TUKEY_C_RAD) ** 2) ** 2, 0.0)
                    wt = (w0 * tw)[use]
                    if wt.sum() <= 0:
                        break
                    jac = np.stack([s * dom / fps, kx, ky], axis=1)[use]
                    jw = jac * wt[:, None]
                    r_use = r[use]
                hess = jac.T @ jw + _HESS_FLOOR
                step = np.linalg.solve(hess, jw.T @ r_use)
                # np.clip's minimum(maximum()) on floats, NaN kept
                logh = min(max(float(logh + step[0]), lo), hi)
                u = u + step[1:]
                if abs(step[0]) < 1e-5 and abs(step[1]) < 1e-4 and abs(step[2]) < 1e-4:
                    break
            if hess is not None:  # else no band has had six usable modes yet
                out = {"logh": logh, "u": u.copy(), "use": use, "r": r, "tw": tw,
                       "hess": hess, "s": s}
        if out:
            # arbiter between starts: robust misfit of every mode, wrapped or not
            out["cost"] = float(np.sum(w0 * np.minimum(out["r"] ** 2, TUKEY_C_RAD**2)))
        return out

    def _phase_step_fit(self, m: dict[str, np.ndarray], fps: float,
                        focal_px: float) -> dict[str, Any]:
        """Best phase-step fit over the velocity candidates (``u`` in the modes' sign
        convention: the water's image velocity); empty when none converges."""
        fit: dict[str, Any] = {}
        for u0 in self._velocity_candidates(m):
            alt0 = self._initial(m, fps, focal_px, u0)
            if alt0 is None:
                continue
            cand = self._refine(m, fps, focal_px, alt0, u0)
            if cand and (not fit or cand["cost"] < fit["cost"]):
                fit = cand
        return fit
