"""``benchmarks/bench_bound.py``: the SNR it reads from a mode's share inverts the share's
expectation, and its bounds behave as information does (more modes or a prior tighten them,
a velocity to fit or wider bins loosen them, noise holds none)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from benchmodule import bench_module

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_bound.py"


@pytest.fixture(scope="module")
def bound():
    return bench_module("bench_bound")


@pytest.mark.parametrize("frames", [10, 15, 30])
def test_the_snr_inverts_the_shares_expectation(bound, frames: int) -> None:
    tiles = 4
    for snr in (0.05, 0.5, 3.0, 20.0):  # summed over the tiles, A / sigma^2
        share = (frames * snr + tiles) / (frames * snr + tiles * (frames - 1))
        assert bound.mode_snr(np.array([share]), frames, tiles)[0] == pytest.approx(snr)
    # the noise's own share, and below it: no signal
    noise = np.array([1.0 / (frames - 1), 0.5 / (frames - 1), 0.0])
    assert np.array_equal(bound.mode_snr(noise, frames, tiles), np.zeros(3))


def _table(n_modes: int, frames: int, altitude: float, velocity, fps: float, focal: float,
           est, share: float, rng: np.random.Generator) -> dict:
    """A periodogram of ``n_modes`` modes (0.2-1.2 rad/px, every direction) whose table holds
    ``share`` at each mode's true phase step (the wave's direction) and the noise's share
    elsewhere, sharpened as the estimator's."""
    kappa = rng.uniform(0.2, 1.2, n_modes)
    ang = rng.uniform(0.0, 2.0 * math.pi, n_modes)
    kx, ky = kappa * np.cos(ang), kappa * np.sin(ang)
    n_psi = 256
    table = np.full((n_modes, n_psi), 1.0 / (frames - 1))
    om = est.omega(kappa * focal / altitude) / fps
    dop = (kx * velocity[0] + ky * velocity[1]) * focal / (altitude * fps)
    pos = np.mod(om - dop, 2.0 * math.pi) * n_psi / (2.0 * math.pi)
    j = np.floor(pos).astype(int)
    table[np.arange(n_modes), j % n_psi] = share
    table[np.arange(n_modes), (j + 1) % n_psi] = share
    return {"frames": frames, "kx": kx, "ky": ky, "kappa": kappa,
            "q": table ** est.sharpness}


def test_the_bounds_order_and_scale_as_information(bound) -> None:
    from wavealt.altimetry.dispersion import DispersionAltimeter

    est = DispersionAltimeter()
    args = dict(frames=15, altitude=6.0, velocity=(0.4, -0.3), fps=30.0, focal=220.0, est=est)
    p = _table(400, share=0.6, rng=np.random.default_rng(1), **args)
    p["tile"] = (96, 96)
    b = bound.bounds(p, est, 6.0, (0.4, -0.3), 30.0, 220.0, 4, 1.0)
    # a velocity to fit can only cost precision; a prior on it gives some back
    assert 0 < b["exact"] < b["prior"] <= b["blind"] < math.inf
    assert b["snr_modes"] == 400
    # the same modes twice: twice the information, the bounds / sqrt 2
    both = {k: v if k in ("frames", "tile") else np.concatenate([v, v]) for k, v in p.items()}
    b2 = bound.bounds(both, est, 6.0, (0.4, -0.3), 30.0, 220.0, 4, 1.0)
    for mode in ("exact", "prior", "blind"):
        assert b2[mode] == pytest.approx(b[mode] / math.sqrt(2.0), rel=1e-4)
    # a higher share at the truth: a higher SNR, a tighter bound
    p_hi = _table(400, share=0.9, rng=np.random.default_rng(1), **args)
    p_hi["tile"] = (96, 96)
    assert bound.bounds(p_hi, est, 6.0, (0.4, -0.3), 30.0, 220.0, 4, 1.0)["blind"] < b["blind"]
    # smaller tiles: wider bins, each mode's peak less certain within them
    small = dict(p, tile=(24, 24))
    assert bound.bounds(small, est, 6.0, (0.4, -0.3), 30.0, 220.0, 4, 1.0)["exact"] > b["exact"]
    # a table at or below the noise holds no information
    p["q"] = np.full_like(p["q"], (0.9 / 14) ** est.sharpness)
    b0 = bound.bounds(p, est, 6.0, (0.4, -0.3), 30.0, 220.0, 4, 1.0)
    assert b0["exact"] == math.inf and b0["snr_modes"] == 0


def test_an_unknown_row_is_refused_in_one_line() -> None:
    res = subprocess.run([sys.executable, str(BENCH), "--rows", "realistic-30-blnd"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2
    assert "unknown row(s) realistic-30-blnd" in res.stderr.strip().splitlines()[-1]
