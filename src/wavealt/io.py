"""Files: atomic writes, images, frame folders, video and frame times. Every stage writes
through this module, so the rules hold everywhere: a file or frame folder appears whole or
not at all (written under a temporary name, then renamed), and it gets the permissions a
plain ``open`` would give it (the umask's), not the ``0o600`` of a temporary file.

Frames are ``(T, H, W, 3)`` float32 in [0, 1]; images on disk are 8-bit RGB. The times of a
video's frames are its presentation timestamps (PTS); a frame folder is read in natural
order (``frame_2`` before ``frame_10``) at ``--fps`` or at the times of a CSV.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from fractions import Fraction
from io import BytesIO
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from natsort import natsorted
from PIL import Image, UnidentifiedImageError

from wavealt._checks import check_frames, check_integer, read_number_columns


# -- atomic writes ------------------------------------------------------------------------
def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def publish(tmp: Path | str, path: Path | str) -> None:
    """Move a finished temporary file onto ``path`` with the permissions a plain ``open``
    would give it (``0o666`` less the umask; ``mkstemp`` makes files ``0o600``)."""
    os.chmod(tmp, 0o666 & ~_umask())
    os.replace(tmp, path)


@contextmanager
def atomic_path(path: Path | str, *, suffix: str = "") -> Iterator[Path]:
    """The one atomic-write pattern: yield a temporary path beside ``path`` for the caller
    to write; on success it replaces ``path`` (umask permissions), on any error it goes.

    ``suffix`` keeps an extension on the temporary name for writers that add one
    (``np.savez`` appends ``.npz`` to a name without it).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        publish(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: Path | str, text: str) -> None:
    """Write ``text`` (UTF-8, newlines as given) to ``path`` atomically."""
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as fh:
        fh.write(text)


def atomic_save_npz(path: Path | str, **arrays: np.ndarray) -> None:
    """``np.savez_compressed`` to ``path`` atomically."""
    with atomic_path(path, suffix=".npz") as tmp:
        np.savez_compressed(tmp, **arrays)


def check_output_folder(out: Path | str, names: Iterable[str], *, force: bool = False,
                        what: str | None = None) -> Path:
    """The one overwrite rule of every command: ``out`` must be a folder (or not exist yet),
    and one that already holds any of ``names`` is refused unless ``force`` — before any
    work, so nothing written earlier is replaced silently. ``what`` names the earlier
    result in the message (default: the files found)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        msg = f"--out {out} is a file; give a folder"
        raise ValueError(msg)
    held = [n for n in names if (out / n).exists()]
    if held and not force:
        msg = f"--out {out} already holds {what or ', '.join(held)}; use another folder or --force"
        raise ValueError(msg)
    return out

# -- images and frame folders ---------------------------------------------------------------
def to_uint8(frames: np.ndarray) -> np.ndarray:
    """Float frames in [0, 1] to uint8, rounding to nearest."""
    return np.round(np.clip(frames, 0.0, 1.0) * 255.0).astype(np.uint8)


def write_png(path: Path | BinaryIO, image: np.ndarray) -> None:
    """Write one ``(H, W, 3)`` frame (float in [0, 1] or uint8) as an 8-bit RGB PNG, to a
    path or a binary stream (the same bytes either way)."""
    img = image if image.dtype == np.uint8 else to_uint8(image)
    Image.fromarray(img, mode=None).save(path, format="PNG", compress_level=1)


def encode_png(image: np.ndarray) -> bytes:
    """The bytes :func:`write_png` writes for ``image``."""
    buf = BytesIO()
    write_png(buf, image)
    return buf.getvalue()


def decode_png(data: bytes, name: str) -> np.ndarray:
    """An image file's bytes as ``(H, W, 3)`` uint8 (exact values); ``name`` says where the
    bytes came from in the error message."""
    try:
        with Image.open(BytesIO(data)) as im:
            return np.asarray(im.convert("RGB"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError) as exc:
        msg = f"cannot read image {name}: {exc}"
        raise ValueError(msg) from None


#: Pillow's modes of 16-bit grey images (PNG, TIFF): a machine-vision camera's frames.
GREY16_MODES = ("I;16", "I;16B", "I;16L", "I;16N")


def read_png(path: Path) -> np.ndarray:
    """Read an image file as ``(H, W, 3)`` float32 in [0, 1].  A 16-bit image keeps its 16
    bits (each value over 65535; a grey one in all three channels): converted to 8-bit RGB
    as other modes are, a grey one's every value above 255 would read as white, and a colour
    one would lose its lower 8 bits."""
    path = Path(path)
    if not path.is_file():
        msg = f"image file not found: {path}"
        raise FileNotFoundError(msg)
    try:
        with Image.open(path) as im:
            if im.mode in GREY16_MODES or im.mode in ("I", "F"):
                grey = _grey16(np.asarray(im), im.mode, path)
                return np.repeat(grey[..., None], 3, axis=2)
            if _colour16(im, path):
                return _read_colour16(path)
            arr = np.asarray(im.convert("RGB"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError) as exc:
        msg = f"cannot read image {path}: {exc}"
        raise ValueError(msg) from None
    return arr.astype(np.float32) / 255.0


def _colour16(im: Image.Image, path: Path) -> bool:
    """Whether ``im``, opened from ``path``, is colour of 16 bits a channel (PNG or TIFF),
    which Pillow opens as 8-bit RGB: the PNG header's bit depth, the TIFF's bits a sample."""
    if im.mode not in ("RGB", "RGBA"):
        return False
    if im.format == "PNG":
        with open(path, "rb") as fh:
            head = fh.read(25)
        return len(head) == 25 and head[24] == 16  # IHDR: 8 + 8 bytes, width, height, depth
    if im.format == "TIFF":
        bits = im.tag_v2.get(258)
        return max(bits if isinstance(bits, tuple) else (bits or 8,)) == 16
    return False


def _read_colour16(path: Path) -> np.ndarray:
    """A 16-bit colour image as ``(H, W, 3)`` float32 in [0, 1] (OpenCV's reader, which keeps
    the 16 bits that Pillow drops)."""
    import cv2  # deferred: 0.45 s, and only 16-bit colour frames need it

    arr = cv2.imread(str(path), cv2.IMREAD_COLOR | cv2.IMREAD_ANYDEPTH)
    if arr is None or arr.dtype != np.uint16:
        msg = f"cannot read image {path}: a 16-bit colour image OpenCV cannot decode"
        raise ValueError(msg)
    return np.ascontiguousarray(arr[..., ::-1]).astype(np.float32) / np.float32(65535.0)


def _grey16(arr: np.ndarray, mode: str, path: Path) -> np.ndarray:
    """A grey image of Pillow ``mode`` as float32 in [0, 1]: 16-bit values over 65535; a
    32-bit integer image (mode ``I``, as some 16-bit files open) only where its values are
    16-bit; a float image (mode ``F``) has no scale to read it by."""
    if mode == "F" or (mode == "I" and (arr.min() < 0 or arr.max() > 65535)):
        kind = "32-bit float" if mode == "F" else "32-bit integer"
        msg = (f"cannot read image {path}: {kind} pixels have no scale to read them by; "
               f"give 8- or 16-bit images")
        raise ValueError(msg)
    return arr.astype(np.float32) / np.float32(65535.0)


def frame_files(folder: Path) -> list[Path]:
    """Image files of a frame folder in natural order (``frame_2`` before ``frame_10``)."""
    exts = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"}
    return natsorted((p for p in Path(folder).iterdir()
                      if p.suffix.lower() in exts and p.is_file()), key=lambda p: p.name)


def read_frames_folder(folder: Path | str) -> np.ndarray:
    """Read every image of ``folder`` (natural order) as ``(T, H, W, 3)`` float32."""
    folder = Path(folder)
    if not folder.is_dir():
        msg = f"frame folder not found: {folder}"
        raise FileNotFoundError(msg)
    files = frame_files(folder)
    if not files:
        msg = f"frame folder {folder} holds no image files"
        raise ValueError(msg)
    frames = [read_png(p) for p in files]
    shapes = {f.shape for f in frames}
    if len(shapes) > 1:
        msg = f"frames in {folder} have different sizes: {sorted(shapes)}"
        raise ValueError(msg)
    return np.stack(frames)


def write_frames_folder(folder: Path | str, frames: np.ndarray) -> None:
    """Write ``(T, H, W, 3)`` frames as ``frame_000.png`` ... atomically.

    The frames go to a temporary sibling folder which is renamed to ``folder``; an existing
    ``folder`` is replaced only once the new one is complete.
    """
    frames = check_frames(frames)
    folder = Path(folder)
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.tmp-", dir=folder.parent))
    try:
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes it 0o700
        for t, frame in enumerate(frames):
            write_png(tmp / f"frame_{t:03d}.png", frame)
        if folder.exists():
            old = folder.with_name(f".{folder.name}.old-{os.getpid()}")
            folder.rename(old)
            tmp.rename(folder)
            shutil.rmtree(old)
        else:
            tmp.rename(folder)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise



# -- video and frame times ----------------------------------------------------------------
VIDEO_SUFFIXES = {".mp4", ".m4v", ".mov", ".avi", ".mkv", ".webm", ".mpg", ".mpeg", ".ts"}
#: ``--fps`` may differ from a video's own rate by this fraction before it is a contradiction.
FPS_TOLERANCE = 0.01


@dataclass(frozen=True)
class Clip:
    """Frames and when they were taken.

    ``frames``: ``(T, H, W, 3)`` float32 in [0, 1] (a folder of images) or uint8 as decoded
    (a video: :class:`wavealt.framesource.VideoFrames`, decoded window by window as
    ``frames[a:b]`` asks, never whole; ``np.asarray`` decodes it all); ``times_s``:
    ``(T,)`` seconds from the first frame, strictly increasing; ``source_fps``: the rate the
    source records (a video's timestamps, ``--fps`` or the CSV's median spacing);
    ``timing``: where the times came from (``"timestamps"``, ``"fps"``, ``"csv"``);
    ``predicted_by``: the codec of a video that predicts frames from other frames with loss
    (:func:`wavealt.framesource.predicting_codec`), None for frames coded alone or without
    loss.
    """

    frames: Any
    times_s: np.ndarray
    source_fps: float
    timing: str
    predicted_by: str | None = None


def read_video(path: Path | str, *, max_frames: int | None = None) -> np.ndarray:
    """Decode a video file with PyAV into ``(T, H, W, 3)`` float32 RGB in [0, 1].

    Frames are decoded one at a time (streaming); ``max_frames`` stops early.
    """
    frames = _decode(path, max_frames=max_frames)[0].astype(np.float32)
    frames /= np.float32(255.0)  # in place: one float copy of the clip, not two
    return frames


def read_video_timed(path: Path | str, *,
                     max_frames: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A video's frames, ``(T, H, W, 3)`` uint8 as decoded, and their presentation times in
    seconds from the first frame."""
    frames, times = _decode(path, max_frames=max_frames)
    if times is None:
        msg = f"video {path} has frames without timestamps; give --fps and --force-fps"
        raise ValueError(msg)
    return frames, times


def _decode(path: Path | str, *,
            max_frames: int | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    from wavealt.framesource import open_video

    frames, times = [], []
    with open_video(path) as container:
        for frame in container.decode(video=0):
            frames.append(frame.to_ndarray(format="rgb24"))
            times.append(frame.time)
            if max_frames is not None and len(frames) >= max_frames:
                break
    if not frames:
        msg = f"video {path} holds no frames"
        raise ValueError(msg)
    arr = np.stack(frames)  # uint8: a float copy would take four times the memory
    if any(t is None for t in times):
        return arr, None
    t = np.asarray(times, np.float64)
    order = np.argsort(t, kind="stable")  # decoders return presentation order; be sure
    if np.any(np.diff(t[order]) <= 0):
        msg = f"video {path} repeats a frame timestamp; give --fps and --force-fps"
        raise ValueError(msg)
    return arr[order], t[order] - t[order][0]


#: A frame interval that differs from the running one by more than this fraction breaks the
#: input: windows never span a dropped frame or a change of rate.
GAP_TOLERANCE = 0.25


def regular_runs(times_s: np.ndarray) -> tuple[list[tuple[int, int]], int]:
    """Split frame times into runs of evenly spaced frames.

    Returns the ``(start, stop)`` frame ranges of the runs and the number of frames missing
    between them (a gap of ``n`` intervals counts ``n - 1`` dropped frames). The running
    interval follows a slowly varying rate (variable frame rate) and restarts after a break.
    """
    t = np.asarray(times_s, np.float64)
    if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        msg = "times_s must be finite and strictly increasing"
        raise ValueError(msg)
    runs, dropped, start, ref = [], 0, 0, None
    for i, d in enumerate(np.diff(t)):
        if ref is not None and abs(d / ref - 1.0) > GAP_TOLERANCE:
            runs.append((start, i + 1))
            dropped += max(0, round(d / ref) - 1)
            start, ref = i + 1, None
            continue
        ref = d if ref is None else 0.9 * ref + 0.1 * d
    runs.append((start, t.size))
    return runs, dropped


def nominal_rate(times_s: np.ndarray) -> float:
    """Frames per second of ``times_s``: over the span of its longest run of evenly spaced
    frames (dropped frames and timestamp rounding do not bias it); NaN for one frame."""
    runs, _ = regular_runs(times_s)
    a, b = max(runs, key=lambda r: r[1] - r[0])
    return float((b - a - 1) / (times_s[b - 1] - times_s[a])) if b - a > 1 else math.nan


def read_frame_times(path: Path | str, n_frames: int) -> np.ndarray:
    """Frame times from a CSV: a header with a ``time_s`` column, one row per frame in the
    folder's (natural) order; seconds, strictly increasing. Returned from the first frame."""
    t = read_number_columns(path, ("time_s",), "frame-times file")[:, 0]
    if t.size != n_frames:
        msg = f"frame-times file {path} has {t.size} rows for {n_frames} frames"
        raise ValueError(msg)
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        msg = f"frame-times file {path}: time_s must be finite and strictly increasing"
        raise ValueError(msg)
    return t - t[0]


def read_clip(path: Path | str, *, fps: float | None = None, frame_times: Path | str | None = None,
              force_fps: bool = False) -> Clip:
    """Frames of ``path`` (a folder of images or a video file) with their times.

    A video's times are its timestamps. ``fps`` that contradicts them (by more than
    :data:`FPS_TOLERANCE`) is an error, unless ``force_fps``, which replaces them with
    evenly spaced times at ``fps``. A folder needs ``fps`` or ``frame_times`` (a CSV, see
    :func:`read_frame_times`).
    """
    path = Path(path)
    if fps is not None and not (math.isfinite(fps) and fps > 0):
        msg = f"--fps must be a positive number; got {fps!r}"
        raise ValueError(msg)
    if force_fps and fps is None:
        msg = "--force-fps needs --fps (the rate to use)"
        raise ValueError(msg)
    if fps is not None and frame_times is not None:
        msg = "give one of --fps and --frame-times, not both"
        raise ValueError(msg)
    if path.is_dir():
        frames = read_frames_folder(path)
        if frame_times is not None:
            t = read_frame_times(frame_times, frames.shape[0])
            return Clip(frames, t, nominal_rate(t), "csv")
        if fps is None:
            msg = f"frame folder {path} has no timestamps: give --fps or --frame-times CSV"
            raise ValueError(msg)
        return Clip(frames, np.arange(frames.shape[0]) / fps, float(fps), "fps")
    if not path.exists():
        msg = f"INPUT not found: {path}"
        raise FileNotFoundError(msg)
    if frame_times is not None:
        msg = "--frame-times is for frame folders; a video's frames carry their own timestamps"
        raise ValueError(msg)
    from wavealt.framesource import VideoFrames, predicting_codec, scan_video

    times, n, height, width = scan_video(path)
    codec = predicting_codec(path)
    if force_fps:
        frames = VideoFrames(path, n, height, width)
        return Clip(frames, np.arange(n) / fps, float(fps), "fps", codec)
    if times is None:
        msg = f"video {path} has frames without timestamps; give --fps and --force-fps"
        raise ValueError(msg)
    if np.all(np.diff(times) > 0):  # read window by window as the fit asks for them
        frames: np.ndarray | VideoFrames = VideoFrames(path, n, height, width, times)
        t = times - times[0]
    else:  # a repeated timestamp: decoded whole, where it is refused in one line
        frames, t = read_video_timed(path)
    own = nominal_rate(t)
    if fps is not None and math.isfinite(own) and abs(fps / own - 1.0) > FPS_TOLERANCE:
        msg = (f"--fps {fps:g} contradicts the video's own frame rate, {own:.3g} fps from its "
               "timestamps; drop --fps, or add --force-fps to override the timestamps")
        raise ValueError(msg)
    return Clip(frames, t, own, "timestamps", codec)


def write_video(path: Path | str, frames: np.ndarray, *, fps: float = 30.0,
                codec: str = "mpeg4", times_s: np.ndarray | None = None) -> None:
    """Encode ``(T, H, W, 3)`` or grey ``(T, H, W)`` frames (float in [0, 1] or uint8) with
    PyAV (tests, demos).

    ``times_s`` stamps each frame with its own time (a 1/60000 s clock, within MPEG-4's
    limit) instead of ``1 / fps`` steps: variable frame rate and dropped frames.
    """
    import av  # deferred: 0.4 s, only for video files

    arr = frames if frames.dtype == np.uint8 else to_uint8(frames)
    if arr.ndim == 3:  # grey frames: written as RGB
        arr = np.repeat(arr[..., None], 3, axis=-1)
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream(codec, rate=Fraction(fps).limit_denominator(1000))
        stream.width, stream.height = arr.shape[2], arr.shape[1]
        # Motion JPEG codes every frame alone (full-range YUV); FFV1 is lossless
        stream.pix_fmt = "yuvj420p" if codec == "mjpeg" else "yuv420p"
        stream.options = {"mpeg4": {"qscale": "2"}, "mjpeg": {"qmin": "1", "qmax": "2"},
                          "ffv1": {}}.get(codec, {"crf": "12"})
        if times_s is not None:
            stream.codec_context.time_base = Fraction(1, 60000)
        for i, img in enumerate(arr):
            frame = av.VideoFrame.from_ndarray(img, format="rgb24")
            if times_s is not None:
                frame.pts = round(float(times_s[i]) * 60000)
                frame.time_base = Fraction(1, 60000)
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


def read_input(path: Path | str) -> np.ndarray:
    """Frames of ``path``: a folder of images (natural order) or a video file."""
    path = Path(path)
    if path.is_dir():
        return read_frames_folder(path)
    if not path.exists():
        msg = f"INPUT not found: {path}"
        raise FileNotFoundError(msg)
    return read_video(path)


#: Fewest frames of a default window (:func:`one_second_window`).
MIN_DEFAULT_WINDOW = 10


def one_second_window(fps: float) -> int:
    """Frames of the default window of a clip at ``fps`` frames/s: one second of them, at
    least ``MIN_DEFAULT_WINDOW``.  The dispersion fit's reach is set by the clip's duration
    (its periodogram's bin is ``2 pi fps / T`` rad/s), so a fast camera takes more frames:
    30 frames at 60 fps are half a second, which reads as the half-second row of
    ``benchmarks/bench_dispersion.py`` does, not the 1-s one."""
    return max(MIN_DEFAULT_WINDOW, round(float(fps)))


def sliding_windows(n_frames: int, *, window: int,
                    step: int | None = None) -> Iterator[tuple[int, int]]:
    """``(start, stop)`` frame ranges of length ``window`` every ``step`` (default half a
    window); a sequence no longer than ``window`` gives one range covering it all."""
    window = check_integer("window", window, low=3)
    step = max(1, window // 2) if step is None else check_integer("step", step, low=1)
    if n_frames <= window:
        yield 0, n_frames
        return
    for start in range(0, n_frames - window + 1, step):
        yield start, start + window


__all__ = ["FPS_TOLERANCE", "GAP_TOLERANCE", "Clip", "atomic_path", "atomic_save_npz",
           "atomic_write_text", "check_output_folder", "decode_png", "encode_png", "frame_files",
           "nominal_rate", "one_second_window", "publish",
           "read_clip", "read_frame_times", "read_frames_folder", "read_input", "read_png",
           "read_video", "read_video_timed", "regular_runs", "sliding_windows", "to_uint8",
           "write_frames_folder", "write_png", "write_video"]
