"""A camera's yaw rate from its corner tiles' cross-spectra, with no altitude needed.

A camera turning about its optical axis at ``Omega`` rad a frame (the top of the image, the
vehicle's nose, to the right) moves the image at a point ``(x, y)`` px from the centre (image
y down) by ``Omega (y, -x)`` px a frame, on top of whatever the sea does there; the sea's
own motion (the waves, the drift) is the same in every tile of a level camera.  So for a
spatial mode ``k`` that two tiles ``i, j`` both see coherently, the difference of their
frame-to-frame phase steps (the angle of ``C_i conj(C_j)``, ``C`` the tile's lag-one
cross-spectrum at ``k``) is ``Omega (k_y dx - k_x dy)``, ``(dx, dy) = r_i - r_j``: the
dispersion relation, the altitude and the drift cancel.  Each unit, one of the six pairs
of the four corner tiles in one of ``YAW_BANDS`` bands of wavenumber, fits ``Omega`` to its
modes (a Tukey-weighted regression through the origin, weights the squared coherence); the
units' median is the estimate and their spread its standard error.  The modes of a tile are
not independent (its window couples neighbouring modes, and each tile's sea differs in
detail from another's), which makes a regression's own standard error too small by several
times; units that share no mode are closer to independent.  Marine-radar current retrieval
fits the same phase steps mode by mode (Young, Rosenthal & Ziemer 1985), for one velocity
over the whole image.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wavealt.altimetry.dispersion.constants import YAW_BANDS, YAW_MIN_PX, YAW_SIGMAS
from wavealt.altimetry.dispersion.spectra import _wrap

#: The pairs of :func:`~.spectra._corners`'s tiles (top left, top right, bottom left,
#: bottom right): two diagonals, two rows, two columns.
PAIRS = ((0, 3), (1, 2), (0, 1), (2, 3), (0, 2), (1, 3))
#: Least coherence, in both tiles, of a mode a pair fits: a mode of coherence ``c`` over
#: ``n`` frame pairs has phase variance ``(1 - c^2) / (2 n c^2)``; at 0.5 and nine pairs,
#: 0.33 rad.
MIN_COHERENCE = 0.5
#: Least number of modes a pair fits.
MIN_PAIR_MODES = 20
#: Tukey's biweight constant (95 % efficiency under Gaussian residuals).
_TUKEY = 4.685
_TUKEY_STEPS = 4


def _median(x: np.ndarray) -> float:
    """``np.median`` of a 1-D array, the same bits without its overhead: the middle value,
    or the mean of the two middle values."""
    n = x.size
    k = n // 2
    if n % 2:
        return float(np.partition(x, k)[k])
    part = np.partition(x, (k - 1, k))
    return float((part[k - 1] + part[k]) / 2.0)


def _unit_rate(d: np.ndarray, geo: np.ndarray, w: np.ndarray, kappa: np.ndarray,
               start: float = 0.0) -> float:
    """The rate of one unit: Tukey-weighted least squares through the origin of the wrapped
    phase differences ``d`` on ``geo``, weights ``w``, from the rate ``start``; first on the
    modes below 1 rad/px (which wrap only at many times the rates of interest), then on all
    about that rate, the residuals' scale (their MAD) taken once in each."""
    om = start
    low = kappa < 1.0
    phases = [(d, geo, w)]
    if int(low.sum()) >= MIN_PAIR_MODES // 2:
        phases.insert(0, (d[low], geo[low], w[low]))
    for dd, gg, ww in phases:
        scale = None
        for _ in range(_TUKEY_STEPS):
            r = _wrap(dd - om * gg)  # about the current rate
            if scale is None:
                scale = _TUKEY * (1.4826 * _median(np.abs(r)) + 1e-9)
            u = r / scale
            tw = np.maximum(1.0 - u * u, 0.0) ** 2 * ww
            om += float(np.dot(tw * gg, r) / max(float(np.dot(tw * gg, gg)), 1e-30))
    return om


def _wraps(rate: float, geo: np.ndarray) -> bool:
    """Whether a turn of ``rate`` rad a frame moves the phase differences of most of a unit's
    modes (``geo`` their lever, :func:`tile_yaw`) by more than a quarter turn."""
    bound = 0.5 * np.pi
    if abs(rate) * float(np.max(np.abs(geo))) <= bound:  # cheap: none does
        return False
    return abs(rate) * float(np.quantile(np.abs(geo), 0.9)) > bound


def tile_yaw(series: np.ndarray, kx: np.ndarray, ky: np.ndarray,
             centres: list[tuple[float, float]]) -> tuple[float, float, int]:
    """The yaw rate that the corner tiles' mode series show: ``(omega, sd, units)``, omega in
    rad a frame, positive turning the top of the image right (the vehicle's nose; the sense
    of :func:`wavealt.camera.unturn_yaw`'s rate), ``sd`` its standard error from the units'
    spread, ``units`` how many pairs and bands of wavenumber held enough modes (``(nan, nan,
    units)`` below three).

    ``series``: ``(4, T, modes)`` complex mode amplitudes of the four tiles (temporal mean
    removed), of the wavenumbers ``kx, ky`` rad/px; ``centres``: the tiles' centres ``(x,
    y)``, px (:func:`~.attitude.tile_centres`).
    """
    g = np.asarray(series)
    cross = np.einsum("itm,itm->im", g[:, 1:], np.conj(g[:, :-1]))  # (4, modes)
    mag = np.abs(g)
    amp = np.einsum("itm,itm->im", mag[:, 1:], mag[:, :-1])
    coh = np.abs(cross) / np.maximum(amp, 1e-30)
    kappa = np.hypot(kx, ky)
    bands: list[list[tuple[np.ndarray, ...]]] = [[] for _ in range(YAW_BANDS)]
    for i, j in PAIRS:
        c = np.minimum(coh[i], coh[j])
        m = np.flatnonzero(c > MIN_COHERENCE)
        if m.size < MIN_PAIR_MODES * YAW_BANDS:
            continue
        # the image at r moves by omega (y, -x) px a frame: tile i past tile j by omega
        # (dy, -dx), which turns the angle of a mode's cross-spectrum by omega (ky dx - kx dy)
        dx = centres[i][0] - centres[j][0]
        dy = centres[i][1] - centres[j][1]
        geo = ky[m] * dx - kx[m] * dy
        d = np.angle(cross[i, m] * np.conj(cross[j, m]))
        w = c[m] ** 2
        # bands of wavenumber: units that share no mode (a tile's window couples only
        # neighbouring modes)
        order = np.argsort(kappa[m], kind="stable")
        for b, part in enumerate(np.array_split(order, YAW_BANDS)):
            bands[b].append((d[part], geo[part], w[part], kappa[m][part]))
    ests: list[float] = []
    below = 0.0
    for units in bands:
        # A turn so fast that the band below's median rate wraps this band's phase
        # differences (by a quarter turn on most of its modes): its units start from that
        # rate, as from 0 their fits would find another; slower, from 0, so that no unit
        # leans on the others' noise.
        rates = [_unit_rate(*unit, start=below if _wraps(below, unit[1]) else 0.0)
                 for unit in units]
        ests += rates
        below = float(np.median(rates)) if rates else below
    if len(ests) < 3:
        return math.nan, math.nan, len(ests)
    e = np.asarray(ests)
    med = float(np.median(e))
    # the median's standard error: 1.2533 sigma / sqrt(n), sigma from the MAD
    sd = 1.2533 * 1.4826 * float(np.median(np.abs(e - med))) / math.sqrt(e.size)
    return med, sd, e.size


def significant_turn(series: np.ndarray, kx: np.ndarray, ky: np.ndarray,
                     centres: list[tuple[float, float]], fps: float,
                     with_sd: bool = False) -> Any:
    """:func:`tile_yaw`'s rate in deg/s (positive: the top of the image turning right, as
    :func:`wavealt.camera.unturn_yaw` takes it) where it is a turn: at least
    ``YAW_SIGMAS`` standard errors from zero, and moving the tiles' centres at least
    ``YAW_MIN_PX`` px a frame; else None.  ``with_sd``: ``(rate, its standard error)``,
    both deg/s, instead of the rate."""
    om, sd, _ = tile_yaw(series, kx, ky, centres)
    if not math.isfinite(om):
        return None
    reach = abs(om) * max(math.hypot(*c) for c in centres)  # px a frame at the tiles
    if abs(om) < YAW_SIGMAS * sd or reach < YAW_MIN_PX:
        return None
    rate = math.degrees(om) * fps
    return (rate, math.degrees(sd) * fps) if with_sd else rate
