import numpy as np
import pytest
import scipy.fft

from wavealt.camera import Camera
from wavealt.sim.sea.spectrum import cox_munk_slope_variance, deep_water_omega
from wavealt.sim.sea.surface import OceanSurface


def make(n=128, dx=0.02, wind=5.0, wdir=0.4, rng=0):
    return OceanSurface(n=n, dx_m=dx, wind_speed_mps=wind, wind_dir_rad=wdir, rng=rng)


def test_field_is_real_and_coefficients_hermitian():
    s = make()
    h = s.coefficients(0.37)
    neg = (-np.arange(s.n)) % s.n
    assert np.allclose(h[neg][:, neg], np.conj(h))
    z = scipy.fft.ifft2(h, norm="forward")
    assert np.abs(z.imag).max() < 1e-12 * np.abs(z.real).max()


def test_nyquist_bins_empty():
    s = make()
    c = s.coefficients(0.1)
    assert np.all(c[s.n // 2, :] == 0) and np.all(c[:, s.n // 2] == 0)


@pytest.mark.parametrize("wind", [2.0, 6.0, 12.0])
def test_slope_variance_equals_cox_munk(wind):
    s = make(wind=wind, rng=3)
    target = float(cox_munk_slope_variance(wind))
    for t in (0.0, 0.5, 3.0):  # conserved over time (Parseval)
        sx, sy = s.slopes(t)
        assert np.mean(sx**2 + sy**2) == pytest.approx(target, rel=0.01)


def test_each_mode_advances_phase_by_omega_dt():
    s = make(rng=5)
    dt = 1 / 30
    h0 = scipy.fft.fft2(s.height(0.2), norm="forward")
    h1 = scipy.fft.fft2(s.height(0.2 + dt), norm="forward")
    strong = s.downwind & (np.abs(h0) > 1e-3 * np.abs(h0).max())
    assert strong.sum() > 50
    ratio = h1[strong] / h0[strong]
    expected = np.exp(-1j * deep_water_omega(s.k[strong]) * dt)
    assert np.allclose(ratio, expected, atol=1e-8)


def test_no_energy_travels_upwind():
    """Split each mode into the part travelling along +k and along -k from two frames."""
    s = make(rng=7)
    dt = 0.05
    h0 = scipy.fft.fft2(s.height(0.0), norm="forward")
    h1 = scipy.fft.fft2(s.height(dt), norm="forward")
    w = deep_water_omega(s.k) * dt
    e_m, e_p = np.exp(-1j * w), np.exp(1j * w)
    det = e_p - e_m
    ok = np.abs(det) > 1e-6
    a = np.where(ok, (h0 * e_p - h1) / np.where(ok, det, 1), 0)  # travels along +k
    upwind = (s.kx * np.cos(0.4) + s.ky * np.sin(0.4)) < 0
    assert np.sum(np.abs(a[upwind]) ** 2) < 1e-12 * np.sum(np.abs(a) ** 2)


def test_measured_spectrum_follows_phillips_tail():
    """Radially averaged power of synthesised fields falls as k^-4 in the tail (eq. 1)."""
    n = 128
    acc = np.zeros((n, n))
    for seed in range(6):
        s = make(n=n, dx=0.05, wind=3.0, rng=seed)
        acc += np.abs(scipy.fft.fft2(s.height(0.0), norm="forward")) ** 2
    k = s.k
    big_l = 3.0**2 / 9.81
    kk = np.geomspace(8 / big_l, 0.6 * np.pi / s.dx_m, 8)
    p = []
    for lo, hi in zip(kk[:-1], kk[1:]):
        sel = (k >= lo) & (k < hi)
        p.append(acc[sel].mean())
    kc = np.sqrt(kk[:-1] * kk[1:])
    slope = np.polyfit(np.log(kc), np.log(p), 1)[0]
    assert slope == pytest.approx(-4.0, abs=0.3)


def test_fast_path_matches_reference():
    s = make(n=64, rng=2)
    times = np.arange(4) / 30.0
    v = (0.4, -0.2)
    fields = list(s.iter_fields(times, crop=(40, 48), velocity_mps=v, with_height=True))
    for t, f in zip(times, fields):
        sx, sy = s.slopes(t, velocity_mps=v)
        h = s.height(t, velocity_mps=v)
        sl = (slice(12, 52), slice(8, 56))
        assert f["slope_x"].shape == (40, 48) and f["slope_x"].dtype == np.float32
        assert np.allclose(f["slope_x"], sx[sl], atol=1e-5)
        assert np.allclose(f["slope_y"], sy[sl], atol=1e-5)
        assert np.allclose(f["height_m"], h[sl], atol=1e-6)


def test_camera_motion_is_a_translation():
    """A camera moving at v sees the still sea shifted by v t (here one grid step)."""
    s = make(n=64, dx=0.02, rng=4)
    t = 0.1
    shifted = s.height(t, velocity_mps=(0.02 / t, 0.0))
    # same time, no motion, but sampled one grid step further along +x
    ref = np.roll(s.height(t), -1, axis=1)
    assert np.allclose(shifted, ref, atol=1e-10)


def test_features_scale_as_inverse_altitude_in_pixels():
    """Spectral centroid of the height field in rad/px doubles when the altitude doubles."""
    focal = 55.4
    size = 128

    def centroid(alt):
        cam = Camera(size, size, focal, alt)
        cs = []
        for seed in range(8):
            s = OceanSurface(n=2 * size, dx_m=cam.gsd_m, wind_speed_mps=1.5, wind_dir_rad=0.4,
                             rng=seed)
            p = np.abs(scipy.fft.fft2(s.height(0.0))) ** 2
            kpx = s.k * s.dx_m
            cs.append((kpx * p).sum() / p.sum())
        return np.mean(cs)

    ratio = centroid(4.0) / centroid(2.0)
    assert 1.8 < ratio < 2.2


@pytest.mark.parametrize("kw, match", [
    (dict(n=7), "n must be"), (dict(dx_m=0.0), "dx_m"), (dict(wind_speed_mps=-1.0), "wind_speed_mps"),
    (dict(wind_dir_rad=float("nan")), "wind_dir_rad"),
])
def test_bad_input(kw, match):
    base = dict(n=32, dx_m=0.01, wind_speed_mps=5.0, wind_dir_rad=0.0, rng=0)
    base.update(kw)
    with pytest.raises(ValueError, match=match):
        OceanSurface(**base)
