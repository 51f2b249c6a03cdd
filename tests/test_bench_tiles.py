"""The corner-tile calibration benchmark's parts: its summary against the distributions it
is read beside, each window's z, and its refusals."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from benchmodule import BENCHMARKS, bench_module
from scipy import stats


@pytest.fixture(scope="module")
def bench():
    return bench_module("bench_tiles")


def test_the_summary_of_draws_matches_the_distribution_it_is_read_beside(bench) -> None:
    """Many draws of a normal, and of a t with two degrees of freedom at the tiles' scale,
    summarise to the closed forms printed beside them."""
    rng = np.random.default_rng(3)
    for dist, scale in ((stats.norm, 1.0), (stats.t(2), bench.TILE_T_SCALE)):
        got = bench.z_summary(scale * dist.rvs(size=200_000, random_state=rng))
        want = bench.reference(dist, scale)
        assert got["n"] == 200_000
        assert got["median_abs_z"] == pytest.approx(want["median_abs_z"], abs=0.01)
        for x in bench.THRESHOLDS:
            key = f"share_over_{x:g}"
            assert got[key] == pytest.approx(want[key], abs=0.003)
    assert bench.reference(stats.norm)["median_abs_z"] == pytest.approx(0.674, abs=1e-3)
    assert bench.z_summary([])["median_abs_z"] is None


def test_a_windows_z_is_each_tiles_log_error_over_its_sigma(bench) -> None:
    """Against the truth and against the fit: ``(log h_tile - log H) / sd``, per tile; a
    window whose tiles were not fitted has none."""
    tiles = [(-80.0, -80.0, math.log(10.5), 0.02), (80.0, 80.0, math.log(9.0), 0.05)]
    truth, fit = bench.window_z((tiles, 10.2), 10.0)
    assert truth == pytest.approx([math.log(1.05) / 0.02, math.log(0.9) / 0.05])
    assert fit == pytest.approx([math.log(10.5 / 10.2) / 0.02, math.log(9.0 / 10.2) / 0.05])
    assert bench.window_z(None, 10.0) == ([], [])


def test_an_unknown_row_or_an_existing_out_is_a_one_line_error(tmp_path) -> None:
    script = str(BENCHMARKS / "bench_tiles.py")
    run = subprocess.run([sys.executable, script, "--rows", "realistic-10-nope"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode != 0
    assert run.stderr.strip().splitlines()[-1].startswith(
        "bench_tiles.py: error: unknown row(s) realistic-10-nope;")
    out = tmp_path / "kept.json"
    out.write_text("{}")
    run = subprocess.run([sys.executable, script, "--out", str(out)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode != 0
    assert "exists" in run.stderr.strip().splitlines()[-1]
    assert out.read_text() == "{}"
