"""``benchmarks/bench_orbit.py``: a short wave carried on a long wave's orbit is brought back
to its crests by the orbit read from the frame; a run reports every step; bad steps are
refused in one line."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from benchmodule import bench_module
from scipy import ndimage

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_orbit.py"


def _short_part(frame: np.ndarray) -> np.ndarray:
    """The frame less its long waves, the border (where the mirror padding shows) cut."""
    return (frame - ndimage.gaussian_filter(frame, 4))[32:-32, 32:-32]


def test_the_orbit_read_from_the_frame_brings_a_short_wave_back_to_its_crests() -> None:
    """A short wave on a long one (128 px, slope 0.15) of the Lagrangian sea: its crests,
    carried by the long wave's orbit, lie off the linear sea's (negative correlation);
    resampled at the rest positions the frame's own long wave gives, they lie near them."""
    bo = bench_module("bench_orbit")
    fs = bo.fs
    fs.set_size(256, None, 30.0)
    sc = replace(fs.draw_scene(7), choppy=1.0)
    kx, ky = fs.wavenumbers(sc)
    amp = np.zeros((fs.GRID, fs.GRID), complex)
    amp[0, 2] = 0.15 / kx[0, 2]  # 320 grid points: 128 px
    amp[30, 40] = 0.02 / np.hypot(kx[30, 40], ky[30, 40])

    def frame(choppy: float) -> np.ndarray:
        sx, sy = fs.slope_frames(replace(sc, choppy=choppy), amp.copy(), 1)
        return bo.SLOPE_DIRECTION[0] * sx + bo.SLOPE_DIRECTION[1] * sy

    lagrangian, linear = frame(1.0), frame(0.0)
    undone = bo.undo_inframe(lagrangian)
    assert undone.shape == lagrangian.shape

    def corr(a: np.ndarray) -> float:
        return float(np.corrcoef(_short_part(a[0]).ravel(), _short_part(linear[0]).ravel())[0, 1])

    assert corr(lagrangian) < 0.0
    assert corr(undone) > 0.6


def test_a_run_reports_each_step_and_refuses_an_unknown_one(tmp_path) -> None:
    out = tmp_path / "run.json"
    res = subprocess.run([sys.executable, str(BENCH), "--clips", "1", "--seed", "92003",
                          "--steps", "as-is,inframe", "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    run = json.loads(out.read_text())
    assert set(run["metrics"]) == {"as-is", "inframe"}
    assert all(m["clips"] == 1 for m in run["metrics"].values())
    (rec,) = run["records"]
    assert rec["seed"] == 92003 and set(rec) >= {"as-is", "inframe", "altitude_m"}
    bad = subprocess.run([sys.executable, str(BENCH), "--steps", "as-is,warp"],
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2
    assert "--steps must be a comma list of as-is, inframe, shell; got 'as-is,warp'" in (
        bad.stderr.strip().splitlines()[-1])
