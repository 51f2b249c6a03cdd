"""The corner tiles fitted one by one: the image scale in four places of the frame, which
the levelling (:mod:`.levelling`) reads a tilt from and the trust verdicts
(:mod:`.trust`) judge a fit by."""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from wavealt.altimetry.dispersion.attitude import tile_centres
from wavealt.altimetry.dispersion.constants import (
    MIN_SIGNIFICANCE,
    RADIAL_RANGE_FACTOR,
    TILE_RANGE_FACTOR,
    TILT_REACH_FACTOR,
    TRUSTED_QUALITY,
    WEAK_TILE_BAR,
)
from wavealt.altimetry.dispersion.result import DispersionResult
from wavealt.altimetry.dispersion.signal import normal_scores
from wavealt.altimetry.dispersion.spectra import _corner_shape, _corners
from wavealt.altimetry.dispersion.trust import _corner_series, _widen, pooled_mean, tile_scatter

#: A corner tile's fit: centre ``(x, y)`` px from the frame's centre, log altitude, its sigma.
Tile = tuple[float, float, float, float]


class _Tiles:
    """The corner tiles' fits of :class:`DispersionAltimeter` (uses ``_aided``,
    ``_fit_periodogram``, ``_plane``, ``altitude_range_m``, ``n_scan``, ``max_modes`` and
    ``corner_tiles``)."""

    def _corner_fits(self, signal: np.ndarray, res: DispersionResult, fps: float,
                     focal_px: float, p: dict[str, Any] | None = None,
                     whole_range: bool = False) -> tuple[list[Tile], list[Tile]]:
        """Each corner tile of ``signal`` fitted alone at the fit's velocity (m/s; the tile's
        own altitude scales it to pixels), with the aided search of :meth:`_aided` on a
        quarter of the modes: ``(x, y, log altitude, sd_log)`` of every tile whose fit holds
        a shell's peak (significant and prominent, as :meth:`_distrust` asks, however wide
        its interval), ``(x, y)`` its centre in px from the frame's centre; and, second, of
        every weak tile: one whose peak is prominent and stands above random phase steps by
        ``WEAK_TILE_BAR`` of a tile's bar, within ``TILT_REACH_FACTOR`` of the fit's
        altitude (a scale that a tilt within the tool's reach gives a corner).  A weak
        tile's peak may be the shell's where the sea shows faintly (a tilted camera sees
        the near side of the sea steeply, darker and with less contrast), and helps to
        measure a tilt where the tiles that hold the shell cannot (:meth:`_level`); no
        trust verdict rests on it.  A tile is searched within ``TILE_RANGE_FACTOR`` of the
        fit's altitude (a tilt within the tool's reach moves a tile's scale by far less,
        and a peak beyond is not the shell), or over the whole range (``whole_range``: a
        fit without a shell's peak), as finely.  ``p``: the fit's periodogram of ``signal``
        on the same corner tiles, whose mode series the tiles take where they hold the
        tile's modes, instead of transforming the tiles again (the same bits)."""
        t = signal.shape[0]
        near = self._near(res, None if whole_range else TILE_RANGE_FACTOR)
        tiles = _corners(signal, self._tile_fraction())
        centres = tile_centres(signal.shape[1:], tiles[0].shape[1:])
        n_fit = self._fit_modes(p, tiles[0].shape[1:])
        series = _corner_series(p, tiles[0].shape[1:])
        fits, weak = [], []
        for i, (tile, (x, y)) in enumerate(zip(tiles, centres)):
            # the tile's series and its power over the plane (its waves' centroids), as
            # the corner tiles' periodogram took them: the same bits as transforming it
            like = (None if series is None
                    else {"corners": False, "frames": t, "_series": series[i:i + 1],
                          "_series_modes": p["_series_modes"],
                          "_power": None if p.get("_powers") is None else p["_powers"][i]})
            fitted = self._tile_fit(near, tile, like, fps, focal_px, res, n_fit)
            if fitted is None:
                continue
            r, bar = fitted
            fit = (x, y, math.log(r.altitude_m), r.altitude_std_m / r.altitude_m)
            if self._holds_shell(r, bar):
                fits.append(fit)
            elif (self._holds_shell(r, WEAK_TILE_BAR * bar)
                  and abs(math.log(r.altitude_m / res.altitude_m)) <= math.log(TILT_REACH_FACTOR)):
                weak.append(fit)
        return fits, weak

    def _near(self, res: DispersionResult, factor: float | None) -> Any:
        """This altimeter searching within ``factor`` of ``res``'s altitude, or over the
        whole range (None), as finely."""
        lo, hi = self.altitude_range_m
        near = copy.copy(self)
        if factor is not None:
            near.altitude_range_m = (max(lo, res.altitude_m / factor),
                                     min(hi, res.altitude_m * factor))
        near.n_scan = max(8, round(self.n_scan * math.log(near.altitude_range_m[1]
                                                          / near.altitude_range_m[0])
                                   / math.log(hi / lo)))
        return near

    def _fit_modes(self, p: dict[str, Any] | None, tile: tuple[int, int]) -> int:
        """The modes of the fit that a tile's significance bar is scaled from: those of its
        periodogram ``p``, else of the corner tiles' plane (``max_modes`` of it) for tiles
        ``tile`` ``(h, w)``."""
        return p["kappa"].size if p is not None else self._plane(*tile)[4].size

    def _tile_fit(self, near: Any, tile: np.ndarray, like: dict[str, Any] | None,
                  fps: float, focal_px: float, res: DispersionResult, n_fit: int
                  ) -> tuple[DispersionResult, float] | None:
        """One tile's frames ``tile`` (or its mode series ``like``) fitted alone by
        ``near``'s aided search at ``res``'s velocity (m/s), and the tile's significance
        bar as a part of the fit's: the fit's for its share of the fit's ``n_fit`` modes.
        A quarter of the modes (a quarter of the corners' data); the square kept in the
        table (``docs/dispersion.md``, twenty-seventh session); scored as the corners.
        None where the tile holds no modes."""
        q = self._fit_periodogram(tile if like else normal_scores(tile), corners=False,
                                  like=like, continuum=False,
                                  max_modes=max(self.max_modes // 4, 8))
        if q is None:
            return None
        r = near._aided(q, tile.shape[0], fps, focal_px, res.camera_velocity_mps)
        return r, math.sqrt(q["kappa"].size / n_fit)

    def _edge_fits(self, signal: np.ndarray, tile: tuple[int, int], res: DispersionResult,
                   fps: float, focal_px: float, p: dict[str, Any] | None
                   ) -> list[tuple[float, float, float]]:
        """The tiles of the corner tiles' size ``tile`` ``(h, w)`` at the middle of each side
        of ``signal``'s frames, each fitted alone as :meth:`_corner_fits` fits a corner, within
        ``RADIAL_RANGE_FACTOR`` of the fit's altitude: ``(mean r^2, log altitude, sd_log)``
        of every one whose fit holds a shell's peak, ``r`` a pixel's distance (px) from the
        frame's centre, averaged over the tile."""
        _, h0, w0 = signal.shape
        h, w = tile
        near = self._near(res, RADIAL_RANGE_FACTOR)
        n_fit = self._fit_modes(p, (h, w))
        out = []
        for y0, x0 in ((0, (w0 - w) // 2), (h0 - h, (w0 - w) // 2), ((h0 - h) // 2, 0),
                       ((h0 - h) // 2, w0 - w)):
            fitted = self._tile_fit(near, signal[:, y0:y0 + h, x0:x0 + w], None, fps,
                                    focal_px, res, n_fit)
            if fitted is not None and self._holds_shell(*fitted):
                r = fitted[0]
                out.append((_mean_r2(h0, w0, y0, x0, h, w), math.log(r.altitude_m),
                            r.altitude_std_m / r.altitude_m))
        return out

    def _radial_verdict(self, fits: list[Tile], res: DispersionResult, signal: np.ndarray,
                        fps: float, focal_px: float, p: dict[str, Any] | None) -> str | None:
        """Why a fit that passes every other test is not trusted because the image scale
        changes from the frame's centre out, None where it does not; the change's part in
        the fit (:func:`radial_offset`) joins its uncertainty, in place.

        A lens's radial distortion (OpenCV's ``1 + k1 r^2``) changes the scale with the
        square of the distance from the centre.  The four corner tiles ``fits`` lie at one
        distance, so they read one scale and no tilt, and the fit, made of their
        periodogram, reads theirs: an untold barrel lens reads high at an uncertainty that
        does not show it, and is trusted (``docs/dispersion.md``, forty-ninth session).  The edge
        tiles (:meth:`_edge_fits`) lie nearer the centre and read part of the change;
        their difference from the corners, on the square of the distance, says what the
        corners read beyond the centre's pinhole scale.  A tilt changes the scale linearly
        across the frame, alike in the mean of the corners and of the edges.  (A centre
        tile is not used: seen along the surface normal, its image is nearly quadratic in
        the slope, and it reads the optics' products.)"""
        if not fits:
            return None
        _, h0, w0 = signal.shape
        h, w = _corner_shape(h0, w0, self._tile_fraction())
        edges = self._edge_fits(signal, (h, w), res, fps, focal_px, p)
        if not edges:
            return None
        corners = [(_mean_r2(h0, w0, 0, 0, h, w), lg, sd) for _, _, lg, sd in fits]
        off, d, s = radial_offset(corners, edges)
        if off == 0.0:
            return None
        _widen(res, off)
        if self._distrust(res) is None:
            return None
        return (f"the frame's edges read {100 * math.expm1(d):+.0f} % from its corners "
                f"({abs(d) / s:.1f} sigma): the image scale changes from the centre out (a "
                f"lens that distorts: give its calibration)")

    @staticmethod
    def _holds_shell(res: DispersionResult, scale: float = 1.0, prominent: bool = True) -> bool:
        """Whether a fit found a shell's peak: significant and prominent (the first two of
        :meth:`_distrust`'s tests; not ``prominent``: the first), however wide its interval.
        ``scale``: of the bar, for a fit on a part of the modes (a corner tile,
        :meth:`_corner_fits`): the score's noise falls as one over the square root of the
        modes averaged, so the same evidence in each mode stands that much less far above it
        (a tile on 1000 of the fit's 2598 modes, 0.62 of the bar)."""
        return (res.significance >= MIN_SIGNIFICANCE * scale
                and (res.quality >= TRUSTED_QUALITY or not prominent))


def _mean_r2(h0: int, w0: int, y0: int, x0: int, h: int, w: int) -> float:
    """The mean squared distance (px^2) from the centre of an ``(h0, w0)`` frame of the
    pixels of its tile ``(h, w)`` whose first pixel is ``(y0, x0)``."""
    ys = np.arange(y0, y0 + h) + 0.5 - h0 / 2.0
    xs = np.arange(x0, x0 + w) + 0.5 - w0 / 2.0
    return float(np.mean(ys * ys) + np.mean(xs * xs))


def _pooled(fits: list[tuple[float, float, float]]) -> tuple[float, float, float]:
    """Random-effects means of ``fits`` (each ``(mean r^2, log altitude, sd_log)``): the
    mean of their squared distances, their log altitude (weighted with their scatter beyond
    their noise, :func:`~.trust.tile_scatter`), and its standard deviation."""
    logs = [(lg, sd) for _, lg, sd in fits]
    mean, sd_mean = pooled_mean(logs, tile_scatter(logs))
    return float(np.mean([r2 for r2, _, _ in fits])), mean, sd_mean


def radial_offset(corners: list[tuple[float, float, float]],
                  edges: list[tuple[float, float, float]]) -> tuple[float, float, float]:
    """How far the corner tiles ``corners`` read from the frame's centre, where the edge
    tiles ``edges`` (each ``(mean r^2, log altitude, sd_log)``, ``r`` px from the centre)
    show a scale that changes with the square of the distance beyond their noise; 0 where
    the edges' mean and the corners' agree within the noise of their difference at test
    level ``TILE_SCATTER_LEVEL``.  Also that difference ``d`` (edges less corners) and its
    standard deviation ``s``, in log altitude.

    With the scale ``log h + a r^2`` (a lens's first radial term) the two means differ by
    ``d = a (R_e - R_c)``, and the corners read ``a R_c`` off the centre; the part of ``d``
    beyond ``s`` (``sqrt(d^2 - s^2)``, DerSimonian and Laird's variance between two
    estimates) is taken, scaled by ``R_c / (R_c - R_e)``.  The result has the sign of the
    corners' reading less the centre's."""
    rc, mc, sc = _pooled(corners)
    re, me, se = _pooled(edges)
    d, s = me - mc, math.hypot(sc, se)
    if rc <= re or tile_scatter([(mc, sc), (me, se)]) <= 0.0:
        return 0.0, d, s
    return -math.copysign(math.sqrt(max(d * d - s * s, 0.0)) * rc / (rc - re), d), d, s
