"""``benchmarks/bench_nulls.py``: clips without dispersion are made as described, none of their
windows is trusted, and bad options are refused in one line."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from benchmodule import bench_module

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_nulls.py"


def _module():
    return bench_module("bench_nulls")


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                          timeout=300)


def test_a_carried_clip_moves_its_first_frame_as_the_velocity_given_says() -> None:
    """The carried clip is one frame rolled by whole pixels a frame (plus noise), and the
    velocity given moves the image by exactly that at the altitude it is drawn for."""
    mod = _module()
    clip, fps, focal, velocity, altitude = mod.make_clip("carried", 0, 3, 10, 64)
    assert clip.shape == (10, 64, 64) and clip.dtype == np.uint8
    shift = (-velocity[0] * focal / (fps * altitude), -velocity[1] * focal / (fps * altitude))
    sx, sy = (round(s) for s in shift)
    assert np.allclose(shift, (sx, sy), atol=1e-9) and (sx, sy) != (0, 0)
    moved = np.roll(clip[0].astype(float), (5 * sy, 5 * sx), axis=(0, 1))
    # the same frame five frames on, to within the noise (2 DN, independent per frame)
    assert np.std(clip[5] - moved) < 4.0 < np.std(clip[5] - clip[0].astype(float))
    rotated = mod.make_clip("rotated", 0, 3, 4, 64)[0]
    assert rotated.shape == (4, 44, 44)
    assert math.isnan(mod.make_clip("frozen", 0, 3, 4, 64)[4])


def test_no_window_of_a_clip_without_dispersion_is_trusted(tmp_path) -> None:
    out = tmp_path / "nulls.json"
    res = _run("--clips", "1", "--frames", "10", "--size", "128", "--seed", "5",
               "--kinds", "frozen,carried", "--out", str(out))
    assert res.returncode == 0, res.stderr[-2000:]
    run = json.loads(out.read_text())
    assert run["windows"] == 2 * 3 == len(run["records"])
    assert run["trusted_windows"] == 0 and run["contract_met"]
    assert {r["mode"] for r in run["records"]} == {"blind", "exact", "prior"}
    carried = [r for r in run["records"] if r["kind"] == "carried" and r["mode"] != "blind"]
    assert all(r["altitude_of_velocity_m"] is not None for r in carried)


@pytest.mark.parametrize(("args", "message"), [
    (("--kinds", "frozen,moving"), "--kinds: unknown moving"),
    (("--frames", "10,x"), "--frames must be whole numbers"),
    (("--frames", "40"), "--frames must be within 3-30"),
    (("--size", "32"), "--size must be within 64-1024 px"),
])
def test_bad_options_are_refused_in_one_line(args, message) -> None:
    res = _run(*args)
    assert res.returncode == 2
    assert message in res.stderr.strip().splitlines()[-1]
