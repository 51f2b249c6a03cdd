"""Frame times from the source: a video's timestamps, natural order in frame folders, a
frame-times CSV, dropped frames and variable rate, and ``--fps`` that contradicts the file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wavealt.altimetry.series import altitude_series
from wavealt.io import (
    nominal_rate,
    read_clip,
    read_frame_times,
    read_frames_folder,
    read_video,
    regular_runs,
    write_png,
    write_video,
)
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence


def _levels(n: int, size: int = 16) -> np.ndarray:
    """``n`` flat frames whose grey level encodes their index."""
    return np.broadcast_to((np.arange(n, dtype=np.float32) / (n + 1))[:, None, None, None],
                           (n, size, size, 3)).copy()


def test_frame_folder_is_read_in_natural_order(tmp_path) -> None:
    frames = _levels(12)
    for i, f in enumerate(frames):  # frame_1 ... frame_12: text order would be 1, 10, 11, 12, 2
        write_png(tmp_path / f"frame_{i + 1}.png", f)
    back = read_frames_folder(tmp_path)
    assert np.all(np.diff(back[:, 0, 0, 0]) > 0)


def test_regular_runs_split_at_gaps_and_follow_a_slow_rate_change() -> None:
    t = np.arange(20) / 30.0
    assert regular_runs(t) == ([(0, 20)], 0)
    cut = np.delete(t, [7, 13, 14])  # one, then two dropped frames
    runs, dropped = regular_runs(cut)
    assert runs == [(0, 7), (7, 12), (12, 17)] and dropped == 3
    vfr = np.concatenate([[0.0], np.cumsum(np.linspace(1 / 30, 1 / 25, 40))])
    assert regular_runs(vfr) == ([(0, 41)], 0)  # 30 -> 25 fps, gradually: one run
    with pytest.raises(ValueError, match="strictly increasing"):
        regular_runs(np.array([0.0, 0.1, 0.1]))


def test_video_times_are_its_timestamps(tmp_path) -> None:
    frames = _levels(12, 32)
    times = np.array([0, 1, 2, 3, 5, 6, 7, 8, 9, 10, 11, 12]) / 25.0  # frame 4 dropped, 25 fps
    path = tmp_path / "clip.mp4"
    write_video(path, frames, fps=25.0, times_s=times)
    clip = read_clip(path)
    assert clip.timing == "timestamps"
    np.testing.assert_allclose(clip.times_s, times, atol=1e-4)
    assert nominal_rate(clip.times_s) == pytest.approx(25.0, rel=1e-3)
    assert read_clip(path, fps=25.0).source_fps == pytest.approx(25.0, rel=1e-3)  # agrees: fine
    with pytest.raises(ValueError, match=r"--fps 15 contradicts the video's own frame rate, 25"):
        read_clip(path, fps=15.0)
    forced = read_clip(path, fps=15.0, force_fps=True)
    np.testing.assert_allclose(forced.times_s, np.arange(12) / 15.0)
    assert forced.timing == "fps"
    # a video's frames stay 8-bit as decoded (a quarter of a float copy); read_video's are
    # the same values as floats
    assert clip.frames.dtype == np.uint8 and forced.frames.dtype == np.uint8
    np.testing.assert_array_equal(forced.frames, clip.frames)
    floats = read_video(path)
    assert floats.dtype == np.float32
    np.testing.assert_array_equal(np.rint(floats * 255.0).astype(np.uint8), clip.frames)


def test_folder_timing_and_its_errors(tmp_path) -> None:
    folder = tmp_path / "f"
    folder.mkdir()
    for i, f in enumerate(_levels(5)):
        write_png(folder / f"f{i}.png", f)
    with pytest.raises(ValueError, match="has no timestamps: give --fps or --frame-times"):
        read_clip(folder)
    with pytest.raises(ValueError, match="--force-fps needs --fps"):
        read_clip(folder, force_fps=True)
    csv = tmp_path / "t.csv"
    csv.write_text("file,time_s\n" + "".join(f"f{i}.png,{10 + 0.05 * i}\n" for i in range(5)))
    clip = read_clip(folder, frame_times=csv)
    np.testing.assert_allclose(clip.times_s, 0.05 * np.arange(5), atol=1e-9)
    assert clip.source_fps == pytest.approx(20.0)
    bad = {"time,x\n1,2\n": "needs a header with the column\\(s\\) time_s",
           "time_s\n0\n0.1\n": "has 2 rows for 5 frames",
           "time_s\n0\n0.1\n0.1\n0.2\n0.3\n": "strictly increasing",
           "time_s\n0\nabc\n0.2\n0.3\n0.4\n": "every time_s must be a number"}
    for text, match in bad.items():
        csv.write_text(text)
        with pytest.raises(ValueError, match=match):
            read_frame_times(csv, 5)
    with pytest.raises(FileNotFoundError, match="frame-times file not found"):
        read_clip(folder, frame_times=tmp_path / "missing.csv")


def _waves(n: int, fps: float) -> tuple[np.ndarray, float, float]:
    """``n`` frames of 64 px linear in the surface slope (an idealised camera) at ``fps``,
    hovering at 3 m over still water; the focal length and the altitude."""
    cfg = preset_config("paper", size=64, frames=n, fps=fps, altitude_m=(3.0, 3.0),
                        wind_speed_mps=(7.0, 7.0))
    data = generate_sequence(cfg.sample_scenario(1), cfg)
    x = data.slope_x + 0.7 * data.slope_y
    x = (x - x.min()) / (x.max() - x.min())
    return x.astype(np.float32), cfg.focal_px, 3.0


def test_windows_never_span_a_dropped_frame_and_take_their_own_rate() -> None:
    frames, focal_px, _ = _waves(31, 30.0)
    t = np.arange(31) / 30.0
    keep = np.r_[0:15, 16:31]  # frame 15 dropped
    summary, rows = altitude_series(frames[keep], times_s=t[keep], focal_px=focal_px, window=10,
                                    step=5, dispersion="gravity", velocity_mps=(0.0, 0.0))
    assert summary["dropped_frames"] == 1
    for r in rows:
        assert r["stop_frame"] <= 15 or r["start_frame"] >= 15  # no window across the gap
        assert r["fps"] == pytest.approx(30.0)
    # the same windows, read at their own times, equal the evenly spaced estimate
    _, plain = altitude_series(frames[:15], fps=30.0, focal_px=focal_px, window=10, step=5,
                               dispersion="gravity", velocity_mps=(0.0, 0.0))
    assert [r["altitude_m"] for r in rows[:len(plain)]] == pytest.approx(
        [r["altitude_m"] for r in plain], rel=1e-9)


def test_the_rate_reaches_the_estimate(tmp_path) -> None:
    """The same frames stamped at half the rate read at 4x the altitude (omega^2 ~ 1/h): the
    timestamps, not an assumed rate, drive the physics."""
    frames, focal_px, alt = _waves(20, 30.0)
    t = np.arange(20) / 30.0
    kw = dict(focal_px=focal_px, window=20, dispersion="gravity", velocity_mps=(0.0, 0.0),
              altitude_range_m=(0.5, 40.0))
    right, _ = altitude_series(frames, times_s=t, **kw)
    slow, _ = altitude_series(frames, times_s=2 * t, **kw)
    assert right["altitude_m"] == pytest.approx(alt, rel=0.03)
    assert slow["altitude_m"] == pytest.approx(4 * right["altitude_m"], rel=0.03)


def test_cli_reads_timestamps_and_refuses_contradictions(tmp_path, run_cli) -> None:
    frames, focal_px, _ = _waves(20, 30.0)
    path = tmp_path / "clip.mp4"
    write_video(path, frames, fps=30.0)
    base = ["altitude", str(path), "--focal-px", str(focal_px), "--dispersion", "gravity",
            "--velocity-mps", "0,0"]
    code, out, err = run_cli([*base, "--json"])
    assert code == 0, err
    assert json.loads(out)["dropped_frames"] == 0
    code, _, err = run_cli([*base, "--fps", "15"])
    assert code == 2 and "contradicts the video's own frame rate" in err
    assert err.strip().count("\n") == 0
    code, out, err = run_cli([*base, "--fps", "15", "--force-fps"])
    assert code == 0 and "frame times from --fps (15 fps)" in out


def test_out_is_checked_before_the_work_and_nothing_is_replaced(tmp_path, run_cli) -> None:
    frames, focal_px, _ = _waves(12, 30.0)
    path = tmp_path / "clip.mp4"
    write_video(path, frames, fps=30.0)
    base = ["altitude", str(path), "--focal-px", str(focal_px), "--velocity-mps", "0,0"]
    afile = tmp_path / "a.txt"
    afile.write_text("keep")
    code, _, err = run_cli([*base, "--out", str(afile)])
    assert code == 2 and "is a file; give a folder" in err and afile.read_text() == "keep"
    out = tmp_path / "series"
    out.mkdir()
    (out / "altitude.csv").write_text("earlier result")
    code, _, err = run_cli([*base, "--out", str(out)])
    assert code == 2 and "already holds altitude.csv" in err and "--force" in err
    assert (out / "altitude.csv").read_text() == "earlier result"
    code, _, err = run_cli([*base, "--out", str(out), "--force"])
    assert code == 0, err
    assert (out / "altitude.csv").read_text().startswith("start_frame,stop_frame,time_s,fps,")
