"""Live altimetry on a stream: estimates per second, latency from a window's last frame to
the MAVLink message sent, frames dropped, and memory over time.

    .venv/bin/python benchmarks/bench_live.py [--minutes 1] [--mode exact|blind] [--out FILE]

A 10-s ``realistic``-preset clip (256 px, 30 fps, 6 m) is encoded into an H.264 stream
repeated for ``--minutes`` and played live at its own pace through ``wavealt.live.run_live``
with the dispersion altimeter (30-frame windows, a new estimate every 2 frames) and a
DISTANCE_SENSOR sent to a UDP port on the loopback.  Targets (issue 17): latency <= 100 ms,
>= 10 estimates/s on 2 cores, memory flat (resident memory every minute).
Prints (and with ``--out`` writes) one JSON object.
"""

from __future__ import annotations

import argparse
import json
import platform
import resource
import socket
import tempfile
import threading
import time
from pathlib import Path

import numpy as np


def _stream(path: Path, minutes: float) -> tuple[object, object]:
    import av

    from wavealt.sim.config import preset_config
    from wavealt.sim.generate import generate_sequence

    cfg = preset_config("realistic", size=256, frames=300, altitude_m=(6.0, 6.0),
                        wind_speed_mps=(7.0, 7.0), camera_speed_mps=(0.3, 0.3))
    sc = cfg.sample_scenario(0)
    clip = (np.clip(generate_sequence(sc, cfg).clean, 0, 1) * 255).astype(np.uint8)
    n = int(minutes * 60 * cfg.fps)
    with av.open(str(path), "w") as out:
        st = out.add_stream("libx264", rate=int(cfg.fps))
        st.width = st.height = 256
        st.pix_fmt = "yuv420p"
        st.options = {"crf": "18", "preset": "veryfast"}
        for i in range(n):
            frame = av.VideoFrame.from_ndarray(clip[i % clip.shape[0]], format="rgb24")
            frame.pts = i
            for pkt in st.encode(frame):
                out.mux(pkt)
        for pkt in st.encode():
            out.mux(pkt)
    return sc, cfg


def _rss_mb() -> float:
    """Resident memory now (Linux /proc), MB; the peak where /proc is missing."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
        return pages * resource.getpagesize() / 2**20
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=1.0)
    ap.add_argument("--mode", choices=["exact", "blind"], default="exact")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()

    from wavealt.altimetry.dispersion import DispersionAltimeter
    from wavealt.live import run_live
    from wavealt.live.mavlink import MavlinkLink

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "stream.mp4"
        sc, cfg = _stream(path, a.minutes)
        est = DispersionAltimeter()
        vel = sc.camera_velocity_mps if a.mode == "exact" else None
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        link = MavlinkLink(f"udpout:127.0.0.1:{port}")
        import gc

        gc.collect()
        rss = {"start_mb": _rss_mb()}
        t0 = time.monotonic()

        def sample() -> None:
            for minute in range(1, int(a.minutes) + 1):
                time.sleep(60.0)
                rss[f"after_{minute}_min_mb"] = _rss_mb()

        threading.Thread(target=sample, daemon=True).start()
        errs = []

        def estimate(frames: np.ndarray, fps: float, arrivals: np.ndarray) -> dict:
            r = est.estimate(frames, fps=fps, focal_px=cfg.focal_px, velocity_mps=vel).to_dict()
            errs.append(abs(r["altitude_m"] / sc.altitude_m - 1))
            return r

        summary = run_live(str(path), estimate=estimate, window=30, step=2,
                           on_estimate=link.send_altitude)
        link.close()
        rss["end_mb"] = _rss_mb()
    res = {"benchmark": "bench_live", "issue": 17, "settings": vars(a),
           "environment": {"python": platform.python_version(), "numpy": np.__version__},
           "summary": summary, "rss": rss, "median_rel_error": float(np.median(errs)),
           "wall_s": time.monotonic() - t0,
           "targets": {"latency_ms_median_le_100": summary["latency_ms_median"] <= 100,
                       "estimates_per_s_ge_10": summary["estimates_per_s"] >= 10}}
    text = json.dumps(res, indent=1)
    if a.out:
        Path(a.out).write_text(text, encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
