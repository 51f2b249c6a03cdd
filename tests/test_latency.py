"""A camera's delay behind the vehicle's ATTITUDE, from the frames' own shake: the image
shift the corner tiles measure is the one the attitude predicts, the delay is found where
the prediction explains it, and an attitude that is not the camera's measures nothing."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from wavealt.altimetry.dispersion import DispersionAltimeter, image_shake
from wavealt.live.latency import (
    MIN_WINDOWS,
    LatencyMeter,
    attitude_shift,
    detrend,
)
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence

SIDE = 176


@pytest.fixture(scope="module")
def sea() -> tuple[np.ndarray, float, float]:
    """A level camera's 30 grey frames of the realistic renderer (4 m), its focal length
    and frame rate."""
    cfg = preset_config("realistic", size=256, frames=30, seed=4, altitude_m=(4.0, 4.0),
                        wind_speed_mps=(8.0, 8.0), camera_speed_mps=(0.4, 0.4))
    frames = generate_sequence(cfg.sample_scenario(0), cfg).clean.mean(axis=-1)
    return frames, float(cfg.focal_px), float(cfg.fps)


def _shake(rng: np.random.Generator, amp_deg: float):
    """Roll and pitch, radians, as functions of time: ``amp sin(2 pi f t + phi)`` per axis,
    ``f`` in 0.7-2 Hz."""
    f, phi = rng.uniform(0.7, 2.0, 2), rng.uniform(0, 2 * np.pi, 2)

    def at(times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(times, dtype=np.float64)
        return tuple(math.radians(amp_deg) * np.sin(2 * np.pi * f[i] * t + phi[i])
                     for i in range(2))
    return at


def _bench(name: str):
    """``benchmarks/<name>.py``, whose cameras these tests fly."""
    import importlib
    import sys
    from pathlib import Path

    path = str(Path(__file__).resolve().parents[1] / "benchmarks")
    if path not in sys.path:
        sys.path.insert(0, path)
    return importlib.import_module(name)


def _shaken(frames: np.ndarray, focal_px: float, roll: np.ndarray,
            pitch: np.ndarray) -> np.ndarray:
    """The central SIDE px of a camera at each frame's roll and pitch (radians) over the
    level camera's frames (``bench_shake.shaken_view``: OpenCV's homography of the
    rotation), in [0, 1]."""
    deg = np.degrees(np.stack([roll, pitch], axis=-1))
    return np.clip(_bench("bench_shake").shaken_view(frames, deg, focal_px, SIDE), 0.0, 1.0)


def test_the_attitudes_shift_is_the_focal_length_times_the_angle() -> None:
    assert np.allclose(attitude_shift(0.0, 0.0, 200.0), 0.0)
    small = attitude_shift(np.array([1e-3, 0.0]), np.array([0.0, 1e-3]), 200.0)
    # a small rotation about one axis moves the image along one axis by f times the angle
    assert np.allclose(np.abs(small), [[0.2, 0.0], [0.0, 0.2]], atol=1e-6)
    # and twice the angle twice as far (to the tangent's curvature)
    assert np.allclose(attitude_shift(2e-3, 0.0, 200.0), 2 * small[0], rtol=1e-5)
    series = np.cumsum(np.ones((10, 2)), axis=0) + 3.0
    assert np.allclose(detrend(series), 0.0)  # a line is all trend


def test_the_image_shake_is_the_shift_the_attitude_predicts(sea) -> None:
    """Through a degree of shake, the corner tiles read the image shift of the camera's
    rotation, sign and size, to 15 % of its root mean square; a level camera reads none."""
    frames, focal, fps = sea
    at = _shake(np.random.default_rng(1), 1.0)
    roll, pitch = at(np.arange(30) / fps)
    alt = DispersionAltimeter(dispersion="gravity-capillary")
    measured = image_shake(_shaken(frames, focal, roll, pitch), alt)
    assert measured is not None and measured.shape == (30, 2)
    predicted = detrend(attitude_shift(roll, pitch, focal))
    rms = float(np.sqrt(np.mean(predicted**2)))
    assert rms > 1.5
    assert float(np.sqrt(np.mean((measured - predicted) ** 2))) < 0.15 * rms
    zeros = np.zeros(30)
    assert image_shake(_shaken(frames, focal, zeros, zeros), alt) is None
    with pytest.raises(ValueError, match="at least 15"):
        image_shake(frames[:10], alt)


def test_the_meter_finds_the_delay_and_an_unrelated_attitude_measures_nothing(sea) -> None:
    """Windows whose frames arrive 70 ms after they were taken: each window finds the delay
    to 20 ms (a slow shake pins it less), the meter gives it to 5 ms once MIN_WINDOWS
    have; the attitude of another shake, or none, adds nothing."""
    frames, focal, fps = sea
    alt = DispersionAltimeter(dispersion="gravity-capillary")
    rng = np.random.default_rng(2)
    meter, wrong = LatencyMeter(), LatencyMeter()
    taken = 100.0 + np.arange(30) / fps
    for n in range(MIN_WINDOWS):
        at, other = _shake(rng, 1.0), _shake(rng, 1.0)
        shake = image_shake(_shaken(frames, focal, *at(taken)), alt)
        assert shake is not None
        assert meter.latency_s is None
        lag = meter.add(shake, taken + 0.07, at, focal)
        assert lag == pytest.approx(0.07, abs=0.0201)
        assert wrong.add(shake, taken + 0.07, other, focal) is None
        assert wrong.add(shake, taken + 0.07, lambda t: None, focal) is None
    assert meter.windows == MIN_WINDOWS
    assert meter.latency_s == pytest.approx(0.07, abs=0.0051)
    assert wrong.windows == 0 and wrong.latency_s is None


def test_windows_that_disagree_give_no_delay(sea) -> None:
    """Three windows that each measure a delay, but each a different one (0, 150 and 300
    ms): pooled, no one delay explains their shake, so the meter gives none."""
    frames, focal, fps = sea
    alt = DispersionAltimeter(dispersion="gravity-capillary")
    rng = np.random.default_rng(3)
    meter = LatencyMeter()
    taken = 100.0 + np.arange(30) / fps
    found = []
    for delay in (0.0, 0.15, 0.3):
        at = _shake(rng, 1.0)
        shake = image_shake(_shaken(frames, focal, *at(taken)), alt)
        found.append(meter.add(shake, taken + delay, at, focal))
    assert found == pytest.approx([0.0, 0.15, 0.3], abs=0.0201)
    assert meter.windows == 3 and meter.latency_s is None


def test_a_stream_is_levelled_at_its_mean_attitude_until_the_delay_is_known(sea) -> None:
    """``VehicleLevelling``: with the delay given, each frame at the attitude of its moment
    (the window's attitudes spread as the shake does); measured, each window at its mean
    attitude until three windows have measured it, then frame by frame at the delay found;
    with no attitude at all, nothing; a level camera with no lens, the frames as they
    came."""
    from wavealt.camera import pinhole
    from wavealt.live.levelling import VehicleLevelling

    frames, focal, fps = sea
    at = _shake(np.random.default_rng(4), 1.0)
    taken = 100.0 + np.arange(30) / fps
    clip = _shaken(frames, focal, *at(taken))
    alt = DispersionAltimeter(dispersion="gravity-capillary", attitude="level")

    def calib(w: int, h: int):
        return pinhole(w, h, focal)

    given = VehicleLevelling(calib, latency_s=0.05, altimeter=alt)
    out, f, info = given.level(clip, taken + 0.05, at)
    rolls = np.degrees(at(taken)[0])
    assert info["camera_latency_ms"] == 50.0 and info["roll_deg"] == pytest.approx(
        rolls.mean(), abs=0.01)
    assert info["attitude_sd_deg"] > 0.3 and out.shape[1] < SIDE and f < focal * 1.001
    assert "yaw_rate_dps" not in info  # no heading given: the turn is left to the altimeter
    # with the heading (turning right at 20 deg/s), each frame also turned back to the
    # middle moment's heading, as a steady turn's frames are
    from wavealt.camera import unturn_yaw

    turned, _, info = given.level(clip, taken + 0.05, at,
                                  heading_at=lambda t: np.radians(20.0) * (t - 100.0))
    assert info["yaw_rate_dps"] == pytest.approx(20.0, abs=1e-3)
    assert np.abs(turned - unturn_yaw(out, 20.0, fps)).max() < 1e-3
    measured = VehicleLevelling(calib, altimeter=alt)
    seen = []
    for n in range(MIN_WINDOWS + 1):
        rng_at = _shake(np.random.default_rng(10 + n), 1.0)
        window = _shaken(frames, focal, *rng_at(taken))
        _, _, info = measured.level(window, taken + 0.08, rng_at)
        seen.append((info["camera_latency_ms"], info["attitude_sd_deg"]))
    # the first windows at one attitude (their mean), then each frame at the delay found
    assert seen[0] == ("", "") and seen[1] == ("", "")
    assert seen[-1][0] == pytest.approx(80.0, abs=5.0) and seen[-1][1] > 0.3
    assert measured.level(clip, taken, lambda t: None) is None
    # a bank beyond what a level view is made for: the frames go as they came
    steep = (lambda t: (np.full(len(t), math.radians(50.0)), np.zeros(len(t))))
    assert given.level(clip, taken + 0.05, steep) is None
    still = VehicleLevelling(calib)
    flat, f0, info = still.level(clip, taken, lambda t: (np.zeros(len(t)), np.zeros(len(t))))
    assert flat is clip and f0 == focal and (info["roll_deg"], info["pitch_deg"]) == (0.0, 0.0)


def _turned(frames: np.ndarray, headings_deg: np.ndarray) -> np.ndarray:
    """A level camera's view of ``frames`` (north up) at each frame's heading
    (``bench_live_shake.turned_view``)."""
    return _bench("bench_live_shake").turned_view(frames, headings_deg)


def test_a_wavering_heading_is_read_as_a_rotation_and_times_the_frames_too(sea) -> None:
    """A camera shaking by half a degree while its heading wavers by two degrees: the
    tiles read the shift the roll and pitch give and the rotation the heading gives (the
    content turns against the nose, to 20 %), and the meter, matching both, finds a
    90-ms delay within 10 ms over three windows."""
    frames, focal, fps = sea
    alt = DispersionAltimeter(dispersion="gravity-capillary", attitude="level")
    taken = 100.0 + np.arange(30) / fps
    meter = LatencyMeter()
    for n in range(MIN_WINDOWS):
        rng = np.random.default_rng(20 + n)
        at = _shake(rng, 0.5)
        f, phi = rng.uniform(0.7, 2.0), rng.uniform(0, 2 * np.pi)

        def heading(t: np.ndarray, f: float = f, phi: float = phi) -> np.ndarray:
            return np.radians(2.0) * np.sin(2 * np.pi * f * np.asarray(t) + phi)

        clip = _shaken(_turned(frames, np.degrees(heading(taken))), focal, *at(taken))
        motion = image_shake(clip, alt, 4.0, rotation=True)
        assert motion is not None
        shift, turn = motion
        want = detrend(np.stack([-heading(taken)] * 2, -1))[:, 0]
        assert np.corrcoef(turn, want)[0, 1] > 0.95
        assert np.std(turn) == pytest.approx(np.std(want), rel=0.2)
        meter.add(shift, taken + 0.09, at, focal, turn, heading, 0.42 * SIDE)
    assert meter.latency_s == pytest.approx(0.09, abs=0.0101)


def test_a_wavering_heading_is_not_trusted_until_the_delay_is_known(sea) -> None:
    """While the delay is unknown, a window whose heading wavers about a steady turn is
    judged NOT TRUSTED (its interval then spans the range); a steady turn is not."""
    from wavealt.camera import pinhole
    from wavealt.live.levelling import VehicleLevelling, judge

    frames, focal, fps = sea
    taken = 100.0 + np.arange(30) / fps
    flat = (lambda t: (np.zeros(len(t)), np.zeros(len(t))))
    # a level camera over a still sea: nothing to measure the delay by, so it stays unknown
    stream = VehicleLevelling(lambda w, h: pinhole(w, h, focal))
    _, _, steady = stream.level(frames[:, :SIDE, :SIDE], taken, flat,
                                heading_at=lambda t: np.radians(15.0) * (t - 100.0))
    assert "distrust" not in steady
    _, _, wavering = stream.level(frames[:, :SIDE, :SIDE], taken, flat,
                                  heading_at=lambda t: np.radians(1.0) * np.sin(9.0 * t))
    assert stream.delay_s is None
    assert float(re.search(r"wavered by ([0-9.]+) deg", wavering["distrust"]).group(1)) > 0.5
    res = judge({"altitude_m": 5.0, "altitude_std_m": 0.05, "trusted": True, "reason": None},
                wavering, (1.0, 20.0))
    assert res["trusted"] is False and "wavered" in res["reason"]
    assert res["altitude_std_m"] >= 19.0 / 3.0 and "distrust" not in res
