"""Altitude over time: the dispersion altimeter on sliding windows of a long input, and the
files that record it (CSV, JSON, a plot)."""

from __future__ import annotations

import csv
import io
import json
import math
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from wavealt._checks import check_finite_number, check_frames
from wavealt.altimetry.coding import PREDICTED_FRAMES, predicted_verdict
from wavealt.altimetry.dispersion import MIN_FRAMES, DispersionAltimeter
from wavealt.io import (
    atomic_write_text,
    check_output_folder,
    one_second_window,
    regular_runs,
    sliding_windows,
)

#: Why a summary with no trusted window is not trusted.
NO_TRUSTED_WINDOW = "no window trusted"

#: Columns of ``altitude.csv``, one row per window.
CSV_COLUMNS = ("start_frame", "stop_frame", "time_s", "fps", "altitude_m", "altitude_std_m",
               "camera_vx_mps", "camera_vy_mps", "quality", "trusted", "mode", "reason",
               "frames", "n_modes", "yaw_rate_dps", "shake_px")


def altitude_series(frames: np.ndarray, *, fps: float | None = None, focal_px: float,
                    window: int | None = None, step: int | None = None,
                    out: Path | str | None = None, progress: bool = False,
                    velocity_mps: tuple[float, float] | None = None,
                    velocity_sigma_mps: float = 0.0, readout_s: float = 0.0,
                    yaw_rate_dps: float | None = None, times_s: np.ndarray | None = None,
                    on_window: Callable[[dict[str, Any]], Any] | None = None,
                    predicted_by: str | None = None,
                    **kw: Any) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Estimates on sliding windows of ``frames`` and a summary of them.

    A sequence of at most ``window`` frames gives one estimate.  The default window is one
    second of frames (at least 10): the blind fit needs about a second to separate the waves
    from the optics' slower products, and the aided fit, which works from 10 frames, is
    several times more accurate with 1 s, its peaks in phase step ``2 pi / T`` narrower
    (``docs/benchmarks.md``).

    Parameters
    ----------
    frames : (T, H, W, 3) or (T, H, W) array
        Frame sequence, float in [0, 1] or uint8; or frames read as windows are asked for
        (:class:`wavealt.framesource.VideoFrames`), only a window's held at a time.
    fps : float, optional
        Frame rate, frames per second, of evenly spaced frames; or give ``times_s``.
    times_s : (T,) array, optional
        Each frame's time (seconds, strictly increasing; a video's timestamps). Windows
        never span a dropped frame or a change of rate (:func:`regular_runs`); each window's
        rate comes from its own times.
    focal_px : float
        Focal length in pixels.
    window : int, optional
        Frames per estimate [one second of frames, at least 10].
    step : int, optional
        Frames between window starts [half a window].
    out : path, optional
        Folder to write ``altitude.csv``, ``altitude.json`` and ``altitude.png`` (altitude
        over time) into, each atomically.
    progress : bool
        Show a progress bar over the windows.
    velocity_mps : (float, float), optional
        The camera's velocity (over the water as far as known), m/s, along image +x
        (columns) and +y (rows); None: blind (:meth:`DispersionAltimeter.estimate`).
    velocity_sigma_mps : float
        How far (m/s, one sigma) the camera's velocity over the water may lie from
        ``velocity_mps``; 0 for exact.
    readout_s : float
        A rolling shutter's readout time, s (:meth:`DispersionAltimeter.estimate`); 0: a
        global shutter.
    yaw_rate_dps : float, optional
        The camera's steady yaw rate, deg/s, taken as the truth; not given, each window's
        is measured (:meth:`DispersionAltimeter.estimate`).
    on_window : callable, optional
        Called with each window's row as soon as it is estimated (e.g. to send it to a
        flight controller).
    predicted_by : str, optional
        The codec of a video that predicts frames from other frames with loss, which the
        frames were decoded from (:func:`wavealt.framesource.predicting_codec`): a window not
        given the velocity exactly is then not trusted (:func:`.coding.predicted_verdict`).
    **kw
        Options of :class:`DispersionAltimeter` (``dispersion``, ``deglint``, ...).

    Returns
    -------
    summary : dict
        :func:`summarize` of the windows.
    rows : list of dict
        One per window: ``start_frame``, ``stop_frame``, ``time_s`` (the window's centre,
        seconds), ``fps`` (its rate) and the fields of its :class:`DispersionResult`
        (``to_dict``).
    """
    if isinstance(frames, np.ndarray) or not hasattr(frames, "shape"):
        arr = check_frames(frames, min_frames=MIN_FRAMES, allow_gray=True)
    else:  # frames read window by window (a video, :mod:`wavealt.framesource`): each
        arr = frames  # window is checked by the altimeter as it is read
    if times_s is None:
        if fps is None:
            msg = "give fps or times_s (the frames' times)"
            raise ValueError(msg)
        fps = check_finite_number("fps", fps, low=0.0, low_open=True)
        t = np.arange(arr.shape[0]) / fps
    else:
        t = np.asarray(times_s, np.float64)
        if t.shape != (arr.shape[0],):
            msg = f"times_s must hold one time per frame ({arr.shape[0]}); got shape {t.shape}"
            raise ValueError(msg)
    runs, dropped = regular_runs(t)
    if window is None:
        window = one_second_window(1.0 / float(np.median(np.diff(t))))
    ranges = [(a + s0, a + s1) for a, b in runs if b - a >= MIN_FRAMES
              for s0, s1 in sliding_windows(b - a, window=window, step=step)]
    if not ranges:
        msg = (f"no run of at least {MIN_FRAMES} evenly spaced frames in the input "
               f"({len(runs)} runs between dropped frames or changes of rate)")
        raise ValueError(msg)
    est = DispersionAltimeter(**kw)
    rows: list[dict[str, Any]] = []
    for start, stop in tqdm(ranges, desc="altitude", unit="window", disable=not progress):
        w_fps = (stop - start - 1) / (t[stop - 1] - t[start])
        res = est.estimate(arr[start:stop], fps=w_fps, focal_px=focal_px,
                           velocity_mps=velocity_mps, velocity_sigma_mps=velocity_sigma_mps,
                           readout_s=readout_s, yaw_rate_dps=yaw_rate_dps)
        rows.append({"start_frame": start, "stop_frame": stop,
                     "time_s": float(0.5 * (t[start] + t[stop - 1])), "fps": float(w_fps),
                     **predicted_verdict(res.to_dict(), predicted_by, est.altitude_range_m)})
        if on_window is not None:
            on_window(rows[-1])
    summary = summarize(rows, frames=int(arr.shape[0]))
    if predicted_by is not None and not summary["trusted"]:
        refused = PREDICTED_FRAMES.format(codec=predicted_by)
        if any(r["reason"] == refused for r in rows):  # they say more than "none trusted"
            summary["reason"] = refused
    summary["predicted_by"] = predicted_by
    summary["dropped_frames"] = int(dropped)
    summary["unused_frames"] = int(arr.shape[0] - len({i for a, b in ranges for i in range(a, b)}))
    if out is not None:
        _write_series(Path(out), summary, rows)
    return summary, rows


def _weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    """The ``w``-weighted median of ``x`` (the lower one at a tie)."""
    order = np.argsort(x)
    cw = np.cumsum(w[order])
    return float(x[order][np.searchsorted(cw, 0.5 * cw[-1])])


def summarize(rows: list[dict[str, Any]], *, frames: int) -> dict[str, Any]:
    """One estimate for a whole input from the estimates of its windows.

    The altitude is the quality-weighted median of the *trusted* windows, its uncertainty
    the larger of their robust spread (``1.4826 * MAD``) and their median uncertainty over
    ``sqrt(n)``; the camera velocity is their median.  With no trusted window the summary is
    not trusted (``reason`` ``"no window trusted"``) and is taken over every window, with an
    uncertainty no smaller than their median one (it must not look precise).  A single
    window is its own summary.

    Parameters
    ----------
    rows : list of dict
        Window rows as :func:`altitude_series` makes them (at least one).
    frames : int
        Frames of the whole input.

    Returns
    -------
    dict
        ``altitude_m``, ``altitude_std_m`` (1 sigma), ``camera_velocity_mps`` (the camera
        relative to the water surface, image +x columns / +y rows, m/s), ``quality`` (mean
        over every window), ``trusted``, ``reason`` (None when trusted), ``mode``,
        ``frames``, ``n_modes``, ``signal``, ``yaw_rate_dps`` (the median of the windows'
        rate turned back at), ``shake_px`` (the median of the shake taken out of them),
        ``windows`` and ``trusted_windows``.
    """
    if not rows:
        msg = "rows must hold at least one window; got none"
        raise ValueError(msg)
    n_trusted = sum(bool(r["trusted"]) for r in rows)
    if len(rows) == 1:
        summary = dict(rows[0])
        for key in ("start_frame", "stop_frame", "time_s", "fps"):
            summary.pop(key, None)
        summary["frames"] = int(frames)
    else:
        trusted = n_trusted > 0
        used = [r for r in rows if r["trusted"]] if trusted else rows
        alts = np.array([r["altitude_m"] for r in used])
        q = np.array([r["quality"] for r in used])
        stds = np.array([r["altitude_std_m"] for r in used])
        med = _weighted_median(alts, q + 1e-9)
        spread = float(1.4826 * np.median(np.abs(alts - med)))
        if trusted:
            std = max(spread, float(np.median(stds)) / math.sqrt(len(used)))
        else:
            std = max(spread, float(np.median(stds)))
        vel = np.median(np.array([r["camera_velocity_mps"] for r in used]), axis=0)
        summary = {"altitude_m": med, "altitude_std_m": float(std),
                   "camera_velocity_mps": [float(vel[0]), float(vel[1])],
                   "quality": float(np.mean([r["quality"] for r in rows])),
                   "trusted": trusted, "reason": None if trusted else NO_TRUSTED_WINDOW,
                   "mode": rows[0]["mode"], "frames": int(frames),
                   "n_modes": int(np.median([r["n_modes"] for r in used])),
                   "signal": Counter(r.get("signal", "") for r in used).most_common(1)[0][0],
                   "yaw_rate_dps": float(np.median([r.get("yaw_rate_dps", 0.0) for r in used])),
                   "shake_px": float(np.median([r.get("shake_px", 0.0) for r in used]))}
    summary["windows"] = len(rows)
    summary["trusted_windows"] = n_trusted
    return summary


def _csv_text(rows: list[dict[str, Any]]) -> str:
    """``altitude.csv``: one line per window (:data:`CSV_COLUMNS`)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in rows:
        vals = {**r, "camera_vx_mps": r["camera_velocity_mps"][0],
                "camera_vy_mps": r["camera_velocity_mps"][1], "trusted": int(bool(r["trusted"])),
                "reason": r["reason"] or ""}
        w.writerow([f"{vals[c]:.6g}" if isinstance(vals[c], float) else vals[c]
                    for c in CSV_COLUMNS])
    return buf.getvalue()


#: The files :func:`altitude_series` writes into its ``out`` folder.
OUT_FILES = ("altitude.csv", "altitude.json", "altitude.png")


def _write_series(out: Path, summary: dict[str, Any], rows: list[dict[str, Any]]) -> None:
    """Write ``altitude.csv``, ``altitude.json`` and ``altitude.png`` into ``out``."""
    check_output_folder(out, OUT_FILES, force=True)  # a file is still refused
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "altitude.csv", _csv_text(rows))
    atomic_write_text(out / "altitude.json",
                      json.dumps({"summary": summary, "windows": rows}, indent=2) + "\n")
    # matplotlib is imported here only: it costs the command line's start-up otherwise
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array([r["time_s"] for r in rows])
    a = np.array([r["altitude_m"] for r in rows])
    sd = np.array([r["altitude_std_m"] for r in rows])
    ok = np.array([bool(r["trusted"]) for r in rows])
    fig, ax = plt.subplots(figsize=(6, 3.2))
    ax.fill_between(t, a - sd, a + sd, alpha=0.3, label="±1 std")
    ax.plot(t, a, "-", color="C0", lw=1)
    ax.plot(t[ok], a[ok], "o", ms=3, color="C0", label="altitude (trusted)")
    if not ok.all():
        ax.plot(t[~ok], a[~ok], "x", ms=4, color="C3", label="not trusted")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("altitude (m)")
    ax.legend(loc="best")
    fig.tight_layout()
    fig.savefig(out / "altitude.png", dpi=120)
    plt.close(fig)


__all__ = ["CSV_COLUMNS", "NO_TRUSTED_WINDOW", "OUT_FILES", "altitude_series", "summarize"]
