"""Physically scaled sea for the ``realistic`` preset: spectra, spreading, synthesis.

Why this module exists.  The paper's sea (``spectrum.phillips``) travels downwind only and is
rescaled so that the slopes *resolved by the grid* carry the Cox–Munk variance; since the grid
spacing is the pixel footprint, that makes the look of a frame nearly independent of altitude
except through grid artefacts.  Here every quantity is physical:

* the omnidirectional spectrum ``F(k)`` (m^2 per rad/m, ``E[h^2] = int F dk``) is Elfouhaily
  et al. (1997) or JONSWAP (Hasselmann et al. 1973) with Elfouhaily's gravity–capillary end,
  whose curvature peaks at ``k_m = 370 rad/m`` (wavelength 1.7 cm) and dies off above it;
* the directional density is ``S(k, theta) = F(k) / k * D(k, theta)`` with either the
  Longuet-Higgins cos-2s spreading ``D ~ cos^{2s}(theta/2)`` (energy in all directions, most
  downwind) or Elfouhaily's centro-symmetric ``(1 + Delta(k) cos 2 theta) / (2 pi)`` (waves
  in both directions);
* dispersion is gravity–capillary, ``omega^2 = g k + (sigma/rho) k^3``;
* the spectrum's level is a physical constant of the wind: it is scaled once so that its mean
  square slope ``int k^2 F dk`` over *all* wavenumbers equals Cox & Munk's (1954)
  ``0.003 + 5.12e-3 U`` (paper eq. (2)).  This factor never looks at the grid.

How altitude enters (and nothing else does).  The camera's ground sampling distance
``gsd = altitude / focal_px`` sets the synthesis grid spacing, so the image holds the
physical surface seen at that scale, split into three wavenumber bands whose slope variances
add up to Cox–Munk's total at every altitude:

1. ``k`` below the grid's fundamental (waves longer than the periodic domain): a few discrete
   long-wave modes, one per logarithmic band, each carrying that band's exact variance and
   evaluated analytically on the pixel grid (no tiling: they are not periodic on the domain);
2. the FFT grid, ``dk = 2 pi / (n gsd)`` up to the pixel Nyquist ``pi / gsd``;
3. everything finer than a pixel: not synthesised, but handed to the renderer as the variance
   of unresolved facet slopes (``subpixel_slope_variance``), which the Cox–Munk glitter model
   (:mod:`wavealt.sim.light.glitter`) turns into the probability that a pixel holds a glinting
   facet.  The average over a pixel's footprint is thus a physical statistic of the sea, not
   the blur of an interpolator.

Changing altitude therefore only moves the band edges in physical wavenumber; the surface's
statistics in physical units are unchanged (``tests/test_realistic.py`` measures this).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import scipy.fft
from scipy.special import gammaln

from wavealt._checks import as_rng, check_choice, check_finite_number
from wavealt.sim.sea.spectrum import (
    GRAVITY_MPS2,
    cox_munk_slope_variance,
    gravity_capillary_omega,
)

#: Wavenumber of the minimum phase speed, ``sqrt(g rho / sigma)`` = 368 rad/m (lambda 1.7 cm);
#: Elfouhaily et al. (1997) round it to 370.
K_M_RADPM = 370.0
#: Phase speed at ``K_M_RADPM`` (Elfouhaily et al. 1997, eq. 41), m/s.
C_M_MPS = 0.23
#: Upper end of the integrals: the capillary term is ~1e-9 of its peak at 10 k_m.
K_MAX_RADPM = 10.0 * K_M_RADPM
SPECTRA = ("elfouhaily", "jonswap")
SPREADINGS = ("cos2s", "elfouhaily")


def friction_velocity(wind_speed_mps: float) -> float:
    """Friction velocity ``u* = sqrt(C_D) U10`` with Wu's (1982) ``C_D = (0.8 + 0.065 U10) 1e-3``."""
    u = float(wind_speed_mps)
    return math.sqrt((0.8 + 0.065 * u) * 1e-3) * u


def phase_speed(k: np.ndarray) -> np.ndarray:
    """Gravity–capillary phase speed ``c = omega / k`` (m/s) of wavenumbers ``k`` > 0."""
    k = np.asarray(k, dtype=np.float64)
    return gravity_capillary_omega(k) / k


def _peak(wind_speed_mps: float, inverse_wave_age: float) -> tuple[float, float]:
    """Spectral peak ``k_p = k_0 Omega^2`` (``k_0 = g / U^2``) and its phase speed."""
    k_p = GRAVITY_MPS2 / wind_speed_mps**2 * inverse_wave_age**2
    return k_p, math.sqrt(GRAVITY_MPS2 / k_p)


def _check_wind(wind_speed_mps: float, inverse_wave_age: float) -> tuple[float, float]:
    u = check_finite_number("wind_speed_mps", wind_speed_mps, low=0.0, low_open=True)
    om = check_finite_number("inverse_wave_age", inverse_wave_age, low=0.83, high=5.0)
    return u, om


def _capillary_curvature(k: np.ndarray, wind_speed_mps: float, l_pm_jp: np.ndarray) -> np.ndarray:
    """Short-wave curvature ``B_h`` of Elfouhaily et al. (1997), eqs. (40)-(44)."""
    u_star = friction_velocity(wind_speed_mps)
    # eq. (44): generalised Phillips-Kitaigorodskii equilibrium range parameter; below
    # u* = c_m / e (U10 ~ 2.8 m/s) the fit turns negative, a negative spectral density (NaN
    # amplitudes): in so light a wind the capillary range holds nothing
    alpha_m = 1e-2 * max(0.0, 1.0 + (math.log(u_star / C_M_MPS) if u_star <= C_M_MPS
                                     else 3.0 * math.log(u_star / C_M_MPS)))
    f_m = l_pm_jp * np.exp(-0.25 * (k / K_M_RADPM - 1.0) ** 2)  # eq. (41)
    return 0.5 * alpha_m * C_M_MPS / phase_speed(k) * f_m


def elfouhaily_omni(k: np.ndarray, *, wind_speed_mps: float,
                    inverse_wave_age: float = 0.84) -> np.ndarray:
    """Omnidirectional spectrum of Elfouhaily et al. (1997), ``F(k) = k^-3 (B_l + B_h)``.

    Parameters
    ----------
    k : array
        Wavenumbers, rad/m (> 0; zero gives 0).
    wind_speed_mps : float
        Wind speed at 10 m, m/s.
    inverse_wave_age : float
        ``Omega = U10 / c_p``: 0.84 fully developed, up to 5 for a young sea.

    Returns
    -------
    F : array like ``k``
        Height spectrum, m^2 / (rad/m): ``E[h^2] = int F dk`` (before Cox–Munk scaling).
    """
    u, om = _check_wind(wind_speed_mps, inverse_wave_age)
    k = np.asarray(k, dtype=np.float64)
    out = np.zeros_like(k)
    nz = k > 0
    kk = k[nz]
    k_p, c_p = _peak(u, om)
    l_pm = np.exp(-1.25 * (k_p / kk) ** 2)  # Pierson-Moskowitz shape, eq. (2)
    gamma = 1.7 if om < 1.0 else 1.7 + 6.0 * math.log10(om)  # eq. (3)
    sig = 0.08 * (1.0 + 4.0 * om**-3)
    j_p = gamma ** np.exp(-((np.sqrt(kk / k_p) - 1.0) ** 2) / (2.0 * sig**2))  # JONSWAP peak
    alpha_p = 6e-3 * math.sqrt(om)  # eq. (34)
    f_p = l_pm * j_p * np.exp(-om / math.sqrt(10.0) * (np.sqrt(kk / k_p) - 1.0))  # eq. (32)
    b_l = 0.5 * alpha_p * c_p / phase_speed(kk) * f_p  # eq. (31)
    b_h = _capillary_curvature(kk, u, l_pm * j_p)
    out[nz] = (b_l + b_h) / kk**3
    return out


def jonswap_omni(k: np.ndarray, *, wind_speed_mps: float, inverse_wave_age: float = 0.84,
                 gamma: float = 3.3) -> np.ndarray:
    """JONSWAP (Hasselmann et al. 1973) in wavenumber with Elfouhaily's capillary end.

    ``F(k) = alpha/2 k^-3 exp(-5/4 (k_p/k)^2) gamma^r E(k) + k^-3 B_h(k)``,
    ``r = exp(-(sqrt(k/k_p) - 1)^2 / (2 sigma^2))``, ``sigma = 0.07`` below and ``0.09`` above
    the peak, ``alpha = 6e-3 sqrt(Omega)``, ``E(k) = exp(-Omega/sqrt(10) (sqrt(k/k_p) - 1))``
    Elfouhaily's hand-over from the gravity range; ``B_h`` is the gravity–capillary curvature of
    Elfouhaily et al. (1997) so that the spectrum has the same physical small-scale end.
    Units as :func:`elfouhaily_omni`.
    """
    u, om = _check_wind(wind_speed_mps, inverse_wave_age)
    check_finite_number("gamma", gamma, low=1.0)
    k = np.asarray(k, dtype=np.float64)
    out = np.zeros_like(k)
    nz = k > 0
    kk = k[nz]
    k_p, _ = _peak(u, om)
    sig = np.where(kk <= k_p, 0.07, 0.09)
    j_p = gamma ** np.exp(-((np.sqrt(kk / k_p) - 1.0) ** 2) / (2.0 * sig**2))
    l_pm = np.exp(-1.25 * (k_p / kk) ** 2)
    alpha = 6e-3 * math.sqrt(om)
    # Elfouhaily's hand-over (eq. 32): the gravity range's curvature fades well above the
    # peak so that the capillary term alone sets the small-scale end
    handover = np.exp(-om / math.sqrt(10.0) * (np.sqrt(kk / k_p) - 1.0))
    out[nz] = (0.5 * alpha * l_pm * j_p * handover
               + _capillary_curvature(kk, u, l_pm * j_p)) / kk**3
    return out


def cos2s_spreading(theta: np.ndarray, *, s: float) -> np.ndarray:
    """Longuet-Higgins et al. (1963) spreading ``D = N(s) cos^{2s}(theta / 2)``, 1/rad.

    ``theta`` is measured from the downwind direction; ``N(s) = Gamma(s+1) / (2 sqrt(pi)
    Gamma(s+1/2))`` makes ``int_{-pi}^{pi} D dtheta = 1``.  ``s = 0`` is isotropic; every
    ``s`` leaves some energy travelling upwind (zero only exactly upwind).
    """
    s = check_finite_number("spreading_s", s, low=0.0)
    norm = math.exp(gammaln(s + 1.0) - gammaln(s + 0.5)) / (2.0 * math.sqrt(math.pi))
    return norm * np.abs(np.cos(0.5 * np.asarray(theta, dtype=np.float64))) ** (2.0 * s)


def elfouhaily_spreading(k: np.ndarray, theta: np.ndarray, *, wind_speed_mps: float,
                         inverse_wave_age: float = 0.84) -> np.ndarray:
    """Elfouhaily et al. (1997) eqs. (57)-(59): ``D = (1 + Delta(k) cos 2 theta) / (2 pi)``.

    Symmetric under ``theta -> theta + pi``: as much energy travels upwind as downwind at each
    ``k`` (the spectrum is the height covariance's transform and cannot tell the two apart).
    """
    u, om = _check_wind(wind_speed_mps, inverse_wave_age)
    k = np.asarray(k, dtype=np.float64)
    _, c_p = _peak(u, om)
    c = phase_speed(np.maximum(k, 1e-12))
    a_m = 0.13 * friction_velocity(u) / C_M_MPS
    delta = np.tanh(math.log(2.0) / 4.0 + 4.0 * (c / c_p) ** 2.5 + a_m * (C_M_MPS / c) ** 2.5)
    return (1.0 + delta * np.cos(2.0 * np.asarray(theta, dtype=np.float64))) / (2.0 * math.pi)


class SeaSpectrum:
    """A directional wave spectrum in physical units, scaled to Cox–Munk's total slope.

    Parameters
    ----------
    wind_speed_mps : float
        Wind speed at 10 m, m/s (> 0).
    wind_dir_rad : float
        Direction the wind blows toward, radians from +x toward +y.
    spectrum : {"elfouhaily", "jonswap"}
        Omnidirectional shape.
    spreading : {"cos2s", "elfouhaily"}
        Directional spreading.
    spreading_s : float
        Exponent ``s`` of the cos-2s spreading (>= 0).
    inverse_wave_age : float
        ``U10 / c_p`` in [0.83, 5].
    slope_variance : float, optional
        Total mean-square slope over all ``k``; default Cox–Munk, paper eq. (2).
    """

    def __init__(self, *, wind_speed_mps: float, wind_dir_rad: float = 0.0,
                 spectrum: str = "elfouhaily", spreading: str = "cos2s", spreading_s: float = 4.0,
                 inverse_wave_age: float = 0.84, slope_variance: float | None = None) -> None:
        check_choice("spectrum", spectrum, SPECTRA)
        check_choice("spreading", spreading, SPREADINGS)
        self.wind_speed_mps, self.inverse_wave_age = _check_wind(wind_speed_mps, inverse_wave_age)
        self.wind_dir_rad = check_finite_number("wind_dir_rad", wind_dir_rad)
        self.spectrum = spectrum
        self.spreading = spreading
        self.spreading_s = check_finite_number("spreading_s", spreading_s, low=0.0)
        self.k_peak = _peak(self.wind_speed_mps, self.inverse_wave_age)[0]
        self.slope_variance = (float(cox_munk_slope_variance(self.wind_speed_mps))
                               if slope_variance is None else
                               check_finite_number("slope_variance", slope_variance, low=0.0,
                                                   low_open=True))
        self.level = 1.0
        raw = self.slope_variance_between(self.k_peak / 20.0, K_MAX_RADPM)
        # one physical constant per wind: the total mss equals Cox & Munk's (paper eq. (2))
        self.level = self.slope_variance / raw

    def omni(self, k: np.ndarray) -> np.ndarray:
        """``F(k)``, m^2 / (rad/m), scaled."""
        fn = elfouhaily_omni if self.spectrum == "elfouhaily" else jonswap_omni
        return self.level * fn(k, wind_speed_mps=self.wind_speed_mps,
                               inverse_wave_age=self.inverse_wave_age)

    def spreading_fn(self, k: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """``D(k, theta)``, 1/rad, ``theta`` from the downwind direction."""
        if self.spreading == "cos2s":
            return np.broadcast_to(cos2s_spreading(theta, s=self.spreading_s),
                                   np.broadcast_shapes(np.shape(k), np.shape(theta)))
        return elfouhaily_spreading(k, theta, wind_speed_mps=self.wind_speed_mps,
                                    inverse_wave_age=self.inverse_wave_age)

    def _polar(self, kx: np.ndarray, ky: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(k, theta from the wind, F(k) / k)`` of wavenumber vectors (0 at k = 0)."""
        kx = np.asarray(kx, dtype=np.float64)
        ky = np.asarray(ky, dtype=np.float64)
        k = np.sqrt(kx**2 + ky**2)
        theta = np.arctan2(ky, kx) - self.wind_dir_rad
        with np.errstate(divide="ignore", invalid="ignore"):
            f_over_k = np.where(k > 0, self.omni(k) / np.where(k > 0, k, 1.0), 0.0)
        return k, theta, f_over_k

    def density(self, kx: np.ndarray, ky: np.ndarray) -> np.ndarray:
        """Directional density ``S(kx, ky) = F(k) / k D(k, theta)``, m^2 / (rad/m)^2."""
        k, theta, f_over_k = self._polar(kx, ky)
        return f_over_k * self.spreading_fn(k, theta)

    def density_pair(self, kx: np.ndarray, ky: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(S(k), S(-k))``: the density toward ``k`` and toward ``-k`` (one ``F`` evaluation)."""
        k, theta, f_over_k = self._polar(kx, ky)
        return (f_over_k * self.spreading_fn(k, theta),
                f_over_k * self.spreading_fn(k, theta + math.pi))

    def slope_variance_between(self, k_lo: float, k_hi: float, *, points: int = 4000) -> float:
        """``int_{k_lo}^{k_hi} k^2 F(k) dk`` (m^2/m^2), trapezoid on a log grid."""
        if not k_hi > k_lo:
            return 0.0
        k = np.geomspace(k_lo, k_hi, points)
        return float(np.trapezoid(k**3 * self.omni(k), np.log(k)))

    def height_variance_between(self, k_lo: float, k_hi: float, *, points: int = 400) -> float:
        """``int_{k_lo}^{k_hi} F(k) dk`` (m^2)."""
        if not k_hi > k_lo:
            return 0.0
        k = np.geomspace(k_lo, k_hi, points)
        return float(np.trapezoid(k * self.omni(k), np.log(k)))

    def sample_direction(self, k: float, rng: np.random.Generator) -> float:
        """A direction (rad, absolute) drawn from ``D(k, .)`` by inverse CDF."""
        th = np.linspace(-math.pi, math.pi, 721)
        cdf = np.cumsum(self.spreading_fn(np.full_like(th, k), th))
        cdf /= cdf[-1]
        return float(np.interp(rng.random(), cdf, th)) + self.wind_dir_rad


def _nested_normals(rng: np.random.Generator, n: int) -> np.ndarray:
    """Standard normals ``(4, n, n)`` drawn mode by mode in order of the square shell
    ``max(|i|, |j|)`` of the integer wavenumber index, then ``i``, then ``j``.

    So two grids over the same physical domain (same ``dk``) share, from the same generator,
    the amplitudes of every mode they both hold: a camera twice as high sees the same sea,
    only with its finest octave moved below the pixel (``tests/test_realistic.py``).
    """
    idx = np.rint(np.fft.fftfreq(n) * n).astype(np.int64)
    ii, jj = np.meshgrid(idx, idx, indexing="ij")
    shell = np.maximum(np.abs(ii), np.abs(jj))
    order = np.lexsort((jj.ravel(), ii.ravel(), shell.ravel()))
    out = np.empty((n * n, 4))
    out[order] = rng.standard_normal((n * n, 4))
    return np.moveaxis(out.reshape(n, n, 4), -1, 0)


class RealisticSea:
    """The physical sea of :class:`SeaSpectrum` seen on a pixel grid of spacing ``dx_m``.

    Parameters
    ----------
    spectrum : SeaSpectrum
        The physical spectrum.
    n : int
        FFT grid points per side (even); the periodic domain is ``n dx_m`` metres.
    dx_m : float
        Grid spacing, metres: the camera's ground sampling distance.
    rng : numpy.random.Generator or int
        Source of the random amplitudes.
    long_bands : int
        Logarithmic bands (one mode each) for waves longer than the domain.

    Attributes
    ----------
    resolved_slope_variance, long_slope_variance, subpixel_slope_variance : float
        Expected mean-square slope (sum of both axes) of the grid modes, of the long modes,
        and of everything finer than the grid; they sum to ``spectrum.slope_variance``.
    """

    def __init__(self, spectrum: SeaSpectrum, *, n: int, dx_m: float, rng: Any = None,
                 long_bands: int = 12) -> None:
        if int(n) != n or n < 4 or n % 2:
            msg = f"n must be an even integer >= 4; got {n!r}"
            raise ValueError(msg)
        self.spectrum = spectrum
        self.n = n = int(n)
        self.dx_m = check_finite_number("dx_m", dx_m, low=0.0, low_open=True)
        rng = as_rng(rng)
        k1 = 2.0 * np.pi * np.fft.fftfreq(n, d=self.dx_m)
        self.kx = k1[np.newaxis, :]
        self.ky = k1[:, np.newaxis]
        self.k = np.sqrt(self.kx**2 + self.ky**2)
        self.dk = 2.0 * np.pi / (n * self.dx_m)
        s, s_neg = spectrum.density_pair(self.kx, self.ky)
        # half plane P: kx > 0, or kx == 0 and ky > 0; Nyquist lines carry nothing
        half = (self.kx > 0) | ((self.kx == 0) & (self.ky > 0))
        half = np.broadcast_to(half, (n, n)).copy()
        half[n // 2, :] = False
        half[:, n // 2] = False
        self.half = half
        # a: waves travelling along +k, b: waves travelling along -k; E|.|^2 = S dk^2 / 2
        grid_rng, long_rng = rng.spawn(2)
        xi = _nested_normals(grid_rng, n)
        unit_a = (xi[0] + 1j * xi[1]) / math.sqrt(2.0)  # circular Gaussian, E|.|^2 = 1
        unit_b = (xi[2] + 1j * xi[3]) / math.sqrt(2.0)
        self.a = np.where(half, np.sqrt(s * self.dk**2 / 2.0) * unit_a, 0)
        self.b = np.where(half, np.sqrt(s_neg * self.dk**2 / 2.0) * unit_b, 0)
        self.omega = np.where(half, gravity_capillary_omega(self.k), 0.0)
        self.resolved_slope_variance = float(np.sum(np.where(half, self.k**2 * (s + s_neg), 0.0))
                                             * self.dk**2)
        self._init_long_modes(long_rng, long_bands)
        self.subpixel_slope_variance = max(
            spectrum.slope_variance - self.resolved_slope_variance - self.long_slope_variance, 0.0)

    def _init_long_modes(self, rng: np.random.Generator, bands: int) -> None:
        # The grid's central cell (area dk^2) is empty: its disc of equal area, radius
        # dk / sqrt(pi), holds the waves longer than the domain.
        k_hi = self.dk / math.sqrt(math.pi)
        k_lo = self.spectrum.k_peak / 4.0
        self.long_k = np.zeros((0, 2))
        self.long_amp = np.zeros(0, dtype=np.complex128)
        self.long_omega = np.zeros(0)
        self.long_slope_variance = 0.0
        if k_hi <= k_lo or bands < 1:
            return
        edges = np.geomspace(k_lo, k_hi, bands + 1)
        kv, amp, om = [], [], []
        for lo, hi in zip(edges[:-1], edges[1:]):
            var = self.spectrum.height_variance_between(lo, hi)
            km = math.sqrt(lo * hi)
            th = self.spectrum.sample_direction(km, rng)
            kv.append((km * math.cos(th), km * math.sin(th)))
            # h = A e^{i(k.x - w t)} + c.c. has variance 2 E|A|^2
            z = rng.standard_normal(2)
            amp.append(math.sqrt(var / 2.0) * (z[0] + 1j * z[1]) / math.sqrt(2.0))
            om.append(float(gravity_capillary_omega(km)))
            self.long_slope_variance += km**2 * var
        self.long_k = np.asarray(kv)
        self.long_amp = np.asarray(amp)
        self.long_omega = np.asarray(om)

    def iter_fields(self, times_s: np.ndarray, *, crop: tuple[int, int] | None = None,
                    velocity_mps: tuple[float, float] = (0.0, 0.0),
                    offset_px: tuple[int, int] = (0, 0),
                    with_height: bool = False) -> Iterator[dict[str, np.ndarray]]:
        """Yield ``{"slope_x", "slope_y"[, "height_m"]}`` float32 ``crop`` fields per time.

        ``crop=(H, W)`` is the central window shifted by ``offset_px=(rows, cols)``; a camera
        moving at ``velocity_mps`` sees each mode's phase advance at ``omega(k) - k.v``.
        """
        n = self.n
        ch, cw = (n, n) if crop is None else crop
        r0 = (n - ch) // 2 + int(offset_px[0])
        c0 = (n - cw) // 2 + int(offset_px[1])
        if ch > n or cw > n or r0 < 0 or c0 < 0 or r0 + ch > n or c0 + cw > n:
            msg = f"crop {crop} shifted by {offset_px} does not fit the domain of {n} points"
            raise ValueError(msg)
        times = np.asarray(times_s, dtype=np.float64).ravel()
        vx, vy = velocity_mps
        kv = self.kx * vx + self.ky * vy
        # H(k) = a e^{-i(w - k.v)t} + conj(b) e^{+i(w + k.v)t}  for k in P;  H(-k) = conj H(k)
        rate_a = np.where(self.half, self.omega - kv, 0.0)
        rate_b = np.where(self.half, -(self.omega + kv), 0.0)
        a = self.a.astype(np.complex64)
        b = np.conj(self.b).astype(np.complex64)
        grad = (1j * self.kx - self.ky).astype(np.complex64)
        steps = np.diff(times)
        uniform = steps.size > 0 and np.allclose(steps, steps[0], rtol=0, atol=1e-12)
        if uniform:  # advance phases by one complex multiply per frame
            rot_a = np.exp(-1j * rate_a * steps[0]).astype(np.complex64)
            rot_b = np.exp(-1j * rate_b * steps[0]).astype(np.complex64)
        # long modes evaluated on the crop: separable plane waves -> two small GEMMs
        x = (np.arange(cw) + c0 - n // 2) * self.dx_m
        y = (np.arange(ch) + r0 - n // 2) * self.dx_m
        lk = self.long_k
        ex = np.exp(1j * np.outer(lk[:, 0], x)) if lk.size else None
        ey = np.exp(1j * np.outer(y, lk[:, 1])) if lk.size else None
        long_rate = self.long_omega - (lk[:, 0] * vx + lk[:, 1] * vy) if lk.size else None
        sa = sb = None
        for t in times:
            if sa is None or not uniform:
                sa = (a * np.exp(-1j * rate_a * t)).astype(np.complex64)
                sb = (b * np.exp(-1j * rate_b * t)).astype(np.complex64)
            else:
                sa *= rot_a
                sb *= rot_b
            hk = sa + sb
            # Hermitian completion: bin of -k is ((-i) mod n, (-j) mod n)
            hfull = hk + np.conj(np.roll(hk[::-1, ::-1], 1, axis=(0, 1)))
            z = scipy.fft.ifft2(grad * hfull, norm="forward")[r0:r0 + ch, c0:c0 + cw]
            sx, sy = z.real.astype(np.float32), z.imag.astype(np.float32)
            if ex is not None:
                ph = self.long_amp * np.exp(-1j * long_rate * t)
                # slope of A e^{i(k.x - wt)} + c.c. is 2 Re(i k A e^{...})
                sx += (2.0 * ((ey * (1j * lk[:, 0] * ph)) @ ex).real).astype(np.float32)
                sy += (2.0 * ((ey * (1j * lk[:, 1] * ph)) @ ex).real).astype(np.float32)
            out = {"slope_x": sx, "slope_y": sy}
            if with_height:
                hh = scipy.fft.ifft2(hfull, norm="forward")[r0:r0 + ch, c0:c0 + cw].real
                if ex is not None:
                    hh = hh + 2.0 * ((ey * (self.long_amp * np.exp(-1j * long_rate * t))) @ ex).real
                out["height_m"] = np.ascontiguousarray(hh, dtype=np.float32)
            yield out


__all__ = [
    "C_M_MPS", "K_MAX_RADPM", "K_M_RADPM", "RealisticSea", "SPECTRA", "SPREADINGS", "SeaSpectrum",
    "cos2s_spreading", "elfouhaily_omni", "elfouhaily_spreading", "friction_velocity",
    "jonswap_omni", "phase_speed",
]
