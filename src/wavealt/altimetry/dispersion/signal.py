"""Signal preparation: luminance with glint spikes suppressed, or the colour (chroma) signal,
from which white content (glint, saturation, foam) drops out."""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtri

from wavealt._checks import check_choice
from wavealt.altimetry.dispersion.constants import (
    BLOCK_PERIOD_PX,
    DEGLINTS,
    MAD_TO_SD,
    MAX_BIN,
    NORMAL_SCORE_LEVELS,
    WORKING_FOCAL_PER_PX,
)


def _to_gray(frames: np.ndarray) -> np.ndarray:
    """``(T, H, W[, 3])`` float or uint8 -> ``(T, H, W)`` float32 luminance-like mean."""
    scale = np.float32(1.0 / 255.0 if frames.dtype == np.uint8 else 1.0)
    if frames.ndim == 4:
        return (frames @ np.full(3, scale / 3.0, dtype=np.float32)).astype(np.float32, copy=False)
    return frames.astype(np.float32) * scale


def working_bin(h: int, w: int, working_px: int, focal_px: float | None = None) -> int:
    """The binning that brings ``h x w`` px frames to the working scale ``working_px``
    (``WORKING_PX``): the largest power of two, at most ``MAX_BIN``, that leaves the shorter
    side at least ``working_px``; 1 for none (and always for ``working_px`` 0).  Given the
    frames' ``focal_px``, at least the power of two that brings it nearest, in ratio, to the
    working focal length ``WORKING_FOCAL_PER_PX * working_px`` while the shorter side keeps
    half ``working_px``: the scale a fit not trusted at the size rule's is made again at
    (``WORKING_FOCAL_PER_PX``)."""
    b = 1
    while working_px and b < MAX_BIN and min(h, w) >= 2 * b * working_px:
        b *= 2
    if focal_px is not None and working_px:
        # nearest in ratio: binned once more while the focal length stays above the
        # working one over sqrt(2)
        least = WORKING_FOCAL_PER_PX * working_px / math.sqrt(2.0)
        while b < MAX_BIN and focal_px / (2 * b) >= least and min(h, w) >= b * working_px:
            b *= 2
    return b


def bin_frames(frames: np.ndarray, b: int) -> np.ndarray:
    """``(T, H, W[, 3])`` uint8 or float frames binned ``b x b`` px (``b`` a power of two):
    each pixel the mean of a block, float32 in [0, 1], ``(T, H // b, W // b[, 3])``.  The rows
    and columns beyond the last whole block are dropped at the bottom and right, so that the
    blocks keep the frame's origin (where a block coder's 8-px lattice starts).  The blocks
    are summed in pairs, rows then columns: a block of equal values gives that value."""
    t, h, w = frames.shape[:3]
    out = np.empty((t, h // b, w // b, *frames.shape[3:]), dtype=np.float32)
    scale = np.float32((1.0 / 255.0 if frames.dtype == np.uint8 else 1.0) / (b * b))
    for frame, dst in zip(frames, out):
        x = frame[:h // b * b, :w // b * b].astype(np.float32)
        n = 1
        while n < b:
            x = x[0::2] + x[1::2]
            x = x[:, 0::2] + x[:, 1::2]
            n *= 2
        np.multiply(x, scale, out=dst)
    return out


def _has_texture(arr: np.ndarray) -> bool:
    """Whether ``arr`` holds more than one value (beyond float rounding)."""
    return float(np.ptp(arr)) > (0 if arr.dtype == np.uint8 else 1e-6)


def _robust_level(x: np.ndarray, n_sample: int) -> tuple[float, float]:
    """Median and MAD-based standard deviation (``1.4826 * MAD``) of ``x``, from a fixed
    subsample of about ``n_sample`` values (a full median of a 10-frame 256^2 clip costs
    more than the rest of the estimate)."""
    sample = x.ravel()[:: max(1, x.size // n_sample)].astype(np.float32)
    k = sample.size // 2  # the upper median: a partition, several times cheaper than np.median
    med = float(np.partition(sample, k)[k])
    dev = np.abs(sample - np.float32(med), out=sample)
    return med, float(np.partition(dev, k)[k]) * MAD_TO_SD


def _clip_outliers(signal: np.ndarray, n_sigma: float,
                   level: tuple[float, float] | None = None) -> np.ndarray:
    """Clip ``signal`` to its robust ``median +- n_sigma`` spread, both ways, in place
    (``level``: that median and spread, when already measured).

    In the chroma signal the water's colour varies smoothly with the waves; whitecaps (white
    foam carried along by the water, not dispersive) and saturated glint (all channels at
    1) are far outliers of it.  Clipping them keeps their outline from posing as waves.
    """
    med, mad = _robust_level(signal, 4_096) if level is None else level
    if mad <= 0:
        return signal
    return np.clip(signal, med - n_sigma * mad, med + n_sigma * mad, out=signal)


def block_excess(signal: np.ndarray, period: int = BLOCK_PERIOD_PX) -> float:
    """How strongly a block coder's lattice shows in ``(T, H, W)`` ``signal``: along each
    axis, the mean absolute difference between neighbouring pixels at each phase of the
    ``period``-px lattice (every third frame of a clip of nine or more), the highest
    phase's excess over the median phase, relative to it; the smaller of the two axes (a
    coder's blocks step both ways; a texture that repeats every ``period`` px along one axis
    does not make both).  0 for a signal that no lattice touches; the chroma of JPEG-coded
    frames: 0.3 and more (``BLOCK_CODED_MIN_EXCESS``).  Frames smaller than two periods
    give 0."""
    frames = signal[::3] if signal.shape[0] >= 9 else signal
    excess = []
    # columns (steps along x, averaged over frames and rows), then rows
    for axis, across in ((2, (0, 1)), (1, (0, 2))):
        n = (frames.shape[axis] - 1) // period * period
        if n < 2 * period:
            return 0.0
        steps = np.abs(np.diff(frames, axis=axis)).mean(axis=across, dtype=np.float64)
        phase = steps[:n].reshape(-1, period).mean(axis=0)
        mid = float(np.median(phase))
        if mid <= 0.0:
            return 0.0
        excess.append((float(phase.max()) - mid) / mid)
    return min(excess)


def normal_scores(part: np.ndarray, levels: int = NORMAL_SCORE_LEVELS) -> np.ndarray:
    """``part``'s values mapped to the normal scores of their ranks, ``Phi^-1`` of each
    value's mid-rank over the whole array (Gaussian anamorphosis), with the array's own
    mean and standard deviation: a new float32 array whose values keep their order.

    A camera records the sea through monotone non-linear steps (the sky's radiance along its
    gradient, Fresnel's reflectance, the sensor's gamma, clipping); each turns the waves'
    Gaussian slopes into a skewed record whose products lie off the dispersion shell.  The
    ranks undo every monotone step at once.  They are the ranks of ``levels`` equal bins of
    the value range (ties share their bin's mid-rank; the mean and spread are the bins').
    An array of one value is returned as it is."""
    x = np.asarray(part, dtype=np.float32)
    lo, hi = float(x.min()), float(x.max())
    if not hi > lo:
        return x.copy()
    scale = levels / (hi - lo)
    idx = np.multiply(x, np.float32(scale)).astype(np.int32)
    idx -= int(math.floor(lo * scale))
    np.clip(idx, 0, levels - 1, out=idx)
    count = np.bincount(idx.ravel(), minlength=levels)[:levels].astype(np.float64)
    n = float(x.size)
    used = count > 0
    mid_rank = (np.cumsum(count) - 0.5 * count) / n
    score = np.where(used, ndtri(np.clip(mid_rank, 0.5 / n, 1.0 - 0.5 / n)), 0.0)
    centre = lo + (np.arange(levels) + 0.5) / scale
    mean = float(count @ centre) / n
    sd = math.sqrt(max(float(count @ (centre - mean) ** 2) / n, 0.0))
    s_mean = float(count @ score) / n
    s_sd = math.sqrt(max(float(count @ (score - s_mean) ** 2) / n, 1e-30))
    table = (mean + (score - s_mean) * (sd / s_sd)).astype(np.float32)
    return table[idx]


def deglint(gray: np.ndarray, *, method: str = "clip", clip_sigma: float = 3.0,
            out: np.ndarray | None = None) -> np.ndarray:
    """Suppress glint spikes in ``(T, H, W)`` gray frames before the spectral analysis.

    ``"clip"`` limits every pixel to ``median + clip_sigma * 1.4826 * MAD`` of the whole
    sequence (glint is sparse, bright and one-sided; the wave texture is not).  ``"median"``
    replaces each pixel by ``min(value, temporal median + clip_sigma * MAD)`` per pixel.
    ``"none"`` returns the input.  Both are invariant to a brightness gain and offset.
    ``out``: where to write the result (``gray`` itself is allowed); default a new array.
    """
    check_choice("deglint", method, DEGLINTS)
    if method == "none":
        return gray
    if method == "clip":
        med, mad = _robust_level(gray, 16_384)
        return np.minimum(gray, np.float32(med + clip_sigma * mad), out=out)
    med_t = np.median(gray, axis=0, keepdims=True)
    mad = float(np.median(np.abs(gray - med_t))) * MAD_TO_SD
    return np.minimum(gray, med_t + clip_sigma * mad, out=out)


class _Signal:
    """Signal preparation of :class:`DispersionAltimeter`: the scalar sequence fitted,
    luminance with glint clipped or chroma (uses ``signal``, ``deglint``, ``clip_sigma``)."""

    def _luma(self, arr: np.ndarray) -> np.ndarray:
        """The luminance of ``arr`` with glint spikes suppressed (:func:`deglint`), float32."""
        gray = _to_gray(arr)  # a new array: deglinted in place
        return deglint(gray, method=self.deglint, clip_sigma=self.clip_sigma, out=gray)

    def _signal(self, arr: np.ndarray) -> tuple[np.ndarray, str]:
        """The scalar image sequence the spectra are taken of first, and which one it is:
        the chroma with ``signal="chroma"`` on colour frames, else the luminance with glint
        spikes clipped (:func:`deglint`).  ``"auto"`` decides per clip (:meth:`_estimate`).
        """
        if self.signal == "chroma" and arr.ndim == 4:
            return self._chroma(arr, self._colour(arr)[0]), "chroma"
        return self._luma(arr), "luma"

    @staticmethod
    def _colour(arr: np.ndarray) -> tuple[np.ndarray, float]:
        """Chroma weights of ``(T, H, W, 3)`` frames and the share of the luminance's
        variance the chroma explains (R^2), both from a fixed subsample of pixels.

        Sun glint is nearly white: it adds about equally to R, G and B (paper eq. (3) adds it
        exactly so), while the wave texture (reflected sky against water colour) is coloured.
        The chroma removes the grey component of every pixel and keeps the first principal
        component of what is left: glint drops out, the texture stays, and saturated
        (all-white) pixels become constant.  The weights ``w`` give it as ``frames @ w``
        (``(x - mean_c(x)) . v == x . (v - mean(v))``), scaled for uint8 input.
        """
        x = arr.reshape(-1, 3)
        sample = x[:: max(1, x.shape[0] // 4_096)].astype(np.float64)
        if arr.dtype == np.uint8:
            sample /= 255.0
        y = sample - sample.mean(axis=1, keepdims=True)
        y -= y.mean(axis=0)
        _, vecs = np.linalg.eigh(y.T @ y)
        w = vecs[:, -1] - vecs[:, -1].mean()
        chroma, luma = sample @ w, sample.mean(axis=1)
        r2 = 1.0
        if chroma.std() > 1e-9 and luma.std() > 1e-9:
            r2 = float(np.corrcoef(chroma, luma)[0, 1] ** 2)
        scale = 1.0 / 255.0 if arr.dtype == np.uint8 else 1.0
        return (w * scale).astype(np.float32), r2

    def _chroma(self, arr: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """The chroma signal ``arr @ weights`` (:meth:`_colour`), its far outliers (foam,
        saturated glint edges) clipped at levels measured on every 6th pixel both ways."""
        med, mad = _robust_level((arr[:, ::6, ::6] @ weights).astype(np.float32, copy=False),
                                 4_096)
        chroma = (arr @ weights).astype(np.float32, copy=False)
        return _clip_outliers(chroma, self.clip_sigma, (med, mad))
