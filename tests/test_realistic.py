"""The physical sea of the realistic preset: spectra, spreading, dispersion, altitude scaling."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.fft

from wavealt.sim.sea.realistic import (
    K_M_RADPM,
    K_MAX_RADPM,
    RealisticSea,
    SeaSpectrum,
    cos2s_spreading,
    elfouhaily_omni,
    elfouhaily_spreading,
    jonswap_omni,
)
from wavealt.sim.sea.spectrum import (
    cox_munk_slope_variance,
    deep_water_omega,
    gravity_capillary_omega,
)

FOCAL_PX = 221.7  # 256 px across a 60 deg field of view


def height_coefficients(sea: RealisticSea, times: np.ndarray, **kw) -> np.ndarray:
    """``H(k, t)`` of the synthesised periodic height fields, ``(T, n, n)``."""
    h = np.stack([f["height_m"] for f in sea.iter_fields(times, with_height=True, **kw)])
    return scipy.fft.fft2(h.astype(np.float64), norm="forward")


def fit_travelling(sea: RealisticSea, times: np.ndarray, rate_a: np.ndarray, rate_b: np.ndarray,
                   coeffs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares ``H(k, t) = A e^{-i rate_a t} + B e^{-i rate_b t}`` per mode of the half
    plane; returns ``A``, ``B`` and the relative residual of each mode."""
    iy, ix = np.nonzero(sea.half)
    y = coeffs[:, iy, ix]  # (T, M)
    ea = np.exp(-1j * np.outer(times, rate_a[iy, ix]))
    eb = np.exp(-1j * np.outer(times, rate_b[iy, ix]))
    # normal equations of the 2-parameter fit, solved per mode
    g11 = np.sum(np.abs(ea) ** 2, 0)
    g22 = np.sum(np.abs(eb) ** 2, 0)
    g12 = np.sum(np.conj(ea) * eb, 0)
    r1 = np.sum(np.conj(ea) * y, 0)
    r2 = np.sum(np.conj(eb) * y, 0)
    det = g11 * g22 - np.abs(g12) ** 2
    a = (g22 * r1 - g12 * r2) / det
    b = (g11 * r2 - np.conj(g12) * r1) / det
    res = y - ea * a - eb * b
    rel = np.sqrt(np.sum(np.abs(res) ** 2, 0) / np.maximum(np.sum(np.abs(y) ** 2, 0), 1e-300))
    return a, b, rel


# -- spectra ---------------------------------------------------------------------------------
@pytest.mark.parametrize("fn", [elfouhaily_omni, jonswap_omni])
def test_spectrum_has_a_peak_and_a_gravity_capillary_end(fn):
    k = np.geomspace(1e-2, K_MAX_RADPM, 4000)
    f = fn(k, wind_speed_mps=8.0)
    assert np.all(f >= 0) and np.all(np.isfinite(f))
    k_p = 9.81 / 8.0**2 * 0.84**2
    assert k[np.argmax(f)] == pytest.approx(k_p, rel=0.15)
    curvature = k**3 * f
    # the capillary bump of the curvature spectrum sits at k_m = 370 rad/m (lambda 1.7 cm) ...
    cap = (k > 100) & (k < 2000)
    assert k[cap][np.argmax(curvature[cap])] == pytest.approx(K_M_RADPM, rel=0.25)
    # ... and dies off above it: the physical small-scale end
    assert curvature[-1] < 1e-6 * curvature[cap].max()


@pytest.mark.parametrize("u", [0.5, 1.0, 1.6, 2.0, 2.5, 2.8])
def test_light_wind_spectrum_is_a_density(u):
    """Elfouhaily's capillary-range fit turns negative below U10 ~ 2.8 m/s; the spectrum
    (and the amplitudes drawn from its square root) must not."""
    k = np.geomspace(1e-2, K_MAX_RADPM, 4000)
    f = elfouhaily_omni(k, wind_speed_mps=u)
    assert np.all(np.isfinite(f)) and np.all(f >= 0)
    sea = RealisticSea(SeaSpectrum(wind_speed_mps=u), n=64, dx_m=0.02, rng=0)
    assert np.all(np.isfinite(sea.a)) and np.all(np.isfinite(sea.b))


def test_spectrum_scaled_to_cox_munk_total_slope():
    for u in (2.0, 6.0, 12.0):
        sp = SeaSpectrum(wind_speed_mps=u)
        total = sp.slope_variance_between(sp.k_peak / 20.0, K_MAX_RADPM)
        assert total == pytest.approx(float(cox_munk_slope_variance(u)), rel=1e-9)
        # Elfouhaily's own level is within a factor 1.6 of Cox-Munk's (at 2 m/s its capillary
        # range is empty and its gravity range alone is 1.54 times Cox-Munk's slope)
        assert 0.62 < sp.level < 1.5


@pytest.mark.parametrize("s", [0.0, 1.0, 4.0, 15.0])
def test_cos2s_spreading_is_normalised_and_reaches_upwind(s):
    th = np.linspace(-math.pi, math.pi, 20001)
    d = cos2s_spreading(th, s=s)
    assert np.trapezoid(d, th) == pytest.approx(1.0, rel=1e-4)
    assert d[np.abs(th) < 1e-3].max() >= d.max() - 1e-12
    assert cos2s_spreading(np.array([math.pi * 0.75]), s=s)[0] > 0  # some energy travels upwind


def test_elfouhaily_spreading_is_centrosymmetric_and_normalised():
    th = np.linspace(-math.pi, math.pi, 20001)
    for k in (0.5, 10.0, 400.0):
        d = elfouhaily_spreading(np.full_like(th, k), th, wind_speed_mps=7.0)
        assert np.trapezoid(d, th) == pytest.approx(1.0, rel=1e-4)
        np.testing.assert_allclose(d, elfouhaily_spreading(np.full_like(th, k), th + math.pi,
                                                           wind_speed_mps=7.0), atol=1e-12)


def test_measured_omnidirectional_spectrum_matches_the_physical_one():
    for name in ("elfouhaily", "jonswap"):
        sp = SeaSpectrum(wind_speed_mps=6.0, spectrum=name)
        sea = RealisticSea(sp, n=256, dx_m=0.01, rng=1, long_bands=0)
        hk = height_coefficients(sea, np.array([0.0]))[0]
        power = np.abs(hk) ** 2
        edges = np.geomspace(8 * sea.dk, 0.9 * math.pi / sea.dx_m, 7)
        for lo, hi in zip(edges[:-1], edges[1:]):
            ring = (sea.k >= lo) & (sea.k < hi)
            assert ring.sum() > 200
            measured = power[ring].sum()
            expected = sp.height_variance_between(lo, hi)
            assert measured == pytest.approx(expected, rel=0.2), (name, lo, hi)


# -- dispersion and directions, measured per mode -------------------------------------------
@pytest.mark.parametrize("velocity", [(0.0, 0.0), (1.5, -0.7)])
def test_each_mode_obeys_gravity_capillary_dispersion(velocity):
    sp = SeaSpectrum(wind_speed_mps=5.0, spreading="elfouhaily")
    sea = RealisticSea(sp, n=32, dx_m=0.002, rng=3, long_bands=0)  # k from 98 to 1570 rad/m
    times = np.arange(24) * 0.004
    coeffs = height_coefficients(sea, times, velocity_mps=velocity)
    kv = sea.kx * velocity[0] + sea.ky * velocity[1]
    for omega_fn, good in ((gravity_capillary_omega, True), (deep_water_omega, False)):
        om = omega_fn(sea.k)
        _, _, rel = fit_travelling(sea, times, om - kv, -(om + kv), coeffs)
        strong = np.abs(coeffs[0][sea.half]) > 1e-3 * np.abs(coeffs[0]).max()
        if good:
            assert np.max(rel[strong]) < 1e-4
        else:
            assert np.median(rel[strong]) > 1e-2


def test_waves_travel_both_ways_with_the_spreading_of_the_spectrum():
    times = np.arange(24) * 0.004
    for spreading, s in (("cos2s", 1.0), ("cos2s", 6.0), ("elfouhaily", 0.0)):
        sp = SeaSpectrum(wind_speed_mps=5.0, spreading=spreading, spreading_s=s,
                         wind_dir_rad=0.4)
        sea = RealisticSea(sp, n=48, dx_m=0.002, rng=5, long_bands=0)
        om = gravity_capillary_omega(sea.k)
        a, b, _ = fit_travelling(sea, times, om, -om, height_coefficients(sea, times))
        iy, ix = np.nonzero(sea.half)
        theta = np.arctan2(sea.ky[iy, 0], sea.kx[0, ix]) - 0.4
        # whiten by the omnidirectional level so that every mode weighs alike
        kk = sea.k[iy, ix]
        w = kk / sp.omni(kk)
        pa, pb = w * np.abs(a) ** 2, w * np.abs(b) ** 2
        energy_down = np.sum(pa * (np.cos(theta) > 0)) + np.sum(pb * (np.cos(theta) < 0))
        fraction = energy_down / np.sum(pa + pb)
        th = np.linspace(-math.pi, math.pi, 20001)
        dens = sp.spreading_fn(np.full_like(th, 300.0), th)
        expected = np.trapezoid(dens * (np.cos(th) > 0), th)
        assert fraction == pytest.approx(expected, abs=0.04), spreading
        assert fraction < 0.999  # energy in both directions


# -- the altitude changes only the scale of the physical surface in pixels ------------------
def test_slope_budget_is_physical_at_every_altitude():
    sp = SeaSpectrum(wind_speed_mps=7.0)
    prev = -1.0
    for alt in (1.0, 2.0, 4.0, 8.0, 15.0):
        sea = RealisticSea(sp, n=128, dx_m=alt / FOCAL_PX, rng=0)
        total = sea.resolved_slope_variance + sea.long_slope_variance + sea.subpixel_slope_variance
        assert total == pytest.approx(sp.slope_variance, rel=1e-9)
        # what a pixel averages is the physical spectrum beyond its Nyquist wavenumber
        beyond = sp.slope_variance_between(math.pi / sea.dx_m, K_MAX_RADPM)
        assert sea.subpixel_slope_variance == pytest.approx(beyond, rel=0.3)
        assert sea.subpixel_slope_variance > prev
        prev = sea.subpixel_slope_variance


def _slope_spectrum_rings(sea: RealisticSea, edges: np.ndarray) -> np.ndarray:
    f = next(sea.iter_fields([0.0]))
    ps = (np.abs(scipy.fft.fft2(f["slope_x"].astype(np.float64), norm="forward")) ** 2
          + np.abs(scipy.fft.fft2(f["slope_y"].astype(np.float64), norm="forward")) ** 2)
    return np.array([ps[(sea.k >= lo) & (sea.k < hi)].sum() for lo, hi in zip(edges[:-1], edges[1:])])


def test_altitude_changes_only_the_pixel_scale_of_the_physical_surface():
    """Two altitudes 4x apart: the slope spectrum in *physical* wavenumber is the same (and the
    physical one), while in *pixel* frequency it is the same curve moved by the GSD ratio; the
    grid spacing, domain and band edges scale with the altitude alone."""
    sp = SeaSpectrum(wind_speed_mps=7.0, spreading_s=2.0)
    n = 256
    low = RealisticSea(sp, n=n, dx_m=2.0 / FOCAL_PX, rng=11, long_bands=0)
    high = RealisticSea(sp, n=n, dx_m=8.0 / FOCAL_PX, rng=12, long_bands=0)
    assert high.dx_m / low.dx_m == pytest.approx(4.0)
    assert low.dk / high.dk == pytest.approx(4.0)
    # overlap of the two resolved bands, in rad/m
    edges = np.geomspace(10 * low.dk, 0.9 * math.pi / high.dx_m, 4)
    m_low, m_high = _slope_spectrum_rings(low, edges), _slope_spectrum_rings(high, edges)
    theory = np.array([sp.slope_variance_between(lo, hi) for lo, hi in zip(edges[:-1], edges[1:])])
    np.testing.assert_allclose(m_low / theory, 1.0, rtol=0.2)
    np.testing.assert_allclose(m_high / theory, 1.0, rtol=0.2)
    # in pixel units (cycles/px = k dx / 2 pi) the same physical band sits 4x higher up
    px_low, px_high = edges * low.dx_m / (2 * math.pi), edges * high.dx_m / (2 * math.pi)
    np.testing.assert_allclose(px_high / px_low, 4.0)


def test_same_seed_same_sea_and_crop_offset_is_a_window():
    sp = SeaSpectrum(wind_speed_mps=4.0)
    a = RealisticSea(sp, n=64, dx_m=0.01, rng=9)
    b = RealisticSea(sp, n=64, dx_m=0.01, rng=9)
    fa = next(a.iter_fields([0.1], velocity_mps=(0.5, 0.2)))
    fb = next(b.iter_fields([0.1], velocity_mps=(0.5, 0.2)))
    np.testing.assert_array_equal(fa["slope_x"], fb["slope_x"])
    win = next(a.iter_fields([0.1], crop=(32, 32), offset_px=(3, -5), velocity_mps=(0.5, 0.2)))
    np.testing.assert_allclose(win["slope_x"], fa["slope_x"][19:51, 11:43], atol=1e-5)


def test_bad_input():
    with pytest.raises(ValueError, match="wind_speed_mps must be > 0"):
        SeaSpectrum(wind_speed_mps=-1.0)
    with pytest.raises(ValueError, match="spectrum must be one of"):
        SeaSpectrum(wind_speed_mps=5.0, spectrum="pm")
    with pytest.raises(ValueError, match="spreading_s must be >= 0"):
        SeaSpectrum(wind_speed_mps=5.0, spreading_s=-2.0)
    with pytest.raises(ValueError, match="inverse_wave_age"):
        SeaSpectrum(wind_speed_mps=5.0, inverse_wave_age=0.2)
    sp = SeaSpectrum(wind_speed_mps=5.0)
    with pytest.raises(ValueError, match="n must be an even integer"):
        RealisticSea(sp, n=33, dx_m=0.01)
    with pytest.raises(ValueError, match="does not fit the domain"):
        next(RealisticSea(sp, n=32, dx_m=0.01, rng=0).iter_fields([0.0], crop=(32, 32),
                                                                   offset_px=(1, 0)))


def test_higher_camera_sees_the_same_sea_with_its_finest_octave_below_the_pixel():
    """The sharpest form of 'altitude changes only the scale': over the same physical domain,
    a camera at twice the altitude (half the pixels across it) from the same seed sees exactly
    the lower camera's sea with the wavenumbers above its own pixel Nyquist removed, sampled at
    every other point; the removed slope variance reappears as sub-pixel glitter variance."""
    sp = SeaSpectrum(wind_speed_mps=6.0, spreading_s=3.0)
    low = RealisticSea(sp, n=128, dx_m=2.0 / FOCAL_PX, rng=np.random.default_rng(21))
    high = RealisticSea(sp, n=64, dx_m=4.0 / FOCAL_PX, rng=np.random.default_rng(21))
    assert low.dk == pytest.approx(high.dk)
    t = np.array([0.0, 0.05])
    vel = (0.8, -0.3)
    h_low = [f["height_m"] for f in low.iter_fields(t, with_height=True, velocity_mps=vel)]
    f_high = list(high.iter_fields(t, with_height=True, velocity_mps=vel))
    idx = np.rint(np.fft.fftfreq(128) * 128)
    keep = (np.abs(idx)[:, None] < 32) & (np.abs(idx)[None, :] < 32)
    # the long-wave modes are shared too (same dk, same bands, same draws)
    np.testing.assert_allclose(low.long_k, high.long_k)
    np.testing.assert_allclose(low.long_amp, high.long_amp)
    lk = low.long_k
    for hl, fh, tt in zip(h_low, f_high, t):
        x = (np.arange(128) - 64) * low.dx_m
        ph = low.long_amp * np.exp(-1j * (low.long_omega - lk @ np.array(vel)) * tt)
        long_part = 2 * ((np.exp(1j * np.outer(x, lk[:, 1])) * ph) @ np.exp(1j * np.outer(lk[:, 0], x))).real
        grid_part = scipy.fft.fft2(hl.astype(np.float64) - long_part, norm="forward")
        low_pass = scipy.fft.ifft2(np.where(keep, grid_part, 0), norm="forward").real + long_part
        scale = np.abs(fh["height_m"]).max()
        np.testing.assert_allclose(low_pass[::2, ::2], fh["height_m"], atol=2e-5 * scale)
        assert np.abs(hl[::2, ::2] - fh["height_m"]).max() > 1e-3 * scale  # fine waves differ
    fine = low.resolved_slope_variance - high.resolved_slope_variance
    assert high.subpixel_slope_variance == pytest.approx(low.subpixel_slope_variance + fine,
                                                          rel=1e-9)
