"""``benchmarks/bench_resample.py``: its resampling is the low-pass filter it measures, a run
reports its rows, and bad options are refused in one line."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from benchmodule import bench_module

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_resample.py"


def _module():
    return bench_module("bench_resample")


def test_a_half_pixel_shift_filters_as_its_interpolation_does() -> None:
    """A wave at half the Nyquist frequency across x, shifted half a pixel: bilinear
    interpolation averages two neighbours, which passes cos(pi / 4) = 0.71 of its amplitude;
    bicubic (OpenCV's, a = -0.75) passes nearly all of it; no interpolation is the frames
    themselves.  Each moves the wave by half a pixel."""
    mod = _module()
    x = np.arange(64)
    omega = math.pi / 2  # rad per pixel: half the Nyquist frequency
    wave = np.tile(np.cos(omega * x).astype(np.float32), (64, 1))[None]
    assert mod.shifted(wave, 0.5, "none") is wave

    def amplitude_and_phase(frame: np.ndarray) -> tuple[float, float]:
        row = frame[32, 8:56]  # away from the reflected edges
        z = np.sum(row * np.exp(-1j * omega * x[8:56])) * 2 / row.size
        return abs(z), math.atan2(z.imag, z.real)

    a0, p0 = amplitude_and_phase(wave[0])
    linear, p_lin = amplitude_and_phase(mod.shifted(wave, 0.5, "linear")[0])
    cubic, p_cub = amplitude_and_phase(mod.shifted(wave, 0.5, "cubic")[0])
    assert linear / a0 == pytest.approx(math.cos(omega / 2), abs=0.02)
    assert cubic / a0 > 0.9
    for p in (p_lin, p_cub):  # moved by half a pixel: the phase turned by omega / 2
        assert abs((p0 - p) - omega / 2) < 0.05


def test_a_one_clip_run_reports_its_rows(tmp_path) -> None:
    out = tmp_path / "run.json"
    res = subprocess.run([sys.executable, str(BENCH), "--clips", "1", "--rows", "exact10",
                          "--interpolation", "cubic", "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    run = json.loads(out.read_text())
    assert run["interpolation"] == "cubic" and run["shift_px"] == 0.5
    assert [r["row"] for r in run["records"]] == ["exact10"] * 3
    assert run["metrics"]["exact10"]["all"]["windows"] == 3


@pytest.mark.parametrize(("args", "message"), [
    (("--interpolation", "lanczos"), "invalid choice: 'lanczos'"),
    (("--rows", "blind99"), "--rows must be a comma list of"),
    (("--shift-px", "9"), "--shift-px must be within 0-8; got 9"),
    (("--clips", "0"), "--clips and --workers must be at least 1"),
])
def test_bad_options_are_refused_in_one_line(args, message) -> None:
    res = subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 2
    assert message in res.stderr.strip().splitlines()[-1]
