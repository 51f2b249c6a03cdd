"""Evaluation: hand-computed metrics, exact constant baseline, files, estimators, bad input."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from wavealt.altimetry.dispersion import reason_class
from wavealt.dataset import Dataset
from wavealt.evaluation import (
    METRIC_KEYS,
    ConstantEstimator,
    altitude_metrics,
    evaluate,
    parse_estimator,
    train_split_mean_m,
)


def test_metrics_match_hand_computed_example() -> None:
    m = altitude_metrics([2.0, 3.0, 7.0], [1.0, 4.0, 4.0])  # errors +1, -1, +3
    assert m == {"n": 3, "mae_m": 5 / 3, "rmse_m": math.sqrt(11 / 3), "bias_m": 1.0,
                 "max_abs_err_m": 3.0,
                 "rel_mae_pct": pytest.approx(100 * (1 / 1 + 1 / 4 + 3 / 4) / 3)}
    assert tuple(m) == METRIC_KEYS


def test_metrics_leave_out_failed_estimates() -> None:
    m = altitude_metrics([2.0, math.nan], [1.0, 4.0])
    assert m["n"] == 1 and m["mae_m"] == 1.0
    assert math.isnan(altitude_metrics([math.nan], [1.0])["mae_m"])
    with pytest.raises(ValueError, match="same length"):
        altitude_metrics([1.0], [1.0, 2.0])


def test_constant_baseline_is_exact(tiny_dataset, tmp_path) -> None:
    ds = Dataset(tiny_dataset)
    mean = float(np.mean([r.altitude_m for r in ds.split("train")]))
    assert train_split_mean_m(ds) == mean
    res = evaluate(tiny_dataset, "constant", conditions=["clean", "glinty"], out=tmp_path,
                   progress=False, figures=False)
    truth = np.array([r.altitude_m for r in ds.split("test")])
    for c in ("clean", "glinty"):
        assert res.metrics[c]["bias_m"] == pytest.approx(mean - truth.mean(), abs=1e-12)
        assert res.metrics[c]["mae_m"] == pytest.approx(np.mean(np.abs(mean - truth)), abs=1e-12)
        np.testing.assert_array_equal(res.predictions[c]["pred_m"], mean)
    on_disk = json.loads((tmp_path / "metrics.json").read_text())
    assert set(on_disk) == {"clean", "glinty"}
    assert all(tuple(v) == METRIC_KEYS for v in on_disk.values())
    with (tmp_path / "predictions.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * len(truth)
    table = (tmp_path / "table.md").read_text()
    assert "Glint penalty" in table and "Baseline: constant" in table


def test_cnn_estimator_and_figures(tiny_dataset, tmp_path) -> None:
    from wavealt.altimetry.data import TrainConfig
    from wavealt.altimetry.train import train

    run = tmp_path / "run"
    train(tiny_dataset, run, TrainConfig(condition="bright", model="resnet-tiny", epochs=1,
                                         batch_size=8), progress=False)
    res = evaluate(tiny_dataset, f"cnn:{run}", conditions=["bright", "clean"],
                   out=tmp_path / "ev", progress=False)
    assert res.metrics["bright"]["n"] == len(Dataset(tiny_dataset).split("test"))
    assert (tmp_path / "ev" / "fig5_predicted_vs_actual.png").stat().st_size > 0
    assert (tmp_path / "ev" / "fig6_error_distribution.png").stat().st_size > 0
    info = json.loads((run / "config.json").read_text())
    const = parse_estimator(f"constant:{run}")
    assert isinstance(const, ConstantEstimator)
    assert const.altitude_m == info["stats"]["target_mean_m"]


def test_bad_input(tiny_dataset, tmp_path) -> None:
    with pytest.raises(ValueError, match="unknown estimator 'magic'"):
        evaluate(tiny_dataset, "magic", progress=False)
    with pytest.raises(FileNotFoundError, match="has no best.pt"):
        evaluate(tiny_dataset, f"cnn:{tmp_path}", progress=False)
    with pytest.raises(FileNotFoundError, match="has no config.json"):
        evaluate(tiny_dataset, f"constant:{tmp_path}", progress=False)
    with pytest.raises(FileNotFoundError, match="no condition 'residual'"):
        evaluate(tiny_dataset, "constant", conditions=["residual"], progress=False)


def test_incomplete_condition_is_skipped_and_refused(tiny_dataset, tmp_path) -> None:
    import shutil

    from wavealt.deglint import deglint_dataset

    root = tmp_path / "ds"
    shutil.copytree(tiny_dataset, root)
    ds = Dataset(root)
    # an interrupted deglint: one sequence written, the condition flagged incomplete
    first = ds.records[0].sequence_id
    ds.write_frames("residual", first, ds.read_frames("glinty", first))
    ds.register_condition("residual", "interrupted", complete=False, method="tmf", window=4)
    ds = Dataset(root)
    assert "residual" not in ds.conditions and not ds.is_complete("residual")
    assert ds.is_complete("clean")
    with pytest.raises(ValueError, match="condition 'residual' .* is incomplete"):
        ds.read_frames("residual", first)
    res = evaluate(root, "constant", out=tmp_path / "ev", progress=False, figures=False)
    assert "residual" not in res.metrics and {"clean", "glinty"} <= set(res.metrics)
    with pytest.raises(ValueError, match="is incomplete"):
        evaluate(root, "constant", conditions=["clean", "residual"], progress=False)
    # finishing the deglint run (resuming the written sequence) makes it usable
    deglint_dataset(root, method="tmf", window=4, progress=False)
    ds = Dataset(root)
    assert "residual" in ds.conditions
    assert "residual" in evaluate(root, "constant", progress=False, figures=False).metrics


def test_dispersion_relation_follows_the_renderer(tiny_dataset) -> None:
    from wavealt.evaluation import DispersionEstimator, dispersion_of
    from wavealt.sim.config import preset_config

    assert dispersion_of(preset_config("paper", sequences=6, size=64)) == "gravity"
    assert dispersion_of(preset_config("realistic", sequences=6, size=64)) == "gravity-capillary"
    assert dispersion_of(None) == "gravity-capillary"
    est = parse_estimator("dispersion:gravity")
    assert isinstance(est, DispersionEstimator) and est.altimeter.dispersion == "gravity"
    est = parse_estimator("dispersion")
    assert est.altimeter is None  # bound to the dataset's renderer when evaluated
    res = evaluate(tiny_dataset, est, conditions=["clean"], progress=False, figures=False)
    assert res.estimator == "dispersion (gravity, blind)"
    assert est.altimeter.dispersion == "gravity"
    aided = parse_estimator("dispersion-aided:gravity-capillary")
    assert aided.aided and aided.name == "dispersion (gravity-capillary, velocity known)"
    assert aided.velocity_sigma_mps == 0.0
    for bad in ("dispersion:water", "dispersion-aided:x", "dispersion-prior:1:2",
                "dispersion-prior:0.5:water"):
        with pytest.raises(ValueError, match=f"unknown estimator '{bad}'"):
            parse_estimator(bad)


@pytest.mark.parametrize(("spec", "sigma", "dispersion"), [
    ("dispersion-prior", 1.0, None), ("dispersion-prior:0.3", 0.3, None),
    ("dispersion-prior:0.3:gravity", 0.3, "gravity"),
    ("dispersion-prior:gravity-capillary", 1.0, "gravity-capillary")])
def test_dispersion_prior_spec(spec, sigma, dispersion) -> None:
    from wavealt.evaluation import DispersionEstimator

    est = parse_estimator(spec)
    assert isinstance(est, DispersionEstimator) and est.aided
    assert est.velocity_sigma_mps == sigma and est.dispersion == dispersion
    assert f"velocity prior ±{sigma:g} m/s" in est.name
    with pytest.raises(ValueError, match="velocity_sigma_mps needs aided"):
        DispersionEstimator(velocity_sigma_mps=sigma)


@pytest.mark.parametrize("bad", ["dispersion-prior:0", "dispersion-prior:-1",
                                 "dispersion-prior:nan", "dispersion-prior:fast"])
def test_dispersion_prior_spec_needs_a_positive_sigma(bad) -> None:
    with pytest.raises(ValueError, match="SIGMA .* must be a number > 0"):
        parse_estimator(bad)


def test_dispersion_of_input_reads_the_dataset_of_a_sequence_folder(tiny_dataset,
                                                                   tmp_path) -> None:
    from wavealt.evaluation import dispersion_of_input

    seq = next(p for p in sorted((tiny_dataset / "clean").iterdir()) if p.is_dir())
    assert dispersion_of_input(seq) == "gravity"  # the paper renderer's waves
    assert dispersion_of_input(tmp_path) == "gravity-capillary"  # real water
    assert dispersion_of_input(tmp_path / "clip.mp4") == "gravity-capillary"


def test_dispersion_reports_the_sequences_it_trusts(tiny_dataset, tmp_path) -> None:
    from wavealt.evaluation import DispersionEstimator

    est = DispersionEstimator(aided=True)
    res = evaluate(tiny_dataset, est, conditions=["clean", "glinty"], out=tmp_path,
                   progress=False, figures=False)
    ds = Dataset(tiny_dataset)
    truth = np.array([r.altitude_m for r in ds.split("test")])
    with (tmp_path / "predictions.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for c in ("clean", "glinty"):
        m = res.metrics[c]
        q = res.predictions[c]["quality"]
        assert q.shape == truth.shape and np.all((q >= 0) & (q <= 1))
        trusted = res.predictions[c]["trusted"]
        assert trusted.dtype == bool and trusted.shape == truth.shape
        assert m["flagged"] == int(np.sum(~trusted))
        assert m["trusted"]["n"] == int(np.sum(trusted)) == len(truth) - m["flagged"]
        if trusted.any():
            err = np.abs(res.predictions[c]["pred_m"][trusted] - truth[trusted])
            assert m["trusted"]["mae_m"] == pytest.approx(err.mean(), abs=1e-12)
        # the quality on disk is the one graded
        on_disk = np.array([float(r["quality"]) for r in rows if r["condition"] == c])
        np.testing.assert_allclose(on_disk, q, atol=5e-4)
        assert [r["trusted"] for r in rows if r["condition"] == c] == [str(int(t)) for t in trusted]
        # each sequence's uncertainty and reason: a reason exactly where it is not trusted,
        # the coverage counted from them, and every flagged sequence's reason counted once
        std = res.predictions[c]["std_m"]
        assert np.all(std > 0)
        mine = [r for r in rows if r["condition"] == c]
        np.testing.assert_allclose([float(r["std_m"]) for r in mine], std, rtol=1e-3)
        assert [bool(r["reason"]) for r in mine] == [not t for t in trusted]
        err = np.abs(res.predictions[c]["pred_m"] - truth)
        assert m["coverage_3sigma"] == pytest.approx(float(np.mean(err <= 3 * std)))
        assert sum(m["flag_reasons"].values()) == m["flagged"]
        assert set(m["flag_reasons"]) == {reason_class(r["reason"]) for r in mine
                                          if r["trusted"] == "0"}
    on_disk = json.loads((tmp_path / "metrics.json").read_text())
    assert set(on_disk["clean"]["trusted"]) == set(METRIC_KEYS)
    table = (tmp_path / "table.md").read_text()
    assert "The sequences it trusts (it flags the others itself: not trusted)" in table
    flagged = res.metrics["clean"]["flagged"]
    assert f"| Clean | {flagged} of {len(truth)} |" in table
    if flagged:
        kind, count = next(iter(res.metrics["clean"]["flag_reasons"].items()))
        assert f"{kind} ({count})" in table


def test_reason_kinds_hide_the_figures_and_keep_the_words() -> None:
    """Two reasons that differ only in what was measured are one kind; counts of tiles and
    the sigma level named in the rule are kept."""
    a = reason_class("3-sigma uncertainty 12 % of the altitude")
    assert a == reason_class("3-sigma uncertainty 31 % of the altitude")
    assert a == "3-sigma uncertainty N % of the altitude"
    assert reason_class("the corner tiles that hold the waves read +21 % from the fit (4.3 "
                        "sigma): its peak is not theirs") == (
        "the corner tiles that hold the waves read N % from the fit (N sigma): its peak is "
        "not theirs")
    assert reason_class("velocity 1.23 m/s from the prior's mean, beyond 3 sigma") == (
        "velocity N m/s from the prior's mean, beyond 3 sigma")
    assert reason_class("2 of the 4 corner tiles hold the waves") != reason_class(
        "1 of the 4 corner tiles holds the waves")
    assert reason_class(None) is None


def test_trust_summary_counts_coverage_and_reasons() -> None:
    from wavealt.evaluation import trust_summary

    out = trust_summary([10.0, 11.0, np.nan, 5.0], [0.1, 1.0, np.nan, 0.5],
                        [True, False, False, False],
                        [None, "3-sigma uncertainty 27 % of the altitude", "frames too dark",
                         "3-sigma uncertainty 12 % of the altitude"], [10.2, 10.0, 7.0, 6.0])
    # 10 +- 0.3 holds 10.2; 11 +- 3 holds 10.0; 5 +- 1.5 holds 6.0; the NaN is left out
    assert out["coverage_3sigma"] == 1.0
    assert out["flag_reasons"] == {"3-sigma uncertainty N % of the altitude": 2,
                                   "frames too dark": 1}
    assert trust_summary([12.0], [0.5], [True], [None], [10.0]) == {
        "coverage_3sigma": 0.0, "flag_reasons": {}}
    assert math.isnan(trust_summary([np.nan], [np.nan], [False], [None], [3.0])[
        "coverage_3sigma"])


def test_printed_numbers_never_read_minus_zero() -> None:
    from wavealt.evaluation import fmt

    assert fmt(-0.001) == "0.00" and fmt(-0.001, signed=True) == "+0.00"
    assert fmt(-0.004, signed=True, digits=2) == "+0.00" and fmt(-0.006, signed=True) == "-0.01"
    assert fmt(float("nan")) == "—" and fmt(None) == "—" and fmt(1.234, digits=1) == "1.2"


def test_a_dataset_coded_with_h264_is_judged_as_a_video_file_is(tmp_path) -> None:
    """The realistic camera's H.264 predicts frames from other frames: a sequence the
    altimeter trusts blind is not trusted in the evaluation, the codec named, and its 3-sigma
    interval spans the range; one it does not trust keeps its own reason."""
    from wavealt.altimetry.coding import PREDICTED_FRAMES, simulated_codec
    from wavealt.altimetry.dispersion import DispersionAltimeter
    from wavealt.dataset import simulate_dataset
    from wavealt.evaluation import DispersionEstimator
    from wavealt.sim.config import preset_config

    # enough sequences that the altimeter trusts some of them on its own (2 of 16 windows)
    cfg = preset_config("realistic", sequences=8, size=128, frames=30, altitude_m=(3.0, 3.0),
                        wind_speed_mps=(8.0, 8.0), compression="h264")
    assert simulated_codec(cfg) == "h264"
    assert simulated_codec(preset_config("realistic")) is None  # JPEG: frames coded alone
    assert simulated_codec(preset_config("paper")) is None
    simulate_dataset(tmp_path / "ds", cfg, progress=False)
    ds = Dataset(tmp_path / "ds")
    est, alone = DispersionEstimator(), DispersionAltimeter(dispersion="gravity-capillary")
    vouched = 0
    for rec in ds.records:
        for cond in ("clean", "glinty"):
            got = est.estimate_graded(ds, cond, rec)
            own = alone.estimate(ds.read_frames(cond, rec.sequence_id),
                                 fps=rec.scenario.fps, focal_px=rec.scenario.focal_px)
            assert got.altitude_m == pytest.approx(own.altitude_m)
            assert got.trusted is False
            if own.trusted:
                vouched += 1
                assert got.reason == PREDICTED_FRAMES.format(codec="h264")
                assert 3.0 * got.std_m >= 19.5
            else:
                assert got.reason == own.reason
    assert vouched  # the verdict was put to the test
