"""``benchmarks/bench_shake.py``: its shaking camera is the one a frame-by-frame levelling
at the attitude undoes, its shakes repeat per sequence, and bad options are refused in one
line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from benchmodule import bench_module

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_shake.py"
LATENCY = BENCH.with_name("bench_latency.py")
LIVE = BENCH.with_name("bench_live_shake.py")


def _module():
    return bench_module("bench_shake")


def test_the_shaken_view_levelled_at_its_attitude_is_the_level_view() -> None:
    """A camera at a degree of roll and pitch sees the level frame moved by about the focal
    length times the angle; levelled frame by frame at its attitude (``NadirView``, as
    ``wavealt altitude --attitude`` does) both frames match the level camera's view, at one
    offset for both (the levelled view is centred on the mean attitude's axis)."""
    import scipy.ndimage as ndi

    from wavealt.camera import NadirView, pinhole

    mod = _module()
    rng = np.random.default_rng(0)
    sea = ndi.gaussian_filter(rng.normal(size=(2, 160, 160)), (0, 5, 5)).astype(np.float32)
    focal = 120.0
    att = np.array([[1.0, 1.0], [-1.0, 0.5]])
    clip = mod.shaken_view(sea, att, focal, 96)
    level = mod.shaken_view(sea, np.zeros((2, 2)), focal, 96)
    scale = float(np.std(level))
    assert float(np.max(np.abs(clip - level)[:, 24:72, 24:72])) / scale > 1.0  # it moved

    def levelled(attitudes: np.ndarray) -> float:
        """How far the clip levelled at ``attitudes`` is from the level view (both frames,
        at their best common whole-pixel offset)."""
        view = NadirView(pinhole(96, 96, focal), 96, 96, roll_deg=attitudes[:, 0],
                         pitch_deg=attitudes[:, 1])
        back = view(clip)
        h, w = back.shape[1:]
        return min(float(np.max(np.abs(
            back[:, h // 2 - 16 + dy:h // 2 + 16 + dy, w // 2 - 16 + dx:w // 2 + 16 + dx]
            - level[:, 32:64, 32:64]))) / scale for dx in range(-3, 4) for dy in range(-3, 4))

    assert levelled(att) < 0.2
    assert levelled(-att) > 0.5  # the attitude the other way does not level it


def test_the_shake_repeats_per_sequence_and_scales_with_the_amplitude() -> None:
    mod = _module()
    a = mod.shake_attitudes(23, 4, 0.5, 30, 30.0)
    b = mod.shake_attitudes(23, 4, 1.0, 30, 30.0)
    assert a.shape == (30, 2) and np.allclose(b, 2.0 * a)
    assert np.abs(a).max() <= 0.5 and np.abs(a).max() > 0.2
    assert not np.allclose(a, mod.shake_attitudes(23, 5, 0.5, 30, 30.0))
    # a lag of one frame is the same shake one frame earlier
    late = mod.shake_attitudes(23, 4, 0.5, 30, 30.0, lag_s=1 / 30.0)
    assert np.allclose(late[1:], a[:-1])


@pytest.mark.parametrize(("script", "args", "message"), [
    (BENCH, ("--amplitudes", "0"), "--amplitudes must be in (0, 5]"),
    (BENCH, ("--amplitudes", "9"), "--amplitudes must be in (0, 5]"),
    (BENCH, ("--seeds", "a"), "--seeds and --amplitudes must be numbers"),
    (BENCH, ("--mode", "prior"), "invalid choice: 'prior'"),
    (BENCH, ("--lags-ms", "x"), "--lags-ms must be comma-separated numbers"),
    (BENCH, ("--lags-ms", "0"), "--lags-ms must be in (0, 1000]"),
    (BENCH, ("--sea", "second", "--frames", "40"),
     "--frames must be at most 30 with --sea second"),
    (LATENCY, ("--delays-ms", "500"), "--delays-ms must be in [0, 400]"),
    (LATENCY, ("--delays-ms", "x"), "--delays-ms must be comma-separated numbers"),
    (LATENCY, ("--frames", "10"), "--frames must be at least 15"),
    (LATENCY, ("--amplitudes", "0"), "--amplitudes must be in (0, 5]"),
    (LATENCY, ("--min-ratio", "0"), "--min-ratio must be a positive number"),
    (LIVE, ("--sea", "second"), "only the realistic renderer's sea"),
    (LIVE, ("--delay-ms", "-5"), "--delay-ms must be in [0, 400]"),
    (LIVE, ("--window", "10"), "--window must be in [15, --frames]"),
    (LIVE, ("--frames", "20", "--window", "30"), "--window must be in [15, --frames]"),
    (LIVE, ("--yaw-jitter-deg", "20"), "--yaw-jitter-deg in [0, 10]"),
], ids=lambda v: v.stem if isinstance(v, Path) else None)
def test_bad_options_are_refused_in_one_line(script, args, message) -> None:
    """bench_shake.py, bench_latency.py and bench_live_shake.py."""
    res = subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 2
    assert message in res.stderr.strip().splitlines()[-1]


def test_the_latency_benchmark_finds_the_delay_it_was_given(tmp_path) -> None:
    """Two shaking sequences arriving 80 ms late: each window measures about 80 ms, the
    next sequence's attitude measures nothing; the file holds the rows."""
    out = tmp_path / "latency.json"
    res = subprocess.run([sys.executable, str(LATENCY), "--seeds", "101", "--sequences", "2",
                          "--amplitudes", "1", "--delays-ms", "80", "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    import json

    cell = json.loads(res.stdout)["by_amplitude_delay"]["1/80"]
    assert cell["measured_share"] == 1.0 and cell["error_ms_max"] <= 20.0
    assert cell["wrong_attitude_measured_share"] == 0.0
    assert len(json.loads(out.read_text())["rows"]) == 2
