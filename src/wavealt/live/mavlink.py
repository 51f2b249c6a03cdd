"""Altitude to the flight controller over MAVLink (pymavlink), and the vehicle's state back.

wavealt speaks as an onboard component (``MAV_COMP_ID_ONBOARD_COMPUTER``): a ``HEARTBEAT``
about once a second and a downward ``DISTANCE_SENSOR`` (orientation ``PITCH_270``) per
estimate. It listens for ``LOCAL_POSITION_NED`` (or ``GLOBAL_POSITION_INT``) and ``ATTITUDE``
to give the altimeter the vehicle's velocity in image axes.

A window the altimeter does not trust must not steer the vehicle. ArduPilot reads
``signal_quality`` 0 as "unknown" (and uses the reading) and 1 as the worst quality, so an
untrusted window is sent as MAVLink's "invalid signal" (1) *and* with ``current_distance``
one centimetre beyond ``max_distance``, which ArduPilot and PX4 both treat as out of range.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from typing import Any

#: DISTANCE_SENSOR's covariance field is uint8 cm^2; 255 means unknown.
COVARIANCE_UNKNOWN = 255
#: MAVLink signal_quality: 1 = invalid signal, 100 = perfect.
SIGNAL_INVALID = 1


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
    ``time.monotonic()`` when each was received.
    """

    velocity_ned_mps: tuple[float, float, float] | None = None
    attitude_rad: tuple[float, float, float] | None = None
    yaw_rate_rad_s: float | None = None
    velocity_time: float = field(default=-math.inf)
    attitude_time: float = field(default=-math.inf)


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

    def time_boot_ms(self) -> int:
        return int(1000 * (time.monotonic() - self._t0)) & 0xFFFFFFFF

    def heartbeat(self, *, every_s: float = 1.0) -> None:
        """Send a HEARTBEAT unless one went out within ``every_s``."""
        now = time.monotonic()
        if now - self._last_heartbeat < every_s:
            return
        m = self._m
        self.conn.mav.heartbeat_send(m.MAV_TYPE_ONBOARD_CONTROLLER, m.MAV_AUTOPILOT_INVALID, 0, 0,
                                     m.MAV_STATE_ACTIVE)
        self._last_heartbeat = now

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
        return self.state

    def camera_velocity_mps(self, *, max_age_s: float = 1.0) -> tuple[float, float] | None:
        """The vehicle's velocity over ground in image axes (:func:`ned_to_image`), or None
        when velocity or heading is older than ``max_age_s`` or not heard."""
        s = self.poll()
        now = time.monotonic()
        if (s.velocity_ned_mps is None or s.attitude_rad is None
                or now - s.velocity_time > max_age_s or now - s.attitude_time > max_age_s):
            return None
        return ned_to_image(s.velocity_ned_mps, s.attitude_rad[2])

    def close(self) -> None:
        self.conn.close()


__all__ = ["COVARIANCE_UNKNOWN", "SIGNAL_INVALID", "MavlinkLink", "VehicleState",
           "distance_fields", "ned_to_image", "use_mavlink2"]
