"""A shaking camera flown live, its windows levelled at the vehicle's attitude as
``wavealt altitude --live --tilt-from-vehicle`` levels them; prints one JSON object.

    python benchmarks/bench_live_shake.py [--seeds 23,31] [--sequences 20] [--amplitudes 0.5,1]
        [--delay-ms 80] [--frames 90] [--window 30] [--step 5] [--mode exact|blind]
        [--workers 1] [--out FILE.json]

Each sequence is a stream: the realistic renderer's sea (``--frames`` frames, 256 px,
altitude 1-15 m, wind 2-12 m/s, drift 0-1 m/s), seen through ``bench_shake.py``'s shake
(roll and pitch ``A sin(2 pi f t + phi)``, 0.7-2 Hz, central 176 px), each frame arriving
``--delay-ms`` after it was taken, and cut into windows of ``--window`` frames every
``--step``, in order.  Per window, four cases: ``live`` (one
:class:`wavealt.live.levelling.VehicleLevelling` per stream, its delay measured from the
frames as the windows come: each window at its mean attitude until then, each frame at its
own after), ``told`` (each frame at the attitude it had), ``latest`` (each window at the
attitude of its last frame's arrival, to the half degree: the live levelling before the
twenty-sixth session) and ``untold`` (not levelled).  ``--mode exact`` gives the camera's
velocity over the water, as ``--velocity-from-vehicle`` with the current known would.  Per
amplitude and case: relative MAE, median, trusted share, trusted windows more than 10 %
off, 3-sigma coverage and the share steadied; ``live`` also split by whether the delay was
known yet (``live-measuring``, ``live-known``).  Exit code 0: a report, not a gate.
"""

from __future__ import annotations

import os

# before NumPy loads: one thread each, so that workers do not fight
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from functools import partial  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_shake import SHAKE_HZ, attitude_of, shake_at, shaken_view  # noqa: E402
from bench_yaw import CAMERA_PX, SEAS, check_sea_args, report, run_rows, sea_parser  # noqa: E402
from bench_yaw import summarise  # noqa: E402

#: The frames' clock starts here (s).
T0 = 1000.0


def heading_at(seed: int, index: int, rate_dps: float, jitter_deg: float,
               times_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vehicle's heading, degrees, and its rate, degrees a second, at ``times_s`` (s
    from the stream's start): a steady turn at ``rate_dps`` and ``jitter_deg`` back and
    forth (``sin(2 pi f t + phi)``, ``f`` in ``SHAKE_HZ`` from the sequence's own stream)."""
    rng = np.random.default_rng([seed, index, 9])
    f, phi = rng.uniform(*SHAKE_HZ), rng.uniform(0.0, 2.0 * np.pi)
    t = np.asarray(times_s, dtype=np.float64)
    w = 2.0 * np.pi * f
    return (rate_dps * t + jitter_deg * np.sin(w * t + phi),
            rate_dps + jitter_deg * w * np.cos(w * t + phi))


def turned_view(frames: np.ndarray, headings_deg: np.ndarray) -> np.ndarray:
    """``frames`` ``(T, H, W)`` (the sea, north up) as a level camera at each frame's
    heading sees them (``bench_yaw.yawing_view``'s geometry, one heading a frame; the
    corners the turn brings in mirror the edge)."""
    import scipy.ndimage as ndi

    t, h, w = frames.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    right, forward = xx - (w - 1) / 2, (h - 1) / 2 - yy
    out = np.empty_like(frames, dtype=np.float32)
    for i in range(t):
        d = math.radians(float(headings_deg[i]))
        north = forward * math.cos(d) - right * math.sin(d)
        east = forward * math.sin(d) + right * math.cos(d)
        out[i] = ndi.map_coordinates(frames[i], [(h - 1) / 2 - north, (w - 1) / 2 + east],
                                     order=1, mode="reflect")
    return out


def run_sequence(task: tuple[int, int], amplitudes: tuple[float, ...], frames: int,
                 window: int, step: int, delay_ms: float, mode: str, yaw_dps: float = 0.0,
                 yaw_jitter_deg: float = 0.0) -> list[dict[str, Any]]:
    from wavealt.altimetry.dispersion import DispersionAltimeter
    from wavealt.camera import NadirView, pinhole, unturn_headings
    from wavealt.live.levelling import VehicleLevelling, judge
    from wavealt.live.mavlink import ned_to_image

    seed, index = task
    sea, truth = SEAS["realistic"](seed, index, frames)
    fps, focal = truth["fps"], truth["focal_px"]
    vx, vy = truth["velocity_mps"]  # the camera over the water, the sea's axes (north up)
    turning = yaw_dps != 0.0 or yaw_jitter_deg != 0.0
    level_est = DispersionAltimeter(dispersion="gravity-capillary", attitude="level")
    free_est = DispersionAltimeter(dispersion="gravity-capillary")
    calib = pinhole(CAMERA_PX, CAMERA_PX, focal)
    taken = T0 + np.arange(frames) / fps
    arrived = taken + delay_ms / 1e3

    def heading(times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return heading_at(seed, index, yaw_dps, yaw_jitter_deg, np.asarray(times) - T0)

    def velocity(heading_deg: float) -> tuple[float, float] | None:
        """Given as --velocity-from-vehicle gives it: in the axes of that heading."""
        if mode != "exact":
            return None
        return ned_to_image((-vy, vx, 0.0), math.radians(heading_deg))

    sea_seen = turned_view(sea, heading(taken)[0]) if turning else sea
    out = []
    for amp in amplitudes:
        deg = shake_at(seed, index, amp, taken - T0)
        clip = np.clip(shaken_view(sea_seen, deg, focal, CAMERA_PX), 0.0, 1.0)

        attitude_at = attitude_of(seed, index, amp, T0)
        stream = VehicleLevelling(lambda w, h: calib, altimeter=level_est)
        for start in range(0, frames - window + 1, step):
            part = slice(start, start + window)
            last = arrived[start + window - 1:start + window]
            mid_taken = 0.5 * (taken[start] + taken[start + window - 1])
            # (frames, focal, estimator, velocity, yaw rate given: None, a still heading,
            # leaves the turn to the altimeter as the runs before --yaw-dps did)
            cases: dict[str, tuple[np.ndarray, float, Any, Any, float | None]] = {}
            got = stream.level(clip[part], arrived[part], attitude_at,
                               heading_at=(lambda t: np.radians(heading(t)[0])) if turning
                               else None)
            each = got[2]["attitude_sd_deg"] != ""  # frame by frame: the delay known
            # as the command line: turned back frame by frame, or at the latest yaw rate;
            # the velocity at the heading of the frames' middle moment as the link reads it
            rate = 0.0 if "yaw_rate_dps" in got[2] else float(heading(last)[1][0])
            middle = 0.5 * (arrived[start] + arrived[start + window - 1]) - (
                stream.delay_s or 0.0)
            cases["live-known" if each else "live-measuring"] = (
                got[0], got[1], level_est, velocity(float(heading([middle])[0][0])),
                rate if turning else None)
            view = NadirView(calib, CAMERA_PX, CAMERA_PX, roll_deg=deg[part, 0],
                             pitch_deg=deg[part, 1])
            told = view(clip[part])
            if turning:
                hd = heading(taken[part])[0]
                told = unturn_headings(told, hd - float(heading([mid_taken])[0][0]))
            cases["told"] = (told, view.focal_px, level_est,
                             velocity(float(heading([mid_taken])[0][0])),
                             0.0 if turning else None)
            # before: the latest ATTITUDE heard when the window's last frame arrives, its
            # yawspeed, and the velocity at its heading
            r, p = (round(math.degrees(float(x[0])) * 2) / 2 for x in attitude_at(last))
            one = NadirView(calib, CAMERA_PX, CAMERA_PX, roll_deg=r, pitch_deg=p)
            cases["latest"] = (one(clip[part]), one.focal_px, level_est,
                               velocity(float(heading(last)[0][0])),
                               float(heading(last)[1][0]) if turning else None)
            cases["untold"] = (clip[part], focal, free_est,
                               velocity(float(heading([mid_taken])[0][0])), None)
            for case, (frames_in, f, est, vel, yaw) in cases.items():
                t0 = time.perf_counter()
                result = est.estimate(frames_in, fps=fps, focal_px=f, velocity_mps=vel,
                                      yaw_rate_dps=None if yaw is None
                                      else float(np.clip(yaw, -180.0, 180.0)))
                res = result.to_dict()
                if case.startswith("live"):  # as the command line judges it
                    judge(res, got[2], est.altitude_range_m)
                row = {"seed": seed, "index": index, "start": start, "amplitude_deg": amp,
                       "case": case, "altitude_m": truth["altitude_m"],
                       "estimate_m": res["altitude_m"], "std_m": res["altitude_std_m"],
                       "trusted": bool(res["trusted"]), "reason": res["reason"],
                       "steadied": "+steadied" in result.signal,
                       "shake_px": round(result.shake_px, 3), "signal": result.signal,
                       "delay_ms": None if stream.delay_s is None else 1e3 * stream.delay_s,
                       "ms": 1e3 * (time.perf_counter() - t0)}
                out.append(row)
                if case.startswith("live"):
                    out.append({**row, "case": "live"})
    return out


def parse_args(argv: list[str] | None = None):
    ap = sea_parser(__doc__, frames=90, mode="exact")
    ap.add_argument("--amplitudes", default="0.5,1",
                    help="roll and pitch amplitudes, degrees, comma-separated")
    ap.add_argument("--delay-ms", type=float, default=80.0,
                    help="how long after it was taken each frame arrives, ms")
    ap.add_argument("--yaw-dps", type=float, default=0.0,
                    help="the vehicle turning at this rate, deg/s (positive: nose right)")
    ap.add_argument("--yaw-jitter-deg", type=float, default=0.0,
                    help="and its heading back and forth by this much, degrees (0.7-2 Hz)")
    ap.add_argument("--window", type=int, default=30)
    ap.add_argument("--step", type=int, default=5)
    a = ap.parse_args(argv)
    if a.sea != "realistic":
        ap.error("--sea: only the realistic renderer's sea is long enough for a stream")
    a.amplitudes = check_sea_args(ap, a, a.amplitudes, "amplitudes")
    if any(not (math.isfinite(r) and 0 < r <= 5) for r in a.amplitudes):
        ap.error(f"--amplitudes must be in (0, 5] degrees; got {a.amplitudes}")
    if not (math.isfinite(a.delay_ms) and 0 <= a.delay_ms <= 400):
        ap.error(f"--delay-ms must be in [0, 400] ms (the meter's reach); got {a.delay_ms}")
    if not (math.isfinite(a.yaw_dps) and abs(a.yaw_dps) <= 60
            and math.isfinite(a.yaw_jitter_deg) and 0 <= a.yaw_jitter_deg <= 10):
        ap.error(f"--yaw-dps must be within +-60 and --yaw-jitter-deg in [0, 10]; got "
                 f"{a.yaw_dps}, {a.yaw_jitter_deg}")
    if not (15 <= a.window <= a.frames and a.step >= 1):
        ap.error(f"--window must be in [15, --frames] and --step >= 1; got {a.window}, "
                 f"{a.step}")
    return a


def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    job = partial(run_sequence, amplitudes=a.amplitudes, frames=a.frames, window=a.window,
                  step=a.step, delay_ms=a.delay_ms, mode=a.mode, yaw_dps=a.yaw_dps,
                  yaw_jitter_deg=a.yaw_jitter_deg)
    rows, seconds = run_rows(a, job)
    known = [r for r in rows if r["case"] == "live-known"]
    summary = {"benchmark": "live_shake", "command": " ".join(["python", *sys.argv]),
               "seeds": list(a.seeds), "sequences": a.sequences,
               "amplitudes_deg": list(a.amplitudes), "delay_ms": a.delay_ms,
               "yaw_dps": a.yaw_dps, "yaw_jitter_deg": a.yaw_jitter_deg,
               "frames": a.frames, "window": a.window, "step": a.step, "mode": a.mode,
               "camera_px": CAMERA_PX,
               "by_amplitude": summarise(rows, "amplitude_deg", ("steadied",)),
               "delay_measured_ms": {
                   "median": float(np.median([r["delay_ms"] for r in known])) if known
                   else None,
                   "max_error": float(np.max([abs(r["delay_ms"] - a.delay_ms)
                                              for r in known])) if known else None},
               "seconds": seconds}
    report(a, summary, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
