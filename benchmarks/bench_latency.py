"""A camera's delay behind the vehicle's attitude, measured from the frames' own shake;
prints one JSON object.

    python benchmarks/bench_latency.py [--seeds 23,31] [--sequences 40] [--amplitudes 0.2,0.5,1]
        [--delays-ms 0,60,150,300] [--frames 30] [--sea realistic|second] [--workers 1]
        [--out FILE.json]

Each sequence is ``bench_shake.py``'s shaking camera (the realistic renderer's sea, or with
``--sea second`` the independent generator's; roll and pitch ``A sin(2 pi f t + phi)``, ``f``
0.7-2 Hz), its frames arriving ``delay`` after they were taken.  The image shift its corner
tiles measure (:func:`wavealt.altimetry.dispersion.image_shake`) is matched against the
attitude the camera had (:class:`wavealt.live.latency.LatencyMeter`) and against the next
sequence's (an attitude that is not the camera's, which must measure nothing).  Per
amplitude and delay: the share of windows that measured a delay and how far off (median,
90th percentile, largest), the share of wrong attitudes that measured one, and a stream's
delay: the meter of each seed fed its sequences in order, when it first gives one and
after all.  Exit code 0: a report, not a gate.
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
from bench_shake import attitude_of, shake_at, shaken_view  # noqa: E402
from bench_yaw import CAMERA_PX, SEAS, check_sea_args, report, run_rows, sea_parser  # noqa: E402

#: The frames' clock starts here (s): any start will do, the attitude is a function of time.
T0 = 1000.0


def run_sequence(task: tuple[int, int], amplitudes: tuple[float, ...],
                 delays_ms: tuple[float, ...], frames: int,
                 sea_name: str = "realistic", min_ratio: float | None = None
                 ) -> list[dict[str, Any]]:
    from wavealt.altimetry.dispersion import DispersionAltimeter, image_shake
    from wavealt.live.latency import SHAKE_MIN_RATIO, LatencyMeter

    seed, index = task
    sea, truth = SEAS[sea_name](seed, index, frames)
    fps, focal = truth["fps"], truth["focal_px"]
    est = DispersionAltimeter(dispersion="gravity-capillary")
    taken = T0 + np.arange(frames) / fps
    out = []
    for amp in amplitudes:
        deg = shake_at(seed, index, amp, taken - T0)
        clip = np.clip(shaken_view(sea, deg, focal, CAMERA_PX), 0.0, 1.0)
        t0 = time.perf_counter()
        # as the live levelling measures it: the shift and a rotation the tiles share
        motion = image_shake(clip, est, SHAKE_MIN_RATIO if min_ratio is None else min_ratio,
                             rotation=True)
        shake = None if motion is None else motion[0]
        ms = 1e3 * (time.perf_counter() - t0)
        for delay in delays_ms:
            right, wrong = LatencyMeter(), LatencyMeter()
            got = None if shake is None else right.add(
                shake, taken + delay / 1e3, attitude_of(seed, index, amp, T0), focal)
            false = None if shake is None else wrong.add(
                shake, taken + delay / 1e3, attitude_of(seed, index + 1, amp, T0), focal)
            out.append({"seed": seed, "index": index, "amplitude_deg": amp, "delay_ms": delay,
                        "shake_px": None if shake is None
                        else float(np.sqrt((shake**2).sum(axis=1).mean())),
                        "measured_ms": None if got is None else 1e3 * got,
                        "wrong_measured_ms": None if false is None else 1e3 * false,
                        "share": None if shake is None else round(right.last_share, 4),
                        "wrong_share": None if shake is None else round(wrong.last_share, 4),
                        "energy": right.energy,
                        "wrong_explained": wrong.explained.tolist() if false is not None
                        else None,
                        "wrong_energy": wrong.energy,
                        "explained": right.explained.tolist() if got is not None else None,
                        "ms": ms})
    return out


def _stream(rows: list[dict[str, Any]], prefix: str = "") -> dict[str, Any]:
    """A stream's meter over ``rows`` (one seed, amplitude and delay, in sequence order;
    ``prefix`` "wrong_": of the attitudes that are not the camera's):
    the windows it had and its delay when it first gave one, and its delay after all, ms."""
    from wavealt.live.latency import LatencyMeter

    meter = LatencyMeter()  # fed the windows' pooled terms, as LatencyMeter.add would
    first = None
    for r in rows:
        if r[prefix + "explained"] is None:
            continue
        meter.explained += np.asarray(r[prefix + "explained"])
        meter.energy += r[prefix + "energy"]
        meter.windows += 1
        if first is None and meter.latency_s is not None:
            first = (meter.windows, 1e3 * meter.latency_s)
    last = meter.latency_s
    return {"windows": meter.windows,
            "first_measured": None if first is None else {"windows": first[0], "ms": first[1]},
            "after_all_ms": None if last is None else 1e3 * last}


def summarise(rows: list[dict[str, Any]], seeds: tuple[int, ...]) -> dict[str, Any]:
    """Per ``amplitude/delay``: the windows' measurement and each seed's stream."""
    table: dict[str, Any] = {}
    for amp, delay in sorted({(r["amplitude_deg"], r["delay_ms"]) for r in rows}):
        sel = [r for r in rows if r["amplitude_deg"] == amp and r["delay_ms"] == delay]
        err = np.array([abs(r["measured_ms"] - delay) for r in sel
                        if r["measured_ms"] is not None])
        table[f"{amp:g}/{delay:g}"] = {
            "windows": len(sel),
            "shake_found_share": round(float(np.mean([r["shake_px"] is not None
                                                      for r in sel])), 3),
            "measured_share": round(err.size / len(sel), 3),
            "error_ms_median": round(float(np.median(err)), 1) if err.size else None,
            "error_ms_p90": round(float(np.percentile(err, 90)), 1) if err.size else None,
            "error_ms_max": round(float(err.max()), 1) if err.size else None,
            "wrong_attitude_measured_share": round(float(np.mean(
                [r["wrong_measured_ms"] is not None for r in sel])), 3),
            "streams": {str(s): _stream([r for r in sel if r["seed"] == s]) for s in seeds},
            # the next sequence's attitude, window after window: must never give a delay
            "wrong_streams": {str(s): _stream([r for r in sel if r["seed"] == s], "wrong_")
                              for s in seeds},
            "image_shake_ms_median": round(float(np.median([r["ms"] for r in sel])), 1)}
    return table


def parse_args(argv: list[str] | None = None):
    ap = sea_parser(__doc__, frames=30, mode="blind")
    ap.add_argument("--amplitudes", default="0.2,0.5,1",
                    help="roll and pitch amplitudes, degrees, comma-separated")
    ap.add_argument("--delays-ms", default="0,60,150,300",
                    help="the frames' delays behind the attitude, ms, comma-separated")
    ap.add_argument("--min-ratio", type=float, default=None,
                    help="the tiles' agreement asked of a shake before it is matched "
                         "(image_shake's min_ratio) [live.latency.SHAKE_MIN_RATIO]")
    a = ap.parse_args(argv)
    a.amplitudes = check_sea_args(ap, a, a.amplitudes, "amplitudes")
    try:
        a.delays_ms = tuple(float(x) for x in a.delays_ms.split(","))
    except ValueError:
        ap.error(f"--delays-ms must be comma-separated numbers of ms; got {a.delays_ms!r}")
    if any(not (math.isfinite(r) and 0 < r <= 5) for r in a.amplitudes):
        ap.error(f"--amplitudes must be in (0, 5] degrees; got {a.amplitudes}")
    if any(not (math.isfinite(d) and 0 <= d <= 400) for d in a.delays_ms):
        ap.error(f"--delays-ms must be in [0, 400] ms (the meter's reach); got {a.delays_ms}")
    if a.min_ratio is not None and not (math.isfinite(a.min_ratio) and a.min_ratio > 0):
        ap.error(f"--min-ratio must be a positive number; got {a.min_ratio}")
    if a.frames < 15:
        ap.error(f"--frames must be at least 15 (the shake's measurement); got {a.frames}")
    return a


def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    job = partial(run_sequence, amplitudes=a.amplitudes, delays_ms=a.delays_ms,
                  frames=a.frames, sea_name=a.sea, min_ratio=a.min_ratio)
    rows, seconds = run_rows(a, job)
    summary = {"benchmark": "latency", "command": " ".join(["python", *sys.argv]),
               "seeds": list(a.seeds), "sequences": a.sequences,
               "amplitudes_deg": list(a.amplitudes), "delays_ms": list(a.delays_ms),
               "frames": a.frames, "sea": a.sea, "camera_px": CAMERA_PX,
               "min_ratio": a.min_ratio,
               "by_amplitude_delay": summarise(rows, a.seeds), "seconds": seconds}
    for r in rows:  # the pooled curves are in the summary's streams; the file stays small
        r.pop("explained")
        r.pop("wrong_explained")
    report(a, summary, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
