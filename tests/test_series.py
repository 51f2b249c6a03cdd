"""Altitude over sliding windows: rows carry each window's verdict, the summary trusts only
trusted windows, and the files record both."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from wavealt.altimetry.coding import PREDICTED_FRAMES, predicted_verdict
from wavealt.altimetry.series import (
    CSV_COLUMNS,
    NO_TRUSTED_WINDOW,
    altitude_series,
    summarize,
)
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence

H_M = 3.0


@pytest.fixture(scope="module")
def waves() -> tuple[np.ndarray, float]:
    """10 frames of 128 px linear in the surface slope (an idealised camera), the camera
    hovering at 3 m over still water; and the focal length.  (At 64 px the clip's shortest
    waves turn so little in 10 frames that its fit is not trusted: 3 sigma 11 %.)"""
    cfg = preset_config("paper", size=128, altitude_m=(H_M, H_M), wind_speed_mps=(7.0, 7.0))
    data = generate_sequence(cfg.sample_scenario(1), cfg)
    x = data.slope_x + 0.7 * data.slope_y
    x = (x - x.min()) / (x.max() - x.min())
    return x.astype(np.float32), cfg.focal_px


def _row(altitude_m: float, std_m: float, quality: float, trusted: bool,
         velocity: tuple[float, float] = (0.0, 0.0)) -> dict:
    return {"start_frame": 0, "stop_frame": 10, "time_s": 0.15, "altitude_m": altitude_m,
            "altitude_std_m": std_m, "camera_velocity_mps": list(velocity), "quality": quality,
            "trusted": trusted, "reason": None if trusted else "no prominent wave-shell peak",
            "mode": "prior", "frames": 10, "n_modes": 100, "signal": "luma/corners"}


@pytest.mark.parametrize(("velocity", "sigma", "mode"), [
    (None, 0.0, "blind"), ((0.0, 0.0), 0.5, "prior"), ((0.0, 0.0), 0.0, "exact")])
def test_rows_carry_the_verdict_and_the_mode(waves, velocity, sigma, mode) -> None:
    """A frozen clip (one frame repeated) has no moving waves: every window says so."""
    frozen = np.repeat(waves[0][:1], 20, axis=0)
    summary, rows = altitude_series(frozen, fps=30.0, focal_px=waves[1], window=10, step=5,
                                    dispersion="gravity", velocity_mps=velocity,
                                    velocity_sigma_mps=sigma)
    assert len(rows) == 3
    for r in rows:
        assert r["mode"] == mode and r["trusted"] is False and r["reason"]
        assert len(r["camera_velocity_mps"]) == 2 and "signal" in r
    assert summary["mode"] == mode


def test_summary_of_untrusted_windows_is_untrusted_with_a_large_std(waves, tmp_path) -> None:
    frozen = np.repeat(waves[0][:1], 30, axis=0)
    summary, rows = altitude_series(frozen, fps=30.0, focal_px=waves[1], window=10, step=10,
                                    dispersion="gravity", velocity_mps=(0.0, 0.0),
                                    out=tmp_path)
    assert summary["trusted"] is False and summary["reason"] == NO_TRUSTED_WINDOW
    assert summary["windows"] == 3 and summary["trusted_windows"] == 0
    assert summary["altitude_std_m"] >= np.median([r["altitude_std_m"] for r in rows])
    on_disk = json.loads((tmp_path / "altitude.json").read_text())
    assert on_disk["summary"] == summary and on_disk["windows"] == rows
    with (tmp_path / "altitude.csv").open(newline="") as fh:
        table = list(csv.DictReader(fh))
    assert list(table[0]) == list(CSV_COLUMNS) and len(table) == 3
    assert {t["trusted"] for t in table} == {"0"} and {t["mode"] for t in table} == {"exact"}
    assert all(t["reason"] == r["reason"] for t, r in zip(table, rows))


def test_summary_takes_the_trusted_windows_only(waves, tmp_path) -> None:
    """Waves, then a frozen second: the summary is the waves' window, untouched by the
    frozen one's estimate."""
    clip, focal_px = waves
    frames = np.concatenate([clip, np.repeat(clip[-1:], 10, axis=0)])
    summary, rows = altitude_series(frames, fps=30.0, focal_px=focal_px, window=10, step=10,
                                    dispersion="gravity", velocity_mps=(0.0, 0.0),
                                    out=tmp_path)
    assert [(r["start_frame"], r["trusted"]) for r in rows] == [(0, True), (10, False)]
    good = rows[0]
    assert abs(good["altitude_m"] - H_M) <= 3.0 * good["altitude_std_m"]
    assert summary["trusted"] is True and summary["reason"] is None
    assert summary["windows"] == 2 and summary["trusted_windows"] == 1
    assert summary["altitude_m"] == good["altitude_m"]
    assert summary["altitude_std_m"] == good["altitude_std_m"]
    assert summary["camera_velocity_mps"] == good["camera_velocity_mps"]
    assert summary["frames"] == 20 and summary["mode"] == "exact"
    with (tmp_path / "altitude.csv").open(newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [t["trusted"] for t in table] == ["1", "0"]
    assert float(table[0]["camera_vx_mps"]) == good["camera_velocity_mps"][0]
    assert table[0]["reason"] == "" and table[1]["reason"] == rows[1]["reason"]


def test_summarize_weights_trusted_windows_and_ignores_confident_untrusted_ones() -> None:
    rows = [_row(3.0, 0.1, 0.5, True, (1.0, 0.0)), _row(3.2, 0.1, 0.9, True, (1.2, 0.2)),
            _row(2.9, 0.1, 0.4, True, (0.8, -0.2)), _row(15.0, 0.2, 0.29, False, (5.0, 5.0))]
    s = summarize(rows, frames=40)
    # quality-weighted median of 2.9 (0.4), 3.0 (0.5), 3.2 (0.9): half the weight at 3.0
    assert s["altitude_m"] == 3.0
    # robust spread 1.4826 * median(|[0, 0.2, 0.1]|) beats median std / sqrt(3)
    assert s["altitude_std_m"] == pytest.approx(1.4826 * 0.1)
    assert s["camera_velocity_mps"] == [1.0, 0.0]
    assert s["trusted"] is True and s["reason"] is None
    assert (s["windows"], s["trusted_windows"], s["frames"]) == (4, 3, 40)
    assert s["quality"] == pytest.approx(np.mean([0.5, 0.9, 0.4, 0.29]))
    assert s["mode"] == "prior" and s["signal"] == "luma/corners"


def test_summarize_untrusted_reports_the_larger_of_spread_and_median_std() -> None:
    rows = [_row(2.0, 0.5, 0.2, False), _row(5.0, 1.0, 0.1, False), _row(9.0, 3.0, 0.25, False)]
    s = summarize(rows, frames=30)
    assert s["trusted"] is False and s["reason"] == NO_TRUSTED_WINDOW
    assert s["altitude_m"] == 5.0  # weights 0.2 / 0.1 / 0.25: 5 m holds the half-way point
    assert s["altitude_std_m"] == pytest.approx(max(1.4826 * 3.0, 1.0))
    tight = [_row(5.0, 2.0, 0.1, False), _row(5.1, 2.0, 0.1, False)]
    assert summarize(tight, frames=20)["altitude_std_m"] == 2.0  # the windows' own std
    with pytest.raises(ValueError, match="rows"):
        summarize([], frames=10)


def test_single_window_is_its_own_summary() -> None:
    row = _row(4.0, 0.3, 0.1, False)
    s = summarize([row], frames=10)
    assert s["altitude_m"] == 4.0 and s["trusted"] is False and s["reason"] == row["reason"]
    assert (s["windows"], s["trusted_windows"]) == (1, 0) and "start_frame" not in s


def test_the_verdict_on_predicted_frames_keeps_a_fits_own_reason_and_the_exact_mode() -> None:
    """A window already not trusted keeps its own reason; an exact one, and frames not
    predicted (no codec), are left as they are; a trusted blind one is refused, its 3-sigma
    interval spanning the range."""
    base = _row(3.0, 0.05, 0.8, True)
    assert predicted_verdict(dict(base), None, (0.5, 20.0)) == base
    assert predicted_verdict({**base, "mode": "exact"}, "h264", (0.5, 20.0))["trusted"] is True
    own = predicted_verdict(_row(3.0, 6.5, 0.1, False), "h264", (0.5, 20.0))
    assert own["reason"] == "no prominent wave-shell peak"
    out = predicted_verdict(dict(base), "hevc", (1.0, 16.0))
    assert out["trusted"] is False and out["reason"] == PREDICTED_FRAMES.format(codec="hevc")
    assert out["altitude_std_m"] == 5.0 and out["altitude_m"] == 3.0
