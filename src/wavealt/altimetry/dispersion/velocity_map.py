"""The velocity map: the periodogram score over the image velocity at one altitude, every
velocity of a lattice at once by one 2-D FFT, its peaks, and the best of them refined."""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
import scipy.fft

from wavealt.altimetry.dispersion.constants import (
    BLIND_MAP_KAPPA,
    BLIND_MAP_REACH,
    BLIND_MAX_SPEED_MPS,
)
from wavealt.altimetry.dispersion.kernel import compiled_module


class _VelocityMap:
    """The velocity map of :class:`DispersionAltimeter` (uses the score of
    :class:`~wavealt.altimetry.dispersion.search._Search` and the compass search of
    :class:`~wavealt.altimetry.dispersion.profile._Profile`)."""

    @staticmethod
    def _map_tables(p: dict[str, Any]) -> dict[str, Any]:
        """What the velocity map (:meth:`_velocity_map_peaks`) needs that does not depend on
        the altitude, built once per periodogram (cached in ``p``): the lattice and its
        modes (:func:`_map_lattice`) and their share tables' Fourier coefficients."""
        if "_map" not in p:
            # the modes at their bins, where the lattice is (the periodogram's centroids
            # are within a bin of them)
            kx, ky, kappa = p.get("_bins", (p["kx"], p["ky"], p["kappa"]))
            m = dict(_map_lattice(kx, ky, kappa, tuple(p["tile"]), int(p["frames"]),
                                  int(p["q"].shape[1])))
            # q(x) = sum_k coef[k] e^{2 pi i k x / n_psi}, up to a constant factor
            m["coef"] = scipy.fft.fft(p["q"][m.pop("modes")], axis=1, workers=1)
            p["_map"] = m
        return p["_map"]

    def _map_step(self, p: dict[str, Any]) -> float:
        """The velocity map's step, px/frame (:meth:`_map_tables`)."""
        return self._map_tables(p)["step"]

    def _velocity_map_peaks(self, p: dict[str, Any], fps: float, focal_px: float,
                            logh: float, n_keep: int = 3,
                            umax: float | None = None) -> list[np.ndarray]:
        """The ``n_keep`` best local maxima (px/frame) of the score of the map's modes
        (:meth:`_map_tables`) over the image velocity at altitude ``exp(logh)``, within
        ``BLIND_MAX_SPEED_MPS`` (and ``max_shift_px``) of still.

        Each mode's share over the phase step is a Fourier series, and the phase step is
        linear in the velocity, ``s omega / fps - kappa . u``; the modes lie on the tile's
        wavenumber lattice ``kappa = 2 pi (a / w, b / h)``, so the sum over the modes, both
        directions ``s`` added, is one 2-D FFT over a velocity lattice of period ``(w, h)``
        px/frame (exact at its points, which are :meth:`_map_step` apart).  ``logh = inf``
        maps a pattern carried without dispersion (:meth:`_carried_velocity`); ``umax``,
        px/frame, replaces the speed bound.
        """
        m = self._map_tables(p)
        mx, my = m["mx"], m["my"]
        om = self.omega(m["kappa"] * focal_px / math.exp(logh)) / fps  # rad/frame
        # both directions: e^{+i k om} + e^{-i k om}, one row per distinct wavenumber
        cos = np.cos(np.outer(om, m["k"]))
        c = np.zeros(mx * my, dtype=np.complex64)
        ck = compiled_module()
        if ck is not None:  # the same sums in one pass
            ck.scatter_products(m["coef"], cos, m["rows"], m["slot"], m["cells"], c)
        else:
            coef = m["coef"] * (2.0 * cos)[m["rows"]]
            c.real = np.bincount(m["idx"], coef.real.ravel(), mx * my)
            c.imag = np.bincount(m["idx"], coef.imag.ravel(), mx * my)
        # score(u = (l_x w / mx, l_y h / my)) = sum_K c[K] e^{-2 pi i K . l / M}
        uy, ux = m["uy"], m["ux"]
        # the local maxima within the speed searched (the map spans a whole period)
        if umax is None:
            umax = BLIND_MAX_SPEED_MPS * focal_px / (math.exp(logh) * fps)
        umax = min(self.max_shift_px, umax)
        rows, cols = np.flatnonzero(np.abs(uy) <= umax), np.flatnonzero(np.abs(ux) <= umax)
        rows, cols = np.arange(rows[0], rows[-1] + 1), np.arange(cols[0], cols[-1] + 1)
        score = _map_window(c.reshape(my, mx), rows, cols)
        uy, ux = uy[rows, None], ux[None, cols]
        score[np.hypot(ux, uy) > umax] = -np.inf
        nx = score.shape[1]
        peaks = (_map_peaks_arrays if ck is None else ck.map_peaks)(score, n_keep)
        return [np.array([ux[0, i % nx], uy[i // nx, 0]]) for i in peaks]

    def _map_best_velocity(self, p: dict[str, Any], fps: float, focal_px: float, logh: float,
                           modes: np.ndarray | None, n_keep: int = 3,
                           umax: float | None = None, min_step: float = 0.0015
                           ) -> tuple[float, np.ndarray] | None:
        """The best of the velocity map's ``n_keep`` best peaks at altitude ``exp(logh)``
        (:meth:`_velocity_map_peaks`, within ``umax``), scored on ``modes``, refined
        (:meth:`_best_velocity` from the map's step down to ``min_step``): its score and
        velocity, or None where the map has no peak."""
        peaks = self._velocity_map_peaks(p, fps, focal_px, logh, n_keep, umax)
        if not peaks:
            return None
        cand = np.array(peaks)
        ck = compiled_module()
        if ck is not None:  # the same choice, scored in one compiled pass
            om, a, to_bins = self._compass_row(p, fps, focal_px, logh, modes)
            k = ck.best_start(om, a["kx"], a["ky"], a["pair"], cand[:, 0].copy(),
                              cand[:, 1].copy(), to_bins)
        else:
            lg = np.full(len(peaks), logh)
            k = int(np.argmax(self._score(p, fps, focal_px, lg, cand[:, 0], cand[:, 1],
                                          modes)))
        return self._best_velocity(p, fps, focal_px, logh, cand[k], modes, self._map_step(p),
                                   min_step)


def _map_lattice(kx: np.ndarray, ky: np.ndarray, kappa: np.ndarray, tile: tuple[int, int],
                 frames: int, n_psi: int) -> dict[str, Any]:
    """The velocity map's lattice for a periodogram's modes ``kx, ky, kappa`` (rad/px) of
    ``(h, w)`` ``tile``, ``frames`` and ``n_psi`` table steps: its modes, the lattice's
    size, step and velocities and each of the modes' Fourier coefficients' place on it (and
    the occupied places, a quarter of the lattice), and the modes' distinct wavenumbers (a
    mode's phase step depends on ``|kappa|`` alone, and a square tile's modes come in fours
    of one ``|kappa|``).  The step, px/frame, is half the width ``(2 pi / T) / kappa`` of
    the peak over the velocity of the longest modes' top (``kappa <= BLIND_MAP_KAPPA``, at
    least 24 modes); the modes reach ``BLIND_MAP_REACH`` times that top, where the step is
    a whole width (``constants``).

    The same modes come back window after window (the periodogram's fixed subsample of a
    tile's plane): the lattices of the last ``_LATTICES_KEPT`` are kept, shared (their
    arrays are not to be written).
    """
    key = (kx.tobytes(), ky.tobytes(), kappa.tobytes(), tile, frames, n_psi)
    if key in _LATTICES:
        return _LATTICES[key]
    modes = np.flatnonzero(kappa <= BLIND_MAP_KAPPA)
    if modes.size < 24:
        modes = np.argsort(kappa, kind="stable")[:24]
    th, tw = tile
    top = float(kappa[modes].max())
    step = 0.5 * (2.0 * np.pi / frames) / top
    modes = np.union1d(modes, np.flatnonzero(kappa <= BLIND_MAP_REACH * top))
    # a fast FFT length at or above the lattice the step asks for (its spacing a little
    # finer): a prime length costs several times as much
    mx, my = (scipy.fft.next_fast_len(max(8, round(n / step))) for n in (tw, th))
    k = np.rint(np.fft.fftfreq(n_psi, 1.0 / n_psi)).astype(np.int64)
    a = np.rint(kx[modes] * tw / (2.0 * np.pi)).astype(np.int64)
    b = np.rint(ky[modes] * th / (2.0 * np.pi)).astype(np.int64)
    idx = (((k[None, :] * b[:, None]) % my) * mx + (k[None, :] * a[:, None]) % mx).ravel()
    distinct, rows = np.unique(kappa[modes], return_inverse=True)
    cells, slot = np.unique(idx, return_inverse=True)
    lattice = {
        "modes": modes, "step": step, "mx": mx, "my": my, "k": k, "kappa": distinct,
        "rows": rows, "idx": idx, "cells": cells, "slot": slot,
        # the lattice's velocities, px/frame, in fftshift's order
        "uy": np.fft.fftshift(np.fft.fftfreq(my, 1.0 / th)),
        "ux": np.fft.fftshift(np.fft.fftfreq(mx, 1.0 / tw))}
    with _LATTICES_LOCK:  # estimates in several threads share the lattices
        while len(_LATTICES) >= _LATTICES_KEPT:
            del _LATTICES[next(iter(_LATTICES))]
        _LATTICES[key] = lattice
    return lattice


#: The lattices last built (:func:`_map_lattice`), oldest first.
_LATTICES: dict[tuple[Any, ...], dict[str, Any]] = {}
_LATTICES_KEPT = 8
_LATTICES_LOCK = threading.Lock()


def _map_window(c: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``fftshift(fft2(c).real)[rows][:, cols]`` of a complex64 lattice ``c`` (SciPy's
    FFT), the same bits for a part of the work: ``fft2`` transforms the columns, then the
    rows, and only the rows kept need the second pass (a test holds it to ``fft2``).  The
    velocity map keeps about a third of its rows (the speeds searched)."""
    my, mx = c.shape
    first = scipy.fft.fft(c, axis=0, workers=1)
    # fftshift: shifted index i holds index (i - n // 2) mod n
    second = scipy.fft.fft(first[(rows - my // 2) % my], axis=1, workers=1)
    return second.real[:, (cols - mx // 2) % mx]


def _map_peaks_arrays(score: np.ndarray, n_keep: int) -> np.ndarray:
    """The flat indices of the ``n_keep`` highest local maxima of ``score`` (2-D): finite
    points at least as high as each of their eight neighbours, highest first, ties in index
    order (the compiled form, :func:`~wavealt.altimetry.dispersion.compiled.map_peaks`, gives
    the same)."""
    ny, nx = score.shape
    pad = np.pad(score, 1, constant_values=-np.inf)
    nb = np.max([pad[1 + dy:1 + dy + ny, 1 + dx:1 + dx + nx]
                 for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx], axis=0)
    peaks = np.flatnonzero(((score >= nb) & np.isfinite(score)).ravel())
    return peaks[np.argsort(-score.ravel()[peaks], kind="stable")][:n_keep]
