"""``wavealt altitude --live``: a real PyAV stream read in its own thread, a rolling window,
drops counted rather than waited for, windows that never span a gap, a clean stop on
SIGTERM, and the vehicle's velocity and attitude from MAVLink on the loopback."""

from __future__ import annotations

import csv
import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from wavealt.io import write_video
from wavealt.live import LIVE_COLUMNS, run_live
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence


def _clip(path, *, frames: int = 60, size: int = 64, times_s=None, fps: float = 30.0):
    cfg = preset_config("paper", size=size, frames=frames, altitude_m=(3.0, 3.0),
                        wind_speed_mps=(7.0, 7.0), camera_speed_mps=(0.3, 0.3), fps=fps)
    sc = cfg.sample_scenario(2)
    data = generate_sequence(sc, cfg)
    write_video(path, data.clean, fps=cfg.fps, times_s=times_s)
    return sc, cfg


def _rows(path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _untrusted() -> dict:
    """A window's result as an estimator that records its calls returns it: untrusted."""
    return {"altitude_m": 1.0, "altitude_std_m": 1.0, "camera_velocity_mps": (0.0, 0.0),
            "trusted": False, "reason": "test", "quality": 0.0, "mode": "blind"}


def test_live_playback_gives_the_estimates_of_the_recorded_file(tmp_path, run_cli) -> None:
    sc, cfg = _clip(tmp_path / "clip.mp4")
    common = ["--focal-px", str(cfg.focal_px), "--dispersion", "gravity", "--window", "10",
              "--step", "5", "--velocity-mps", ",".join(map(str, sc.camera_velocity_mps))]
    code, _, err = run_cli(["altitude", "--live", str(tmp_path / "clip.mp4"), *common,
                            "--out", str(tmp_path / "live")])
    assert code == 0, err
    code, _, err = run_cli(["altitude", str(tmp_path / "clip.mp4"), *common,
                            "--out", str(tmp_path / "file")])
    assert code == 0, err
    live = _rows(tmp_path / "live" / "live.csv")
    rec = _rows(tmp_path / "file" / "altitude.csv")
    assert list(live[0]) == list(LIVE_COLUMNS)
    # the same windows (frames 0-10, 5-15, ...) give the same altitudes, in order
    assert len(live) == len(rec) == 11
    for a, b in zip(live, rec):
        assert float(a["altitude_m"]) == pytest.approx(float(b["altitude_m"]), rel=1e-5)
        assert float(a["fps"]) == pytest.approx(30.0, rel=1e-3)
        assert a["mode"] == "exact"


def test_a_slow_estimator_drops_the_oldest_frames_and_never_stalls_the_reader(tmp_path) -> None:
    _clip(tmp_path / "clip.mp4")
    seen = []

    def slow(frames: np.ndarray, fps: float, arrivals: np.ndarray) -> dict:
        seen.append(frames.shape[0])
        time.sleep(0.25)  # far slower than 30 frames/s
        return _untrusted()

    t0 = time.monotonic()
    summary = run_live(str(tmp_path / "clip.mp4"), estimate=slow, window=5, step=1, capacity=8)
    elapsed = time.monotonic() - t0
    assert summary["frames"] == 60  # every frame was read, at the file's own pace
    # about 7.5 frames come per estimate and it takes 5: the rest leave the buffer unused
    assert summary["dropped_frames"] > 10
    assert summary["estimates"] == len(seen) < 20 and set(seen) == {5}
    assert elapsed < 2.0 + 0.25 * len(seen) + 1.0  # 2 s of stream: the reader never waited
    assert summary["stopped_by"] == "end of stream"


def test_windows_never_span_a_gap_in_the_frame_times(tmp_path) -> None:
    times = np.arange(40) / 30.0
    times[20:] += 5 / 30.0  # five frames lost after frame 19
    _clip(tmp_path / "gap.mp4", frames=40, times_s=times)
    rates = []

    def record(frames: np.ndarray, fps: float, arrivals: np.ndarray) -> dict:
        rates.append(fps)
        return _untrusted()

    # played at its own pace (1.4 s), so that the windows across the gap come up one by one
    # (unpaced, a busy machine may read the whole file before the first window is taken)
    summary = run_live(str(tmp_path / "gap.mp4"), estimate=record, window=10, step=2,
                       capacity=1000)
    assert summary["windows_skipped_for_gaps"] >= 1
    assert rates and np.allclose(rates, 30.0, rtol=1e-3)


@pytest.mark.parametrize("fps", [30.0, 60.0])
def test_the_default_live_window_is_one_second_of_the_streams_frames(tmp_path, fps) -> None:
    """Without a window, the times of the stream's first frames give its rate, and every
    estimate takes one second of frames at it, as a recorded clip's windows do (30 frames
    of a 60-fps camera are half a second, which reads as the half-second row does)."""
    _clip(tmp_path / "clip.mp4", frames=round(1.4 * fps), fps=fps)
    taken = []

    def record(frames: np.ndarray, rate: float, arrivals: np.ndarray) -> dict:
        taken.append((frames.shape[0], rate))
        return _untrusted()

    summary = run_live(str(tmp_path / "clip.mp4"), estimate=record)
    n = round(fps)
    assert (summary["window_frames"], summary["step_frames"]) == (n, n // 15)
    assert taken and {k for k, _ in taken} == {n}
    assert np.allclose([r for _, r in taken], fps, rtol=1e-3)


def test_a_default_window_is_capped_for_a_stream_that_comes_too_fast(tmp_path) -> None:
    """Frames stamped 2 ms apart (a source timed by its bursty arrivals looks so) make no
    window longer than ``MAX_RATE_WINDOW`` frames, nor a buffer of thousands."""
    from wavealt.live.stream import MAX_RATE_WINDOW

    n = MAX_RATE_WINDOW + 60
    _clip(tmp_path / "fast.mp4", frames=n, times_s=np.arange(n) * 0.002)
    taken = []

    def record(frames: np.ndarray, rate: float, arrivals: np.ndarray) -> dict:
        taken.append(frames.shape[0])
        return _untrusted()

    summary = run_live(str(tmp_path / "fast.mp4"), estimate=record, pace=False)
    assert summary["window_frames"] == MAX_RATE_WINDOW and set(taken) <= {MAX_RATE_WINDOW}


def test_a_stream_without_timestamps_needs_its_rate(tmp_path) -> None:
    """A raw H.264 stream carries no timestamps: timed as decoded, a file or pipe read faster
    than real time would hand every window a wrong rate (the altitude goes as its inverse
    square), so without ``fps`` it is a one-line error; with it, frame n is at n / fps."""
    import av

    if "libx264" not in av.codecs_available:
        pytest.skip("this PyAV has no H.264 encoder to write the raw stream with")
    from fractions import Fraction

    frames = (np.random.default_rng(0).random((90, 64, 64, 3)) * 255).astype(np.uint8)
    path = tmp_path / "raw.h264"
    with av.open(str(path), mode="w", format="h264") as container:
        stream = container.add_stream("libx264", rate=Fraction(60))
        stream.width = stream.height = 64
        stream.pix_fmt = "yuv420p"
        for img in frames:
            for packet in stream.encode(av.VideoFrame.from_ndarray(img, format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    taken = []

    def record(clip: np.ndarray, rate: float, arrivals: np.ndarray) -> dict:
        taken.append((clip.shape[0], rate))
        return _untrusted()

    with pytest.raises(ValueError, match="carry no timestamps, so their rate is not known"):
        run_live(str(path), estimate=record, fmt="h264")
    assert not taken
    summary = run_live(str(path), estimate=record, fmt="h264", fps=60.0)
    assert summary["window_frames"] == 60 and taken
    assert np.allclose([r for _, r in taken], 60.0)


def test_sigterm_stops_cleanly_and_leaves_a_complete_log(tmp_path) -> None:
    sc, cfg = _clip(tmp_path / "long.mp4", frames=240)  # 8 s at its own pace
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "wavealt", "altitude", "--live", str(tmp_path / "long.mp4"),
           "--focal-px", str(cfg.focal_px), "--window", "10", "--step", "5",
           "--velocity-mps", "0,0", "--out", str(out)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if (out / "live.csv").is_file() and len(_rows(out / "live.csv")) >= 2:
                break
            time.sleep(0.1)
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 0, stderr
    assert "stopped by signal" in stdout
    rows = _rows(out / "live.csv")
    assert 2 <= len(rows) < 47  # stopped well before the stream's end
    assert all(None not in r.values() and r["altitude_m"] for r in rows)


@pytest.mark.parametrize("argv, match", [
    (["--live", "missing.mp4", "--focal-px", "200"], "cannot read missing.mp4"),
    (["clip", "--live", "x.mp4", "--focal-px", "200"], "INPUT (a frame folder"),
    (["--focal-px", "200"], "INPUT (a frame folder"),
    (["clip", "--focal-px", "200", "--duration", "3"], "go with --live"),
    (["--live", "x.mp4", "--focal-px", "200", "--velocity-from-vehicle"],
     "need --live and --mavlink"),
    (["--live", "x.mp4", "--focal-px", "200", "--duration", "-1"], "--duration must be"),
    (["--live", "x.mp4", "--focal-px", "200", "--fps", "-3"], "--fps must be a positive"),
    (["--live", "x.mp4", "--focal-px", "200", "--camera-latency-ms", "30"],
     "goes with --tilt-from-vehicle"),
])
def test_live_bad_arguments_are_one_line_errors(tmp_path, run_cli, argv, match) -> None:
    os.chdir(tmp_path)
    code, out, err = run_cli(["altitude", *argv])
    assert code == 2 and match in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("kwargs, match", [
    ({"fps": 0}, "fps must be > 0; got 0"),
    ({"fps": -30.0}, "fps must be > 0; got -30"),
    ({"fps": math.nan}, "fps must be finite"),
    ({"fps": "fast"}, "fps must be a number"),
    ({"duration_s": 0.0}, "duration_s must be > 0"),
    ({"window": 2}, "window must be an integer >= 3; got 2"),
    ({"window": 10.5}, "window must be an integer >= 3; got 10.5"),
    ({"step": 0}, "step must be an integer >= 1; got 0"),
    ({"capacity": True}, "capacity must be an integer >= 1; got True"),
])
def test_run_live_refuses_bad_arguments_before_opening_the_source(tmp_path, kwargs,
                                                                  match) -> None:
    # the source exists and the log would be written: neither is touched
    log = tmp_path / "live.csv"
    log.write_text("kept\n")
    calls = []
    with pytest.raises(ValueError, match=re.escape(match)) as info:
        run_live(str(tmp_path / "missing.mp4"), estimate=lambda *a: calls.append(a) or {},
                 log=log, **kwargs)
    assert "\n" not in str(info.value) and "missing.mp4" not in str(info.value)
    assert log.read_text() == "kept\n" and not calls


def test_the_vehicles_velocity_and_attitude_are_used(tmp_path, run_cli) -> None:
    from test_mavlink import _free_port

    from wavealt.live.mavlink import use_mavlink2

    mavutil = use_mavlink2()
    sc, cfg = _clip(tmp_path / "clip.mp4", frames=90)
    port = _free_port()
    autopilot = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}")
    stop = threading.Event()

    requests = []

    def vehicle() -> None:
        # streams its state at 4 Hz (fresh for the altimeter's 1 s, too seldom to level frame
        # by frame) once it has heard the companion's first estimate, however long that took
        heard, last = False, -math.inf
        while not stop.is_set():
            msg = autopilot.recv_match(blocking=True, timeout=0.05)
            if msg is not None and msg.get_type() == "COMMAND_LONG":
                requests.append((msg.command, msg.param1, msg.param2))
            elif msg is not None:
                heard = True
            if heard and time.monotonic() - last >= 0.25:
                last = time.monotonic()
                autopilot.mav.local_position_ned_send(0, 0.0, 0.0, -3.0, 0.0, 0.0, 0.0)
                autopilot.mav.attitude_send(0, 0.1, -0.05, 0.0, 0.0, 0.0, 0.1)

    thread = threading.Thread(target=vehicle, daemon=True)
    thread.start()
    try:
        code, _, err = run_cli(["altitude", "--live", str(tmp_path / "clip.mp4"),
                                "--focal-px", str(cfg.focal_px), "--window", "10", "--step", "5",
                                "--mavlink", f"udpout:127.0.0.1:{port}",
                                "--velocity-from-vehicle", "--velocity-sigma-mps", "0.5",
                                "--tilt-from-vehicle",
                                "--out", str(tmp_path / "out")])
    finally:
        stop.set()
        thread.join(timeout=2)
        autopilot.close()
    assert code == 0, err
    rows = _rows(tmp_path / "out" / "live.csv")
    modes = [r["mode"] for r in rows]
    # blind until the vehicle's velocity is heard, then a prior around it
    assert modes[0] == "blind" and modes[-1] == "prior", modes
    assert json.dumps(modes).count("prior") >= 5
    # ATTITUDE asked for at 50 Hz (MAV_CMD_SET_MESSAGE_INTERVAL, every 20000 us)
    assert requests and requests[0] == (511, 30, 20000.0)
    # ATTITUDE once per estimate is too seldom to level frame by frame: each window is
    # levelled at the latest heard (rounded to the view cache's 0.5 deg)
    assert (float(rows[-1]["roll_deg"]), float(rows[-1]["pitch_deg"])) == (5.5, -3.0)
    assert rows[-1]["attitude_sd_deg"] == ""
    # and turned back at its yaw rate (ATTITUDE's yawspeed, 0.1 rad/s)
    assert float(rows[0]["yaw_rate_dps"]) == 0.0
    assert float(rows[-1]["yaw_rate_dps"]) == pytest.approx(math.degrees(0.1))


def _streaming_vehicle(port: int, stop: threading.Event):
    """An autopilot on the loopback that streams ATTITUDE at 100 Hz (roll 2 deg at 3 Hz,
    pitch -1 deg) once it has heard the companion computer."""
    from wavealt.live.mavlink import use_mavlink2

    autopilot = use_mavlink2().mavlink_connection(f"udpin:127.0.0.1:{port}")

    def run() -> None:
        t0, heard = time.monotonic(), False
        while not stop.is_set():
            heard = heard or autopilot.recv_match(blocking=False) is not None
            t = time.monotonic() - t0
            if heard:
                roll = math.radians(2.0) * math.sin(2 * math.pi * 3.0 * t)
                autopilot.mav.attitude_send(int(1000 * t), roll, math.radians(-1.0), 0.0,
                                            0.0, 0.0, 0.0)
            time.sleep(0.01)
        autopilot.close()

    return threading.Thread(target=run, daemon=True)


@pytest.mark.parametrize("latency", ["20", None])
def test_a_shaking_vehicle_levels_each_frame_at_its_own_attitude(tmp_path, run_cli,
                                                                 latency) -> None:
    """ATTITUDE streamed at 100 Hz: with the camera's delay given, each frame is levelled
    at the attitude of its own moment, so a window's attitudes spread as the roll does over
    it (rms 2/sqrt(2) deg over about a cycle).  Without it, and no shake in the frames to
    measure it from, each window is levelled at its mean attitude."""
    from test_mavlink import _free_port

    sc, cfg = _clip(tmp_path / "clip.mp4", frames=60)
    port = _free_port()
    stop = threading.Event()
    vehicle = _streaming_vehicle(port, stop)
    vehicle.start()
    given = [] if latency is None else ["--camera-latency-ms", latency]
    try:
        code, _, err = run_cli(["altitude", "--live", str(tmp_path / "clip.mp4"),
                                "--focal-px", str(cfg.focal_px), "--window", "15", "--step", "5",
                                "--mavlink", f"udpout:127.0.0.1:{port}", "--tilt-from-vehicle",
                                *given, "--out", str(tmp_path / "out")])
    finally:
        stop.set()
        vehicle.join(timeout=2)
    assert code == 0, err
    rows = [r for r in _rows(tmp_path / "out" / "live.csv") if r["roll_deg"] != ""]
    assert len(rows) >= 5
    for r in rows:
        assert float(r["pitch_deg"]) == pytest.approx(-1.0, abs=0.02)
        assert abs(float(r["roll_deg"])) <= 2.0
        if latency is None:  # not measured: the window at one attitude, its mean
            assert r["attitude_sd_deg"] == r["camera_latency_ms"] == ""
        else:
            assert float(r["camera_latency_ms"]) == 20.0
    if latency is not None:  # once the history covers a window, frame by frame
        spread = [float(r["attitude_sd_deg"]) for r in rows if r["attitude_sd_deg"] != ""]
        assert len(spread) >= 4 and all(1.0 < s < 1.8 for s in spread), spread


def test_a_pipe_on_standard_input_is_read_live(tmp_path) -> None:
    sc, cfg = _clip(tmp_path / "clip.ts", frames=30)  # MPEG-TS, as a camera or ffmpeg pipes it
    cmd = [sys.executable, "-m", "wavealt", "altitude", "--live", "-", "--live-format", "mpegts",
           "--focal-px", str(cfg.focal_px), "--window", "10", "--step", "10", "--json",
           "--velocity-mps", ",".join(map(str, sc.camera_velocity_mps))]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    with open(tmp_path / "clip.ts", "rb") as stdin:
        proc = subprocess.run(cmd, stdin=stdin, capture_output=True, text=True, env=env,
                              timeout=120)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    # a pipe is not paced: how many windows the estimator gets to depends on how fast the
    # frames come, always from the newest ones
    assert summary["frames"] == 30 and 1 <= summary["estimates"] <= 3
    assert summary["stopped_by"] == "end of stream"


def _trusted(mode: str) -> dict:
    """A window's result as an altimeter that vouched for it returns it."""
    return {"altitude_m": 3.0, "altitude_std_m": 0.05, "camera_velocity_mps": (0.3, 0.0),
            "trusted": True, "reason": None, "quality": 0.8, "mode": mode}


@pytest.mark.parametrize(("codec", "mode", "kept"), [
    ("libx264", "blind", False), ("libx264", "prior", False), ("libx264", "exact", True),
    ("mjpeg", "blind", True), ("ffv1", "blind", True)])
def test_a_stream_that_predicts_frames_is_not_trusted_without_the_exact_velocity(
        tmp_path, codec, mode, kept) -> None:
    """H.264 codes most frames from others (motion-compensated texture, which biases a fit
    without the velocity high): such windows are not trusted, with the codec named, and their
    3-sigma interval spans the range, before a flight controller is told; with the velocity
    exact, or from Motion JPEG (every frame coded alone) or FFV1 (frames predicted without
    loss), the verdict stands."""
    cfg = preset_config("paper", size=64, frames=24, altitude_m=(3.0, 3.0),
                        wind_speed_mps=(7.0, 7.0))
    path = tmp_path / ("clip.mkv" if codec == "ffv1" else "clip.mp4")
    write_video(path, generate_sequence(cfg.sample_scenario(2), cfg).clean, codec=codec)
    sent = []
    summary = run_live(str(path), estimate=lambda *a: _trusted(mode),
                       window=10, step=5, on_estimate=sent.append, log=tmp_path / "live.csv",
                       altitude_range_m=(0.5, 20.0))
    rows = _rows(tmp_path / "live.csv")
    assert rows and len(sent) == len(rows) == summary["estimates"]
    assert summary["trusted_estimates"] == (len(rows) if kept else 0)
    assert summary["predicted_by"] == ("h264" if codec == "libx264" else None)
    for res, row in zip(sent, rows):
        assert res["trusted"] is kept and row["trusted"] == str(kept)
        if kept:
            assert res["reason"] is None and res["altitude_std_m"] == 0.05
        else:
            assert res["reason"].startswith("the frames were decoded from h264 video, which "
                                             "predicts frames from other frames")
            assert row["reason"] == res["reason"]
            assert 3.0 * res["altitude_std_m"] >= 19.5 and res["altitude_m"] == 3.0
