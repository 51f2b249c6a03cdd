"""How long after its exposure a frame arrives, measured from the frames' own shake against
the vehicle's ``ATTITUDE``.

A camera fixed to the airframe rolls and pitches with it, and a rotation by ``R`` moves the
image's content near its centre by ``-f (r_x / r_z, r_y / r_z)`` px (``r`` the rotated
optical axis, ``f`` the focal length): half a degree is 2 px at a 60-degree view of 256 px.
The altimeter's corner tiles measure that shift frame by frame (:func:`wavealt.altimetry.
dispersion.image_shake`, less its mean motion); the attitude history predicts it at any
assumed delay ``L`` between a frame's exposure and its arrival.  At the right delay the
prediction explains the measured shake almost wholly, with a gain of 1; a delay off by ``dL``
leaves a shake of ``2 pi f_shake dL`` times its amplitude (a 2-Hz shake, 30 ms: 40 %).
Each window that shakes enough to be measured adds its explained variance at every
candidate delay, and the delay is the candidates' best once ``MIN_WINDOWS`` windows agree
with the model (``MIN_EXPLAINED``, ``MAX_GAIN_ERROR``).  The same estimate of a camera's
time offset from an inertial sensor's motion is a step of visual-inertial calibration
(Furgale, Rehder & Siegwart 2013, Kalibr; Qin & Shen 2018, VINS-Mono's online offset).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from wavealt.altimetry.dispersion.jitter import detrend
from wavealt.camera import tilt_rotation

#: Candidate delays from exposure to arrival, s: a USB or CSI camera and its driver take
#: 20-150 ms, an encoder and a network link more.
LATENCY_GRID_S = np.round(np.arange(0.0, 0.4001, 0.005), 3)
#: A window measures the delay where the attitude's predicted image shift, at its best
#: delay, explains at least this share of the measured shake's variance ...
MIN_EXPLAINED = 0.8
#: ... with a gain within this of 1 (a shift that the rotation does not scale is not its).
MAX_GAIN_ERROR = 0.3
#: Windows that measured a delay before it is used.
MIN_WINDOWS = 3
#: The corner tiles' agreement on a shake (mean square over the noise of their mean,
#: :func:`wavealt.altimetry.dispersion.jitter.common_shake`) before a window's shake is
#: matched: half the altimeter's own bar, since the match itself rejects a shake the
#: attitude does not explain: more windows measure the delay than at the altimeter's bar,
#: with no larger error, while a still lower bar admits shakes too faint to time
#: (``docs/benchmarks.md``, twenty-sixth session).
SHAKE_MIN_RATIO = 4.0
#: A live stream measures every window until this many have measured the delay, then every
#: ``MEASURE_EVERY``-th (the delay does not change; about 5 ms a 30-frame 256^2 window).
SETTLE_WINDOWS = 10
MEASURE_EVERY = 15


def attitude_shift(roll_rad: np.ndarray, pitch_rad: np.ndarray, focal_px: float) -> np.ndarray:
    """The image shift, px ``(..., 2)`` (x, y), of the content at the image centre of a camera
    at ``roll_rad, pitch_rad`` (:func:`wavealt.camera.tilt_rotation`'s axes) against a level
    one's: ``-f (r_x / r_z, r_y / r_z)``, ``r`` the rotated optical axis."""
    roll, pitch = np.broadcast_arrays(np.asarray(roll_rad, float), np.asarray(pitch_rad, float))
    axes = np.array([tilt_rotation(r, p)[:, 2] for r, p in
                     zip(np.degrees(roll).ravel(), np.degrees(pitch).ravel())])
    shift = -focal_px * axes[:, :2] / axes[:, 2:]
    return shift.reshape(*roll.shape, 2)


class LatencyMeter:
    """The delay from a frame's exposure to its arrival, pooled over the windows that
    measure it (module docstring).  ``latency_s``: the delay, None until ``MIN_WINDOWS``
    windows measured it and, pooled, the best delay explains ``MIN_EXPLAINED`` of their
    shake's variance (windows that each found a different delay do not agree on one);
    ``windows``: how many did; ``last_share``: the share the last window's best delay
    explained (whether or not it measured one)."""

    def __init__(self) -> None:
        self.explained = np.zeros(LATENCY_GRID_S.size)
        self.energy = 0.0
        self.windows = 0
        self.last_share = float("nan")

    @property
    def latency_s(self) -> float | None:
        best = int(np.argmax(self.explained))
        if self.windows < MIN_WINDOWS or self.explained[best] < MIN_EXPLAINED * self.energy:
            return None
        return float(LATENCY_GRID_S[best])

    def add(self, shake_px: np.ndarray, arrivals: np.ndarray,
            attitude_at: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray] | None],
            focal_px: float, rotation_rad: np.ndarray | None = None,
            heading_at: Callable[[np.ndarray], np.ndarray | None] | None = None,
            radius_px: float = 0.0) -> float | None:
        """Add one window: its measured image shake ``(T, 2)`` px, when its frames arrived
        (s, the attitude's clock), ``attitude_at(times)`` the (roll, pitch) rad at any
        times (None where it cannot tell), and the focal length, px.  With the image's
        measured rotation ``rotation_rad`` ``(T,)`` and ``heading_at(times)`` (rad, the nose
        right), the rotation joins the match: a heading ``psi`` turns the image's content by
        ``-psi``, weighed as the shift it gives at ``radius_px`` from the centre (the corner
        tiles').  Returns the window's own best delay, s, where it measures one (else None,
        and nothing is added)."""
        shake = np.asarray(shake_px, dtype=np.float64)
        arrivals = np.asarray(arrivals, dtype=np.float64)
        if shake.shape != (arrivals.size, 2) or not np.all(np.isfinite(shake)):
            return None
        times = arrivals[None, :] - LATENCY_GRID_S[:, None]  # (delays, T)
        att = attitude_at(times.ravel())
        if att is None:
            return None
        pred = detrend(attitude_shift(att[0].reshape(times.shape), att[1].reshape(times.shape),
                                      focal_px))
        measured = detrend(shake)
        heads = None
        if rotation_rad is not None and heading_at is not None and radius_px > 0:
            heads = heading_at(times.ravel())
        if heads is not None and np.all(np.isfinite(rotation_rad)):
            turn = -radius_px * np.asarray(heads, dtype=np.float64).reshape(times.shape)
            seen = radius_px * np.asarray(rotation_rad, dtype=np.float64)
            # the rotation as a third column, detrended as the shifts are
            pred = np.concatenate([pred, detrend(turn[..., None])], -1)
            measured = np.concatenate([measured, detrend(seen[:, None])], -1)
        mm = float((measured**2).sum())
        dot = (pred * measured).sum(axis=(1, 2))
        pp = np.maximum((pred**2).sum(axis=(1, 2)), 1e-30)
        explained = dot**2 / pp / max(mm, 1e-30)
        best = int(np.argmax(explained))
        self.last_share = float(explained[best])
        if explained[best] < MIN_EXPLAINED or abs(dot[best] / pp[best] - 1.0) > MAX_GAIN_ERROR:
            return None
        self.explained += explained * mm
        self.energy += mm
        self.windows += 1
        return float(LATENCY_GRID_S[best])


__all__ = ["LATENCY_GRID_S", "MAX_GAIN_ERROR", "MEASURE_EVERY", "MIN_EXPLAINED", "MIN_WINDOWS",
           "SETTLE_WINDOWS", "SHAKE_MIN_RATIO", "LatencyMeter", "attitude_shift", "detrend"]
