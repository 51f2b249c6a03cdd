import numpy as np
import pytest

from wavealt.sim.sea.spectrum import (
    GRAVITY_MPS2,
    cox_munk_slope_variance,
    deep_water_omega,
    gravity_capillary_omega,
    phillips,
)


def test_cox_munk_eq2():
    assert cox_munk_slope_variance(0.0) == pytest.approx(0.003)
    assert cox_munk_slope_variance(10.0) == pytest.approx(0.003 + 0.0512)


def test_phillips_zero_upwind_and_at_origin():
    k = np.linspace(-50, 50, 101)
    kx, ky = np.meshgrid(k, k)
    s = phillips(kx, ky, wind_speed_mps=5.0, wind_dir_rad=0.7)
    upwind = (kx * np.cos(0.7) + ky * np.sin(0.7)) <= 0
    assert np.all(s[upwind] == 0)
    assert s[50, 50] == 0
    assert np.all(s[~upwind] > 0)


def test_phillips_k4_tail_and_cos2_spreading():
    big_l = 5.0**2 / GRAVITY_MPS2
    k = np.array([100.0, 200.0]) / big_l  # kL >> 1: exp factor ~ 1
    s = phillips(k, 0 * k, wind_speed_mps=5.0, wind_dir_rad=0.0)
    assert np.log(s[1] / s[0]) / np.log(2.0) == pytest.approx(-4.0, abs=1e-3)
    th = np.pi / 3
    s_off = phillips(k[0] * np.cos(th), k[0] * np.sin(th), wind_speed_mps=5.0, wind_dir_rad=0.0)
    assert s_off / s[0] == pytest.approx(np.cos(th) ** 2)


def test_dispersion_relations():
    k = np.array([1.0, 10.0, 100.0])
    assert np.allclose(deep_water_omega(k) ** 2, GRAVITY_MPS2 * k)
    # capillary term negligible for long waves, dominant for short ones; minimum phase speed
    # of gravity-capillary waves near 1.7 cm wavelength (about 0.23 m/s).
    kk = np.linspace(50, 1500, 5000)
    c = gravity_capillary_omega(kk) / kk
    k_min = kk[np.argmin(c)]
    assert 2 * np.pi / k_min == pytest.approx(0.017, rel=0.05)
    assert c.min() == pytest.approx(0.23, rel=0.05)


def test_phillips_rejects_bad_wind():
    with pytest.raises(ValueError, match="wind_speed_mps"):
        phillips(np.ones(2), np.ones(2), wind_speed_mps=0.0, wind_dir_rad=0.0)
