"""MAVLink on the loopback with real pymavlink at both ends: what the autopilot receives,
dropouts that it must ignore, and the vehicle's velocity turned into image axes."""

from __future__ import annotations

import math
import socket
import time

import numpy as np
import pytest

from wavealt.cli import main
from wavealt.io import write_video
from wavealt.live.mavlink import (
    COVARIANCE_UNKNOWN,
    SIGNAL_INVALID,
    MavlinkLink,
    distance_fields,
    ned_to_image,
    use_mavlink2,
)
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence

mavutil = use_mavlink2()  # the autopilot's end speaks MAVLink 2, as ArduPilot and PX4 do
M = mavutil.mavlink


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _collect(conn, kinds: set[str], *, seconds: float = 3.0, until: int = 1) -> list:
    """Messages of ``kinds`` received within ``seconds`` (stops after ``until`` of the last
    kind asked for... or at the deadline)."""
    got, deadline = [], time.monotonic() + seconds
    while time.monotonic() < deadline:
        msg = conn.recv_match(blocking=True, timeout=0.1)
        if msg is not None and msg.get_type() in kinds:
            got.append(msg)
            if sum(m.get_type() == "DISTANCE_SENSOR" for m in got) >= until:
                break
    return got


def test_distance_fields_trusted_and_dropout() -> None:
    ok = distance_fields(7.234, 0.05, True, min_m=0.5, max_m=20.0, quality=0.87)
    assert ok == {"min_distance": 50, "max_distance": 2000, "current_distance": 723,
                  "covariance": 25, "signal_quality": 87}
    wide = distance_fields(12.0, 0.3, True, min_m=0.5, max_m=20.0, quality=0.01)
    assert wide["covariance"] == COVARIANCE_UNKNOWN  # 900 cm^2 does not fit: never understated
    assert wide["signal_quality"] == 2  # trusted never looks like "invalid" (1) or "unknown" (0)
    for bad in (distance_fields(7.0, 0.05, False, min_m=0.5, max_m=20.0, quality=0.9),
                distance_fields(25.0, 0.05, True, min_m=0.5, max_m=20.0, quality=0.9),
                distance_fields(math.nan, 0.05, True, min_m=0.5, max_m=20.0, quality=0.9)):
        assert bad["current_distance"] > bad["max_distance"]
        assert bad["signal_quality"] == SIGNAL_INVALID


def test_ned_to_image_axes() -> None:
    # heading north, flying north: forward = image up = -y
    assert ned_to_image((2.0, 0.0, 0.0), 0.0) == pytest.approx((0.0, -2.0))
    # heading east, flying north: the vehicle moves to its left = image -x
    assert ned_to_image((2.0, 0.0, 0.0), math.pi / 2) == pytest.approx((-2.0, 0.0))
    # heading east, flying east: forward again
    assert ned_to_image((0.0, 1.5, 0.0), math.pi / 2) == pytest.approx((0.0, -1.5))


def test_bad_endpoint_is_one_line() -> None:
    with pytest.raises(ValueError, match="cannot open the connection"):
        MavlinkLink("/dev/no-such-serial-port")
    with pytest.raises(ValueError, match="0 < min < max"):
        MavlinkLink("udpout:127.0.0.1:9", min_m=5.0, max_m=1.0)


def test_link_sends_heartbeat_and_distance_and_hears_the_vehicle() -> None:
    port = _free_port()
    autopilot = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=1,
                                           source_component=1)
    link = MavlinkLink(f"udpout:127.0.0.1:{port}", min_m=0.5, max_m=20.0, fov_rad=(1.0, 0.8))
    try:
        sent = link.send_altitude({"altitude_m": 4.2, "altitude_std_m": 0.04, "trusted": True,
                                   "quality": 0.9})
        got = _collect(autopilot, {"HEARTBEAT", "DISTANCE_SENSOR"})
        hb = [m for m in got if m.get_type() == "HEARTBEAT"]
        ds = [m for m in got if m.get_type() == "DISTANCE_SENSOR"]
        assert hb and hb[0].type == M.MAV_TYPE_ONBOARD_CONTROLLER
        assert hb[0].get_srcComponent() == M.MAV_COMP_ID_ONBOARD_COMPUTER
        d = ds[0]
        assert d.orientation == M.MAV_SENSOR_ROTATION_PITCH_270
        assert (d.current_distance, d.min_distance, d.max_distance) == (420, 50, 2000)
        assert d.covariance == sent["covariance"] == 16 and d.signal_quality == 90
        assert d.horizontal_fov == pytest.approx(1.0) and d.vertical_fov == pytest.approx(0.8)
        # the autopilot answers (it now knows our address): velocity and heading come back
        autopilot.mav.local_position_ned_send(1000, 0.0, 0.0, -5.0, 3.0, 0.0, 0.0)
        autopilot.mav.attitude_send(1000, 0.0, 0.0, math.pi / 2, 0.0, 0.0, 0.0)
        deadline = time.monotonic() + 3.0
        v = None
        while v is None and time.monotonic() < deadline:
            v = link.camera_velocity_mps()
            time.sleep(0.02)
        assert v == pytest.approx((-3.0, 0.0), abs=1e-6)  # north at 3 m/s, heading east
        assert link.state.yaw_rate_rad_s == pytest.approx(0.0)
        autopilot.mav.attitude_send(1100, 0.0, 0.0, math.pi / 2, 0.0, 0.0, 0.25)
        deadline = time.monotonic() + 3.0
        while link.poll().yaw_rate_rad_s != pytest.approx(0.25) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert link.state.yaw_rate_rad_s == pytest.approx(0.25)  # ATTITUDE's yawspeed
    finally:
        link.close()
        autopilot.close()


def test_attitude_history_is_interpolated_on_our_clock() -> None:
    """ATTITUDE at 50 Hz on the autopilot's clock (``time_boot_ms``, started 100 s before
    ours) is placed on this computer's clock and interpolated at any moment it covers;
    moments it does not cover, or covers too sparsely, give None; a restart of the
    autopilot's clock starts the history again."""
    port = _free_port()
    autopilot = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}")
    link = MavlinkLink(f"udpout:127.0.0.1:{port}")
    try:
        link.request_attitude_rate(50.0)
        cmd = _collect(autopilot, {"COMMAND_LONG"}, seconds=3.0)
        assert cmd and (cmd[0].command, cmd[0].param1, cmd[0].param2) == (
            M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, 20000.0)

        def roll_at(t: float) -> float:
            return 0.02 * math.sin(2 * math.pi * 1.5 * t)

        def yaw_at(t: float) -> float:  # turning right at 1 rad/s through +-pi
            return math.remainder(3.0 + 1.0 * (t - 100.0), 2 * math.pi)

        t0 = time.monotonic() - 100.0  # the autopilot booted 100 s ago
        start = time.monotonic()
        while time.monotonic() - start < 1.0:
            t = time.monotonic() - t0
            autopilot.mav.attitude_send(int(1000 * t), roll_at(t), -0.01, yaw_at(t), 0.0, 0.0,
                                        0.0)
            link.poll()
            time.sleep(0.02)
        link.poll()
        times = np.linspace(start + 0.1, start + 0.9, 25)
        got = link.attitude_at(times)
        assert got is not None
        # the delay of the loopback (well under 5 ms) is all that is left
        assert np.allclose(got[0], [roll_at(t - t0) for t in times], atol=0.02 * 0.05)
        assert np.allclose(got[1], -0.01)
        # the heading unwrapped through +-pi: one steady turn, 3 rad + 1 rad/s
        heads = link.heading_at(times)
        assert np.ptp(np.diff(heads)) < 0.005 and np.all(np.diff(heads) > 0)  # no jump of 2 pi
        assert np.allclose(np.remainder(heads - (3.0 + (times - t0 - 100.0)) + np.pi,
                                        2 * np.pi) - np.pi, 0.0, atol=0.005)
        assert link.attitude_at([start - 5.0, start + 0.5]) is None  # before the history
        assert link.attitude_at([start + 0.5, time.monotonic() + 1.0]) is None  # after it
        # a gap of 0.3 s in the stream: the moments across it are not covered
        time.sleep(0.3)
        t = time.monotonic() - t0
        autopilot.mav.attitude_send(int(1000 * t), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        deadline = time.monotonic() + 2.0
        while len(link.poll().attitude_history) < 2 or (
                link.state.attitude_history[-1][2] != 0.0 and time.monotonic() < deadline):
            time.sleep(0.01)
        assert link.attitude_at([start + 0.9, time.monotonic() - 0.05]) is None
        # the autopilot restarts: its clock begins again, and so does the history
        autopilot.mav.attitude_send(500, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        deadline = time.monotonic() + 2.0
        while len(link.poll().attitude_history) != 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert len(link.state.attitude_history) == 1
        with pytest.raises(ValueError, match="ATTITUDE rate"):
            link.request_attitude_rate(0.0)
    finally:
        link.close()
        autopilot.close()


def test_cli_streams_every_window_and_flags_the_untrusted(tmp_path, capsys) -> None:
    """`wavealt altitude CLIP --mavlink udpout:...`: one DISTANCE_SENSOR per window; frozen
    frames (no wave motion) are never trusted, so they arrive as an invalid, out-of-range
    reading the autopilot ignores."""
    cfg = preset_config("paper", size=64, frames=20, altitude_m=(3.0, 3.0),
                        wind_speed_mps=(7.0, 7.0))
    data = generate_sequence(cfg.sample_scenario(1), cfg)
    frozen = np.repeat(data.clean[:1], 20, axis=0)
    path = tmp_path / "frozen.mp4"
    write_video(path, frozen, fps=30.0)
    port = _free_port()
    autopilot = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}")
    try:
        main(["altitude", str(path), "--focal-px", str(cfg.focal_px), "--window", "10",
              "--step", "5", "--velocity-mps", "0,0", "--json",
              "--mavlink", f"udpout:127.0.0.1:{port}"])  # returns on success
        assert '"trusted": false' in capsys.readouterr().out
        got = [m for m in _collect(autopilot, {"DISTANCE_SENSOR"}, until=3)
               if m.get_type() == "DISTANCE_SENSOR"]
        assert len(got) == 3  # windows 0-10, 5-15, 10-20
        for d in got:
            assert d.signal_quality == SIGNAL_INVALID and d.current_distance > d.max_distance
    finally:
        autopilot.close()
