"""The camera's tilt from its corner tiles' image scales (:mod:`wavealt.altimetry.dispersion.
attitude`): the geometry against a numerical projection onto the sea, the test's level, and
the tiles' placement."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wavealt.altimetry.dispersion.attitude import fit_tilt, tile_centres
from wavealt.altimetry.dispersion.constants import ATTITUDE_LEVEL
from wavealt.altimetry.dispersion.spectra import _corners
from wavealt.camera import tilt_rotation


def _sea_scale(x: float, y: float, focal: float, rot: np.ndarray, height: float) -> float:
    """The altitude a one-scale fit reads around pixel ``(x, y)``: ``focal`` times the
    square root of the area on the sea of one pixel there, by central differences of the
    rays' intersections with the sea ``height`` below (no closed form)."""
    def sea(px: float, py: float) -> np.ndarray:
        d = rot @ np.array([px, py, focal])
        return height * d[:2] / d[2]
    e = 1e-3
    jac = np.stack([(sea(x + e, y) - sea(x - e, y)) / (2 * e),
                    (sea(x, y + e) - sea(x, y - e)) / (2 * e)], axis=1)
    return focal * math.sqrt(abs(np.linalg.det(jac)))


@pytest.mark.parametrize("roll, pitch", [(0.0, 0.0), (8.0, -3.0), (-12.0, 14.0), (0.0, 25.0)])
@pytest.mark.parametrize("height", [1.5, 9.0])
def test_the_tilt_of_exact_tile_scales_is_the_cameras(roll, pitch, height) -> None:
    focal = 268.5
    rot = tilt_rotation(roll, pitch)
    centres = tile_centres((256, 256), (100, 100))
    fits = [(x, y, math.log(_sea_scale(x, y, focal, rot, height)), 0.03) for x, y in centres]
    tilt = fit_tilt(fits, focal)
    assert tilt is not None
    assert np.allclose(tilt.roll_pitch_deg, (roll, pitch), atol=1e-4)
    assert tilt.chi2_tilt < 1e-12
    assert tilt.significant(ATTITUDE_LEVEL) == (roll != 0.0 or pitch != 0.0)
    assert tilt.tilt_deg == pytest.approx(math.degrees(math.acos(rot[2, 2])), abs=1e-4)
    # three tiles determine it too, with nothing left to check it against
    three = fit_tilt(fits[:3], focal)
    assert np.allclose(three.roll_pitch_deg, (roll, pitch), atol=1e-4)


def test_the_tilt_test_fires_at_its_level_on_a_level_camera() -> None:
    rng = np.random.default_rng(5)
    centres = tile_centres((256, 256), (100, 100))
    fired, n = 0, 3000
    for _ in range(n):
        sd = rng.uniform(0.01, 0.08, 4)
        fits = [(x, y, 1.7 + s * rng.standard_normal(), s) for (x, y), s in zip(centres, sd)]
        tilt = fit_tilt(fits, 268.5)
        fired += tilt is not None and tilt.significant(ATTITUDE_LEVEL)
    assert abs(fired / n - ATTITUDE_LEVEL) < 0.006, fired / n


def test_tiles_of_a_symmetric_frame_leave_the_altitude_unmoved_by_the_tilt() -> None:
    centres = tile_centres((256, 256), (100, 100))
    tilt = fit_tilt([(x, y, 1.0, 0.05) for x, y in centres], 268.5)
    assert tilt.extra_var_log() == pytest.approx(0.0, abs=1e-12)
    # one tile lost: the mean of the other three moves with the tilt
    assert fit_tilt([(x, y, 1.0, 0.05) for x, y in centres[:3]], 268.5).extra_var_log() > 0
    assert fit_tilt([(x, y, 1.0, 0.05) for x, y in centres[:2]], 268.5) is None


def test_tile_centres_are_those_of_the_corner_tiles() -> None:
    h, w = 90, 120
    xs = np.broadcast_to(np.arange(w) - (w - 1) / 2, (1, h, w))
    ys = np.broadcast_to((np.arange(h) - (h - 1) / 2)[:, None], (1, h, w))
    tx, ty = _corners(xs, 0.4), _corners(ys, 0.4)
    for (cx, cy), a, b in zip(tile_centres((h, w), tx[0].shape[1:]), tx, ty):
        assert cx == pytest.approx(float(a.mean())) and cy == pytest.approx(float(b.mean()))
