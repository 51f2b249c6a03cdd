"""Cold start of the command line: `wavealt altitude CLIP` on one 10-frame 256^2 video, from
process start to the printed altitude (import, decode, estimate), JSON out.

    python benchmarks/bench_cold_start.py [--runs 5] [--out cold_start.json]

Target (the flight-ready issue): <= 1 s. Each run is a fresh process; the clip is written
once by the paper renderer (camera velocity known: the exact mode).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from wavealt.io import write_video
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    cfg = preset_config("paper", size=256, frames=10, altitude_m=(4.0, 4.0))
    data = generate_sequence(cfg.sample_scenario(0), cfg)
    with tempfile.TemporaryDirectory() as tmp:
        clip = Path(tmp) / "clip.mp4"
        write_video(clip, data.clean, fps=cfg.fps)
        cmd = [sys.executable, "-m", "wavealt", "altitude", str(clip), "--focal-px",
               str(cfg.focal_px), "--velocity-mps", "0,0", "--window", "10"]
        times = []
        for _ in range(a.runs):
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True)
            times.append(time.perf_counter() - t0)
    res = {"command": "wavealt altitude CLIP (10 frames, 256^2, exact)", "runs": a.runs,
           "median_s": round(statistics.median(times), 3), "max_s": round(max(times), 3),
           "target_s": 1.0, "python": sys.version.split()[0]}
    text = json.dumps(res, indent=2)
    print(text)
    if a.out:
        a.out.write_text(text + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
