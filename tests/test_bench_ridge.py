"""``benchmarks/bench_ridge.py``: the ridge it follows passes through the truth and peaks there
on a table that holds one shell, its measures follow from the ridge as defined, and a sea of
waves one way leaves a flatter ridge than waves every way (drift then trades against
altitude)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from benchmodule import bench_module

from wavealt.altimetry.dispersion.spectra import sharpness_at

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_ridge.py"


@pytest.fixture(scope="module")
def ridge_bench():
    return bench_module("bench_ridge")


def _table(est, altitude: float, velocity, fps: float, focal: float, frames: int,
           spread: float, rng: np.random.Generator) -> dict:
    """A periodogram whose modes (0.15-1.0 rad/px, directions within ``spread`` of +x, both
    signs of the wave's travel) hold a peak one bin wide at their true phase step, the
    noise's share elsewhere, sharpened as the estimator's."""
    n_modes, n_psi = 600, 256
    kappa = rng.uniform(0.15, 1.0, n_modes)
    ang = rng.uniform(-spread, spread, n_modes)
    kx, ky = kappa * np.cos(ang), kappa * np.sin(ang)
    table = np.full((n_modes, n_psi), 1.0 / (frames - 1))
    om = est.omega(kappa * focal / altitude) / fps
    dop = (kx * velocity[0] + ky * velocity[1]) * focal / (altitude * fps)
    pos = np.mod(om - dop, 2.0 * math.pi) * n_psi / (2.0 * math.pi)
    # a peak as wide as the clip resolves (2 pi / T), falling linearly to the noise
    width = n_psi / frames
    d = np.abs(((np.arange(n_psi)[None, :] - pos[:, None]) + n_psi / 2) % n_psi - n_psi / 2)
    table = np.maximum(table, 0.8 * np.clip(1.0 - d / width, 0.0, 1.0))
    return {"frames": frames, "kx": kx, "ky": ky, "kappa": kappa,
            "q": (table ** sharpness_at(est.sharpness, frames)).astype(np.float32)}


@pytest.fixture(scope="module")
def est():
    from wavealt.altimetry.dispersion import DispersionAltimeter
    from wavealt.altimetry.dispersion.kernel import use_compiled

    use_compiled()
    return DispersionAltimeter()


def test_the_ridge_passes_through_the_truth_and_peaks_there(ridge_bench, est) -> None:
    h, v, fps, focal = 6.0, (0.5, -0.2), 30.0, 220.0
    p = _table(est, h, v, fps, focal, 30, math.pi, np.random.default_rng(3))
    r = ridge_bench.ridge(est, p, h, v, fps, focal)
    grid = r["log_h"]
    assert grid.size == 2 * 13 + 1 and grid[r["truth"]] == pytest.approx(math.log(h))
    assert np.all(np.isfinite(r["score"]))
    m = ridge_bench.ridge_measures(r, h, v, 1.0, 2.0)
    assert abs(m["peak_err"]) < 0.5 * ridge_bench.BLIND_PROFILE_STEP_LOG
    assert m["path_err_mps"] < 0.05
    assert m["drop_sd"] > 0.0
    # the prior's reach and the sigma for the target follow from the slope as defined
    assert m["prior_pct"] == pytest.approx(100.0 * 1.0 / m["slope_mps"])
    assert m["sigma_for_target_mps"] == pytest.approx(0.02 * m["slope_mps"])


def test_waves_one_way_leave_a_flatter_ridge_than_waves_every_way(ridge_bench, est) -> None:
    h, v, fps, focal = 6.0, (0.3, 0.1), 30.0, 220.0
    drops = {}
    for name, spread in (("every way", math.pi), ("one way", 0.3)):
        p = _table(est, h, v, fps, focal, 15, spread, np.random.default_rng(5))
        r = ridge_bench.ridge(est, p, h, v, fps, focal)
        drops[name] = ridge_bench.ridge_measures(r, h, v, 1.0, 5.0)["drop_sd"]
    assert drops["one way"] < drops["every way"]


def test_a_window_without_a_periodogram_measures_nothing(ridge_bench) -> None:
    empty = {"log_h": np.zeros(0), "score": np.zeros(0), "velocity_mps": np.zeros((0, 2)),
             "noise": 0.0, "truth": None}
    m = ridge_bench.ridge_measures(empty, 1.0, (0.0, 0.0), 1.0, 1.0)
    assert all(math.isnan(x) for x in m.values())


def test_an_unknown_row_is_refused_in_one_line() -> None:
    res = subprocess.run([sys.executable, str(BENCH), "--rows", "realistic-10-prio"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2
    assert "unknown row(s) realistic-10-prio" in res.stderr.strip().splitlines()[-1]


def test_the_ideal_cameras_clip_is_its_slope_plus_the_square_asked_for(ridge_bench) -> None:
    fs = ridge_bench._foreign_sea()
    clip0, sc = ridge_bench.square_clip(5000, 4, 0.0)
    clip2, sc2 = ridge_bench.square_clip(5000, 4, 2.0)
    assert clip0.shape == (4, fs.SIZE, fs.SIZE) and clip0.dtype == np.uint8
    assert sc == sc2  # the same scene, amplitudes and direction: only the square differs
    amp = fs.random_amplitudes(sc, np.random.default_rng((sc.seed, 1)))
    sx, sy = fs.slope_frames(sc, amp, 4)
    angle = np.random.default_rng((5000, 7)).uniform(0.0, 2.0 * math.pi)
    lin = (sx * math.cos(angle) + sy * math.sin(angle)).ravel()
    sq = (sx * sx + sy * sy).ravel()

    def r2(clip, *parts) -> float:
        """The share of the clip's variance that a least-squares fit on ``parts`` explains."""
        y = clip.astype(float).ravel()
        a = np.column_stack([np.ones_like(y), *parts])
        res = y - a @ np.linalg.lstsq(a, y, rcond=None)[0]
        return 1.0 - res.var() / y.var()
    # the linear camera's image is its slope (8-bit rounding aside); the square's is not,
    # until the squared slope joins the fit
    assert r2(clip0, lin) > 0.99
    assert r2(clip2, lin) < 0.9
    assert r2(clip2, lin, sq) > 0.97  # (the square's tail clipped at 255 aside)
    optics, _ = ridge_bench.square_clip(5000, 4, None)
    assert optics.shape == clip0.shape and optics.dtype == np.uint8


@pytest.mark.parametrize("args", [["--square", "0,-1"], ["--square", "x"],
                                  ["--square", "0", "--frames", "2"],
                                  ["--square", "0", "--clips", "0"]])
def test_bad_square_options_are_refused_in_one_line(args) -> None:
    res = subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 2
    assert "error:" in res.stderr.strip().splitlines()[-1]
