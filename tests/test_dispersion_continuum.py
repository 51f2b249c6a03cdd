"""The optics' square: what a camera's response to the square of the slope puts between the
dispersion shells, predicted from the frames themselves and taken out of the periodogram."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wavealt.altimetry.dispersion.continuum import (
    centring_map,
    continuum_lags,
    explained_of_lags,
    square_share,
)
from wavealt.altimetry.dispersion.spectra import _hann2d, _windowed_modes


def _sea(t: int, n: int, rng: np.random.Generator, waves: int = 300) -> np.ndarray:
    """``(t, n, n)`` float64 frames of a Gaussian sea of unit variance: ``waves`` random-phase
    travelling waves of wavenumber 0.3-0.5 rad/px within 40 degrees of +x, each stepping by
    ``1.6 sqrt(kappa)`` rad a frame (a dispersion of its own), periodic in the frame."""
    k_bin = 2.0 * math.pi / n
    kappa = rng.uniform(0.3, 0.5, waves)
    angle = rng.uniform(-0.7, 0.7, waves)
    # whole cycles across the frame: every wave is one mode of the plane, no leakage
    kx = np.round(kappa * np.cos(angle) / k_bin) * k_bin
    ky = np.round(kappa * np.sin(angle) / k_bin) * k_bin
    step = 1.6 * np.sqrt(np.hypot(kx, ky))
    phase0 = rng.uniform(0.0, 2.0 * math.pi, waves)
    y, x = np.mgrid[0:n, 0:n].astype(float)
    frames = np.empty((t, n, n))
    for i in range(t):
        arg = (kx[:, None, None] * x + ky[:, None, None] * y - step[:, None, None] * i
               + phase0[:, None, None])
        frames[i] = np.cos(arg).sum(axis=0)
    return frames / frames.std()


def test_square_share_inverts_the_skewness_of_a_plus_square() -> None:
    rng = np.random.default_rng(0)
    s = rng.standard_normal(2_000_000)
    for a, b in ((1.0, 0.0), (1.0, 0.2), (1.0, 0.5), (1.0, 0.8)):
        want = 2 * b * b / (a * a + 2 * b * b)
        assert square_share(a * s + b * s * s) == pytest.approx(want, abs=0.01)
        # the sign of the square (a darker or brighter tilt) does not matter
        assert square_share(a * s - b * s * s) == pytest.approx(want, abs=0.01)
    assert square_share(s * s) == pytest.approx(1.0, abs=0.02)
    assert square_share(np.exp(3 * s)) == 1.0  # more skewed than any square: all of it
    assert square_share(np.full(100, 3.0)) == 0.0


def test_centring_map_is_the_mean_removal_of_a_stationary_series() -> None:
    t = 7
    a = centring_map(t)
    white = np.zeros(2 * t - 1)
    white[t - 1] = 1.0  # unit variance, no correlation between frames
    # E sum_s Y_{s+l} Y_s for Y = X - mean(X): T - 1 at lag 0, -(T - l) / T beyond
    want = np.array([t - 1.0] + [-(t - lag) / t for lag in range(1, t)])
    np.testing.assert_allclose(a @ white, want, atol=1e-12)
    # and against the sample: an AR(1) series' centred autocorrelation, averaged
    rng = np.random.default_rng(1)
    phi, n = 0.6, 40_000
    e = rng.standard_normal((n, t + 50))
    x = np.zeros_like(e)
    for i in range(1, x.shape[1]):
        x[:, i] = phi * x[:, i - 1] + e[:, i]
    x = x[:, -t:]
    y = x - x.mean(axis=1, keepdims=True)
    sample = np.array([np.mean(np.sum(y[:, lag:] * y[:, :t - lag], axis=1))
                       for lag in range(t)])
    rho = phi ** np.abs(np.arange(-(t - 1), t)) / (1 - phi * phi)
    np.testing.assert_allclose(a @ rho, sample, rtol=0.05, atol=0.05)


@pytest.mark.parametrize("t, n_psi", [(5, 64), (40, 64)])
def test_explained_of_lags_is_the_periodogram_of_the_series(t: int, n_psi: int) -> None:
    rng = np.random.default_rng(2)
    x = rng.standard_normal((3, t)) + 1j * rng.standard_normal((3, t))
    r = np.array([[np.sum(row[lag:] * np.conj(row[:t - lag])) for lag in range(t)]
                  for row in x])
    psi = 2 * np.pi * np.arange(n_psi) / n_psi
    direct = np.abs(x @ np.exp(1j * np.outer(np.arange(t), psi))) ** 2
    np.testing.assert_allclose(explained_of_lags(r, n_psi), direct, rtol=1e-9, atol=1e-9)


def test_the_square_of_a_sea_is_predicted_from_its_frames() -> None:
    """A sea of waves at 0.3-0.5 rad/px seen through ``s + b s^2``: at 0.65-0.95 rad/px only
    the square's sum products are, and the continuum predicted from the frames' own
    statistics lies at the phase steps where they are, with their energy's order: about
    half of it (the frames' covariance holds the square's own, and the normalisation over
    the plane gives part of the square's energy to its slow difference products, most of
    which the mean over the frames takes), so the periodogram takes out too little of it
    rather than too much."""
    t, n = 10, 64
    rng = np.random.default_rng(3)
    s = _sea(t, n, rng)
    frames = (s + 0.35 * s * s).astype(np.float32)
    k = 2 * np.pi * np.fft.fftfreq(n)
    kappa = np.hypot(*np.meshgrid(k[: n // 2 + 1], k, indexing="xy")).ravel()
    idx = np.flatnonzero((kappa > 0.65) & (kappa < 0.95))
    window = _hann2d(n, n)
    g = _windowed_modes([frames], idx).astype(np.complex128)
    g -= g.mean(axis=1, keepdims=True)
    observed = np.array([[np.sum(m[lag:] * np.conj(m[:t - lag])) for lag in range(t)]
                         for m in g[0].T])
    predicted = continuum_lags([frames], idx, window)[0]
    n_psi = 64
    obs_table = explained_of_lags(observed, n_psi)
    pred_table = explained_of_lags(predicted.astype(np.complex128), n_psi)
    # the same energy, over these modes ...
    ratio = predicted[:, 0].real.sum() / observed[:, 0].real.sum()
    assert 0.35 < ratio < 1.2
    # ... at the same phase steps (the sum products' 2 x 1.6 sqrt(0.4) rad a frame)
    corr = np.corrcoef(obs_table.sum(axis=0), pred_table.sum(axis=0))[0, 1]
    assert corr > 0.98
    # a sea seen linearly has no square, and none is predicted
    linear = continuum_lags([s.astype(np.float32)], idx, window)[0]
    assert np.abs(linear[:, 0]).sum() < 0.05 * observed[:, 0].real.sum()


def test_the_continuum_is_per_part_and_of_the_given_modes() -> None:
    t, n = 8, 32
    rng = np.random.default_rng(4)
    parts = [(lambda s: (s + 0.3 * s * s).astype(np.float32))(_sea(t, n, rng, 60))
             for _ in range(2)]
    idx = np.array([5, 40, 77, 300])
    both = continuum_lags(parts, idx, _hann2d(n, n))
    assert both.shape == (2, idx.size, t) and both.dtype == np.complex64
    np.testing.assert_array_equal(both[1], continuum_lags(parts[1:], idx, _hann2d(n, n))[0])
    # lag 0 is an energy: real and not negative (to float32's rounding)
    assert np.all(both[:, :, 0].real > -1e-5 * np.abs(both).max())
    np.testing.assert_allclose(both[:, :, 0].imag, 0, atol=1e-3 * np.abs(both).max())


def test_taking_the_continuum_out_leaves_the_waves_and_takes_the_square() -> None:
    """The periodogram's use: each mode's explained energy less the predicted continuum.  A
    wave's own peak (0.3-0.5 rad/px) keeps nearly all of its height; the modes that hold
    only the square's products lose a large part of theirs, wherever in phase step."""
    t, n, n_psi = 10, 64, 64
    s = _sea(t, n, np.random.default_rng(6))
    frames = (s + 0.2 * s * s).astype(np.float32)
    k = 2 * np.pi * np.fft.fftfreq(n)
    kappa = np.hypot(*np.meshgrid(k[: n // 2 + 1], k, indexing="xy")).ravel()
    window = _hann2d(n, n)
    for band, kept in (((0.3, 0.5), (0.97, 1.0)), ((0.65, 0.95), (0.0, 0.5))):
        idx = np.flatnonzero((kappa > band[0]) & (kappa < band[1]))
        g = _windowed_modes([frames], idx).astype(np.complex128)
        g -= g.mean(axis=1, keepdims=True)
        r = np.array([[np.sum(m[lag:] * np.conj(m[:t - lag])) for lag in range(t)]
                      for m in g[0].T])
        before = explained_of_lags(r, n_psi)
        cont = explained_of_lags(continuum_lags([frames], idx, window)[0].astype(complex),
                                 n_psi)
        after = np.maximum(before - cont, 0.0)
        peak = before.max(axis=1)
        strong = peak >= np.quantile(peak, 0.5)  # the band's stronger modes
        left = after[strong].max(axis=1).sum() / peak[strong].sum()
        assert kept[0] <= left <= kept[1], (band, left)


@pytest.mark.parametrize("t", [3, 10, 30])
def test_the_lag_sums_are_each_series_autocorrelation_and_compiled_the_same_bits(
        t: int) -> None:
    """``lag_sums`` is ``sum_s X_{s+l} conj(X_s)`` of each column (against complex128
    products), and the compiled loop gives the array form's bits."""
    from wavealt.altimetry.dispersion import compiled, continuum

    rng = np.random.default_rng(t)
    x = (rng.standard_normal((t, 517)) + 1j * rng.standard_normal((t, 517))).astype(
        np.complex64)
    re, im = continuum.lag_sums(x)
    direct = np.array([np.sum(x[lag:].astype(np.complex128)
                              * np.conj(x[:t - lag].astype(np.complex128)), axis=0)
                       for lag in range(t)])
    np.testing.assert_allclose(re + 1j * im, direct, rtol=0, atol=1e-5 * t)
    arrays = [np.full((t, 517), np.nan, dtype=np.float32) for _ in range(4)]
    r, i = np.ascontiguousarray(x.real), np.ascontiguousarray(x.imag)
    continuum.lag_sums_arrays(r, i, arrays[0], arrays[1])
    compiled.lag_sums(r, i, arrays[2], arrays[3])
    assert np.array_equal(arrays[0], arrays[2]) and np.array_equal(arrays[1], arrays[3])
    # the lag-0 sum is each series' energy, real
    np.testing.assert_allclose(arrays[0][0], np.sum(np.abs(x) ** 2, axis=0), rtol=1e-5)
    assert np.array_equal(arrays[1][0], np.zeros(517, dtype=np.float32))
