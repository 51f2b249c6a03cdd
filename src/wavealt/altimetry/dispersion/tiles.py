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
    TILE_RANGE_FACTOR,
    TILT_REACH_FACTOR,
    TRUSTED_QUALITY,
    WEAK_TILE_BAR,
)
from wavealt.altimetry.dispersion.result import DispersionResult
from wavealt.altimetry.dispersion.signal import normal_scores
from wavealt.altimetry.dispersion.spectra import _corners
from wavealt.altimetry.dispersion.trust import _corner_series

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
        lo, hi = self.altitude_range_m
        near = copy.copy(self)
        if not whole_range:
            near.altitude_range_m = (max(lo, res.altitude_m / TILE_RANGE_FACTOR),
                                     min(hi, res.altitude_m * TILE_RANGE_FACTOR))
        near.n_scan = max(8, round(self.n_scan * math.log(near.altitude_range_m[1]
                                                          / near.altitude_range_m[0])
                                   / math.log(hi / lo)))
        tiles = _corners(signal, self.corner_tiles or 0.4)
        centres = tile_centres(signal.shape[1:], tiles[0].shape[1:])
        # a tile's significance bar is the fit's for its share of the fit's modes (those of
        # the corner tiles' plane, ``max_modes`` of it, where ``p`` is not given)
        n_fit = (p["kappa"].size if p is not None
                 else self._plane(*tiles[0].shape[1:])[4].size)
        series = _corner_series(p, tiles[0].shape[1:])
        fits, weak = [], []
        for i, (tile, (x, y)) in enumerate(zip(tiles, centres)):
            # the tile's series and its power over the plane (its waves' centroids), as
            # the corner tiles' periodogram took them: the same bits as transforming it
            like = (None if series is None
                    else {"corners": False, "frames": t, "_series": series[i:i + 1],
                          "_series_modes": p["_series_modes"],
                          "_power": None if p.get("_powers") is None else p["_powers"][i]})
            # a quarter of the modes (a quarter of the corners' data); the square kept in the
            # table (``docs/dispersion.md``, twenty-seventh session); scored as the corners
            q = self._fit_periodogram(tile if like else normal_scores(tile), corners=False,
                                      like=like, continuum=False,
                                      max_modes=max(self.max_modes // 4, 8))
            if q is None:
                continue
            r = near._aided(q, t, fps, focal_px, res.camera_velocity_mps)
            bar = math.sqrt(q["kappa"].size / n_fit)
            fit = (x, y, math.log(r.altitude_m), r.altitude_std_m / r.altitude_m)
            if self._holds_shell(r, bar):
                fits.append(fit)
            elif (self._holds_shell(r, WEAK_TILE_BAR * bar)
                  and abs(math.log(r.altitude_m / res.altitude_m)) <= math.log(TILT_REACH_FACTOR)):
                weak.append(fit)
        return fits, weak

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
