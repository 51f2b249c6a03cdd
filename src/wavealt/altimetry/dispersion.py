"""Physics-based altimeter: fit the wave dispersion relation to a short frame sequence.

A nadir pinhole camera at ``altitude_m`` images a sea wave of physical wavenumber ``k``
(rad/m) at pixel wavenumber ``kappa = k * altitude_m / focal_px`` (rad/px).  Deep-water
waves obey ``omega^2 = g k + (sigma/rho) k^3`` (Lamb 1932, §266; the capillary term matters
only below a few centimetres), and water moving at ``w`` relative to the camera Doppler
shifts every mode, so the phase of mode ``kappa`` advances per frame by

    psi(kappa) = ( s * omega(|kappa| focal_px / altitude_m) + kappa . u ) / fps,    (1)

with ``s = +1`` for a wave travelling along ``+kappa`` and ``-1`` against it, and
``u = w focal_px / altitude_m`` the water's image velocity in px/s.  In the gravity regime
``omega = a sqrt(|kappa|)`` with ``a^2 = g focal_px / altitude_m`` (Spencer, Shah & Guha,
IEEE TIP 2006, recovered image scale this way).

The estimator tabulates, for every spatial mode of the frame's four corner tiles (where the
image is closest to linear in slope), the share of its temporal energy that one travelling
wave explains as a function of the phase step per frame (a whitened, sharpened periodogram
of the mode's complex amplitudes over the clip), and scores a candidate
``(altitude_m, u)`` by the mean share at the phase steps eq. (1) predicts:

* **exact** (the camera's velocity over the water known, e.g. from satellite navigation):
  a scan over log altitude and the most *prominent* peak of it, refined on a fine grid;
* **blind** (velocity unknown): a per-mode phase-step fit (cross-spectra of consecutive
  frames, Gauss–Newton with Tukey weights on ``(log altitude, u)``) gives a start, and the
  altitude is the most prominent peak of the score's *profile* over log altitude, the
  velocity re-fitted at every altitude.  The phase-step fit alone is exact on imagery
  linear in slope but biased on rendered frames, whose non-linear optics (Fresnel, glint)
  add difference-frequency products that move slower than the waves; the profile needs a
  clip long enough to resolve them (about 1 s).

With a velocity *prior* (the camera's velocity known to within ``sigma``: a vehicle's
navigation, the water's current unknown) exact fits at velocities spread over the prior
propagate its uncertainty into the altitude's.

Every result carries a trust decision (:meth:`DispersionAltimeter._judge`): the shell's
peak must stand out of what random phase steps would give (significance), be prominent in
the altitude scan (quality), have a 3-sigma interval within 10 % of the altitude, and lie
inside the altitude range searched.  The uncertainty is the spread of the peak over bands
of wavenumber (the true shell gives one altitude at every wavenumber; the optics' products
do not) plus a systematic floor; an untrusted window's interval spans the whole range.
Glint is first clipped (per-pixel spikes far above the sequence's robust spread), or
removed with the colour (chroma) signal.

References: Young, Rosenthal & Ziemer (J. Geophys. Res. 1985), dispersion-shell fits to
image sequences; Senet, Seemann & Ziemer (IEEE TGRS 2001), the shell and its harmonics;
Serafino, Lugni & Soldovieri (IEEE GRSL 2010), normalised scalar products with the shell;
Spencer, Shah & Guha (IEEE TIP 2006), image scale from dispersion.
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import scipy.fft

from wavealt._checks import check_choice, check_finite_number, check_frames
from wavealt.ocean.spectrum import GRAVITY_MPS2, SURFACE_TENSION_OVER_DENSITY

DISPERSIONS = ("gravity", "gravity-capillary")
DEGLINTS = ("none", "clip", "median")
TILES = ("quadrants", "full")
SIGNALS = ("auto", "chroma", "luma")
#: Systematic floor of the fit's relative uncertainty (log altitude), for clips of at least
#: ``FULL_CLIP_FRAMES`` frames.
SD_FLOOR_LOG = 0.01
#: Shorter clips get the floor ``SD_FLOOR_LOG (FULL_CLIP_FRAMES / T)^3`` (2.9 % at 7 frames,
#: 8 % at 5, 37 % at 3): with fewer frames the optics' products and the shell share one
#: periodogram bin.  Paper renderer at 30 fps, seed 11, aided, the first T frames of 100
#: windows: 3-sigma coverage at T = 3 / 5 / 7 rose from 0.60-0.75 / 0.79-0.87 / 0.87-0.93 to
#: 1.00 / 1.00 / 0.99-1.00, and no window of 3 or 5 frames is trusted any more (before, 16-31
#: and 6-8 were trusted with errors above 10 %).
FULL_CLIP_FRAMES = 10
#: Quality below which an estimate says it is not to be trusted.
TRUSTED_QUALITY = 0.3
#: Largest phase-step misfit (chi^2 per mode against the coherence-predicted phase noise)
#: of a blind phase-step fit that may stand in for an indecisive profile: 0.6-2.2 on frames
#: linear in slope (8 windows), 2.6-10 on the paper renderer's (24 windows of 10 and 30
#: frames).
PHASE_STEP_CHI2 = 2.0
MIN_FRAMES = 3
#: Largest 3-sigma relative uncertainty of a trusted estimate: the contract is that no
#: trusted window is off by more than 10 %, so one whose own 3-sigma interval is wider
#: cannot be trusted.
MAX_TRUSTED_3SIGMA = 0.10
#: Least significance of the shell's peak: its score above the mean that random phase
#: steps would give, in units of that score's standard deviation (each mode's share
#: averaged over all phase steps; :meth:`DispersionAltimeter._result`).  Uniform RGB noise,
#: 12 frames of 64-256 px, exact and blind (18 windows): 4.6-19, the most prominent of the
#: many candidate peaks; rendered sea windows that pass the other tests: 49-145.
MIN_SIGNIFICANCE = 30.0
#: An estimate within this factor of an end of ``altitude_range_m`` is not trusted: the
#: shell's peak may lie beyond the end, and the fit is pinned to it.
EDGE_FACTOR = 1.15


#: Quality below which an aided chroma fit (``signal="auto"``) is checked against the
#: luminance's (a blind one: below ``TRUSTED_QUALITY``).
#: Paper renderer, 296 windows of seeds 5, 7 and 11 that chose the chroma: 90 % grade
#: 0.86-0.90; the realistic preset's clean chroma, whose colour does not all follow the
#: waves, graded 0.74-0.80 while 23-59 % off (the luminance: 0.88-0.90, within 0.4 %).
CHROMA_CHECK_QUALITY = 0.85


@dataclass
class DispersionResult:
    """The outcome of one dispersion fit.

    Attributes
    ----------
    altitude_m : float
        Estimated camera altitude above the mean sea surface, metres.
    altitude_std_m : float
        One-sigma uncertainty of ``altitude_m``, metres (large when the fit is poor).
    camera_velocity_mps : tuple of float
        ``(vx, vy)``: the camera's velocity relative to the water surface along image +x
        (columns) and +y (rows), m/s; the same convention as the ``velocity_mps`` that
        :meth:`DispersionAltimeter.estimate` takes.  A camera hovering over water that
        drifts at ``c`` has ``-c``.
    quality : float
        In [0, 1]: relative prominence of the wave shell's peak, discounted for a large
        relative uncertainty.
    trusted : bool
        Whether the estimate may be used (an autopilot link sends an untrusted one as a
        dropout, never as a reading).
    reason : str or None
        Why it is not trusted (None when trusted).
    mode : {"blind", "prior", "exact"}
        Velocity unknown; a prior on it (``velocity_sigma_mps > 0``); known exactly.
    frames : int
        Number of frames used.
    n_modes : int
        Number of spatial modes in the final fit.
    signal : str
        The scalar sequence fitted (``"luma"`` or ``"chroma"``) and the tiles it was
        transformed on (``"corners"`` or ``"full"``), e.g. ``"chroma/corners"``.
    """

    altitude_m: float
    altitude_std_m: float
    camera_velocity_mps: tuple[float, float]
    quality: float
    trusted: bool
    reason: str | None
    mode: str
    frames: int
    n_modes: int
    signal: str = ""
    #: How far the shell's peak stands above the score of random phase steps, in standard
    #: deviations of it (``MIN_SIGNIFICANCE``); internal to the trust decision.
    significance: float = field(default=0.0, repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able dict (floats, ints, a two-item list for the velocity)."""
        d = asdict(self)
        d["camera_velocity_mps"] = [float(v) for v in self.camera_velocity_mps]
        for key in ("altitude_m", "altitude_std_m", "quality"):
            d[key] = float(d[key])
        d["trusted"] = bool(self.trusted)
        del d["significance"]
        return d


def _wrap(phase: np.ndarray) -> np.ndarray:
    """Wrap angles to ``(-pi, pi]``."""
    return np.angle(np.exp(1j * phase))


def _to_gray(frames: np.ndarray) -> np.ndarray:
    """``(T, H, W[, 3])`` float or uint8 -> ``(T, H, W)`` float32 luminance-like mean."""
    scale = np.float32(1.0 / 255.0 if frames.dtype == np.uint8 else 1.0)
    if frames.ndim == 4:
        return (frames @ np.full(3, scale / 3.0, dtype=np.float32)).astype(np.float32, copy=False)
    return frames.astype(np.float32) * scale


@functools.lru_cache(maxsize=8)
def _hann2d(h: int, w: int) -> np.ndarray:
    """Separable Hann window ``(h, w)`` float32, zero-free (spectral leakage of a clip);
    cached, read-only."""
    win = (np.hanning(h + 2)[1:-1, None] * np.hanning(w + 2)[None, 1:-1]).astype(np.float32)
    win.flags.writeable = False
    return win


def _windowed_modes(parts: list[np.ndarray], idx: np.ndarray) -> np.ndarray:
    """Hann-windowed 2-D spectra of equal-sized ``(T, h, w)`` float32 ``parts`` (views
    welcome) at the flat rfft2 indices ``idx``: ``(len(parts), T, len(idx))`` complex64.

    The FFTs are SciPy's (single precision). On the corner tiles they are as fast as
    PyTorch's MKL transform (four 30-frame 96^2 tiles: 1.8 ms on one core either way), and
    not importing torch saves about a second of start-up.
    """
    t, h, w = parts[0].shape
    win = _hann2d(h, w)
    x = np.empty((len(parts), t, h, w), dtype=np.float32)
    for i, part in enumerate(parts):
        np.multiply(part, win, out=x[i])
    return scipy.fft.rfft2(x, overwrite_x=True).reshape(len(parts), t, -1)[:, :, idx]


def _one_blas_thread() -> Any:
    """Context in which NumPy's BLAS runs on one thread.

    The matrix products of one window are small; threaded, OpenBLAS's workers keep
    spinning after each product and fight other threads for the cores: on two cores the
    median 10-frame window took 26 ms instead of 19 (p90 86 against 22 ms).
    """
    from threadpoolctl import ThreadpoolController

    global _BLAS_CONTROLLER
    if _BLAS_CONTROLLER is None:
        _BLAS_CONTROLLER = ThreadpoolController()
    return _BLAS_CONTROLLER.limit(limits=1, user_api="blas")


_BLAS_CONTROLLER: Any = None


def _fast_len(n: int) -> int:
    """The largest ``2^a 3^b <= n`` (``n >= 1``): a size the FFT transforms fast (a 10-frame
    stack of four 102^2 tiles took 4.6 ms, of 96^2 tiles 0.7 ms)."""
    best, p3 = 1, 1
    while p3 <= n:
        best = max(best, p3 << (n // p3).bit_length() - 1)
        p3 *= 3
    return best


def _corners(arr: np.ndarray, frac: float = 0.5) -> list[np.ndarray]:
    """The four corner tiles of ``(T, H, W)`` frames (views), each side the largest fast FFT
    size within ``frac`` of the frame's (:func:`_fast_len`; ``frac = 0.5`` on a
    power-of-two frame: the quadrants)."""
    _, h0, w0 = arr.shape
    h, w = _fast_len(int(frac * h0)), _fast_len(int(frac * w0))
    return [arr[:, :h, :w], arr[:, :h, w0 - w:], arr[:, h0 - h:, :w], arr[:, h0 - h:, w0 - w:]]


def _has_texture(arr: np.ndarray) -> bool:
    """Whether ``arr`` holds more than one value (beyond float rounding)."""
    return float(np.ptp(arr)) > (0 if arr.dtype == np.uint8 else 1e-6)


def _sharpen(q: np.ndarray, exponent: float) -> np.ndarray:
    """``q ** exponent``, by repeated multiplication when the exponent is a small integer."""
    e = float(exponent)
    if e != int(e) or not 1 <= e <= 16:
        return q ** np.float32(e)
    out = q.copy()
    for _ in range(int(e) - 1):
        out *= q
    return out


def _robust_level(x: np.ndarray, n_sample: int) -> tuple[float, float]:
    """Median and MAD-based standard deviation (``1.4826 * MAD``) of ``x``, from a fixed
    subsample of about ``n_sample`` values (a full median of a 10-frame 256^2 clip costs
    more than the rest of the estimate)."""
    sample = x.ravel()[:: max(1, x.size // n_sample)].astype(np.float32)
    k = sample.size // 2  # the upper median: a partition, several times cheaper than np.median
    med = float(np.partition(sample, k)[k])
    dev = np.abs(sample - np.float32(med), out=sample)
    return med, float(np.partition(dev, k)[k]) * 1.4826


def _clip_outliers(signal: np.ndarray, n_sigma: float,
                   level: tuple[float, float] | None = None) -> np.ndarray:
    """Clip ``signal`` to its robust ``median +- n_sigma`` spread, both ways, in place
    (``level``: that median and spread, when already measured).

    In the chroma signal the water's colour varies smoothly with the waves; whitecaps (white
    foam carried along by the water, not dispersive) and saturated glint (all channels at
    1) are far outliers of it.  Clipping them keeps their outline from posing as waves.
    Measured on 30 paper-renderer scenes (aided, 256 px): relative MAE clean 4.2 -> 3.8 %,
    glinty 14.8 -> 4.4 %; on 16 realistic clean scenes, confident (quality > 0.5) errors
    above 10 % fell from 5 to 1.
    """
    med, mad = _robust_level(signal, 4_096) if level is None else level
    if mad <= 0:
        return signal
    return np.clip(signal, med - n_sigma * mad, med + n_sigma * mad, out=signal)


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
    mad = float(np.median(np.abs(gray - med_t))) * 1.4826
    return np.minimum(gray, med_t + clip_sigma * mad, out=out)


class DispersionAltimeter:
    """Altitude, its uncertainty and the water's velocity from frames, by wave dispersion.

    Parameters
    ----------
    dispersion : {"gravity-capillary", "gravity"}
        Dispersion relation of the water.  ``"gravity-capillary"``
        (``omega^2 = g k + (sigma/rho) k^3``) is the physics of real water; the ``paper``
        simulator preset moves its waves with ``omega = sqrt(g k)``, so evaluate it with
        ``"gravity"`` (at 1 m the capillary term is several times ``g k`` at the Nyquist
        wavenumber).
    deglint : {"clip", "median", "none"}
        Glint suppression before the analysis (:func:`deglint`).
    clip_sigma : float
        Threshold of the glint clip of the luminance and of the outlier clip of the chroma
        signal (foam, saturated glint), in robust standard deviations.
    max_modes : int
        Most spatial modes entering the fit (phase-step start: the most coherent-energy
        ones; periodogram: a fixed, even subsample of the plane).
    min_kappa_bins : float
        Lowest radial wavenumber used, in FFT bins (lower ones carry the window's leakage
        and the illumination's slow gradients).
    max_kappa_frac : float
        Highest radial wavenumber used, as a fraction of the Nyquist wavenumber pi rad/px.
    max_shift_px : float
        Largest water image speed searched, pixels per frame.
    altitude_range_m : tuple of float
        Altitudes the fit may return, metres (the tool is made for 1-15 m; a wider range lets
        slow, nearly static image content pose as a very high camera).
    tiles : {"quadrants", "full"}
        Cross-spectra of the blind start on the four image quadrants (summed), or on the
        whole frame.
    signal : {"auto", "luma", "chroma"}
        Scalar sequence analysed (:meth:`_signal`): the luminance, glint-clipped, or the
        chroma, from which white content (glint, saturation, foam) drops out.  ``"auto"``
        (the default) fits the chroma of colour frames whose colour explains less than
        ``glint_r2`` of the luminance's variance (white glint dominates the luminance), and
        the luminance too where that fit grades below ``CHROMA_CHECK_QUALITY`` (keeping the
        better) or the colour explains more.  Paper renderer, 10 frames, aided, 2 x 100
        scenes (seeds 7 and 11), relative MAE glinty 3.25 / 2.38 % with the luminance
        alone, 1.46 / 1.78 % auto (before the corner tiles); clean unchanged.  The realistic
        preset's chroma carries colour content that does not follow the waves (chroma
        alone: 127 % clean): most such fits flag themselves, and the check against the
        luminance catches those that do not (40 scenes, 10 frames, clean: three confident
        errors of -59 to +23 % -> one of -16 %, which the luminance makes too).
    glint_r2 : float
        ``"auto"`` fits the chroma first when the squared correlation of luminance and
        chroma over the frame's pixels is below this.  White glint adds to the luminance and
        not to the chroma: on the paper renderer R^2 is 0.3-0.99 (median 0.65) on clean
        frames and 0-0.5 (median 0.08) on glinty ones.
    n_psi : int, optional
        Phase steps tabulated by the periodogram; default: enough to resolve its peak
        (``2 pi / T`` wide) with about six steps, at least 64.
    n_scan : int
        Points of the aided altitude scan over ``altitude_range_m``.
    n_groups : int
        Mode groups whose spread gives the uncertainty.
    sharpness : float
        Exponent applied to every mode's explained share (:meth:`_periodogram`).
    corner_tiles : float
        Side of the four corner tiles the periodogram is taken over, as a fraction of the
        frame's (0.5: the quadrants; :meth:`_periodogram`); 0, or tiles under 32 px, for
        the whole frame.  An aided fit on the tiles that flags itself is tried on the whole
        frame too (:meth:`_fit_signal`).
    """

    def __init__(self, *, dispersion: str = "gravity-capillary", deglint: str = "clip",
                 clip_sigma: float = 3.0, max_modes: int = 4000, min_kappa_bins: float = 2.5,
                 max_kappa_frac: float = 0.85, max_shift_px: float = 16.0,
                 altitude_range_m: tuple[float, float] = (0.5, 20.0),
                 tiles: str = "full", signal: str = "auto", glint_r2: float = 0.3,
                 n_psi: int | None = None, n_scan: int = 80, n_groups: int = 8,
                 sharpness: float = 5.0, corner_tiles: float = 0.4) -> None:
        check_choice("signal", signal, SIGNALS)
        self.corner_tiles = check_finite_number("corner_tiles", corner_tiles, low=0.0, high=0.5)
        self.signal = signal
        self.glint_r2 = check_finite_number("glint_r2", glint_r2, low=0.0, high=1.0)
        for name, v, least in (("n_psi", n_psi, 16), ("n_scan", n_scan, 8), ("n_groups", n_groups, 3)):
            if v is None and name == "n_psi":
                continue
            if int(v) != v or v < least:
                msg = f"{name} must be an integer >= {least}; got {v!r}"
                raise ValueError(msg)
        self.n_psi = None if n_psi is None else int(n_psi)
        self.n_scan, self.n_groups = int(n_scan), int(n_groups)
        self.sharpness = check_finite_number("sharpness", sharpness, low=1.0)
        check_choice("tiles", tiles, TILES)
        self.tiles = tiles
        check_choice("dispersion", dispersion, DISPERSIONS)
        check_choice("deglint", deglint, DEGLINTS)
        self.dispersion = dispersion
        self.deglint = deglint
        self.clip_sigma = check_finite_number("clip_sigma", clip_sigma, low=0.0, low_open=True)
        if int(max_modes) != max_modes or max_modes < 8:
            msg = f"max_modes must be an integer >= 8; got {max_modes!r}"
            raise ValueError(msg)
        self.max_modes = int(max_modes)
        self.min_kappa_bins = check_finite_number("min_kappa_bins", min_kappa_bins, low=1.0)
        self.max_kappa_frac = check_finite_number("max_kappa_frac", max_kappa_frac, low=0.0,
                                                  high=1.0, low_open=True)
        self.max_shift_px = check_finite_number("max_shift_px", max_shift_px, low=0.0)
        lo, hi = altitude_range_m
        check_finite_number("altitude_range_m[0]", lo, low=0.0, low_open=True)
        check_finite_number("altitude_range_m[1]", hi, low=lo, low_open=True)
        self.altitude_range_m = (float(lo), float(hi))

    # -- physics ---------------------------------------------------------------------------
    def omega(self, k: np.ndarray) -> np.ndarray:
        """Angular frequency (rad/s) of physical wavenumber ``k`` (rad/m), deep water."""
        if self.dispersion == "gravity":
            return np.sqrt(GRAVITY_MPS2 * k)
        return np.sqrt(GRAVITY_MPS2 * k + SURFACE_TENSION_OVER_DENSITY * k**3)

    def _omega_and_dlog(self, kappa: np.ndarray, focal_px: float,
                        altitude_m: float) -> tuple[np.ndarray, np.ndarray]:
        """``omega`` and ``d omega / d log(altitude)`` at pixel wavenumbers ``kappa``."""
        k = kappa * focal_px / altitude_m
        w = self.omega(k)
        if self.dispersion == "gravity":
            return w, -0.5 * w
        # d omega/dk = (g + 3 T k^2) / (2 omega);  dk/dlog h = -k
        return w, -k * (GRAVITY_MPS2 + 3.0 * SURFACE_TENSION_OVER_DENSITY * k**2) / (2.0 * w)

    # -- spectra ---------------------------------------------------------------------------
    def _modes(self, gray: np.ndarray) -> dict[str, np.ndarray]:
        """Per-mode phase step, weight and wavenumber from the frame cross-spectra."""
        t, h0, w0 = gray.shape
        if self.tiles == "quadrants":
            # Near nadir the Fresnel reflectance is quadratic in slope (harmonics) and its
            # linear part is the slope times the view tilt, which changes sign across the
            # image centre; an odd modulation smears each mode over its neighbours (biasing
            # toward the stronger, slower low wavenumbers).  Quadrant tiles see one sign.
            parts = _corners(gray)
            h, w = parts[0].shape[1:]
        else:
            h, w = h0, w0
            parts = [gray]
        win = _hann2d(h, w)
        cross = np.zeros((h, w // 2 + 1), dtype=np.complex128)
        amp = np.zeros((h, w // 2 + 1))
        for part in parts:
            x = part - part.mean(axis=(1, 2), keepdims=True)
            f = scipy.fft.rfft2(x * win, axes=(1, 2), workers=1)
            cross += np.sum(f[1:] * np.conj(f[:-1]), axis=0)
            amp += np.sum(np.abs(f[1:]) * np.abs(f[:-1]), axis=0)
        kx, ky, kappa, band, _ = self._plane(h, w)
        bin_kappa = 2.0 * np.pi / max(h, w)
        mag = np.abs(cross)
        coh = np.where(amp > 0, mag / np.maximum(amp, 1e-30), 0.0)
        idx = band
        # keep every low mode (the velocity search starts there) and, above, the modes of
        # most coherent energy after whitening the steep ~kappa^-2 image spectrum
        low = kappa.ravel()[idx] <= max(0.25, 6.0 * bin_kappa)
        score = (coh.ravel()[idx] ** 2 * mag.ravel()[idx] * kappa.ravel()[idx] ** 2)
        score[low] = np.inf
        if idx.size > self.max_modes:
            idx = idx[np.argpartition(-score, self.max_modes)[:self.max_modes]]
        c = np.clip(coh.ravel()[idx], 0.0, 0.999)
        pairs = t - 1
        # phase variance of a coherence-c cross-spectrum over n pairs: (1-c^2)/(2 n c^2)
        var = (1.0 - c**2) / (2.0 * pairs * np.maximum(c, 1e-3) ** 2)
        return {
            "psi": -np.angle(cross.ravel()[idx]),
            "kx": kx.ravel()[idx].astype(np.float64),
            "ky": ky.ravel()[idx].astype(np.float64),
            "kappa": kappa.ravel()[idx].astype(np.float64),
            "weight": 1.0 / (var + 1e-4),
            "energy": mag.ravel()[idx].astype(np.float64),
            "total_energy": np.array(float(mag.ravel()[band].sum())),
            "bin_kappa": np.array(bin_kappa),
            "shape": (h, w),
        }

    # -- fitting ---------------------------------------------------------------------------
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
            n = max(2, int(math.ceil(half / step)))
            g = np.arange(-n, n + 1) * step
            gx, gy = np.meshgrid(center[0] + g, center[1] + g, indexing="ij")
            ring = ring_all[sel] - ring_all[sel].min()
            r = _wrap(psi[sel][None, :] - (gx.ravel()[:, None] * kx[sel][None, :]
                                           + gy.ravel()[:, None] * ky[sel][None, :]))
            cost = self._ring_cost(r, ring, w0[sel], int(ring.max()) + 1).reshape(gx.shape)
            # local minima of the grid, best first
            pad = np.pad(cost, 1, constant_values=np.inf)
            nb = np.min(np.stack([pad[1 + dy:1 + dy + cost.shape[0], 1 + dx:1 + dx + cost.shape[1]]
                                  for dy in (-1, 0, 1) for dx in (-1, 0, 1)
                                  if dy or dx]), axis=0)
            mins = np.flatnonzero((cost <= nb).ravel())
            mins = mins[np.argsort(cost.ravel()[mins])][:keep]
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

    # -- blind fit: per-mode phase steps (velocity unknown) -----------------------------
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
        c_tukey = 0.6  # rad: beyond this a mode is an outlier (harmonic, glint, noise)
        out: dict[str, Any] = {}
        for kb in bands:
            for _ in range(6):
                h = math.exp(logh)
                om, dom = self._omega_and_dlog(kappa, focal_px, h)
                # keep modes whose own wave phase step does not wrap (unambiguous s)
                use = (kappa <= kb) & (om / fps < 0.9 * np.pi)
                if np.count_nonzero(use) < 6:
                    break
                dop = kx * u[0] + ky * u[1]
                rp = _wrap(psi - (om / fps + dop))
                rm = _wrap(psi - (-om / fps + dop))
                s = np.where(np.abs(rp) <= np.abs(rm), 1.0, -1.0)
                r = np.where(s > 0, rp, rm)
                tw = np.where(np.abs(r) < c_tukey, (1.0 - (r / c_tukey) ** 2) ** 2, 0.0)
                wt = (w0 * tw)[use]
                if wt.sum() <= 0:
                    break
                jac = np.stack([s * dom / fps, kx, ky], axis=1)[use]
                jw = jac * wt[:, None]
                hess = jac.T @ jw + np.diag([1e-9, 1e-9, 1e-9])
                step = np.linalg.solve(hess, jw.T @ r[use])
                logh = float(np.clip(logh + step[0], lo, hi))
                u = u + step[1:]
                if abs(step[0]) < 1e-5 and np.max(np.abs(step[1:])) < 1e-4:
                    break
            out = {"logh": logh, "u": u.copy(), "use": use, "r": r, "tw": tw, "hess": hess,
                   "s": s}
        if out:
            # arbiter between starts: robust misfit of every mode, wrapped or not
            out["cost"] = float(np.sum(w0 * np.minimum(out["r"] ** 2, c_tukey**2)))
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
        if fit:
            # phase residuals of the inlier modes relative to the noise their coherence
            # predicts: ~1 when the steps follow one shell (imagery linear in slope), 3-10 on
            # rendered frames, whose non-linear products bias the steps
            use, r, tw = fit["use"], fit["r"], fit["tw"]
            wn = (m["weight"] * tw)[use]
            fit["chi2"] = float(np.sum(wn * r[use] ** 2) / max(np.sum(tw[use] > 0) - 3, 1))
        return fit

    # -- signal ----------------------------------------------------------------------------
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

    # -- whitened periodogram ----------------------------------------------------------------
    def _periodogram(self, signal: np.ndarray, corners: bool = True) -> dict[str, Any]:
        """Per spatial mode, the share of its temporal energy one travelling wave explains,
        tabulated over the phase step per frame.

        For mode ``kappa`` with complex amplitudes ``X_t`` (temporal mean removed), the least-
        squares fit of ``a exp(-i psi t) + b`` explains ``|sum_t X_t exp(i psi t)|^2 / D(psi)``
        of ``E = sum_t |X_t|^2``, with ``D(psi) = T - |sum_t exp(i psi t)|^2 / T``.  The table
        ``Q[mode, j] = explained / E`` at ``psi_j = 2 pi j / n_psi`` is independent of the
        mode's power: every mode votes with equal weight (whitening), so the strong but
        poorly resolved long waves do not drown the short ones, whose phase steps are large
        against the 2 pi / T resolution of a short clip.

        The table is taken over the four corner tiles of the frame (``corner_tiles``;
        explained and total energy summed over them).  Near nadir the Fresnel reflectance is
        quadratic in the angle between the surface normal and the line of sight, so where
        the line of sight is vertical (the image centre) the image records the slope
        squared: sum and difference products of wave pairs, off the dispersion shell.
        Toward the edges the term linear in slope (slope times view tilt) dominates, and a
        tile within one corner sees that tilt with one sign (across the centre it changes
        sign, an odd modulation that smears every mode over its neighbours).  Paper
        renderer, 10 frames, aided, 100 scenes each of seeds 5, 7 and 11 (frames stored as
        float16), relative MAE with the whole frame plus its quadrants -> with corner tiles
        of 0.4: clean 1.49 / 0.77 / 1.08 -> 0.96 / 0.50 / 0.85 %, glinty 3.10 / 1.19 / 1.46
        -> 1.66 / 1.01 / 1.37 %.
        """
        t, h, w = signal.shape
        n_psi = self.n_psi or max(64, 1 << math.ceil(math.log2(6.4 * t)))
        psi = 2.0 * np.pi * np.arange(n_psi) / n_psi
        arg = np.outer(np.arange(t), psi)
        cos, sin = np.cos(arg).T, np.sin(arg).T  # (n_psi, T)
        # [Re z; Im z] = basis @ [Re X; Im X] for z_j = sum_t X_t e^{+i psi_j t}
        basis = np.block([[cos, -sin], [sin, cos]]).astype(np.float32)
        dirichlet = np.abs(np.exp(1j * np.outer(psi, np.arange(t))).sum(axis=1)) ** 2
        denom = np.maximum(t - dirichlet / t, 1e-9)
        corners = corners and _fast_len(int(self.corner_tiles * min(h, w))) >= 32
        parts = _corners(signal, self.corner_tiles) if corners else [signal]
        q, kx, ky, kappa = self._share_table(parts, basis, denom, self.max_modes)
        return {"q": q, "kx": kx, "ky": ky, "kappa": kappa, "frames": t, "corners": corners}

    def _share_table(self, parts: list[np.ndarray], basis: np.ndarray, denom: np.ndarray,
                     limit: int) -> tuple[np.ndarray, ...]:
        """Sharpened explained-share table (:meth:`_periodogram`) of at most ``limit`` modes
        of equal-sized ``parts`` ``(T, h, w)``, explained and total energy summed over the
        parts; and the modes' ``kx, ky, kappa``."""
        t, h, w = parts[0].shape
        kx, ky, kappa, _, idx = self._plane(h, w, limit)
        g = _windowed_modes(parts, idx)  # (parts, T, modes) complex64
        # the temporal mean of every pixel, removed where it is cheap: per selected mode
        g -= g.mean(axis=1, keepdims=True)
        x = np.concatenate([g.real, g.imag], axis=1)  # (parts, 2T, modes)
        energy = np.einsum("ptm,ptm->m", x, x).astype(np.float64)
        # z_j = sum_t X_t e^{+i psi_j t} for every mode and table step as one real matrix
        # product per part (T is short: this beats an n_psi-point FFT per mode)
        z = np.matmul(basis, x)  # (parts, 2 n_psi, modes): Re z over Im z
        z *= z
        z = z.sum(axis=0)
        n_psi = denom.size
        explained = np.ascontiguousarray((z[:n_psi] + z[n_psi:]).T)
        keep = energy > 1e-20 * max(float(energy.max(initial=0.0)), 1e-30)
        if not keep.all():
            idx, explained, energy = idx[keep], explained[keep], energy[keep]
        # explained share |z|^2 / D(psi) / E
        share = explained
        share *= (1.0 / denom).astype(np.float32)[None, :]
        share *= (1.0 / energy).astype(np.float32)[:, None]
        share[:, denom < 0.05 * t] = 0.0  # psi ~ 0: a static pattern, not a wave
        # Sharpen: a mode counts in proportion to (explained share)^sharpness, so modes that
        # one travelling wave explains almost wholly dominate, and modes that mix the wave
        # with the rendering's non-linear products (harmonics, sum and difference
        # frequencies, glint) count little.  Measured on the paper renderer (velocity known,
        # 14 scenes, 1-15 m): relative MAE 9.4 % at 1, 1.05 % at 4, 0.89 % at 6.
        return _sharpen(share, self.sharpness), kx[idx], ky[idx], kappa[idx]

    def _plane(self, h: int, w: int, limit: int | None = None) -> tuple[np.ndarray, ...]:
        """Flat ``kx, ky, kappa`` (rad/px) of an ``(h, w)`` rfft2 plane, the indices of the
        band ``[min_kappa_bins, max_kappa_frac pi]`` (one of each ``+-ky`` pair on the
        ``kx = 0`` column) and the periodogram's fixed, even subsample of it, at most
        ``limit`` (default ``max_modes``; the strongest would be the low wavenumbers only).
        Cached per size and limit."""
        limit = self.max_modes if limit is None else int(limit)
        key = (h, w, limit)
        cache = self.__dict__.setdefault("_plane_cache", {})
        if key not in cache:
            ky = 2.0 * np.pi * np.fft.fftfreq(h)[:, None]
            kx = 2.0 * np.pi * np.fft.rfftfreq(w)[None, :]
            ky, kx = (a.ravel() for a in np.broadcast_arrays(ky, kx))
            kappa = np.hypot(kx, ky)
            bin_kappa = 2.0 * np.pi / max(h, w)
            band = np.flatnonzero((kappa >= self.min_kappa_bins * bin_kappa)
                                  & (kappa <= self.max_kappa_frac * np.pi)
                                  & ~((kx == 0) & (ky < 0)))
            even = band
            if band.size > limit:
                sel = np.random.default_rng(0).choice(band.size, limit, replace=False)
                even = band[np.sort(sel)]
            cache[key] = (kx, ky, kappa, band, even)
        return cache[key]

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
        return arrays if modes is None else {k: v[modes] for k, v in arrays.items()}

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
        if self.dispersion == "gravity":
            # omega = sqrt(g kappa f / h): one outer product instead of a matrix of sqrt
            scale = np.sqrt(GRAVITY_MPS2 * focal_px / np.exp(logh)) * (to_bins / fps)
            om = scale.astype(np.float32)[:, None] * a["sqrt_kappa"][None, :]
        else:
            om = (self.omega(a["kappa"][None, :] * focal_px / np.exp(logh)[:, None])
                  * (to_bins / fps)).astype(np.float32)
        dop = (np.atleast_1d(ux) * to_bins).astype(np.float32)[:, None] * a["kx"][None, :]
        dop += (np.atleast_1d(uy) * to_bins).astype(np.float32)[:, None] * a["ky"][None, :]
        flat = pair.ravel()
        base = np.arange(n_modes, dtype=np.int64)[None, :] * n_psi
        best = wt = None
        # phase steps in table bins, s = +1 and -1 (the second overwrites om, done with)
        for pos in (om - dop, np.negative(np.add(om, dop, out=om), out=om)):
            jf = np.floor(pos)
            frac = pos - jf
            j = jf.astype(np.int64)
            if n_psi & (n_psi - 1) == 0:
                j &= n_psi - 1  # the table's period, also for negative steps
            else:
                j %= n_psi
            if turns:
                # cycles the predicted phase step turns over the clip, minus half a cycle
                w = j.astype(np.float32)
                w += frac
                np.minimum(w, n_psi - w, out=w)
                w *= np.float32(p["frames"] / n_psi)
                w -= np.float32(0.5)
                np.clip(w, 0.0, 1.0, out=w)
            j += base
            g = flat[j]
            val = g.imag * frac
            val += g.real
            if turns:
                wt = w if wt is None else np.where(val > best, w, wt)
            best = val if best is None else np.maximum(best, val)
        return best, wt

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

    # -- public ------------------------------------------------------------------------
    def estimate(self, frames: Any, *, fps: float, focal_px: float,
                 velocity_mps: tuple[float, float] | None = None,
                 velocity_sigma_mps: float = 0.0) -> DispersionResult:
        """Estimate altitude, its uncertainty and the camera's velocity over the water.

        Three modes (``DispersionResult.mode``):

        * **blind** (no ``velocity_mps``): altitude and the camera's velocity relative to the
          water are searched jointly;
        * **prior** (``velocity_mps`` and ``velocity_sigma_mps > 0``): the camera's velocity
          relative to the water lies within about ``3 velocity_sigma_mps`` of
          ``velocity_mps`` (a vehicle's velocity over ground from satellite navigation, the
          water's current and wind drift unknown: sigma ~ the largest current expected);
        * **exact** (``velocity_sigma_mps = 0``): the camera's velocity over the water is
          ``velocity_mps`` (a hovering camera over still water: ``(0, 0)``).

        Parameters
        ----------
        frames : (T, H, W, 3) or (T, H, W) array
            Frame sequence, float in [0, 1] or uint8, ``T >= 3``, evenly spaced in time.
        fps : float
            Frame rate, frames per second.
        focal_px : float
            Focal length in pixels (``(W / 2) / tan(fov_x / 2)``).
        velocity_mps : (float, float), optional
            The camera's velocity (over the water as far as known), m/s, along image +x
            (columns) and +y (rows).
        velocity_sigma_mps : float
            How far, m/s (one sigma, per axis), the camera's velocity over the water may lie
            from ``velocity_mps``; 0 for exact.  Ignored without ``velocity_mps``.

        Returns
        -------
        DispersionResult
        """
        with _one_blas_thread():
            return self._estimate(frames, fps=fps, focal_px=focal_px,
                                  velocity_mps=velocity_mps,
                                  velocity_sigma_mps=velocity_sigma_mps)

    def _estimate(self, frames: Any, *, fps: float, focal_px: float,
                  velocity_mps: tuple[float, float] | None,
                  velocity_sigma_mps: float = 0.0) -> DispersionResult:
        arr = check_frames(frames, min_frames=MIN_FRAMES, allow_gray=True)
        fps = check_finite_number("fps", fps, low=0.0, low_open=True)
        focal_px = check_finite_number("focal_px", focal_px, low=0.0, low_open=True)
        velocity_sigma_mps = check_finite_number("velocity_sigma_mps", velocity_sigma_mps,
                                                 low=0.0)
        if velocity_mps is not None:
            if np.ndim(velocity_mps) != 1 or len(velocity_mps) != 2:
                msg = f"velocity_mps must be two numbers (vx, vy); got {velocity_mps!r}"
                raise ValueError(msg)
            velocity_mps = tuple(check_finite_number("velocity_mps", v) for v in velocity_mps)
        t, h, w = arr.shape[:3]
        if min(h, w) < 16:
            msg = f"frames must be at least 16x16 px; got {h}x{w}"
            raise ValueError(msg)
        # flat input: decided on a subsample when that shows texture (nearly always), else
        # on every pixel
        if not _has_texture(arr[:, ::7, ::7]) and not _has_texture(arr):
            msg = "frames hold no texture (flat, black or saturated); no waves to measure"
            raise ValueError(msg)
        prior = None if velocity_mps is None else (*velocity_mps, velocity_sigma_mps)
        res = self._fit(arr, fps, focal_px, prior)
        res.mode = ("blind" if velocity_mps is None
                    else "prior" if velocity_sigma_mps > 0 else "exact")
        return self._judge(res)

    def _judge(self, res: DispersionResult) -> DispersionResult:
        """The trust decision of a finished fit, in place: a shell peak significant against
        random phase steps (``MIN_SIGNIFICANCE``) and prominent (``TRUSTED_QUALITY``), a
        3-sigma interval within ``MAX_TRUSTED_3SIGMA`` of the altitude, and an estimate
        inside the altitude range (not within ``EDGE_FACTOR`` of an end of it)."""
        lo, hi = self.altitude_range_m
        rel3 = 3.0 * res.altitude_std_m / res.altitude_m
        reason = res.reason
        if res.significance < MIN_SIGNIFICANCE:
            reason = reason or "no wave signal above the noise"
        elif res.quality < TRUSTED_QUALITY:
            reason = reason or "no prominent wave-shell peak"
        elif rel3 > MAX_TRUSTED_3SIGMA:
            reason = f"3-sigma uncertainty {100 * rel3:.0f} % of the altitude"
        elif not lo * EDGE_FACTOR < res.altitude_m < hi / EDGE_FACTOR:
            reason = "at the edge of the altitude range searched"
        res.trusted = reason is None
        res.reason = reason
        if not res.trusted:
            # a window that cannot be measured says so in its uncertainty too: its
            # 3-sigma interval spans the whole altitude range searched
            res.altitude_std_m = max(res.altitude_std_m, (hi - lo) / 3.0)
        return res

    def _fit(self, arr: np.ndarray, fps: float, focal_px: float,
             prior: tuple[float, float, float] | None) -> DispersionResult:
        """The fit of the signal(s) of checked frames ``arr`` (:meth:`estimate`); ``prior``:
        the camera's velocity ``(vx, vy)`` and its sigma (0: exact), None for blind."""
        if self.signal == "auto" and arr.ndim == 4:
            weights, r2 = self._colour(arr)
            if r2 < self.glint_r2:
                # The colour explains little of the luminance: white content (glint) that the
                # luminance's clip leaves in.  The chroma is free of it; a well-graded chroma
                # fit stands, else the luminance's is tried and the better kept (the realistic
                # preset's chroma holds colour content that does not follow the waves).
                res = self._fit_signal(self._chroma(arr, weights), "chroma", fps, focal_px,
                                       prior)
                # (blind fits grade lower, their profile being broader: checked only when
                # untrusted; checking them at 0.85 fitted both on most 30-frame glinty windows,
                # 0.54 -> 1.2 s each, for no gain: 1.34 -> 1.40 %)
                check = (CHROMA_CHECK_QUALITY if prior is not None and prior[2] == 0
                         else TRUSTED_QUALITY)
                if res.quality >= check:
                    return res
                alt = self._fit_signal(self._luma(arr), "luma", fps, focal_px, prior)
                return alt if alt.quality >= res.quality else res
        return self._fit_signal(*self._signal(arr), fps=fps, focal_px=focal_px,
                                prior=prior)

    def _fit_signal(self, signal: np.ndarray, kind: str, fps: float, focal_px: float,
                    prior: tuple[float, float, float] | None) -> DispersionResult:
        """Fit to one scalar ``(T, H, W)`` sequence of ``kind`` (``"luma"``/``"chroma"``),
        the path taken recorded in the result's ``signal``."""
        res = self._fit_path(signal, fps, focal_px, prior)
        res.signal = f"{kind}/{res.signal or 'corners'}"
        return res

    def _fit_path(self, signal: np.ndarray, fps: float, focal_px: float,
                  prior: tuple[float, float, float] | None) -> DispersionResult:
        """Exact, prior or blind fit to one scalar sequence (:meth:`estimate`); a result from
        the whole frame rather than the corner tiles says ``signal="full"``."""
        t = signal.shape[0]
        if float(np.mean(np.var(signal[:, ::4, ::4], axis=0))) <= 1e-12:
            return self._failed(t)
        p = self._periodogram(signal)
        if p["kappa"].size < 12:
            return self._failed(t)
        if prior is not None and prior[2] == 0:
            res = self._aided(p, t, fps, focal_px, prior[:2])
            if res.quality < TRUSTED_QUALITY and p["corners"]:
                # A fast drift carries the water across a corner tile within the clip (3 m/s
                # at 3 m: 7.5 px per frame); the whole frame keeps it in view longer.
                # Realistic preset, 30 frames, 2.9 m at 2.9 m/s: +593 % flagged -> +0.3 %.
                alt = self._aided(self._periodogram(signal, corners=False), t, fps, focal_px,
                                  prior[:2])
                if alt.quality > res.quality:
                    res = alt
                    res.signal = "full"
            return res
        if prior is not None:
            return self._prior(p, t, fps, focal_px, prior)
        m = self._modes(signal)
        if m["kappa"].size < 12:
            return self._failed(t)
        start = self._phase_step_fit(m, fps, focal_px)
        if not start:
            return self._failed(t)
        fit = self._fit_blind(p, fps, focal_px, start["logh"], -start["u"])
        res = self._result(p, fit, t, fps, focal_px)
        if res.quality < TRUSTED_QUALITY and start["chi2"] <= PHASE_STEP_CHI2:
            # The profile does not pin the altitude (a short clip or a small frame) but the
            # phase steps follow one shell to within their noise (imagery linear in slope,
            # where the phase-step fit is exact): report that fit, with the profile's
            # uncertainty (untrusted: the whole range).
            alt = math.exp(start["logh"])
            res.altitude_std_m = float(res.altitude_std_m / res.altitude_m * alt)
            res.altitude_m = float(alt)
            res.camera_velocity_mps = (float(-start["u"][0] * fps * alt / focal_px),
                                       float(-start["u"][1] * fps * alt / focal_px))
        return res

    def _prior(self, p: dict[str, Any], t: int, fps: float, focal_px: float,
               prior: tuple[float, float, float]) -> DispersionResult:
        """The camera's velocity over the water known to ``sigma`` m/s (``prior = (vx, vy,
        sigma)``): exact fits at the prior's mean and at the eight points ``sigma`` away
        along and between the image axes.

        The estimate is the fit at the mean; the spread of the nine altitudes adds to its
        uncertainty, so an altitude that depends on the unknown drift (a short clip, waves
        one way) is not trusted, while one that does not (waves both ways pin the drift)
        keeps the exact fit's precision (what was tried instead: ``docs/dispersion.md``).
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
        one at the shrunk scan's when that is trusted and better graded (:meth:`_fit_aided`)."""
        fits = self._fit_aided(p, fps, focal_px, velocity_mps)
        res = self._result(p, fits[0], t, fps, focal_px)
        for fit in fits[1:]:
            alt = self._result(p, fit, t, fps, focal_px)
            if alt.quality >= TRUSTED_QUALITY and alt.quality > res.quality:
                res = alt
        return res

    def _fit_aided(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                   velocity_mps: tuple[float, float]) -> list[dict[str, Any]]:
        """Known camera velocity over the water: a 1-D search over the altitude alone.

        A coarse scan over log altitude picks its most *prominent* peak (not the highest:
        slow content makes the scan rise toward high altitudes, and a bump on that rise is
        no wave shell).  The scan weights each mode by how far the candidate makes it turn
        over the clip (:meth:`_mode_values`): when the camera drifts downwind, the Doppler
        shift cancels the waves' own motion on a band of modes, which then stand nearly
        still in the image and hold only the optics' slow products; unweighted, those
        made the scan rise with no peak near the truth (paper renderer, 10 frames, 100
        scenes: 6 errors of 30-95 % at 7-15 m clean).  The fine stage, on every mode and
        unweighted, takes the highest point within +-4 coarse steps and refines it with a
        parabola; the mode groups' spread there gives the uncertainty (:meth:`_result`).
        Where the unweighted values rise through those steps with no peak (the nearly still
        modes again), the fine stage is weighted too: paper renderer, 10 frames, 100
        scenes each of seeds 5 and 11, relative MAE clean 1.72 / 1.53 -> 1.49 / 1.08 %;
        such estimates are flagged by the quality below.
        The quality is the prominence of the *unweighted* scan's peak at the estimate (none
        within two steps: no quality), so an estimate that only the weighting found is not
        trusted.

        Returns the fit at the weighted scan's peak and, where a shrunk weighted scan (see
        below) peaks elsewhere, the fit there too; :meth:`_aided` grades both.
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
        grid = np.arange(lo - math.log(1.5), hi + math.log(4.0) + step / 2, step)
        # the coarse scans need no more than a fixed subsample of the modes
        sub = np.arange(0, p["kappa"].size, max(1, p["kappa"].size // 300))
        ux, uy = u_of(grid)
        # both coarse scans from one pass: weighted (picks the peak) and plain (grades it)
        vals, wt = self._branch_values(p, fps, focal_px, grid, ux, uy, modes=sub, turns=True)
        scan = vals.mean(axis=1)
        wsum, wtot = np.sum(vals * wt, axis=1), wt.sum(axis=1)
        i = _most_prominent(wsum / np.maximum(wtot, 1e-9), grid, lo - step, hi + step)[0]
        fits = [self._fine_aided(p, fps, focal_px, grid[i], step, u_of, scan, grid)]
        # The weighted mean of a candidate at which few modes turn rests on few modes: on
        # small frames (128 px, 1-5 m) it made spurious peaks at 5-15 times the altitude, and
        # confident errors of +300-600 %.  Pulled toward the plain scan's median by a tenth
        # of the modes, the true peak stands out there; where that peak lies elsewhere it is
        # refined too, and kept when trusted and more so (:meth:`_aided`).
        n0 = 0.1 * wt.shape[1]
        shrunk = (wsum + n0 * float(np.median(scan))) / (wtot + n0)
        k = _most_prominent(shrunk, grid, lo - step, hi + step)[0]
        if abs(k - i) > 4:
            fits.append(self._fine_aided(p, fps, focal_px, grid[k], step, u_of, scan, grid))
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

    def _best_velocity(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                       logh: float, u: np.ndarray, modes: np.ndarray | None, step: float,
                       min_step: float = 0.0015) -> tuple[float, np.ndarray]:
        """Image velocity (px/frame) of highest score at altitude ``exp(logh)``: a compass
        (pattern) search from ``u``, nine candidates per call, halving ``step`` to
        ``min_step``."""
        off = np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)], dtype=np.float64)
        lg = np.full(9, logh)
        best = float(self._score(p, fps, focal_px, lg[:1], u[:1], u[1:], modes)[0])
        while step >= min_step:
            cand = u[None, :] + step * off
            val = self._score(p, fps, focal_px, lg, cand[:, 0], cand[:, 1], modes)
            j = int(np.argmax(val))
            if j != 4 and val[j] > best:
                best, u = float(val[j]), cand[j]
            else:
                step *= 0.5
        return best, u

    def _fit_blind(self, p: dict[str, np.ndarray], fps: float, focal_px: float,
                   logh0: float, u0: np.ndarray) -> dict[str, Any]:
        """Velocity unknown: the profile of the periodogram score over log altitude, the
        velocity re-fitted at every altitude.

        The per-mode phase steps of the cross-spectra are biased on rendered frames: the
        difference-frequency products of the non-linear optics (wave groups, which move at
        the drift plus half the phase speed) pull every measured step toward a slower shell,
        and a slower shell plus more drift fits them (+10 to +40 % in altitude on the paper
        renderer).  The periodogram separates the shell from those products once the clip
        resolves them (about 1 s); along the profile, a drift that trades against altitude
        leaves a flat profile, which the quality reports.  The profile follows the ridge
        from the phase-step fit ``(logh0, u0)`` (``u0`` in the periodogram's convention)
        over ``x1/4 .. x1.5`` of its altitude (its bias is mostly upward, but a start two to
        three times too high is common on rendered frames); the most prominent
        peak is refined on all modes like the aided fit.
        """
        lo, hi = (math.log(a) for a in self.altitude_range_m)
        step = 0.05
        grid = logh0 + np.arange(-math.log(4.0), 0.4 + step / 2, step)
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
        i, prominence, interior = _most_prominent(scan, grid, lo - step, hi + step)
        local = grid[i] + np.linspace(-1.0, 1.0, 5) * step
        us = np.empty((local.size, 2))
        for j, lg in enumerate(local):
            us[j] = self._best_velocity(p, fps, focal_px, float(lg), path[i], None, 0.005)[1]
        # per-mode values along the ridge: the group spread then includes the drift's trade
        vals = self._mode_values(p, fps, focal_px, local, us[:, 0], us[:, 1])
        mean = vals.mean(axis=1)
        logh = float(np.clip(_parabolic_peak(local, mean), lo, hi))
        u = np.array([np.interp(logh, local, us[:, 0]), np.interp(logh, local, us[:, 1])])
        return {"logh": logh, "u": u, "scan": scan, "interior": interior,
                "prominence": prominence, "local": local, "vals": vals}

    def _failed(self, frames: int) -> DispersionResult:
        lo, hi = self.altitude_range_m
        mid = math.sqrt(lo * hi)
        return DispersionResult(altitude_m=mid, altitude_std_m=hi - lo,
                                camera_velocity_mps=(0.0, 0.0), quality=0.0, trusted=False,
                                reason="no wave signal to fit (flat or frozen frames)",
                                mode="blind",
                                frames=int(frames), n_modes=0)

    def _result(self, p: dict[str, np.ndarray], fit: dict[str, Any], t: int, fps: float,
                focal_px: float) -> DispersionResult:
        """Uncertainty from the spread of the peak over groups of modes (the velocity held,
        or along the ridge when it is free); quality from the peak's prominence in the
        altitude scan or profile."""
        logh, u = fit["logh"], fit["u"]
        vals, local = fit["vals"], fit["local"]
        n = vals.shape[1]
        # groups are bands of wavenumber: the shell of the true altitude is the same at every
        # wavenumber, while the optics' products (sum frequencies faster than the shell,
        # difference frequencies slower) pose as altitudes that change with it
        labels = np.empty(n, dtype=np.int64)
        labels[np.argsort(p["kappa"], kind="stable")] = np.arange(n) * self.n_groups // n
        # per-group mean curves over the fine grid from one pass over the (grid, mode) matrix
        sums = np.stack([np.bincount(labels, weights=row, minlength=self.n_groups)
                         for row in vals], axis=1)
        ests = np.array([_parabolic_peak(local, row) for row in sums])
        # statistical spread of the mode groups, plus a systematic floor: the bias the finite
        # clip and the optics' non-linearity leave (0.2-0.4 % even on an ideal camera, a few
        # per cent at 6-15 m on rendered frames; bench_dispersion.py), larger for short clips
        floor = SD_FLOOR_LOG * max(1.0, FULL_CLIP_FRAMES / t) ** 3
        sd_logh = math.hypot(float(np.std(ests, ddof=1) / math.sqrt(len(ests))), floor)
        # The wave shell of a real sea stands out of the altitude scan as a prominent peak
        # (prominence 0.45-0.95 of its height on rendered clean and glinty frames, 1-15 m);
        # textures without dispersion (noise, frozen or carried patterns) make at most small
        # bumps on a scan that rises toward the edge of the range.
        # significance of the peak against random phase steps: each mode's share averaged
        # over all phase steps (its mean and variance) gives the score's null distribution
        if "_null" not in p:  # one periodogram serves several fits (prior mode: nine)
            q_all = p["q"]
            p["_null"] = (float(q_all.mean()),
                          float(np.sqrt(np.sum(q_all.var(axis=1)))) / q_all.shape[0])
        null_mean, null_sd = p["_null"]
        z = (float(np.max(vals.mean(axis=1))) - null_mean) / max(null_sd, 1e-30)
        rel_prom = fit["prominence"] / max(float(np.max(fit["scan"])), 1e-30)
        q = float(np.clip((rel_prom - 0.1) / 0.3, 0.0, 1.0))
        if not fit["interior"]:
            q = 0.0  # the most prominent peak lies outside the altitude range, or none
        q *= float(np.clip(1.0 - sd_logh / 0.1, 0.0, 1.0))
        sd_logh = sd_logh + (1.0 - q) ** 3  # an untrusted fit must not look precise
        alt = math.exp(logh)
        # u is the camera's image velocity over the water (px/frame)
        vel = (float(u[0] * fps * alt / focal_px), float(u[1] * fps * alt / focal_px))
        return DispersionResult(altitude_m=float(alt), altitude_std_m=float(alt * sd_logh),
                                camera_velocity_mps=vel, quality=q, trusted=False, reason=None,
                                mode="blind", frames=int(t), n_modes=int(n),
                                significance=z)


def peak_prominences(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The local maxima of ``y`` (a plateau counts once, at its middle, as SciPy does) and
    their topographic prominences: the height above the higher of the two lowest points
    between the peak and the nearest strictly higher sample (or the end) on either side.

    The same peaks and prominences as ``scipy.signal.find_peaks(y, prominence=0)`` (a test
    holds it to that), written out because importing ``scipy.signal`` costs the command
    line about 0.4 s of its 1-s start-up budget; the scans are a few hundred points.
    """
    y = np.asarray(y, np.float64)
    n = y.size
    peaks = []
    i = 1
    while i < n - 1:
        if y[i - 1] < y[i]:
            j = i
            while j + 1 < n and y[j + 1] == y[i]:
                j += 1
            if j + 1 < n and y[j + 1] < y[i]:
                peaks.append((i + j) // 2)
            i = j + 1
        else:
            i += 1
    prom = np.empty(len(peaks))
    for k, p in enumerate(peaks):
        left = p
        while left > 0 and y[left - 1] <= y[p]:
            left -= 1
        right = p
        while right < n - 1 and y[right + 1] <= y[p]:
            right += 1
        prom[k] = y[p] - max(y[left:p + 1].min(), y[p:right + 1].min())
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
    j = int(np.clip(np.argmax(y), 1, y.size - 2))
    den = y[j - 1] - 2.0 * y[j] + y[j + 1]
    off = 0.5 * (y[j - 1] - y[j + 1]) / den if den < 0 else 0.0
    return float(x[j] + float(np.clip(off, -1.0, 1.0)) * (x[1] - x[0]))


def estimate_altitude(frames: Any, *, fps: float, focal_px: float,
                      velocity_mps: tuple[float, float] | None = None,
                      velocity_sigma_mps: float = 0.0, **kw: Any) -> DispersionResult:
    """Convenience: ``DispersionAltimeter(**kw).estimate(frames, fps=, focal_px=,
    velocity_mps=, velocity_sigma_mps=)``."""
    return DispersionAltimeter(**kw).estimate(frames, fps=fps, focal_px=focal_px,
                                              velocity_mps=velocity_mps,
                                              velocity_sigma_mps=velocity_sigma_mps)


__all__ = ["DISPERSIONS", "DispersionAltimeter", "DispersionResult", "deglint",
           "estimate_altitude"]
