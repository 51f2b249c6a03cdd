"""The dispersion altimeter on a camera that shakes in roll and pitch; prints one JSON object.

    python benchmarks/bench_shake.py [--seeds 23,31] [--sequences 40] [--amplitudes 0.5,1]
        [--frames 30] [--mode exact|blind] [--sea realistic|second] [--lags-ms 10,30]
        [--workers 1] [--out FILE.json]

A camera on a vehicle without a gimbal rolls and pitches by fractions of a degree, back and
forth, within every second.  Each sequence of the realistic renderer (256 px, altitude 1-15
m, wind 2-12 m/s, drift 0-1 m/s, clean frames) is the sea seen by a level camera; a camera
whose roll and pitch each follow ``A sin(2 pi f t + phi)`` (``f`` drawn in 0.7-2 Hz and
``phi`` in 0-2 pi per axis and sequence, from a stream of the sequence's own) sees its
central 176 px through the homography of that attitude (OpenCV's ``warpPerspective``,
:func:`wavealt.camera.tilt_rotation`'s axes).  Every amplitude, including 0 (the
reference: the same crop, level), is fitted as it is (``untold``) and levelled frame by
frame at the attitude the camera had (``told``: :class:`wavealt.camera.NadirView`, as
``wavealt altitude --attitude`` does).  ``--lags-ms`` adds cases levelled at the attitude
the camera had that long before each frame (``told+30ms``): what a frame time off by that
much costs (``wavealt altitude --live --tilt-from-vehicle`` takes the attitude at each
frame's arrival less ``--camera-latency-ms``).  ``--mode exact`` gives the camera's velocity over
the water; ``blind`` none.  Per amplitude and case: relative MAE, median, trusted share,
trusted windows more than 10 % off, 3-sigma coverage, latency; and how often the fit
steadied the frames (``+steadied``).  ``--sea second`` takes the sea of
``bench_foreign_sea.py``'s independent generator (as ``bench_yaw.py --sea second``).
Exit code 0: a report, not a gate.
"""

from __future__ import annotations

import os

# before NumPy loads: one thread each, so that workers do not fight
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from functools import partial  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_yaw import (  # noqa: E402
    CAMERA_PX,
    SEAS,
    check_sea_args,
    report,
    run_rows,
    sea_parser,
    summarise,
)


#: The shake's frequencies, Hz (a multirotor's attitude loop, a boat's roll in a chop).
SHAKE_HZ = (0.7, 2.0)


def shake_at(seed: int, index: int, amplitude_deg: float, times_s: np.ndarray) -> np.ndarray:
    """``(len(times_s), 2)`` roll and pitch, degrees, of sequence ``index`` of ``seed``
    shaking at ``amplitude_deg`` at ``times_s`` (frame ``i`` is taken at ``i / fps``): each
    axis ``A sin(2 pi f t + phi)``, ``f`` and ``phi`` drawn from the sequence's own stream
    (the same for every amplitude)."""
    rng = np.random.default_rng([seed, index, 7])
    f = rng.uniform(*SHAKE_HZ, 2)
    phi = rng.uniform(0.0, 2.0 * np.pi, 2)
    t = np.asarray(times_s, dtype=np.float64)[:, None]
    return amplitude_deg * np.sin(2.0 * np.pi * f[None, :] * t + phi[None, :])


def attitude_of(seed: int, index: int, amplitude_deg: float, t0: float = 0.0):
    """:func:`shake_at` as the vehicle's attitude history gives it: ``at(times)``, roll
    and pitch in radians at ``times`` s on a clock whose frame 0 is taken at ``t0``."""
    def at(times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        deg = shake_at(seed, index, amplitude_deg, np.asarray(times) - t0)
        return np.radians(deg[:, 0]), np.radians(deg[:, 1])
    return at


def shake_attitudes(seed: int, index: int, amplitude_deg: float, frames: int,
                    fps: float, lag_s: float = 0.0) -> np.ndarray:
    """:func:`shake_at` of the ``frames`` frames, or ``lag_s`` before each."""
    return shake_at(seed, index, amplitude_deg, np.arange(frames) / fps - lag_s)


def shaken_view(frames: np.ndarray, attitudes: np.ndarray, focal_px: float,
                side: int) -> np.ndarray:
    """The central ``side`` px of a camera at each frame's ``(roll, pitch)`` degrees over
    the level camera's ``frames`` ``(T, H, W)`` (same focal length, the same optical
    centre): each pixel samples the level frame where its ray meets it."""
    import cv2

    from wavealt.camera import tilt_rotation

    t, h, w = frames.shape
    k = np.array([[focal_px, 0.0, (w - 1) / 2], [0.0, focal_px, (h - 1) / 2], [0.0, 0.0, 1.0]])
    k_out = np.array([[focal_px, 0.0, (side - 1) / 2], [0.0, focal_px, (side - 1) / 2],
                      [0.0, 0.0, 1.0]])
    out = np.empty((t, side, side), dtype=np.float32)
    for i in range(t):
        hom = k @ tilt_rotation(*attitudes[i]) @ np.linalg.inv(k_out)  # out px -> level px
        out[i] = cv2.warpPerspective(frames[i].astype(np.float32), hom, (side, side),
                                     flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                     borderMode=cv2.BORDER_REFLECT)
    return out


def run_sequence(task: tuple[int, int], amplitudes: tuple[float, ...], frames: int,
                 mode: str, sea_name: str = "realistic",
                 lags_ms: tuple[float, ...] = ()) -> list[dict[str, Any]]:
    from wavealt.altimetry.dispersion import DispersionAltimeter
    from wavealt.camera import NadirView, pinhole

    seed, index = task
    sea, truth = SEAS[sea_name](seed, index, frames)
    kw: dict[str, Any] = {"fps": truth["fps"]}
    if mode == "exact":
        kw["velocity_mps"] = truth["velocity_mps"]
    est = DispersionAltimeter(dispersion="gravity-capillary")
    out = []
    for amp in (0.0, *amplitudes):
        att = shake_attitudes(seed, index, amp, sea.shape[0], truth["fps"])
        clip = np.clip(shaken_view(sea, att, truth["focal_px"], CAMERA_PX), 0.0, 1.0)
        cases = {"untold": None, "told": att}
        for lag in lags_ms:
            cases[f"told+{lag:g}ms"] = shake_attitudes(seed, index, amp, sea.shape[0],
                                                       truth["fps"], lag / 1000.0)
        for case, level in cases.items():
            if amp == 0.0 and level is not None:
                continue
            frames_in, focal = clip, truth["focal_px"]
            if level is not None:
                view = NadirView(pinhole(CAMERA_PX, CAMERA_PX, focal), CAMERA_PX, CAMERA_PX,
                                 roll_deg=level[:, 0], pitch_deg=level[:, 1])
                frames_in, focal = view(clip), view.focal_px
            t0 = time.perf_counter()
            res = est.estimate(frames_in, focal_px=focal, **kw)
            out.append({"seed": seed, "index": index, "amplitude_deg": amp, "case": case,
                        "altitude_m": truth["altitude_m"], "estimate_m": res.altitude_m,
                        "std_m": res.altitude_std_m, "trusted": bool(res.trusted),
                        "reason": res.reason, "steadied": "+steadied" in res.signal,
                        "shake_px": round(res.shake_px, 3), "signal": res.signal,
                        "ms": 1e3 * (time.perf_counter() - t0)})
    return out


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = sea_parser(__doc__, frames=30, mode="blind")
    ap.add_argument("--amplitudes", default="0.5,1",
                    help="roll and pitch amplitudes, degrees, comma-separated")
    ap.add_argument("--lags-ms", default="",
                    help="also level at the attitude this long before each frame, ms, "
                         "comma-separated (none by default)")
    a = ap.parse_args(argv)
    a.amplitudes = check_sea_args(ap, a, a.amplitudes, "amplitudes")
    if any(not (math.isfinite(r) and 0 < r <= 5) for r in a.amplitudes):
        ap.error(f"--amplitudes must be in (0, 5] degrees; got {a.amplitudes}")
    try:
        a.lags_ms = tuple(float(x) for x in a.lags_ms.split(",") if x.strip())
    except ValueError:
        ap.error(f"--lags-ms must be comma-separated numbers of ms; got {a.lags_ms!r}")
    if any(not (math.isfinite(x) and 0 < x <= 1000) for x in a.lags_ms):
        ap.error(f"--lags-ms must be in (0, 1000] ms; got {a.lags_ms}")
    return a


def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    job = partial(run_sequence, amplitudes=a.amplitudes, frames=a.frames, mode=a.mode,
                  sea_name=a.sea, lags_ms=a.lags_ms)
    rows, seconds = run_rows(a, job)
    summary = {"benchmark": "shake", "command": " ".join(["python", *sys.argv]),
               "seeds": list(a.seeds), "sequences": a.sequences,
               "amplitudes_deg": list(a.amplitudes), "shake_hz": list(SHAKE_HZ),
               "lags_ms": list(a.lags_ms),
               "frames": a.frames, "mode": a.mode, "sea": a.sea, "camera_px": CAMERA_PX,
               "by_amplitude": summarise(rows, "amplitude_deg", ("steadied",)),
               "seconds": seconds}
    report(a, summary, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
