"""Altitude to the flight controller over MAVLink (pymavlink), and the vehicle's state back.

wavealt speaks as an onboard component (``MAV_COMP_ID_ONBOARD_COMPUTER``): a ``HEARTBEAT``
about once a second and a downward ``DISTANCE_SENSOR`` (orientation ``PITCH_270``) per
estimate. It listens for ``LOCAL_POSITION_NED`` (or ``GLOBAL_POSITION_INT``) and ``ATTITUDE``
to give the altimeter the vehicle's velocity in image axes, and keeps the last seconds of
``ATTITUDE`` so that each frame of a window can be levelled at the attitude the camera had
when it was taken (a camera without a gimbal shakes by fractions of a degree within every
second). Each ``ATTITUDE`` is placed on this computer's clock by its own ``time_boot_ms``
plus the smallest offset between that and its arrival over the history: the link's delay
and its jitter (a serial port or a radio delivers messages in bursts) drop out, leaving the
fastest message's delay.

A window the altimeter does not trust must not steer the vehicle. ArduPilot reads
``signal_quality`` 0 as "unknown" (and uses the reading) and 1 as the worst quality, so an
untrusted window is sent as MAVLink's "invalid signal" (1) *and* with ``current_distance``
one centimetre beyond ``max_distance``, which ArduPilot and PX4 both treat as out of range.
"""

from __future__ import annotations

import math
import os
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: DISTANCE_SENSOR's covariance field is uint8 cm^2; 255 means unknown.
COVARIANCE_UNKNOWN = 255
#: MAVLink signal_quality: 1 = invalid signal, 100 = perfect.
SIGNAL_INVALID = 1
#: ATTITUDE rate asked of the autopilot (MAV_CMD_SET_MESSAGE_INTERVAL), Hz: a shake of 2 Hz
#: sampled 25 times a cycle, so that linear interpolation between samples is within 1 % of
#: its amplitude (ArduPilot streams ATTITUDE at 4-10 Hz unless asked).
ATTITUDE_RATE_HZ = 50.0
#: A window's frames are levelled one by one only where no two ATTITUDE samples around them
#: lie further apart than this, s (a 2-Hz shake at 10 Hz: within 20 % of its amplitude).
ATTITUDE_MAX_GAP_S = 0.1
#: How much ATTITUDE history is kept, s (a window is 1 s; the clock offset is the minimum
#: over this span, short enough that two clocks' drift, ~50 ppm, stays below 1 ms).
ATTITUDE_HISTORY_S = 10.0


def use_mavlink2() -> Any:
    """pymavlink's ``mavutil`` speaking MAVLink 2 (DISTANCE_SENSOR's field of view and
    signal quality are MAVLink 2 extensions; pymavlink picks its wire version from the
    ``MAVLINK20`` environment variable, process-wide). Returns ``mavutil``."""
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil

    if mavutil.mavlink.WIRE_PROTOCOL_VERSION != "2.0":
        mavutil.set_dialect(mavutil.current_dialect)
    return mavutil


@dataclass
class VehicleState:
    """The latest vehicle state heard on the link (None until heard).

    ``velocity_ned_mps``: (north, east, down) over ground; ``attitude_rad``: (roll, pitch,
    yaw); ``yaw_rate_rad_s``: the yaw rate (positive nose right); ``*_time``:
    ``time.monotonic()`` when each was received; ``attitude_history``: the last
    ``ATTITUDE_HISTORY_S`` of ATTITUDE as (time_boot_ms / 1000, arrival, roll, pitch, yaw).
    """

    velocity_ned_mps: tuple[float, float, float] | None = None
    attitude_rad: tuple[float, float, float] | None = None
    yaw_rate_rad_s: float | None = None
    velocity_time: float = field(default=-math.inf)
    attitude_time: float = field(default=-math.inf)
    attitude_history: deque[tuple[float, ...]] = field(default_factory=deque)


def ned_to_image(v_ned: tuple[float, float, float], yaw_rad: float) -> tuple[float, float]:
    """A horizontal NED velocity in image axes of a camera looking straight down with the top
    of the image toward the vehicle's nose: +x columns = the vehicle's right, +y rows = its
    tail. Returns (vx, vy), m/s."""
    vn, ve = float(v_ned[0]), float(v_ned[1])
    forward = vn * math.cos(yaw_rad) + ve * math.sin(yaw_rad)
    right = -vn * math.sin(yaw_rad) + ve * math.cos(yaw_rad)
    return right, -forward


def distance_fields(altitude_m: float, std_m: float, trusted: bool, *, min_m: float,
                    max_m: float, quality: float) -> dict[str, int]:
    """The DISTANCE_SENSOR integers for one estimate: distances in cm, covariance in cm^2
    (255 when it does not fit: unknown, never understated), signal quality 2-100 when
    trusted; when not trusted, out of range and invalid (see the module docstring)."""
    min_cm, max_cm = round(min_m * 100), round(max_m * 100)
    if not (trusted and math.isfinite(altitude_m) and min_m <= altitude_m <= max_m):
        return {"min_distance": min_cm, "max_distance": max_cm, "current_distance": max_cm + 1,
                "covariance": COVARIANCE_UNKNOWN, "signal_quality": SIGNAL_INVALID}
    var_cm2 = (100.0 * std_m) ** 2 if math.isfinite(std_m) else math.inf
    cov = round(var_cm2) if var_cm2 <= 254 else COVARIANCE_UNKNOWN
    sq = int(min(100, max(2, round(100 * quality))))
    return {"min_distance": min_cm, "max_distance": max_cm,
            "current_distance": round(altitude_m * 100), "covariance": cov, "signal_quality": sq}


class MavlinkLink:
    """A MAVLink connection (``udpout:HOST:PORT``, ``udpin:HOST:PORT``, ``tcp:HOST:PORT`` or a
    serial device) that sends the altitude and hears the vehicle.

    Parameters
    ----------
    endpoint : str
        pymavlink connection string.
    min_m, max_m : float
        The sensor's range, sent with every reading (the autopilot ignores readings outside).
    fov_rad : (float, float)
        Horizontal and vertical field of view, radians (0 when unknown).
    system_id : int
        The vehicle's system id (a companion computer shares it).
    """

    def __init__(self, endpoint: str, *, min_m: float = 0.5, max_m: float = 20.0,
                 fov_rad: tuple[float, float] = (0.0, 0.0), system_id: int = 1) -> None:
        mavutil = use_mavlink2()
        if not (0 < min_m < max_m <= 655.0):
            msg = f"the MAVLink range must satisfy 0 < min < max <= 655 m; got {min_m}, {max_m}"
            raise ValueError(msg)
        self._m = mavutil.mavlink
        try:
            self.conn = mavutil.mavlink_connection(
                endpoint, source_system=int(system_id),
                source_component=self._m.MAV_COMP_ID_ONBOARD_COMPUTER, autoreconnect=True)
        except Exception as exc:  # pymavlink raises OSError, SerialException, ValueError ...
            msg = f"--mavlink {endpoint}: cannot open the connection ({exc})"
            raise ValueError(msg) from None
        self.min_m, self.max_m, self.fov_rad = float(min_m), float(max_m), fov_rad
        self.state = VehicleState()
        self._t0 = time.monotonic()
        self._last_heartbeat = -math.inf
        self._local_time = -math.inf  # when LOCAL_POSITION_NED was last heard
        self.attitude_hz: float | None = None  # the ATTITUDE rate asked for, if any

    def time_boot_ms(self) -> int:
        return int(1000 * (time.monotonic() - self._t0)) & 0xFFFFFFFF

    def heartbeat(self, *, every_s: float = 1.0) -> None:
        """Send a HEARTBEAT unless one went out within ``every_s``; with it, the request
        for ATTITUDE again while it comes at less than half the rate asked for (a request
        lost, or an autopilot that started later)."""
        now = time.monotonic()
        if now - self._last_heartbeat < every_s:
            return
        m = self._m
        self.conn.mav.heartbeat_send(m.MAV_TYPE_ONBOARD_CONTROLLER, m.MAV_AUTOPILOT_INVALID, 0, 0,
                                     m.MAV_STATE_ACTIVE)
        self._last_heartbeat = now
        if self.attitude_hz is not None:
            recent = sum(now - s[1] <= 1.0 for s in self.state.attitude_history)
            if recent < self.attitude_hz / 2:
                self._send_attitude_request()

    def send_altitude(self, result: dict[str, Any]) -> dict[str, int]:
        """Send one DISTANCE_SENSOR for an estimate (a window row or summary: ``altitude_m``,
        ``altitude_std_m``, ``trusted``, ``quality``); return the fields sent."""
        self.heartbeat()
        f = distance_fields(float(result["altitude_m"]), float(result["altitude_std_m"]),
                            bool(result["trusted"]), min_m=self.min_m, max_m=self.max_m,
                            quality=float(result.get("quality", 0.0)))
        m = self._m
        self.conn.mav.distance_sensor_send(
            self.time_boot_ms(), f["min_distance"], f["max_distance"], f["current_distance"],
            m.MAV_DISTANCE_SENSOR_UNKNOWN, 0, m.MAV_SENSOR_ROTATION_PITCH_270, f["covariance"],
            float(self.fov_rad[0]), float(self.fov_rad[1]), [0.0, 0.0, 0.0, 0.0],
            f["signal_quality"])
        return f

    def poll(self) -> VehicleState:
        """Read every message waiting (never blocks) into :attr:`state`."""
        while (msg := self.conn.recv_match(blocking=False)) is not None:
            kind = msg.get_type()
            now = time.monotonic()
            if kind == "LOCAL_POSITION_NED":
                self.state.velocity_ned_mps = (msg.vx, msg.vy, msg.vz)
                self.state.velocity_time = self._local_time = now
            elif kind == "GLOBAL_POSITION_INT" and now - self._local_time > 1.0:
                # only when no LOCAL_POSITION_NED is coming: cm/s
                self.state.velocity_ned_mps = (msg.vx / 100, msg.vy / 100, msg.vz / 100)
                self.state.velocity_time = now
            elif kind == "ATTITUDE":
                self.state.attitude_rad = (msg.roll, msg.pitch, msg.yaw)
                self.state.yaw_rate_rad_s = msg.yawspeed
                self.state.attitude_time = now
                self._remember_attitude(msg.time_boot_ms / 1000.0, now, msg.roll, msg.pitch,
                                        msg.yaw)
        return self.state

    def _remember_attitude(self, boot_s: float, now: float, roll: float, pitch: float,
                           yaw: float) -> None:
        h = self.state.attitude_history
        if h and boot_s <= h[-1][0]:
            if boot_s > h[-1][0] - 1.0:
                return  # a repeat, or UDP out of order: the history stays in time order
            h.clear()  # the autopilot restarted: its clock began again
        h.append((boot_s, now, float(roll), float(pitch), float(yaw)))
        while h[-1][0] - h[0][0] > ATTITUDE_HISTORY_S:
            h.popleft()

    def request_attitude_rate(self, hz: float = ATTITUDE_RATE_HZ) -> None:
        """Ask the autopilot (component 1 of this link's system) to stream ATTITUDE at
        ``hz`` (MAV_CMD_SET_MESSAGE_INTERVAL), now and with each heartbeat while it does
        not."""
        if not (math.isfinite(hz) and 0 < hz <= 1000):
            msg = f"the ATTITUDE rate must be in (0, 1000] Hz; got {hz}"
            raise ValueError(msg)
        self.attitude_hz = float(hz)
        self._send_attitude_request()

    def _send_attitude_request(self) -> None:
        m = self._m
        self.conn.mav.command_long_send(self.conn.source_system, m.MAV_COMP_ID_AUTOPILOT1,
                                        m.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                        m.MAVLINK_MSG_ID_ATTITUDE, 1e6 / self.attitude_hz,
                                        0, 0, 0, 0, 0)

    def _track(self, times: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The history's times on our clock, its samples ``(n, 5)`` and ``times`` as an
        array, where the history covers ``times`` (:meth:`attitude_at`); else None."""
        self.poll()
        h = self.state.attitude_history
        t = np.asarray(times, dtype=np.float64)
        if len(h) < 2 or t.size == 0 or not np.all(np.isfinite(t)):
            return None
        a = np.array(h)
        local = a[:, 0] + np.min(a[:, 1] - a[:, 0])  # the autopilot's clock on ours
        first, last = float(t.min()), float(t.max())
        if first < local[0] or last > local[-1] + ATTITUDE_MAX_GAP_S:
            return None
        i0 = int(np.searchsorted(local, first, side="right")) - 1
        i1 = int(np.searchsorted(local, last, side="left"))
        if np.any(np.diff(local[i0:i1 + 1]) > ATTITUDE_MAX_GAP_S):
            return None
        return local, a, t

    def attitude_at(self, times: Any) -> tuple[np.ndarray, np.ndarray] | None:
        """Roll and pitch (rad) at each of ``times`` (``time.monotonic()`` seconds, when
        each frame was taken), interpolated linearly in the ATTITUDE history; None unless
        the history holds a sample at or before the first time, samples no more than
        ``ATTITUDE_MAX_GAP_S`` apart through the times, and one within that of the last."""
        track = self._track(times)
        if track is None:
            return None
        local, a, t = track
        return np.interp(t, local, a[:, 2]), np.interp(t, local, a[:, 3])

    def heading_at(self, times: Any) -> np.ndarray | None:
        """The vehicle's heading (ATTITUDE's yaw, rad, positive turning the nose right) at
        each of ``times``, as :meth:`attitude_at` interpolates, unwrapped through +-pi."""
        track = self._track(times)
        if track is None:
            return None
        local, a, t = track
        return np.interp(t, local, np.unwrap(a[:, 4]))

    def camera_velocity_mps(self, *, max_age_s: float = 1.0,
                            yaw_rad: float | None = None) -> tuple[float, float] | None:
        """The vehicle's velocity over ground in image axes (:func:`ned_to_image`) at the
        heading ``yaw_rad`` (the frames' own, where they were turned to one; default the
        latest heard), or None when velocity or heading is older than ``max_age_s`` or not
        heard."""
        s = self.poll()
        now = time.monotonic()
        if (s.velocity_ned_mps is None or s.attitude_rad is None
                or now - s.velocity_time > max_age_s or now - s.attitude_time > max_age_s):
            return None
        return ned_to_image(s.velocity_ned_mps, s.attitude_rad[2] if yaw_rad is None
                            else float(yaw_rad))

    def close(self) -> None:
        self.conn.close()


__all__ = ["ATTITUDE_MAX_GAP_S", "ATTITUDE_RATE_HZ", "COVARIANCE_UNKNOWN", "SIGNAL_INVALID",
           "MavlinkLink", "VehicleState", "distance_fields", "ned_to_image", "use_mavlink2"]
