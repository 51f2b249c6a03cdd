"""``benchmarks/bench_dispersion.py``: its options reach the simulator, and bad ones are
refused with one line."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_dispersion.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                          timeout=300)


@pytest.mark.parametrize(("args", "message"), [
    (("--compression", "png"), "invalid choice: 'png'"),
    (("--compression", "h264", "--jpeg-quality", "50"), "--jpeg-quality needs the jpeg encoder"),
    (("--jpeg-quality", "0"), "--jpeg-quality must be in 1-100"),
    (("--rows", "realistic-30-blnd"), "--rows: unknown"),
])
def test_bad_options_are_refused_in_one_line(args, message) -> None:
    res = _run(*args)
    assert res.returncode == 2
    assert message in res.stderr.strip().splitlines()[-1]


def test_the_encoder_option_reaches_the_realistic_frames(tmp_path) -> None:
    """Uncompressed and JPEG frames of one sequence differ, the run records the encoder, and
    every window is reported."""
    runs = {}
    for comp, extra in (("none", ()), ("jpeg", ("--jpeg-quality", "40"))):
        out = tmp_path / f"{comp}.json"
        res = _run("--rows", "realistic-10-exact", "--seeds", "3", "--sequences", "1",
                   "--size", "128", "--no-cache", "--compression", comp, *extra,
                   "--out", str(out))
        assert res.returncode == 0, res.stderr[-2000:]
        runs[comp] = json.loads(out.read_text())
        assert runs[comp]["settings"]["realistic_camera"]["compression"] == comp
        lines = out.with_suffix(".csv").read_text().splitlines()
        assert len(lines) == 3  # header, clean, glinty
        # each window names the path its estimate took and the turn it read
        for rec in csv.DictReader(lines):
            assert rec["signal"].split("/")[0] in ("luma", "chroma"), rec["signal"]
            assert float(rec["yaw_rate_dps"]) == 0.0 or "+yaw" in rec["signal"]
    assert runs["jpeg"]["settings"]["realistic_camera"]["jpeg_quality"] == 40
    est = [[line.split(",")[8] for line in (tmp_path / f"{c}.csv").read_text().splitlines()[1:]]
           for c in ("none", "jpeg")]
    assert est[0] != est[1]
