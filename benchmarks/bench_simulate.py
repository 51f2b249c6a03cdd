"""Simulator speed: paired (clean + glinty) frames per second, JSON out.

Synthesis + rendering alone (in memory) at 224^2 and 512^2 on one worker, and the
end-to-end rate of ``simulate_dataset`` (with PNG writing) on one and two workers, plus
the peak resident memory.  Run: ``python benchmarks/bench_simulate.py [--sequences N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import tempfile
import time

import numpy as np

from wavealt.dataset import simulate_dataset
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence


def synth_rate(size: int, sequences: int, repeats: int = 3) -> dict[str, float]:
    """Best and median of ``repeats`` timings (a shared VM's speed drifts by +-20 %)."""
    cfg = preset_config("paper", size=size, sequences=sequences)
    generate_sequence(cfg.sample_scenario(0), cfg)  # warm-up (FFT plans, imports)
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        frames = 0
        for i in range(sequences):
            frames += generate_sequence(cfg.sample_scenario(i), cfg).clean.shape[0]
        rates.append(frames / (time.perf_counter() - t0))
    return {"best": round(max(rates), 1), "median": round(float(np.median(rates)), 1)}


def end_to_end_rate(size: int, sequences: int, workers: int) -> float:
    cfg = preset_config("paper", size=size, sequences=sequences)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        simulate_dataset(os.path.join(tmp, "ds"), cfg, workers=workers, progress=False)
        dt = time.perf_counter() - t0
    return sequences * cfg.frames / dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sequences", type=int, default=20)
    args = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    out: dict = {"benchmark": "simulate", "unit": "paired frames/s",
                 "cpu_count": os.cpu_count(), "python": platform.python_version(),
                 "numpy": np.__version__, "synthesis_and_render_1_worker": {},
                 "end_to_end_with_png": {}}
    for size in (224, 512):
        n = args.sequences if size == 224 else max(2, args.sequences // 4)
        out["synthesis_and_render_1_worker"][f"{size}x{size}"] = synth_rate(size, n)
        for workers in (1, 2):
            out["end_to_end_with_png"][f"{size}x{size}_workers{workers}"] = round(
                end_to_end_rate(size, n, workers), 1)
    out["peak_rss_mib"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    out["target_synthesis_224_fps"] = 200
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
