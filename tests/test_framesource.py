"""Frames read window by window: a video's windows are the frames the whole decode gives,
only a window's frames are held, and ``wavealt altitude`` reads a video so with the same
results as from memory."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wavealt.camera import NadirView, pinhole
from wavealt.framesource import VideoFrames, WindowMap, predicting_codec, scan_video
from wavealt.io import read_clip, read_video_timed, write_video


def _texture(size: int = 48) -> np.ndarray:
    """A smooth random texture, uint8 RGB."""
    rng = np.random.default_rng(7)
    f = np.fft.ifft2(np.fft.fft2(rng.standard_normal((size, size)))
                     * np.exp(-np.add.outer(np.fft.fftfreq(size) ** 2,
                                            np.fft.fftfreq(size) ** 2) * 200.0)).real
    g = (f - f.min()) / np.ptp(f) * 200.0 + 20.0
    return np.repeat(g[..., None], 3, axis=-1).astype(np.uint8)


def _video(tmp_path, n: int = 40, size: int = 48):
    rng = np.random.default_rng(4)
    base = rng.integers(0, 255, (size + n, size + n, 3)).astype(np.uint8)
    frames = np.stack([base[t:t + size, t:t + size] for t in range(n)])  # moving texture
    path = tmp_path / "clip.mp4"
    write_video(path, frames, fps=20.0)
    return path


def test_windows_are_the_frames_of_the_whole_decode_and_only_a_window_is_held(tmp_path):
    path = _video(tmp_path)
    whole, times = read_video_timed(path)
    t, n, h, w = scan_video(path)
    np.testing.assert_allclose(t - t[0], times)
    frames = VideoFrames(path, n, h, w)
    assert frames.shape == whole.shape and len(frames) == n
    for a, b in [(0, 10), (5, 15), (10, 20), (30, 40), (2, 7), (35, 45)]:
        window = frames[a:b]  # forward, a jump ahead, back to the start, past the end
        np.testing.assert_array_equal(window, whole[a:b])
        assert window.dtype == np.uint8
    assert frames.max_held <= 10
    np.testing.assert_array_equal(np.asarray(frames), whole)
    assert frames[7:7].shape == (0, h, w, 3)
    with pytest.raises(TypeError, match=r"frames\[start:stop\]"):
        frames[3]
    frames.close()


def test_a_video_that_changed_since_it_was_scanned_is_an_error(tmp_path) -> None:
    """Fewer frames than the packets promised, or frames at other times than theirs: an
    error naming the frame, not a window of the wrong frames."""
    path = _video(tmp_path, n=20)
    t, n, h, w = scan_video(path)
    frames = VideoFrames(path, n + 5, h, w)  # as if the file had been longer when scanned
    with pytest.raises(ValueError, match=r"ended after 20 frames; it held 25"):
        frames[10:25]
    shifted = VideoFrames(path, n, h, w, t + np.where(np.arange(n) >= 6, 0.01, 0.0))
    np.testing.assert_array_equal(shifted[0:6], VideoFrames(path, n, h, w, t)[0:6])
    with pytest.raises(ValueError, match=r"frame 6 decodes at 0.300000 s, its packet says "
                                         r"0.310000 s; give --fps and --force-fps"):
        shifted[4:8]


def test_a_window_map_levels_each_window_as_the_whole_clip_would_be(tmp_path) -> None:
    """One attitude per frame: a window levelled at its own attitudes is the same as that
    window of the whole clip levelled."""
    path = _video(tmp_path, n=12, size=64)
    whole, _ = read_video_timed(path)
    roll = np.linspace(-4.0, 6.0, 12)
    view = NadirView(pinhole(64, 64, 60.0), 64, 64, roll_deg=roll, pitch_deg=roll / 2)
    levelled = view(whole)
    lazy = WindowMap(VideoFrames(path, *scan_video(path)[1:]),
                     lambda window, start: view(window, first=start),
                     levelled.shape, levelled.dtype)
    np.testing.assert_array_equal(lazy[4:9], levelled[4:9])
    with pytest.raises(ValueError, match="12 attitudes for frames 10-14"):
        view(whole[:5], first=10)
    with pytest.raises(ValueError, match="12 attitudes for 5 frames"):
        view(whole[:5])


def test_the_altitude_of_a_video_read_window_by_window_is_the_one_from_memory(
        tmp_path, run_cli) -> None:
    from wavealt.altimetry.series import altitude_series

    path = _video(tmp_path, n=40)
    clip = read_clip(path)
    assert isinstance(clip.frames, VideoFrames)
    kw = {"times_s": clip.times_s, "focal_px": 60.0, "window": 12, "step": 6,
          "velocity_mps": (0.1, 0.0)}
    lazy, lazy_rows = altitude_series(clip.frames, **kw)
    assert clip.frames.max_held <= 12  # one window's frames at a time
    memory, memory_rows = altitude_series(np.asarray(clip.frames), **kw)
    assert lazy_rows == memory_rows and lazy == memory
    code, out, err = run_cli(["altitude", str(path), "--focal-px", "60", "--window", "12",
                              "--step", "6", "--velocity-mps", "0.1,0", "--json"])
    assert code == 0, err
    assert json.loads(out)["altitude_m"] == pytest.approx(memory["altitude_m"], rel=1e-12)


@pytest.mark.parametrize(("codec", "name"), [("libx264", "h264"), ("mpeg4", "mpeg4"),
                                             ("mjpeg", None), ("ffv1", None)])
def test_a_codec_that_predicts_frames_from_others_is_named(tmp_path, codec, name) -> None:
    """H.264 and MPEG-4 code most frames from other frames, with loss (their packets are
    not key frames); Motion JPEG codes every frame alone; FFV1 predicts without loss."""
    frames = np.stack([np.roll(_texture(), t, axis=1) for t in range(12)])  # moving
    path = tmp_path / ("clip.mkv" if codec == "ffv1" else "clip.mp4")
    write_video(path, frames, codec=codec)
    assert predicting_codec(path) == name
    with pytest.raises(FileNotFoundError, match="video file not found"):
        predicting_codec(tmp_path / "missing.mp4")
