"""Frame input for real footage: a folder of images or a video file, and sliding windows."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

VIDEO_SUFFIXES = {".mp4", ".m4v", ".mov", ".avi", ".mkv", ".webm", ".mpg", ".mpeg", ".ts"}


def read_video(path: Path | str, *, max_frames: int | None = None) -> np.ndarray:
    """Decode a video file with PyAV into ``(T, H, W, 3)`` float32 RGB in [0, 1].

    Frames are decoded one at a time (streaming); ``max_frames`` stops early.
    """
    import av

    path = Path(path)
    if not path.is_file():
        msg = f"video file not found: {path}"
        raise FileNotFoundError(msg)
    frames = []
    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                msg = f"{path} holds no video stream"
                raise ValueError(msg)
            for frame in container.decode(video=0):
                frames.append(frame.to_ndarray(format="rgb24"))
                if max_frames is not None and len(frames) >= max_frames:
                    break
    except av.error.FFmpegError as exc:
        msg = f"cannot decode video {path}: {exc}"
        raise ValueError(msg) from None
    if not frames:
        msg = f"video {path} holds no frames"
        raise ValueError(msg)
    return np.stack(frames).astype(np.float32) / 255.0


def write_video(path: Path | str, frames: np.ndarray, *, fps: float = 30.0,
                codec: str = "mpeg4") -> None:
    """Encode ``(T, H, W, 3)`` frames (float in [0, 1] or uint8) with PyAV (tests, demos)."""
    import av
    from fractions import Fraction

    from wavealt.dataset import to_uint8

    arr = frames if frames.dtype == np.uint8 else to_uint8(frames)
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream(codec, rate=Fraction(fps).limit_denominator(1000))
        stream.width, stream.height = arr.shape[2], arr.shape[1]
        stream.pix_fmt = "yuv420p"
        stream.options = {"qscale": "2"} if codec == "mpeg4" else {"crf": "12"}
        for img in arr:
            for packet in stream.encode(av.VideoFrame.from_ndarray(img, format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


def read_input(path: Path | str) -> np.ndarray:
    """Frames of ``path``: a folder of images (sorted by name) or a video file."""
    from wavealt.dataset import read_frames_folder

    path = Path(path)
    if path.is_dir():
        return read_frames_folder(path)
    if not path.exists():
        msg = f"INPUT not found: {path}"
        raise FileNotFoundError(msg)
    return read_video(path)


def sliding_windows(n_frames: int, *, window: int, step: int | None = None) -> Iterator[tuple[int, int]]:
    """``(start, stop)`` frame ranges of length ``window`` every ``step`` (default half a
    window); a sequence no longer than ``window`` gives one range covering it all."""
    if int(window) != window or window < 3:
        msg = f"window must be an integer >= 3; got {window!r}"
        raise ValueError(msg)
    step = max(1, window // 2) if step is None else int(step)
    if step < 1:
        msg = f"step must be >= 1; got {step}"
        raise ValueError(msg)
    if n_frames <= window:
        yield 0, n_frames
        return
    for start in range(0, n_frames - window + 1, step):
        yield start, start + window


__all__ = ["read_input", "read_video", "sliding_windows", "write_video"]
