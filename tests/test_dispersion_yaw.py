"""A camera that turns about its axis: its corner tiles measure the rate, and the altimeter
turns the frames back before it fits them (given the rate, or measuring it)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from benchmodule import bench_module
from contract import assert_honest

from wavealt.altimetry.dispersion import DispersionAltimeter
from wavealt.altimetry.dispersion.constants import YAW_BANDS, YAW_PASSES
from wavealt.altimetry.dispersion.result import DispersionResult
from wavealt.altimetry.dispersion.yaw import significant_turn, tile_yaw
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence

FPS = 30.0
#: Tile centres ``(x, y)`` px from the frame's centre, in the corner tiles' order (top
#: left, top right, bottom left, bottom right; image y down).
CENTRES = [(-50.0, -50.0), (50.0, -50.0), (-50.0, 50.0), (50.0, 50.0)]


def _tile_series(omega: float, rng: np.random.Generator, *, frames: int = 10,
                 noise: float = 0.1, kappa_max: float = 2.0, noisier_short: bool = False
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mode series of four tiles of one sea drifting at ``(0.7, -0.3)`` px a frame, its
    waves stepping by a dispersion term of their own, seen by a camera turning at ``omega``
    rad a frame (the top of the image to the right: the image moves by ``omega (y, -x)``);
    ``noisier_short``: the noise grows with the wavenumber, to six times ``noise`` at
    ``kappa_max`` (as a rendered sea's short waves are weaker)."""
    n = 800
    kappa = rng.uniform(0.3, kappa_max, n)
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    kx, ky = kappa * np.cos(angle), kappa * np.sin(angle)
    t = np.arange(frames)[:, None]
    series = []
    for x, y in CENTRES:
        vx, vy = 0.7 + omega * y, -0.3 - omega * x
        step = -(kx * vx + ky * vy) + 0.5 * np.sqrt(kappa)  # the waves' own, in every tile
        g = np.exp(1j * (step * t + rng.uniform(0.0, 2.0 * np.pi, n)))
        scale = noise * (6.0 * kappa / kappa_max if noisier_short else 1.0)
        g += scale * (rng.standard_normal(g.shape) + 1j * rng.standard_normal(g.shape))
        series.append(g - g.mean(axis=0))
    return np.stack(series), kx, ky


@pytest.mark.parametrize("omega", [0.004, -0.0025, 0.02])
def test_the_tiles_read_the_turn_and_not_the_drift_or_the_waves(omega: float) -> None:
    rng = np.random.default_rng(5)
    series, kx, ky = _tile_series(omega, rng)
    est, sd, pairs = tile_yaw(series, kx, ky, CENTRES)
    assert pairs == 6 * YAW_BANDS
    assert abs(est - omega) < 0.03 * abs(omega), (est, omega)
    rate = significant_turn(series, kx, ky, CENTRES, FPS)
    assert rate is not None and abs(rate / (math.degrees(omega) * FPS) - 1.0) < 0.03


def test_a_fast_turn_is_read_through_the_wrapped_short_waves() -> None:
    """At 0.025 rad a frame (43 deg/s at 30 frames a second) the short waves' phase
    differences between the diagonal tiles wrap several times; their band starts from the
    longer waves' rate, and the turn is read."""
    series, kx, ky = _tile_series(0.025, np.random.default_rng(5), kappa_max=2.5,
                                  noisier_short=True)
    est, sd, _ = tile_yaw(series, kx, ky, CENTRES)
    assert abs(est / 0.025 - 1.0) < 0.03 and abs(est) > 10 * sd, (est, sd)


def test_a_still_camera_shows_no_turn() -> None:
    for seed in range(5):
        series, kx, ky = _tile_series(0.0, np.random.default_rng(seed))
        est, sd, _ = tile_yaw(series, kx, ky, CENTRES)
        assert abs(est) < 1e-4
        assert significant_turn(series, kx, ky, CENTRES, FPS) is None


def test_tiles_of_noise_show_no_turn() -> None:
    """White noise leaves a few modes coherent by chance in every tile; their phase steps
    fit some rate, which the units' spread does not call a turn."""
    for seed in range(60):
        rng = np.random.default_rng(seed)
        noise = rng.standard_normal((4, 10, 500)) + 1j * rng.standard_normal((4, 10, 500))
        kx, ky = rng.uniform(-2.0, 2.0, 500), rng.uniform(-2.0, 2.0, 500)
        assert significant_turn(noise, kx, ky, CENTRES, FPS) is None, seed


def _yawing(frames: np.ndarray, rate_dps: float, fps: float, side: int) -> np.ndarray:
    """``benchmarks/bench_yaw.py``'s yawing camera (written from MAVLink's axes, not from
    :func:`wavealt.camera.unturn_yaw`)."""
    return bench_module("bench_yaw").yawing_view(frames, rate_dps, fps, side)


def _sea(frames: int) -> tuple[np.ndarray, dict]:
    """The realistic renderer's clean frames (grey) of a camera 4 m up drifting at 0.4 m/s,
    and the altimeter's arguments for them (the camera's velocity given)."""
    cfg = preset_config("realistic", size=256, frames=frames, altitude_m=(4.0, 4.0),
                        wind_speed_mps=(7.0, 7.0), camera_speed_mps=(0.4, 0.4))
    sc = cfg.sample_scenario(3)
    kw = {"fps": cfg.fps, "focal_px": cfg.focal_px, "velocity_mps": sc.camera_velocity_mps}
    return generate_sequence(sc, cfg).clean.mean(axis=-1), kw


@pytest.fixture(scope="module")
def sea() -> tuple[np.ndarray, dict]:
    return _sea(10)


@pytest.mark.parametrize("rate", [-10.0, 5.0, 20.0])
def test_the_rendered_sea_seen_turning_shows_its_rate(sea, rate: float) -> None:
    frames, kw = sea
    est = DispersionAltimeter()
    measured = est._measured_turn(None, _yawing(frames, rate, kw["fps"], 176), kw["fps"])
    assert measured is not None and abs(measured / rate - 1.0) < 0.25, measured
    assert est._measured_turn(None, _yawing(frames, 0.0, kw["fps"], 176), kw["fps"]) is None


@pytest.mark.parametrize("rate", [5.0, 15.0])
def test_a_yawing_camera_reads_its_altitude_with_its_yaw_rate_given_or_measured(
        sea, rate: float) -> None:
    """The image turns 0.15-0.5 degree a frame: the corner tiles each see the water carried
    a different way, which one velocity does not fit (before the turn was measured, 4 m read
    as 7.5 m, not trusted).  Given the rate, the frames turned back read as a still camera's;
    not given, the tiles measure it and the frames are turned back at that; a rate given is
    the truth (0 declares a still camera, and nothing is measured); given with the wrong
    sign, the estimate keeps the contract."""
    frames, kw = sea
    est = DispersionAltimeter()
    still = est.estimate(_yawing(frames, 0.0, kw["fps"], 176), **kw)
    clip = _yawing(frames, rate, kw["fps"], 176)
    told = est.estimate(clip, yaw_rate_dps=rate, **kw)
    assert still.trusted and still.yaw_rate_dps == 0.0 and "+yaw" not in still.signal
    assert "+unturned" in told.signal and told.yaw_rate_dps == rate
    assert abs(told.altitude_m / still.altitude_m - 1.0) < 0.02
    assert_honest(told, 4.0)
    # turned back by 5 degrees over the clip (15 deg/s), the frames' replicated borders
    # sweep the corner tiles and the fit is graded lower than the still camera's (0.79
    # against 0.88): its 3-sigma interval may then just exceed the bar (10.0 %); at 5 deg/s
    # it is trusted
    assert told.trusted or (rate > 10.0 and told.reason.startswith("3-sigma uncertainty"))
    measured = est.estimate(clip, **kw)
    # measured, the rate is a little off (13.7 for 15 deg/s), and what the turn-back leaves
    # may set the tiles apart (then not trusted): the reading holds either way
    assert "+yaw" in measured.signal, measured
    assert abs(measured.altitude_m / still.altitude_m - 1.0) < 0.03
    # the measured rate's uncertainty is in the altitude's: no surer than the rate told
    assert not told.trusted or measured.altitude_std_m >= told.altitude_std_m * 0.999
    declared = est.estimate(clip, yaw_rate_dps=0.0, **kw)  # declared still: not measured
    assert declared.yaw_rate_dps == 0.0 and "+yaw" not in declared.signal
    assert abs(measured.yaw_rate_dps / rate - 1.0) < 0.2
    assert_honest(measured, 4.0)
    assert abs(measured.altitude_m / 4.0 - 1.0) < 0.05
    assert measured.to_dict()["yaw_rate_dps"] == measured.yaw_rate_dps
    assert_honest(est.estimate(clip, yaw_rate_dps=-rate, **kw), 4.0)


def test_the_command_line_reports_the_turn_it_measured(sea, tmp_path, run_cli) -> None:
    """A frame folder of a camera turning at 15 deg/s, its rate not given: the JSON's
    ``yaw_rate_dps`` is the rate measured, the text says the frames were turned back, and
    ``altitude.csv`` holds each window's rate."""
    import csv
    import json

    from wavealt.io import write_frames_folder

    frames, kw = sea
    grey = np.clip(_yawing(frames, 15.0, kw["fps"], 176), 0.0, 1.0)
    clip = np.repeat(grey[..., None], 3, axis=-1)
    write_frames_folder(tmp_path / "f", clip)
    vx, vy = kw["velocity_mps"]
    args = ["altitude", str(tmp_path / "f"), "--fps", str(kw["fps"]), "--focal-px",
            str(kw["focal_px"]), "--velocity-mps", f"{vx},{vy}"]
    code, out, err = run_cli([*args, "--json"])
    assert code == 0, err
    summary = json.loads(out)
    assert abs(summary["yaw_rate_dps"] / 15.0 - 1.0) < 0.25, summary
    code, out, err = run_cli([*args, "--out", str(tmp_path / "out")])
    assert code == 0, err
    assert "measured from the frames" in out
    with open(tmp_path / "out" / "altitude.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert float(rows[0]["yaw_rate_dps"]) == pytest.approx(summary["yaw_rate_dps"], rel=1e-5)
    code, out, err = run_cli([*args, "--yaw-rate-dps", "15"])
    assert code == 0 and "measured from the frames" not in out


def test_a_binned_yawing_camera_turned_back_keeps_its_image_scale(sea) -> None:
    """Frames twice the working scale are binned (``working_px``); turned back at the rate
    their tiles measure, they are fitted again from the camera's own frames and focal
    length, binned as before.  The pass once took the binned focal length as the camera's
    and binned it again: a 512-px clip of the second generator (seed 3029) read 6.05 m as
    2.99 m at sigma 3 %, trusted, and a 1080-line video, binned 4, would read a quarter."""
    frames, kw = sea
    clip = _yawing(frames, 15.0, kw["fps"], 176)
    est = DispersionAltimeter(working_px=88)
    # the fit at the working scale (which ``estimate`` may replace by a trusted finer one)
    binned = est._estimate_at(clip, 2, 0.0, **kw)
    assert "+yaw" in binned.signal and "+binned2" in binned.signal, binned.signal
    assert abs(binned.altitude_m / 4.0 - 1.0) < 0.1, binned
    assert_honest(binned, 4.0)
    assert_honest(est.estimate(clip, **kw), 4.0)


@pytest.fixture(scope="module")
def sea30() -> tuple[np.ndarray, dict]:
    return _sea(30)


def test_a_turn_whose_frames_turned_back_lose_the_shell_is_refuted(sea30) -> None:
    """A still camera's frames turned back at a rate it did not turn (a second of 90
    deg/s: +-45 degrees over the clip) hold no shell: the turn is refuted, and the fit of the
    frames as they are is finished, kept and marked.  A turning camera's frames turned back
    at its rate hold the shell: the turn stands and the still fit is not made."""
    frames, kw = sea30
    est = DispersionAltimeter()
    made: list[DispersionResult] = []

    def still(clip: np.ndarray):
        def finish() -> DispersionResult:
            made.append(est.estimate(clip, yaw_rate_dps=0.0, **kw))
            return made[-1]
        return finish

    clip = _yawing(frames, 0.0, kw["fps"], 176)
    again = {"frames": clip, "binning": 1, "velocity_sigma_mps": 0.0, **kw}
    # the last pass: a pass at the rate the turned frames show would take the turn back
    res = est._turn_back(again, 0.0, (90.0, 1.0), YAW_PASSES - 1, still(clip))
    assert len(made) == 1 and res is made[0], res
    assert "+turn-refuted" in res.signal and res.yaw_rate_dps == 0.0
    assert_honest(res, 4.0)
    assert abs(res.altitude_m / 4.0 - 1.0) < 0.03
    made.clear()
    turning = _yawing(frames, 15.0, kw["fps"], 176)
    res = est._turn_back({**again, "frames": turning}, 0.0, (15.0, 0.5), 0, still(turning))
    assert not made and "+yaw" in res.signal and "+turn-refuted" not in res.signal
    assert res.yaw_rate_dps == pytest.approx(15.0, abs=3.0)
    assert_honest(res, 4.0)


def test_a_refuted_turn_leaves_the_still_fit_untrusted_while_the_tiles_show_it(
        sea30, monkeypatch) -> None:
    """End to end: tiles that keep showing a turn the camera did not make (a 90 deg/s turn
    injected into the tiles' measurement of a still camera) are refuted by the fit, whose
    altitude is the still camera's; the result says so and is not trusted, since the turn
    it leaves is not modelled."""
    frames, kw = sea30
    clip = _yawing(frames, 0.0, kw["fps"], 176)
    est = DispersionAltimeter()
    still = est.estimate(clip, **kw)
    assert still.trusted and "+yaw" not in still.signal
    monkeypatch.setattr(est, "_measured_turn",
                        lambda p, signal, fps, with_sd=False: (90.0, 1.0) if with_sd else 90.0)
    res = est.estimate(clip, **kw)
    assert "+turn-refuted" in res.signal and res.yaw_rate_dps == 0.0, res.signal
    assert not res.trusted and "turned +90.0 deg/s" in res.reason, res.reason
    assert res.altitude_m == pytest.approx(still.altitude_m, rel=1e-9)
    assert_honest(res, 4.0)


def test_a_turn_whose_frames_turned_back_need_a_tilt_is_refuted(sea, monkeypatch) -> None:
    """A still, level camera's tiles showing a turn it did not make (3 deg/s, injected into
    the tiles' measurement of the frames as they are): turned back at that rate, the tiles
    read scales that change across the frame, and the frames are levelled at a tilt the
    camera does not have.  The frames as they are pass every test but the turn's without a
    tilt, so the turn is refuted with the tilt it brought: the altitude is the still
    camera's, and not trusted while the tiles show the turn."""
    frames, kw = sea
    clip = _yawing(frames, 0.0, kw["fps"], 176)
    est = DispersionAltimeter()
    still = est.estimate(clip, **kw)
    assert still.trusted and still.attitude_deg is None
    # the premise: turned back at 3 deg/s, the frames are levelled
    assert est.estimate(clip, yaw_rate_dps=3.0, **kw).attitude_deg is not None
    shown: list[np.ndarray] = []

    def measured(p, signal, fps, with_sd=False):
        shown.append(shown[0] if shown else signal)
        if signal is not shown[0]:  # the frames turned back show no turn
            return None
        return (3.0, 0.6) if with_sd else 3.0

    monkeypatch.setattr(est, "_measured_turn", measured)
    res = est.estimate(clip, **kw)
    assert "+turn-refuted" in res.signal and res.attitude_deg is None, res.signal
    assert res.yaw_rate_dps == 0.0 and res.altitude_m == pytest.approx(still.altitude_m,
                                                                       rel=1e-9)
    assert not res.trusted and "turned +3.0 deg/s" in res.reason, res.reason
    assert_honest(res, 4.0)
