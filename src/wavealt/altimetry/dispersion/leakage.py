"""Where a mode's waves lie: the wavenumber centroid of what a tile's window admits.

A Hann-windowed tile's mode holds the sea's waves within about a bin and a half of its bin,
weighted by the window's power response and by their own power: its phase step is theirs,
power-weighted.  Where the sea's spectrum falls with the wavenumber the lower side weighs
more, so a mode's waves step as those of a slightly longer wavelength than its bin's
centre, and a fit that puts them at the centre reads a slower shell, a higher camera (a
bias of the blind fit under a per cent: ``docs/dispersion.md``, twenty-first and
twenty-eighth sessions).  To first order the shift is ``(1/3) bin^2 d log S / d k`` (the
window's power response has a second moment of 1/3 bin^2); :func:`mode_shifts` takes it as
the centroid of the 3 x 3 neighbouring bins, each weighted by the window's response and its
power, which is bounded by a bin where the spectrum turns.  The dispersion model then
places each mode at its centroid.
"""

from __future__ import annotations

import numpy as np
import scipy.fft

#: The Hann window's power response one bin off, relative to its own bin (its transform is
#: ``(-1/4, 1/2, -1/4)``, squared ``(1/16, 1/4, 1/16)``): the second moment of the three is
#: 1/3 bin^2, the continuous window's.
_SIDE = 0.25


def full_power(half: np.ndarray, w: int) -> np.ndarray:
    """The ``(h, w)`` plane of a real image's power from its rfft2 half ``(h, w // 2 + 1)``
    (``P(-k) = P(k)``)."""
    h, n = half.shape
    full = np.empty((h, w), dtype=half.dtype)
    full[:, :n] = half
    full[:, n:] = half[(-np.arange(h)) % h][:, w - np.arange(n, w)]
    return full


def centroid_shifts(power: np.ndarray, w: int, idx: np.ndarray) -> np.ndarray:
    """``(2, len(idx))``: the shifts ``(dkx, dky)``, rad/px, of the modes ``idx`` (flat
    indices of an ``(h, w)`` rfft2 plane) to the centroid of the power ``power`` (the
    plane's half) that a Hann window admits into each: its 3 x 3 neighbouring bins
    weighted by the window's power response times their power."""
    h = power.shape[0]
    full = full_power(power.astype(np.float64), w)
    side = (_SIDE, 1.0, _SIDE)
    den = np.zeros_like(full)
    num_x = np.zeros_like(full)
    num_y = np.zeros_like(full)
    for dy in (-1, 0, 1):
        rolled = np.roll(full, -dy, axis=0)
        for dx in (-1, 0, 1):
            v = np.roll(rolled, -dx, axis=1) * (side[dy + 1] * side[dx + 1])
            den += v
            num_x += dx * v
            num_y += dy * v
    r, c = np.divmod(idx, w // 2 + 1)
    d = np.maximum(den[r, c], 1e-300)
    return np.stack([num_x[r, c] / d * (2.0 * np.pi / w), num_y[r, c] / d * (2.0 * np.pi / h)])


def plane_powers(parts: list[np.ndarray], window: np.ndarray,
                 planes: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The power of equal-sized ``parts`` ``(T, h, w)`` windowed by ``window``, summed over
    the frames with each pixel's mean over the frames removed (a still pattern is not a
    wave), over the rfft2 half plane: summed over the parts ``(h, w // 2 + 1)`` and each
    part's ``(parts, h, w // 2 + 1)`` (a part alone: its sum's bits), float64.
    ``planes``: the windowed frames' rfft2 planes ``(parts, T, h, w // 2 + 1)`` where
    already made (the same bits as transforming the parts here)."""
    t, h, w = parts[0].shape
    power = np.zeros((h, w // 2 + 1))
    each = np.empty((len(parts), h, w // 2 + 1))
    for i, part in enumerate(parts):
        f = scipy.fft.rfft2(part * window, workers=1) if planes is None else planes[i]
        mean = f.mean(axis=0)
        total = (f.real ** 2 + f.imag ** 2).sum(axis=0, dtype=np.float64)
        still = t * (mean.real.astype(np.float64) ** 2 + mean.imag.astype(np.float64) ** 2)
        power += total
        power -= still
        np.subtract(total, still, out=each[i])
    return power, each


def mode_shifts(parts: list[np.ndarray], idx: np.ndarray, window: np.ndarray,
                planes: np.ndarray | None = None) -> np.ndarray:
    """:func:`centroid_shifts` of the modes ``idx`` of ``parts`` windowed by ``window``,
    from their power summed over the parts (:func:`plane_powers`)."""
    power = plane_powers(parts, window, planes)[0]
    return centroid_shifts(np.maximum(power, 0.0), parts[0].shape[2], idx)
