"""Frames read as they are needed: a video decoded window by window, and a map applied to
each window of such frames (the level view), so that a long recording is never held in memory
whole.  ``wavealt altitude VIDEO`` reads through these: at 1080 lines a second of video is
0.19 GB of 8-bit frames, a minute 11 GB.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from itertools import islice
from pathlib import Path
from typing import Any

import numpy as np


@contextmanager
def open_video(path: Path | str) -> Iterator[Any]:
    """A PyAV container of the video file ``path`` that holds a video stream, closed on
    leaving; decoding errors inside raised as one-line ValueErrors naming the file
    (a missing file as ``FileNotFoundError``).  Every reader of video files opens them
    here."""
    import av  # deferred: 0.4 s, only for video files

    path = Path(path)
    if not path.is_file():
        msg = f"video file not found: {path}"
        raise FileNotFoundError(msg)
    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                msg = f"{path} holds no video stream"
                raise ValueError(msg)
            yield container
    except av.error.FFmpegError as exc:
        msg = f"cannot decode video {path}: {exc}"
        raise ValueError(msg) from None


def scan_video(path: Path | str) -> tuple[np.ndarray | None, int, int, int]:
    """Every frame's presentation time (seconds, ascending; None where a packet has none),
    the number of frames and their height and width, from the container's packets (no
    frame decoded but the first): 0.14 s for ten seconds of 1080-line H.264, against 18 s
    to decode it.  :class:`VideoFrames` holds the decoder to these times."""
    with open_video(path) as container:
        stream = container.streams.video[0]
        pts = [p.pts for p in container.demux(stream) if p.size]
        base = stream.time_base
    with open_video(path) as container:
        first = next(iter(container.decode(video=0)), None)
    if not pts or first is None:
        msg = f"video {path} holds no frames"
        raise ValueError(msg)
    t = (None if any(x is None or base is None for x in pts)
         else np.sort(np.asarray(pts, np.float64)) * float(base))
    return t, len(pts), first.height, first.width


def lossy_predicting(codec: Any) -> str | None:
    """The name (FFmpeg's) of PyAV codec context ``codec`` where its codec is lossy, which a
    codec that predicts frames from other frames then does with loss (H.264, HEVC, MPEG-4,
    VP9); None for a lossless one (FFV1, raw video), whose predictions lose nothing."""
    return codec.name if codec.codec.lossy else None


def predicting_codec(path: Path | str) -> str | None:
    """The name (FFmpeg's) of the codec of video file ``path`` where it predicts frames from
    other frames with loss (a packet that is not a key frame, of a lossy codec: H.264, HEVC,
    ... with P- or B-frames), None where every frame is coded alone (Motion JPEG,
    all-key-frame video) or the codec is lossless (FFV1); from the packets, no frame decoded
    (:mod:`wavealt.altimetry.coding` says what such prediction does to a fit)."""
    with open_video(path) as container:
        stream = container.streams.video[0]
        predicted = any(p.size and not p.is_keyframe for p in container.demux(stream))
        return lossy_predicting(stream.codec_context) if predicted else None


class _Windows:
    """Frames ``(T, H, W[, 3])`` read as windows, ``frames[start:stop]`` (``shape`` and
    ``_window`` given by the subclass); ``np.asarray`` reads them all."""

    ndim = 4
    shape: tuple[int, ...]

    def __len__(self) -> int:
        return self.shape[0]

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        out = self[0:len(self)]
        return out if dtype is None else out.astype(dtype)

    def __getitem__(self, key: slice) -> np.ndarray:
        if not isinstance(key, slice) or key.step not in (None, 1):
            msg = "frames are read as windows: frames[start:stop]"
            raise TypeError(msg)
        start, stop, _ = key.indices(self.shape[0])
        return self._window(start, stop)

    def _window(self, start: int, stop: int) -> np.ndarray:
        raise NotImplementedError


class VideoFrames(_Windows):
    """The frames of a video file, ``(T, H, W, 3)`` uint8 RGB, decoded as windows of them are
    asked for: ``frames[a:b]`` decodes up to frame ``b`` and keeps only the frames from ``a``
    on, so windows that move forward (sliding windows) hold one window's frames at a time
    (``max_held`` records the most).  A window that starts before the frames held decodes
    the file again from its start.  ``np.asarray(frames)`` decodes them all.

    ``n_frames``, ``height``, ``width`` and ``times_s`` (absolute, or None): :func:`scan_video`'s,
    which the decoder must give again, frame by frame (a file whose packets and frames
    disagree, or that changed since, is an error, not a wrong window).
    """

    dtype = np.dtype(np.uint8)

    def __init__(self, path: Path | str, n_frames: int, height: int, width: int,
                 times_s: np.ndarray | None = None) -> None:
        self.path = Path(path)
        self.shape = (int(n_frames), int(height), int(width), 3)
        self.times_s = times_s
        self.max_held = 0
        self._held: deque[np.ndarray] = deque()
        self._first = 0  # index of the first frame held (the next to decode when none is)
        self._next = 0  # index of the next frame the decoder gives
        self._opened: Any = None  # the open_video context, entered
        self._frames: Any = None

    def _open(self) -> None:
        self.close()
        self._opened = open_video(self.path)
        self._frames = self._opened.__enter__().decode(video=0)
        self._held.clear()
        self._first = self._next = 0

    def _decode_next(self) -> np.ndarray:
        import av

        try:
            frame = next(self._frames)
        except StopIteration:
            msg = (f"video {self.path} ended after {self._next} frames; it held "
                   f"{self.shape[0]} when it was first read")
            raise ValueError(msg) from None
        except av.error.FFmpegError as exc:  # raised where the context cannot see it
            msg = f"cannot decode video {self.path}: {exc}"
            raise ValueError(msg) from None
        want = None if self.times_s is None else float(self.times_s[self._next])
        if want is not None and frame.time is not None and abs(frame.time - want) > 1e-6:
            msg = (f"video {self.path}: frame {self._next} decodes at {frame.time:.6f} s, its "
                   f"packet says {want:.6f} s; give --fps and --force-fps")
            raise ValueError(msg)
        arr = frame.to_ndarray(format="rgb24")
        if arr.shape != self.shape[1:]:
            msg = f"video {self.path}: frame {self._next} is {arr.shape}, not {self.shape[1:]}"
            raise ValueError(msg)
        self._next += 1
        return arr

    def _window(self, start: int, stop: int) -> np.ndarray:
        if stop <= start:
            return np.empty((0, *self.shape[1:]), np.uint8)
        if self._frames is None or start < self._first:
            self._open()
        while self._held and self._first < start:  # frames before the window: let go
            self._held.popleft()
            self._first += 1
        if not self._held:
            self._first = self._next
        while self._next < stop:
            arr = self._decode_next()
            if self._next - 1 < start:  # before the window (a jump forward): not kept
                self._first = self._next
                continue
            self._held.append(arr)
        self.max_held = max(self.max_held, len(self._held))
        return np.stack(list(islice(self._held, start - self._first, stop - self._first)))

    def close(self) -> None:
        """Close the decoder (a later window opens it again)."""
        if self._opened is not None:
            self._opened.__exit__(None, None, None)
        self._opened = self._frames = None


class WindowMap(_Windows):
    """``fn`` applied to each window of frames ``source`` as it is asked for:
    ``view[a:b] = fn(source[a:b], a)``, of shape ``shape`` (``source``'s frame count); the
    window's start tells ``fn`` which frames it has (a level view with one attitude per
    frame)."""

    def __init__(self, source: Any, fn: Callable[[np.ndarray, int], np.ndarray],
                 shape: tuple[int, ...], dtype: Any) -> None:
        self.source, self.fn = source, fn
        self.shape, self.dtype = tuple(shape), np.dtype(dtype)

    def _window(self, start: int, stop: int) -> np.ndarray:
        return self.fn(self.source[start:stop], start)
