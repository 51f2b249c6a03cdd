"""Paired frames per second of the ``realistic`` preset beside ``paper``, same run, one core.

    PYTHONPATH=src python benchmarks/bench_realistic.py [--size 256] [--sequences 4] [--frames 10]

Prints one JSON object.  Each preset generates ``sequences`` sequences (after one warm-up
sequence) with :func:`wavealt.sim.generate.generate_sequence`; a paired frame is one clean plus
one glinty frame.  The stages of one realistic sequence are timed as well.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import numpy as np  # noqa: E402


def bench_preset(name: str, size: int, sequences: int, frames: int, **overrides) -> dict:
    from wavealt.sim.config import preset_config
    from wavealt.sim.generate import generate_sequence

    cfg = preset_config(name, size=size, frames=frames, sequences=sequences + 1, **overrides)
    generate_sequence(cfg.sample_scenario(sequences), cfg)  # warm-up (FFT plans, imports)
    t0 = time.perf_counter()
    for i in range(sequences):
        generate_sequence(cfg.sample_scenario(i), cfg)
    dt = time.perf_counter() - t0
    return {"seconds": dt, "paired_frames": sequences * frames,
            "paired_frames_per_s": sequences * frames / dt}


def stages(size: int, frames: int) -> dict:
    import math

    from wavealt.sim.config import preset_config
    from wavealt.sim.light.optics import sun_vector
    from wavealt.sim.realistic import make_sea, realistic_draws, render_radiance
    from wavealt.sim.sensor import capture_pair

    cfg = preset_config("realistic", size=size, frames=frames)
    s = cfg.sample_scenario(0)
    out = {}
    t = time.perf_counter()
    sea = make_sea(s, cfg, realistic_draws(s, cfg))
    out["sea_setup_s"] = time.perf_counter() - t
    t = time.perf_counter()
    f = list(sea.iter_fields(np.arange(frames) / s.fps, crop=(size, size),
                             velocity_mps=s.camera_velocity_mps))
    out["synthesis_s"] = time.perf_counter() - t
    sx = np.stack([x["slope_x"] for x in f])
    sy = np.stack([x["slope_y"] for x in f])
    from wavealt.camera import Camera
    view = Camera(size, size, s.focal_px, s.altitude_m).view_vectors()
    t = time.perf_counter()
    c, g = render_radiance(sx, sy, view, sun_vector(math.radians(s.sun_zenith_deg), 0.0),
                           subpixel_slope_variance=sea.subpixel_slope_variance, glint_severity=1.0)
    out["render_s"] = time.perf_counter() - t
    t = time.perf_counter()
    capture_pair(c, g, sensor=cfg.sensor, rng=0)
    out["sensor_jpeg_s"] = time.perf_counter() - t
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--sequences", type=int, default=4)
    ap.add_argument("--frames", type=int, default=10)
    a = ap.parse_args()
    res = {
        "benchmark": "bench_realistic", "size": a.size, "frames": a.frames,
        "sequences": a.sequences, "python": platform.python_version(), "numpy": np.__version__,
        "paper": bench_preset("paper", a.size, a.sequences, a.frames),
        "realistic": bench_preset("realistic", a.size, a.sequences, a.frames),
        "realistic_no_compression": bench_preset("realistic", a.size, a.sequences, a.frames,
                                                 compression="none"),
        "realistic_stages_one_sequence": stages(a.size, a.frames),
    }
    res["realistic_over_paper_speed"] = (res["realistic"]["paired_frames_per_s"]
                                         / res["paper"]["paired_frames_per_s"])
    print(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
