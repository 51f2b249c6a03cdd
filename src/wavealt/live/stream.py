"""Live altimetry: frames from a camera, a stream or a pipe (PyAV), a rolling window, an
estimate whenever ``step`` new frames have come, a CSV log, and optionally the autopilot.

The reader runs in its own thread and never waits for the estimator: it keeps the newest
frames in a ring buffer, and a frame that leaves the buffer before any window used it is
counted as dropped.  The estimator takes a snapshot of the newest ``window`` frames; a
snapshot that spans a gap in the frame times (the camera dropped frames) waits for the next.
A file is played back at the pace of its own timestamps, as a camera would deliver it.
SIGINT and SIGTERM stop the loop after the current estimate; the log is flushed and the
link closed.
"""

from __future__ import annotations

import csv
import math
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from wavealt._checks import check_finite_number, check_integer
from wavealt.altimetry.coding import predicted_verdict
from wavealt.framesource import lossy_predicting
from wavealt.io import nominal_rate, one_second_window, regular_runs

#: Columns of ``live.csv``, one row per estimate.
LIVE_COLUMNS = ("wall_time", "time_s", "altitude_m", "altitude_std_m", "camera_vx_mps",
                "camera_vy_mps", "trusted", "reason", "quality", "mode", "frames", "fps",
                "latency_ms", "dropped_frames", "roll_deg", "pitch_deg", "attitude_sd_deg",
                "camera_latency_ms", "yaw_rate_dps", "shake_px")
LIVE_FILE = "live.csv"
#: The summary's latency median and p90 are over at most this many of the newest estimates.
LATENCY_WINDOW = 10000
#: Frames whose times set a stream's default window (``run_live``'s ``window=None``).
RATE_PROBE_FRAMES = 8
#: The reader's buffer while those frames come (before the window is known).
PROBE_CAPACITY = 1024
#: The most frames a window set by the stream's rate takes (one second at 240 fps, the
#: fastest rate the benches run): a source whose times jitter or burst must not make a
#: window, and a buffer of four, of thousands of frames.
MAX_RATE_WINDOW = 240


@dataclass
class _Buffered:
    time_s: float
    arrival: float  # time.monotonic() when the frame was decoded
    frame: np.ndarray
    used: bool = False
    predicted: bool = False  # decoded from other frames (not a key frame)


@dataclass
class ReaderStats:
    frames: int = 0
    dropped: int = 0
    untimed: int = 0  # frames without a timestamp and no rate given: timed as they came
    error: str | None = None
    finished: bool = False
    opened: threading.Event = field(default_factory=threading.Event)


class FrameReader(threading.Thread):
    """Decodes ``source`` (a file, a device, a URL, or ``-`` for standard input) into a ring
    buffer of ``capacity`` frames, RGB uint8 with their times in seconds.

    ``fmt`` is FFmpeg's input format (``v4l2`` for a camera device, ``mpegts`` or ``h264``
    for a pipe); ``pace`` plays a file back at the rate of its timestamps.  ``fps``: the
    rate of a source whose frames carry no timestamps (a raw H.264 stream): its frame ``n``
    is at ``n / fps`` s; without it such frames are timed as they are decoded, and counted
    (``stats.untimed``).
    """

    def __init__(self, source: str, *, capacity: int, fmt: str | None = None,
                 pace: bool | None = None, fps: float | None = None) -> None:
        super().__init__(name="wavealt-frame-reader", daemon=True)
        self.source, self.fmt, self.fps = source, fmt, fps
        self.pace = Path(source).is_file() if pace is None else pace
        self.buffer: deque[_Buffered] = deque()
        self.capacity = int(capacity)
        self.lock = threading.Lock()
        self.new_frame = threading.Condition(self.lock)
        self.stop_event = threading.Event()
        self.stats = ReaderStats()
        self.codec: str | None = None  # FFmpeg's name of the stream's lossy codec, once open

    def run(self) -> None:
        import av  # deferred: 0.4 s of the command line's start-up

        target = sys.stdin.buffer if self.source == "-" else self.source
        try:
            with av.open(target, format=self.fmt) as container:
                if not container.streams.video:
                    self._fail(f"{self.source} holds no video stream")
                    return
                # a lossless codec's predictions lose nothing (FFV1): not named
                self.codec = lossy_predicting(container.streams.video[0].codec_context)
                self.stats.opened.set()
                start = None
                for n, frame in enumerate(container.decode(video=0)):
                    if self.stop_event.is_set():
                        break
                    now = time.monotonic()
                    t = (frame.time if frame.time is not None
                         else n / self.fps if self.fps else now)
                    self.stats.untimed += frame.time is None and not self.fps
                    if self.pace:
                        start = (now - t) if start is None else start
                        delay = start + t - time.monotonic()
                        if delay > 0 and self.stop_event.wait(delay):
                            break
                    self._push(t, frame.to_ndarray(format="rgb24"), not frame.key_frame)
        except (av.error.FFmpegError, OSError) as exc:
            self._fail(f"cannot read {self.source}: {exc}")
            return
        finally:
            with self.lock:
                self.stats.finished = True
                self.stats.opened.set()
                self.new_frame.notify_all()

    def _fail(self, message: str) -> None:
        self.stats.error = message
        self.stats.opened.set()

    def _push(self, t: float, frame: np.ndarray, predicted: bool = False) -> None:
        with self.lock:
            self.buffer.append(_Buffered(float(t), time.monotonic(), frame, False, predicted))
            self.stats.frames += 1
            while len(self.buffer) > self.capacity:  # drop the oldest, never wait
                if not self.buffer.popleft().used:
                    self.stats.dropped += 1
            self.new_frame.notify_all()

    def snapshot(self, n: int, after: int, timeout: float) -> tuple[list[_Buffered], int]:
        """The newest ``n`` frames once at least ``after`` frames have arrived in all (or
        the stream ended: then the newest there are), and the count of frames arrived."""
        with self.lock:
            self.new_frame.wait_for(
                lambda: self.stats.frames >= after or self.stats.finished
                or self.stop_event.is_set(), timeout=timeout)
            items = list(self.buffer)[-n:]
            for it in items:
                it.used = True
            return items, self.stats.frames

    def stop(self) -> None:
        self.stop_event.set()
        with self.lock:
            self.new_frame.notify_all()


def run_live(source: str, *, estimate: Callable[[np.ndarray, float], dict[str, Any]],
             window: int | None = None, step: int | None = None, fmt: str | None = None,
             duration_s: float | None = None,
             log: Path | None = None, on_estimate: Callable[[dict[str, Any]], Any] | None = None,
             pace: bool | None = None, capacity: int | None = None,
             fps: float | None = None,
             altitude_range_m: tuple[float, float] = (0.5, 20.0)) -> dict[str, Any]:
    """Estimate the altitude from ``source`` until it ends, ``duration_s`` passes, or SIGINT /
    SIGTERM; return a summary.

    ``estimate(frames, fps, arrivals)`` takes ``(window, H, W, 3)`` uint8 frames, their rate
    and when each was decoded (``time.monotonic()`` seconds), and returns a result dict
    (``DispersionResult.to_dict()`` keys, and where the frames were levelled the attitude as
    ``roll_deg`` and ``pitch_deg``, the window's mean, ``attitude_sd_deg``, how far the
    frames' attitudes spread about it, and ``camera_latency_ms``, the frames' delay behind
    the attitude they were levelled at); each becomes a row of ``log`` (``LIVE_COLUMNS``) and
    is passed to ``on_estimate``.

    ``window``: frames per estimate; None for one second of them at the rate of the stream's
    first ``RATE_PROBE_FRAMES`` frames (:func:`~wavealt.io.one_second_window`, as a recorded
    clip's; at most ``MAX_RATE_WINDOW``).  ``step``: new frames between estimates; None for
    a fifteenth of the window (at most 15 estimates a second).  ``capacity``: the reader's
    buffer, frames (default four windows).  The summary gives the ``window_frames`` and
    ``step_frames`` used (None where the stream ended before its rate was known).  ``fps``:
    the rate of a source whose frames carry no timestamps; such a source without it is a
    ``ValueError`` (timed by when its frames are decoded, a pipe that decodes faster than
    real time would give every window a wrong rate, and the altitude goes as its inverse
    square).  A rate or duration that is not a positive number, a window of fewer than 3
    frames, or a step or capacity below 1 is a ``ValueError`` before the source is opened.
    A window that holds frames a lossy codec predicted from other frames, estimated without
    the velocity exactly, is not trusted (:func:`~wavealt.altimetry.coding.predicted_verdict`;
    ``altitude_range_m``, the altimeter's range, is then its 3-sigma interval); the summary
    names such a codec (``predicted_by``).
    """
    if fps is not None:
        fps = check_finite_number("fps", fps, low=0.0, low_open=True)
    if duration_s is not None:
        duration_s = check_finite_number("duration_s", duration_s, low=0.0, low_open=True)
    for name, value, least in (("window", window, 3), ("step", step, 1),
                               ("capacity", capacity, 1)):
        if value is not None:
            check_integer(name, value, low=least)
    reader = FrameReader(source, capacity=capacity or 4 * (window or PROBE_CAPACITY // 4),
                         fmt=fmt, pace=pace, fps=fps)
    stop = threading.Event()
    previous = {}

    def on_signal(signum: int, _frame: Any) -> None:
        stop.set()
        reader.stop()

    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, on_signal)
    fh = writer = None
    t_start = time.monotonic()
    # a flight runs for hours: the latency statistics are kept over the newest estimates
    rows, skipped, first_done, last_done = 0, 0, math.nan, math.nan
    latencies: deque[float] = deque(maxlen=LATENCY_WINDOW)
    trusted = 0
    predicted_by = None
    try:
        reader.start()
        reader.stats.opened.wait(timeout=30.0)
        if reader.stats.error:
            raise ValueError(reader.stats.error)
        if log is not None:
            fh = log.open("w", newline="", encoding="utf-8")
            writer = csv.DictWriter(fh, fieldnames=LIVE_COLUMNS)
            writer.writeheader()
            fh.flush()
        seen = 0
        while not stop.is_set():
            if duration_s is not None and time.monotonic() - t_start >= duration_s:
                break
            if reader.stats.untimed:
                msg = (f"{source}: its frames carry no timestamps, so their rate is not "
                       f"known; give it (--fps)")
                raise ValueError(msg)
            if window is None:  # one second of frames, at the rate the first ones came at
                items, arrived = reader.snapshot(RATE_PROBE_FRAMES, RATE_PROBE_FRAMES, 0.5)
                if reader.stats.error:
                    raise ValueError(reader.stats.error)
                rate = (nominal_rate(np.array([it.time_s for it in items]))
                        if arrived >= RATE_PROBE_FRAMES else math.nan)
                if math.isfinite(rate) and rate > 0:
                    window = min(one_second_window(rate), MAX_RATE_WINDOW)
                    with reader.lock:
                        reader.capacity = capacity or 4 * window
                elif arrived >= RATE_PROBE_FRAMES:
                    msg = (f"{source}: the times of its first {RATE_PROBE_FRAMES} frames give "
                           f"no frame rate; give the window in frames")
                    raise ValueError(msg)
                elif reader.stats.finished:
                    break
                continue
            step = max(1, window // 15) if step is None else step
            need = max(window, seen + step)
            items, arrived = reader.snapshot(window, need, timeout=0.5)
            if reader.stats.error:
                raise ValueError(reader.stats.error)
            if arrived < need:
                if reader.stats.finished:
                    break
                continue  # timed out waiting: check the stop conditions again
            seen = arrived
            times = np.array([it.time_s for it in items])
            # the recorded-input rule: one run of evenly spaced frames (video.regular_runs)
            if (len(items) < window or np.any(np.diff(times) <= 0)
                    or len(regular_runs(times)[0]) != 1):
                skipped += 1
                continue
            fps = (len(times) - 1) / (times[-1] - times[0])
            res = estimate(np.stack([it.frame for it in items]), float(fps),
                           np.array([it.arrival for it in items]))
            if reader.codec is not None and any(it.predicted for it in items):
                predicted_by = reader.codec
                res = predicted_verdict(res, predicted_by, altitude_range_m)
            if on_estimate is not None:
                on_estimate(res)
            # from the window's last frame to the estimate delivered (sent, when linked)
            latency = time.monotonic() - items[-1].arrival
            latencies.append(latency)
            last_done = time.monotonic()
            first_done = last_done if rows == 0 else first_done
            row = {"wall_time": round(time.time(), 3), "time_s": round(float(times[-1]), 4),
                   "altitude_m": res["altitude_m"], "altitude_std_m": res["altitude_std_m"],
                   "camera_vx_mps": res["camera_velocity_mps"][0],
                   "camera_vy_mps": res["camera_velocity_mps"][1],
                   "trusted": res["trusted"], "reason": res["reason"] or "",
                   "quality": res["quality"], "mode": res["mode"], "frames": len(items),
                   "fps": round(float(fps), 3), "latency_ms": round(1e3 * latency, 1),
                   "dropped_frames": reader.stats.dropped,
                   "roll_deg": res.get("roll_deg", ""), "pitch_deg": res.get("pitch_deg", ""),
                   "attitude_sd_deg": res.get("attitude_sd_deg", ""),
                   "camera_latency_ms": res.get("camera_latency_ms", ""),
                   "yaw_rate_dps": res.get("yaw_rate_dps", ""),
                   "shake_px": res.get("shake_px", "")}
            if writer is not None:
                writer.writerow(row)
                fh.flush()
            rows += 1
            trusted += bool(res["trusted"])
    finally:
        reader.stop()
        reader.join(timeout=5.0)
        if fh is not None:
            fh.close()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    elapsed = time.monotonic() - t_start
    lat = np.array(latencies) if latencies else np.array([math.nan])
    return {"estimates": rows, "trusted_estimates": trusted, "frames": reader.stats.frames,
            "dropped_frames": reader.stats.dropped, "windows_skipped_for_gaps": skipped,
            "seconds": round(elapsed, 3), "window_frames": window,
            "step_frames": None if window is None else step,
            # the steady rate: from the first estimate (once a window has filled) to the last
            "estimates_per_s": (round((rows - 1) / (last_done - first_done), 3)
                                if rows > 1 and last_done > first_done else 0.0),
            "latency_ms_median": round(1e3 * float(np.median(lat)), 1),
            "latency_ms_p90": round(1e3 * float(np.quantile(lat, 0.9)), 1),
            "stopped_by": ("signal" if stop.is_set() else "end of stream"
                           if reader.stats.finished else "duration"),
            "predicted_by": predicted_by}


__all__ = ["LIVE_COLUMNS", "LIVE_FILE", "FrameReader", "ReaderStats", "run_live"]
