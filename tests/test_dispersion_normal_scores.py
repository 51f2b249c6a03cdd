"""Each corner tile's values as the normal scores of their ranks (Gaussian anamorphosis)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import kurtosis, skew
from test_dispersion import _linear_frames

from wavealt.altimetry.dispersion import DispersionAltimeter
from wavealt.altimetry.dispersion.signal import normal_scores


def _standard(y: np.ndarray) -> np.ndarray:
    return (y - y.mean(dtype=np.float64)) / y.std(dtype=np.float64)


def test_normal_scores_are_normal_in_order_with_the_values_mean_and_spread() -> None:
    x = np.random.default_rng(3).exponential(size=(8, 64, 64)).astype(np.float32)
    y = normal_scores(x)
    assert y.shape == x.shape and y.dtype == np.float32
    assert abs(skew(x.ravel())) > 1.5  # the exponential's skew is 2
    assert abs(skew(y.ravel())) < 0.02 and abs(kurtosis(y.ravel())) < 0.05
    assert y.mean() == pytest.approx(x.mean(), rel=1e-3)
    assert y.std() == pytest.approx(x.std(), rel=1e-3)
    # the order of the values is kept (ties only within one bin of the value range)
    ys = y.ravel()[np.argsort(x.ravel(), kind="stable")]
    assert np.all(np.diff(ys) >= 0)


def test_a_monotone_transform_of_8_bit_values_gives_the_same_scores() -> None:
    levels = np.random.default_rng(4).integers(1, 256, size=(5, 48, 48)).astype(np.float32)
    x = levels / 255
    for f in (np.sqrt, np.exp, lambda v: v ** (1 / 2.2), lambda v: -np.log(1.5 - v)):
        assert np.allclose(_standard(normal_scores(f(x))), _standard(normal_scores(x)),
                           atol=1e-5)


def test_a_constant_array_is_returned_as_a_copy() -> None:
    x = np.full((3, 8, 8), 0.25, dtype=np.float32)
    y = normal_scores(x)
    assert np.array_equal(y, x) and y is not x


def test_a_monotone_non_linear_camera_reads_as_the_linear_one() -> None:
    # the linear camera's frames put through an exponential (a record convex in the slope,
    # as Fresnel's reflectance and a sky brighter toward the horizon make it): each corner
    # tile's ranks are the same, so the exact fit reads the same altitude (without the
    # normal scores the exponential moved it by 1.1 %)
    frames, focal_px, v = _linear_frames(3.0, 7.0, 0.3, 30.0, size=128, frames=10)
    est = DispersionAltimeter(dispersion="gravity", deglint="none")
    lin = est.estimate(frames, fps=30.0, focal_px=focal_px, velocity_mps=v)
    convex = np.minimum(np.expm1(6.0 * frames) / np.expm1(6.0), 1.0).astype(np.float32)
    curved = est.estimate(convex, fps=30.0, focal_px=focal_px, velocity_mps=v)
    assert abs(lin.altitude_m / 3.0 - 1) < 0.03
    assert curved.altitude_m == pytest.approx(lin.altitude_m, rel=1e-3)
