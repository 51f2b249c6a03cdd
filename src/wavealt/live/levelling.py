"""A camera fixed to the airframe, its frames levelled at the vehicle's attitude as they come.

Each frame is levelled at the attitude of the moment it was taken: its arrival less the
camera's delay, given or measured from the frames' own shake (:mod:`.latency`).  Until the
delay is known, a window is levelled at its mean attitude (a tilt is levelled; a shake is
left for the altimeter to steady), or at the latest attitude heard where the history does
not cover the window.  A stream's windows share one view per half-degree box of attitudes
and each attitude's map (:meth:`wavealt.camera.NadirView.level_each`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from wavealt.altimetry.dispersion.jitter import detrend
from wavealt.altimetry.dispersion.result import refuse
from wavealt.live.latency import MEASURE_EVERY, SETTLE_WINDOWS, SHAKE_MIN_RATIO, LatencyMeter

#: Views kept per stream (each a half-degree box of attitudes, or one attitude).
MAX_VIEWS = 64
#: While the camera's delay is not known, a window's frames are turned back at a steady
#: yaw rate; where the vehicle's heading over the window departs from a steady turn by more
#: than this, degrees rms, the window is not trusted (a quarter of a degree turns the corner
#: tiles' content by about 0.3 px against the 2 px of half a degree of roll or pitch).
MAX_YAW_WAVER_DEG = 0.25
#: The altimeter's corner tiles' centres lie about this far from the frame's centre, as a
#: share of its shorter side (tiles of 0.4 of it: 0.3 along each axis): the radius at which
#: a rotation's shift weighs as much as the shake's in the delay's match.
CORNER_RADIUS = 0.42

AttitudeAt = Callable[[np.ndarray], "tuple[np.ndarray, np.ndarray] | None"]


class VehicleLevelling:
    """Level a stream's windows at the vehicle's attitude.

    Parameters
    ----------
    calibration : callable
        ``calibration(w, h)``: the camera (:class:`wavealt.camera.Calibration`) of ``w x h``
        frames.
    latency_s : float, optional
        The camera's delay from exposure to arrival, s, taken as the truth; None: measured
        (:class:`.latency.LatencyMeter`).
    altimeter : DispersionAltimeter, optional
        Whose signal, tiles and working scale measure the frames' shake.
    """

    def __init__(self, calibration: Callable[[int, int], Any], *,
                 latency_s: float | None = None, altimeter: Any = None) -> None:
        self.calibration = calibration
        self.latency_s = latency_s
        self.meter = LatencyMeter() if latency_s is None else None
        self.altimeter = altimeter
        self.windows = 0
        self._views: dict[tuple[Any, ...], Any] = {}

    @property
    def delay_s(self) -> float | None:
        """The delay used: given, or measured (None until it is)."""
        return self.latency_s if self.meter is None else self.meter.latency_s

    def _view(self, w: int, h: int, rolls: np.ndarray, pitches: np.ndarray) -> Any:
        """A view for frames at ``rolls, pitches`` (degrees): made for the box of attitudes
        about their mean, both to the next half degree, so that a stream's windows share it
        (and the maps of the frames they share); None where no level view can be made."""
        from wavealt.camera import NadirView

        mr, mp = round(float(rolls.mean()) * 2) / 2, round(float(pitches.mean()) * 2) / 2
        dr = math.ceil(float(np.abs(rolls - mr).max()) * 2) / 2
        dp = math.ceil(float(np.abs(pitches - mp).max()) * 2) / 2
        key = (w, h, mr, mp, dr, dp)
        if key not in self._views:
            if len(self._views) >= MAX_VIEWS:
                self._views.clear()
            try:
                self._views[key] = NadirView(self.calibration(w, h), w, h,
                                             roll_deg=[mr - dr, mr + dr, mr - dr, mr + dr],
                                             pitch_deg=[mp - dp, mp - dp, mp + dp, mp + dp])
            except ValueError:
                # beyond the tilt a level view is made for (MAX_TILT_DEG), or none left of
                # the frame: the frames go as they came, their tilt the altimeter's to measure
                self._views[key] = None
        return self._views[key]

    def measure(self, frames: np.ndarray, arrivals: np.ndarray, attitude_at: AttitudeAt,
                heading_at: Callable[[np.ndarray], np.ndarray | None] | None = None) -> None:
        """Add a window to the delay's measurement: every window until ``SETTLE_WINDOWS``
        have measured it (at most the stream's first ``4 SETTLE_WINDOWS``: a camera that
        does not shake enough is not measured at every window's cost), then every
        ``MEASURE_EVERY``-th; clips under 15 frames, and a delay given, not at all."""
        if self.meter is None or len(frames) < 15:
            return
        settling = self.meter.windows < SETTLE_WINDOWS and self.windows < 4 * SETTLE_WINDOWS
        if not settling and self.windows % MEASURE_EVERY:
            return
        from wavealt.altimetry.dispersion import image_shake

        h, w = frames.shape[1:3]
        # the shift and the rotation (a wavering heading) the tiles share
        motion = image_shake(frames, self.altimeter, SHAKE_MIN_RATIO, rotation=True)
        if motion is not None:
            focal = float(self.calibration(w, h).camera_matrix[0, 0])
            self.meter.add(motion[0], arrivals, attitude_at, focal, motion[1], heading_at,
                           CORNER_RADIUS * min(h, w))

    def level(self, frames: np.ndarray, arrivals: np.ndarray, attitude_at: AttitudeAt,
              latest: tuple[float, float] | None = None,
              heading_at: Callable[[np.ndarray], np.ndarray | None] | None = None
              ) -> tuple[np.ndarray, float, dict[str, Any]] | None:
        """``frames`` ``(T, H, W[, 3])`` that arrived at ``arrivals`` (s, the attitude's
        clock) levelled at the attitude (``attitude_at(times)``: roll and pitch, rad, or None
        where it cannot tell; ``latest``: the latest heard, rad): the frames, their focal
        length, px, and what was done (``roll_deg`` / ``pitch_deg`` the window's mean,
        ``attitude_sd_deg`` the frames' spread about it or "" for one attitude,
        ``camera_latency_ms`` the delay used or "").  None where no attitude is known, or
        where it is beyond what a level view is made for (the frames then go as they came).

        Frame by frame, with ``heading_at(times)`` (the heading, rad, positive the nose
        right, or None), each frame is also turned back to the heading of the window's
        middle moment (:func:`wavealt.camera.unturn_headings`), and ``yaw_rate_dps`` in what
        was done is the window's mean turn rate: the frames no longer turn."""
        self.measure(frames, arrivals, attitude_at, heading_at)
        self.windows += 1
        h, w = frames.shape[1:3]
        delay = self.delay_s
        info: dict[str, Any] = {"attitude_sd_deg": "",
                                "camera_latency_ms": "" if delay is None
                                else round(1e3 * delay, 1)}
        each = attitude_at(arrivals - delay) if delay is not None else None
        if each is not None:  # each frame at the attitude it was taken with
            rolls, pitches = np.degrees(each[0]), np.degrees(each[1])
            view = self._view(w, h, rolls, pitches)
            if view is None:
                return None
            info["attitude_sd_deg"] = round(float(np.sqrt(np.mean(
                (rolls - rolls.mean()) ** 2 + (pitches - pitches.mean()) ** 2))), 3)
            info["roll_deg"] = round(float(rolls.mean()), 2)
            info["pitch_deg"] = round(float(pitches.mean()), 2)
            out = view.level_each(frames, rolls, pitches)
            heads = heading_at(arrivals - delay) if heading_at is not None else None
            if heads is not None:  # and turned back to the middle moment's heading
                from wavealt.camera import unturn_headings

                turn = np.degrees(heads - np.interp((len(heads) - 1) / 2.0,
                                                    np.arange(len(heads)), heads))
                if float(np.abs(turn).max()) > 1e-3:
                    out = unturn_headings(out, turn)
                span = float(arrivals[-1] - arrivals[0])
                info["yaw_rate_dps"] = round(float(turn[-1] - turn[0]) / span, 3) if span else 0.0
            return out, view.focal_px, info
        heads = heading_at(arrivals) if heading_at is not None else None
        if heads is not None:  # the delay not yet known: is the turn steady?
            waver = math.degrees(float(np.sqrt(np.mean(detrend(heads[:, None]) ** 2))))
            if waver > MAX_YAW_WAVER_DEG:
                info["distrust"] = (f"the vehicle's heading wavered by {waver:.2f} deg about a "
                                    f"steady turn over the window, and the camera's delay "
                                    f"behind ATTITUDE is not yet known to turn each frame back")
        now = attitude_at(arrivals)
        if now is not None:  # the delay not yet known: the window at its mean attitude
            roll, pitch = (math.degrees(float(np.mean(a))) for a in now)
        elif latest is not None:
            roll, pitch = (math.degrees(a) for a in latest)
        else:
            return None
        roll, pitch = round(roll * 2) / 2, round(pitch * 2) / 2  # a view per half degree
        info["roll_deg"], info["pitch_deg"] = roll, pitch
        calib = self.calibration(w, h)
        if (roll, pitch) == (0.0, 0.0) and not np.any(calib.dist_coeffs):
            return frames, float(calib.camera_matrix[0, 0]), info  # nothing to undo
        view = self._view(w, h, np.array([roll]), np.array([pitch]))
        if view is None:
            return None
        return view.level_each(frames, np.full(len(frames), roll),
                               np.full(len(frames), pitch)), view.focal_px, info


def judge(result: dict[str, Any], info: dict[str, Any],
          altitude_range_m: tuple[float, float]) -> dict[str, Any]:
    """A result dict (``DispersionResult.to_dict()``) with what the levelling did
    (:meth:`VehicleLevelling.level`'s ``info``) recorded in it, and NOT TRUSTED, its 3-sigma
    interval spanning ``altitude_range_m`` as the altimeter's untrusted ones do, where the
    levelling could not undo the vehicle's motion (``info["distrust"]``)."""
    info = dict(info)
    reason = info.pop("distrust", None)
    result.update(info)
    return result if reason is None else refuse(result, reason, altitude_range_m)


__all__ = ["CORNER_RADIUS", "MAX_VIEWS", "MAX_YAW_WAVER_DEG", "VehicleLevelling", "judge"]
