"""The waves' dispersion in water of a finite depth (:mod:`wavealt.altimetry.dispersion.waves`)
and the altimeter told the depth (``water_depth_m``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wavealt.altimetry.dispersion import DispersionAltimeter
from wavealt.altimetry.dispersion.waves import deep_omega2, omega, omega_and_dlog_k
from wavealt.sim.sea.spectrum import GRAVITY_MPS2
from wavealt.sim.sea.surface import OceanSurface

DISPERSIONS = ("gravity", "gravity-capillary")


@pytest.mark.parametrize("dispersion", DISPERSIONS)
def test_deep_and_shallow_limits(dispersion: str) -> None:
    """Deep water (``k d >> 1``) drops the depth; shallow water (``k d << 1``) takes
    ``tanh(k d) = k d``: gravity waves are then non-dispersive, ``omega = k sqrt(g d)``; the
    depth only ever slows a wave."""
    k = np.geomspace(0.5, 50.0, 40)
    deep = omega(k, dispersion)
    assert np.allclose(omega(k, dispersion, 1e3), deep, rtol=1e-12, atol=0)
    assert np.all(omega(k, dispersion, 0.3) < deep)
    d = 1e-3  # k d <= 0.05: tanh(k d) = k d (1 - (k d)^2 / 3 ...)
    assert np.allclose(omega(k, dispersion, d), np.sqrt(deep_omega2(k, dispersion) * k * d),
                       rtol=2e-3)
    assert np.allclose(omega(k, "gravity", d), k * np.sqrt(GRAVITY_MPS2 * d), rtol=2e-3)


@pytest.mark.parametrize("dispersion", DISPERSIONS)
@pytest.mark.parametrize("depth_m", [None, 0.05, 0.4, 3.0])
def test_the_slope_in_log_k_is_the_relations_own(dispersion: str, depth_m: float | None) -> None:
    """``d omega / d log k`` against a central difference of :func:`omega` itself."""
    k = np.geomspace(0.5, 200.0, 60)
    w, slope = omega_and_dlog_k(k, dispersion, depth_m)
    e = 1e-6
    numeric = (omega(k * math.exp(e), dispersion, depth_m)
               - omega(k * math.exp(-e), dispersion, depth_m)) / (2 * e)
    assert np.array_equal(w, omega(k, dispersion, depth_m))
    assert np.allclose(slope, numeric, rtol=1e-6)


def _shallow_sea(h: float, depth_m: float, *, focal_px: float = 100.0, size: int = 128,
                 frames: int = 30, fps: float = 30.0) -> np.ndarray:
    """Frames linear in the slope (an ideal camera, still over still water) of a sea whose
    waves obey the gravity relation in water ``depth_m`` deep."""
    def relation(k: np.ndarray) -> np.ndarray:
        return np.sqrt(GRAVITY_MPS2 * k * np.tanh(k * depth_m))

    sea = OceanSurface(n=2 * size, dx_m=h / focal_px, wind_speed_mps=6.0, wind_dir_rad=0.7,
                       rng=3, dispersion=relation)
    x = np.stack([f["slope_x"] + 0.7 * f["slope_y"]
                  for f in sea.iter_fields(np.arange(frames) / fps, crop=(size, size))])
    return ((x - x.min()) / (x.max() - x.min())).astype(np.float32)


def test_told_the_depth_the_altimeter_reads_a_shallow_sea() -> None:
    """Water 0.1 m deep under a camera 6 m up: the longest waves the tiles hold (about 1 m)
    run at 0.6 of their deep-water speed.  Told the depth, the fit is exact and blind within
    1 % and trusted; fitted as deep water, the slow long waves read as a higher camera."""
    h, depth = 6.0, 0.1
    clip = _shallow_sea(h, depth)
    told = DispersionAltimeter(dispersion="gravity", water_depth_m=depth)
    deep = DispersionAltimeter(dispersion="gravity")
    for kw in ({"velocity_mps": (0.0, 0.0)}, {}):
        res = told.estimate(clip, fps=30.0, focal_px=100.0, **kw)
        assert res.trusted and abs(res.altitude_m / h - 1) < 0.01
        assert abs(res.altitude_m - h) <= 3 * res.altitude_std_m
    exact_told = told.estimate(clip, fps=30.0, focal_px=100.0, velocity_mps=(0.0, 0.0))
    exact_deep = deep.estimate(clip, fps=30.0, focal_px=100.0, velocity_mps=(0.0, 0.0))
    assert exact_deep.altitude_m > 1.005 * exact_told.altitude_m


def test_deep_water_given_as_a_depth_is_deep_water() -> None:
    """A depth far beyond every wavelength reads what no depth reads (the same relation, to
    rounding)."""
    clip = _shallow_sea(4.0, 0.2, frames=12)
    for kw in ({"velocity_mps": (0.0, 0.0)}, {"velocity_mps": (0.0, 0.0),
                                               "velocity_sigma_mps": 0.3}):
        a = DispersionAltimeter(water_depth_m=1e4).estimate(clip, fps=30.0, focal_px=100.0, **kw)
        b = DispersionAltimeter().estimate(clip, fps=30.0, focal_px=100.0, **kw)
        assert a.altitude_m == pytest.approx(b.altitude_m, rel=1e-9)
        assert a.trusted == b.trusted


@pytest.mark.parametrize(("value", "match"), [(0, "water_depth_m must be > 0; got 0"),
                                              (-2.0, "water_depth_m must be > 0"),
                                              (math.nan, "water_depth_m must be finite"),
                                              ("deep", "water_depth_m must be a number")])
def test_a_bad_depth_is_refused(value, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        DispersionAltimeter(water_depth_m=value)
