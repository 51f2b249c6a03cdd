"""``benchmarks/bench_yaw.py``: its yawing camera is the one ``unturn_yaw`` undoes, and bad
options are refused in one line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from benchmodule import bench_module

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_yaw.py"


def test_the_yawing_view_turned_back_is_the_still_view() -> None:
    """Turned at 30 deg/s over 5 frames and turned back by the altimeter's own step, every
    frame matches the unturned view away from the corners the turn takes out of sight (to
    the two bilinear resamplings' blur); turned back the other way, it does not."""
    from wavealt.camera import unturn_yaw

    mod = bench_module("bench_yaw")
    rng = np.random.default_rng(0)
    import scipy.ndimage as ndi

    sea = ndi.gaussian_filter(rng.normal(size=(5, 96, 96)), (0, 3, 3)).astype(np.float32)
    still = mod.yawing_view(sea, 0.0, 10.0, 64)
    turned = mod.yawing_view(sea, 30.0, 10.0, 64)
    inner = slice(12, 52)
    scale = float(np.std(still))

    def off(clip: np.ndarray) -> float:
        return float(np.max(np.abs(clip[:, inner, inner] - still[:, inner, inner]))) / scale

    assert off(turned) > 1.0  # the turn moved the view
    assert off(unturn_yaw(turned, 30.0, 10.0)) < 0.2
    assert off(unturn_yaw(turned, -30.0, 10.0)) > 1.0


@pytest.mark.parametrize(("args", "message"), [
    (("--rates", "0"), "--rates must be non-zero"),
    (("--rates", "400"), "--rates must be non-zero and within +-180"),
    (("--seeds", "a"), "--seeds and --rates must be numbers"),
    (("--mode", "prior"), "invalid choice: 'prior'"),
    (("--sea", "second", "--frames", "40"), "--frames must be at most 30 with --sea second"),
    (("--sea", "paper"), "invalid choice: 'paper'"),
    (("--working-px", "-1"), "--working-px must be >= 0; got -1"),
    (("--sea", "second", "--max-tilt-deg", "40"), "--max-tilt-deg must be within 0-30; got 40"),
    (("--max-tilt-deg", "5"), "--max-tilt-deg needs --sea second"),
])
def test_bad_options_are_refused_in_one_line(args, message) -> None:
    res = subprocess.run([sys.executable, str(BENCH), *args], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 2
    assert message in res.stderr.strip().splitlines()[-1]


def test_the_second_sea_is_the_independent_generators_clip_turned() -> None:
    """``--sea second``: the frames are the generator's clip of seed + index, scaled to [0,
    1], with its altitude, frame rate, focal length and velocity over the water; a run of
    one sequence gives the still and the turned rows of that sea."""
    mod = bench_module("bench_yaw")
    gen = mod._generator()
    sea, truth = mod._second_sea(3000, 2, 10)
    sc = gen.draw_scene(3002)
    clip, _ = gen.render_clip(sc)
    assert sea.shape == (10, *clip.shape[1:]) and sea.dtype == np.float32
    np.testing.assert_array_equal(sea * 255.0, clip[:10].astype(np.float32))
    assert truth["altitude_m"] == sc.altitude_m and truth["fps"] == gen.FPS
    assert truth["velocity_mps"] == tuple(sc.over_water)
    rows = mod.run_sequence((3000, 2), (10.0,), 10, "exact", "second")
    assert [(r["rate_dps"], r["case"]) for r in rows] == [(0.0, "untold"), (10.0, "untold"),
                                                          (10.0, "told")]
    assert all(r["altitude_m"] == sc.altitude_m for r in rows)
    assert rows[2]["yaw_rate_dps"] == 10.0  # told: the rate given, taken as the truth
    assert not any("+binned" in r["signal"] for r in rows)
    # at a working scale of about half the camera's (its side and its focal length), the
    # windows are fitted binned by 2
    binned = mod.run_sequence((3000, 2), (10.0,), 10, "exact", "second", working_px=120)
    assert [r["rate_dps"] for r in binned] == [r["rate_dps"] for r in rows]
    assert all("+binned2" in r["signal"] for r in binned)


def test_the_second_seas_camera_is_tilted_as_the_generator_tilts_it() -> None:
    """``--max-tilt-deg``: the clip is the generator's own with its camera tilted (the
    scene drawn with that radius, the same draw otherwise), and the rows carry the tilt."""
    mod = bench_module("bench_yaw")
    gen = mod._generator()
    sea, truth = mod._second_sea(3000, 2, 10, max_tilt_deg=8.0)
    sc = gen.draw_scene(3002, max_tilt_deg=8.0)
    assert 0.0 < sc.tilt_deg <= 8.0 and truth["tilt_deg"] == sc.tilt_deg
    assert truth["altitude_m"] == gen.draw_scene(3002).altitude_m
    clip, _ = gen.render_clip(sc)
    np.testing.assert_array_equal(sea * 255.0, clip[:10].astype(np.float32))
    level, _ = mod._second_sea(3000, 2, 10)
    assert not np.array_equal(level, sea)
    rows = mod.run_sequence((3000, 2), (10.0,), 10, "exact", "second", max_tilt_deg=8.0)
    assert [r["tilt_deg"] for r in rows] == [sc.tilt_deg] * 3


def test_plot_writes_a_png_of_a_run(tmp_path) -> None:
    res = subprocess.run([sys.executable, str(BENCH), "--seeds", "101", "--sequences", "1",
                          "--rates", "10", "--plot", str(tmp_path / "yaw.png"),
                          "--out", str(tmp_path / "yaw.json")],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert (tmp_path / "yaw.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
