"""``benchmarks/bench_live.py`` runs: a short H.264 stream through ``run_live`` to a MAVLink
port on the loopback, and its JSON reports what the stream gave."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_live.py"


def test_a_short_live_run_reports_its_estimates(tmp_path) -> None:
    """Six seconds of stream (0.1 min): windows of 30 frames every 2 estimated to its end,
    the codec named, and the exact fits near the truth (6 m).  (The bench's estimator had
    fallen behind ``run_live``'s three-argument call and failed at its first window.)"""
    out = tmp_path / "live.json"
    res = subprocess.run([sys.executable, str(BENCH), "--minutes", "0.1", "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    d = json.loads(out.read_text())
    s = d["summary"]
    assert s["frames"] == 180 and s["stopped_by"] == "end of stream"
    assert s["window_frames"] == 30 and s["step_frames"] == 2 and s["estimates"] > 0
    assert s["predicted_by"] == "h264"
    assert d["median_rel_error"] < 0.05
