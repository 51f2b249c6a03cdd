"""Speed of the eq. (5) sliding temporal minimum; prints one JSON object.

For a 1920x1080 RGB uint8 sequence and a 224x224 RGB float32 sequence, with ``w = 10``
(11-frame centred window), frames per second of:

- ``stream``: :func:`wavealt.deglint.sliding_min_stream` over an iterator (van Herk), in
  the steady state of a longer stream (``4 x`` the frames, cycled), outputs dropped one by one;
- ``stream_nocopy``: the same with ``copy=False`` (producer yields fresh arrays);
- ``in_memory``: :func:`wavealt.deglint.temporal_minimum` (van Herk via ``minimum.accumulate``);
- ``scipy``: ``scipy.ndimage.minimum_filter1d(frames, 2 h + 1, axis=0, mode="nearest")``;
- ``naive``: ``np.min`` over each truncated window;

plus the peak memory (tracemalloc, which sees NumPy's allocations) of the streaming path fed
by a generator that makes one frame at a time, in frames and in MB.  Every result is checked
equal to the naive one.  Best of ``--repeat`` runs.

    python benchmarks/bench_deglint.py [--frames-1080p 30] [--frames-224 300] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import platform
import time
import tracemalloc

import numpy as np
from scipy import ndimage

from wavealt.deglint import sliding_min_stream, temporal_minimum


def naive(frames: np.ndarray, window: int) -> np.ndarray:
    h = window // 2
    n = len(frames)
    out = np.empty_like(frames)
    for t in range(n):
        np.min(frames[max(0, t - h):min(n, t + h + 1)], axis=0, out=out[t])
    return out


def stream(frames: np.ndarray, window: int, n_frames: int, copy: bool = True) -> None:
    """Consume a stream of ``n_frames`` (cycling through ``frames``) as a video pipeline
    would: one output at a time, then dropped.  Long enough to reach the steady state."""
    source = (frames[t % len(frames)] for t in range(n_frames))
    for _ in sliding_min_stream(source, window=window, copy=copy):
        pass


def stream_collect(frames: np.ndarray, window: int, copy: bool) -> np.ndarray:
    return np.stack(list(sliding_min_stream(iter(frames), window=window, copy=copy)))


def scipy_min(frames: np.ndarray, window: int) -> np.ndarray:
    return ndimage.minimum_filter1d(frames, 2 * (window // 2) + 1, axis=0, mode="nearest")


def best_time(fn, repeat: int) -> tuple[float, np.ndarray]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def stream_peak_memory(shape: tuple[int, ...], dtype, n_frames: int, window: int) -> float:
    """Peak bytes traced while streaming ``n_frames`` generated frames (outputs dropped)."""
    rng = np.random.default_rng(0)
    proto = (rng.random(shape, dtype=np.float32) * (255 if dtype == np.uint8 else 1)).astype(dtype)

    def producer():
        for t in range(n_frames):
            yield np.roll(proto, t, axis=1)  # a new frame each time, one alive at once

    tracemalloc.start()
    tracemalloc.reset_peak()
    for _ in sliding_min_stream(producer(), window=window):
        pass
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return float(peak)


def case(name: str, shape: tuple[int, ...], dtype, n_frames: int, window: int,
         repeat: int, stream_frames: int) -> dict:
    rng = np.random.default_rng(1)
    x = rng.random((n_frames,) + shape, dtype=np.float32)
    x = (x * 255).astype(np.uint8) if dtype == np.uint8 else x
    t_naive, ref = best_time(lambda: naive(x, window), repeat)
    result = {"shape": list(shape), "dtype": np.dtype(dtype).name, "frames": n_frames,
              "stream_frames": stream_frames,
              "window": window, "frame_mb": x[0].nbytes / 1e6}
    fps = {"naive": n_frames / t_naive}
    for label, fn in (("in_memory", lambda: temporal_minimum(x, window=window)),
                      ("scipy_minimum_filter1d", lambda: scipy_min(x, window))):
        t, out = best_time(fn, repeat)
        if not np.array_equal(out, ref):
            msg = f"{name}: {label} differs from the naive minimum"
            raise RuntimeError(msg)
        fps[label] = n_frames / t
    for label, copy in (("stream", True), ("stream_nocopy", False)):
        if not np.array_equal(stream_collect(x, window, copy), ref):
            msg = f"{name}: {label} differs from the naive minimum"
            raise RuntimeError(msg)
        t, _ = best_time(lambda: stream(x, window, stream_frames, copy), max(1, repeat - 1))
        fps[label] = stream_frames / t
    result["fps"] = {k: round(v, 1) for k, v in fps.items()}
    result["speedup_vs_naive"] = {k: round(v / fps["naive"], 2) for k, v in fps.items()
                                  if k != "naive"}
    peak = stream_peak_memory(shape, dtype, stream_frames, window)
    result["stream_peak_memory"] = {"frames_streamed": stream_frames, "peak_mb": round(peak / 1e6, 1),
                                    "peak_in_frames": round(peak / x[0].nbytes, 1),
                                    "bound_frames": 3 * (2 * (window // 2) + 1) + 5}
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames-1080p", type=int, default=30)
    ap.add_argument("--frames-224", type=int, default=300)
    ap.add_argument("--window", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    out = {
        "benchmark": "deglint.sliding_min",
        "numpy": np.__version__,
        "machine": platform.machine(),
        "threads_note": "NumPy ufuncs here are single-threaded",
        "cases": {
            "1080p_uint8": case("1080p_uint8", (1080, 1920, 3), np.uint8, args.frames_1080p,
                                args.window, args.repeat, stream_frames=4 * args.frames_1080p),
            "224_float32": case("224_float32", (224, 224, 3), np.float32, args.frames_224,
                                args.window, args.repeat, stream_frames=4 * args.frames_224),
        },
    }
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
