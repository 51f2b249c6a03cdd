"""Where a mode's waves lie: a Hann-windowed mode on a sea whose spectrum falls with the
wavenumber steps as the waves at its power-weighted centroid, not at its bin's centre."""

from __future__ import annotations

import math

import numpy as np

from wavealt.altimetry.dispersion import DispersionAltimeter
from wavealt.altimetry.dispersion.leakage import centroid_shifts, full_power, mode_shifts


def test_the_full_plane_is_the_real_images_power() -> None:
    rng = np.random.default_rng(0)
    for h, w in ((8, 8), (9, 12), (16, 7)):
        img = rng.standard_normal((h, w))
        half = np.abs(np.fft.rfft2(img)) ** 2
        np.testing.assert_allclose(full_power(half, w), np.abs(np.fft.fft2(img)) ** 2,
                                   rtol=1e-10, atol=1e-10)


def test_a_flat_spectrum_moves_no_mode_and_a_falling_one_moves_each_toward_long_waves(
        ) -> None:
    h = w = 64
    idx = np.arange(h * (w // 2 + 1))
    flat = centroid_shifts(np.ones((h, w // 2 + 1)), w, idx)
    assert np.abs(flat).max() < 1e-12
    ky = 2 * np.pi * np.fft.fftfreq(h)[:, None]
    kx = 2 * np.pi * np.fft.rfftfreq(w)[None, :]
    kappa = np.hypot(kx, ky)
    power = np.maximum(kappa, 1e-3) ** -3.0
    dkx, dky = centroid_shifts(power, w, idx)
    r, c = np.divmod(idx, w // 2 + 1)
    k_x, k_y, k = kx[0, c], ky[r, 0], kappa[r, c]
    band = (k > 0.6) & (k < 2.0)
    # toward the origin, and to first order (1/3) bin^2 d log S / d k = -(3/3) bin^2 / k
    radial = (dkx * k_x + dky * k_y)[band] / k[band]
    assert np.all(radial < 0)
    bin_k = 2 * np.pi / w
    np.testing.assert_allclose(radial, -bin_k ** 2 / k[band], rtol=0.25)
    # never past a neighbouring bin
    assert np.abs(dkx).max() < bin_k and np.abs(dky).max() < bin_k


def test_the_shifts_of_windowed_frames_are_the_same_from_frames_or_their_planes() -> None:
    import scipy.fft

    rng = np.random.default_rng(2)
    parts = [rng.standard_normal((5, 24, 32)).astype(np.float32) for _ in range(2)]
    win = (np.hanning(24)[:, None] * np.hanning(32)[None]).astype(np.float32)
    idx = np.arange(0, 24 * 17, 3)
    planes = np.stack([scipy.fft.rfft2(p * win, workers=1) for p in parts])
    np.testing.assert_allclose(mode_shifts(parts, idx, win, planes),
                               mode_shifts(parts, idx, win), rtol=1e-5, atol=1e-9)


def _steep_sea(n: int, t: int, waves: int, rng: np.random.Generator) -> np.ndarray:
    """``(t, n, n)`` frames of ``waves`` random-phase waves of continuous wavenumbers
    0.15-1.2 rad/px within 70 degrees of +x, power falling as ``kappa^-3`` (per unit
    wavenumber), each stepping ``1.6 sqrt(kappa)`` rad a frame."""
    kap = np.exp(rng.uniform(math.log(0.15), math.log(1.2), waves))
    ang = rng.uniform(-1.2, 1.2, waves)
    amp = 1.0 / kap  # log-uniform draws: power per unit kappa ~ kappa^-3
    step = 1.6 * np.sqrt(kap)
    phase = rng.uniform(0.0, 2.0 * math.pi, waves)
    pos = np.arange(n)
    ex = np.exp(1j * np.outer(kap * np.cos(ang), pos))  # (waves, n)
    ey = np.exp(1j * np.outer(kap * np.sin(ang), pos))
    frames = np.empty((t, n, n))
    for i in range(t):
        c = amp * np.exp(1j * (phase - step * i))
        frames[i] = (ey.T @ (c[:, None] * ex)).real  # [y, x]
    return frames


def test_a_modes_peak_lies_at_its_centroids_phase_step() -> None:
    """On a steep sea the peaks of the modes' periodograms lie below the steps of their
    bins' centres (slower, longer waves), and at their centroids' steps."""
    frames = _steep_sea(96, 30, 3000, np.random.default_rng(3)).astype(np.float32)
    p = DispersionAltimeter()._periodogram(frames, corners=False)
    measured = np.argmax(p["q"], axis=1) * 2.0 * math.pi / p["q"].shape[1]
    bins = p["_bins"][2]
    sel = (bins > 0.2) & (bins < 1.0)
    res = {}
    for name, kappa in (("bins", bins), ("centroids", p["kappa"])):
        r = np.angle(np.exp(1j * (measured - 1.6 * np.sqrt(kappa))))
        near = sel & (np.abs(r) < 0.3)
        assert near.sum() > 200
        res[name] = float(np.median(r[near]))
    assert res["bins"] < -0.004
    assert abs(res["centroids"]) < 0.3 * abs(res["bins"])
