"""``wavealt evaluate``: an estimator on a dataset's test split, per condition.

``evaluate`` writes into its output folder:

``metrics.json``    ``{"<condition>": {"n", "mae_m", "rmse_m", "bias_m", "max_abs_err_m"}}``
                    (bias = mean of predicted - true; n = sequences with a finite estimate);
                    for the dispersion altimeter also the count it ``flagged``, the metrics
                    of the sequences it ``trusted``, the share whose error its 3-sigma
                    interval covers (``coverage_3sigma``) and why it flagged the others
                    (``flag_reasons``: kind of reason -> count, figures as ``N``)
``predictions.csv`` one row per (condition, sequence); for the dispersion altimeter also its
                    ``quality``, whether it ``trusted`` the estimate (1 / 0), its one-sigma
                    uncertainty ``std_m`` and the ``reason`` it is not trusted
``table.md``        laid out like the paper's Table 2, with the glint-penalty row and the
                    constant baseline; for the dispersion altimeter the sequences it trusts,
                    the 3-sigma coverage and why it flagged the others
``fig5_predicted_vs_actual.png``, ``fig6_error_distribution.png``
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from wavealt.dataset import open_dataset
from wavealt.evaluation.estimators import (
    CnnEstimator,
    ConstantEstimator,
    DispersionEstimator,
    Estimator,
    parse_estimator,
    train_split_mean_m,
)
from wavealt.evaluation.metrics import EvaluationResult, altitude_metrics, trust_summary
from wavealt.evaluation.tables import predictions_csv, table_markdown
from wavealt.io import atomic_write_text, check_output_folder
from wavealt.plots import figure_error_distribution, figure_predicted_vs_actual


def _baseline_for(est: Estimator, dataset: Any) -> ConstantEstimator:
    if isinstance(est, ConstantEstimator):
        return est
    if isinstance(est, CnnEstimator):
        return ConstantEstimator(est.train_mean_m, source=str(est.run))
    return ConstantEstimator(train_split_mean_m(dataset), source="dataset train split")


def evaluate(dataset: Path | str, estimator: str | Estimator, *,
             conditions: Sequence[str] | None = None, out: Path | str | None = None,
             split: str = "test", progress: bool = True, figures: bool = True,
             device: str = "auto", force: bool = False) -> EvaluationResult:
    """Evaluate ``estimator`` on the ``split`` sequences of each condition.

    Parameters
    ----------
    dataset : path or str
        A dataset folder, or a sharded dataset (a path or an fsspec URL), read in manifest
        order so that each shard is read once per condition.
    estimator : str or Estimator
        A spec string (``cnn:RUN``, ``constant:RUN``, ``constant``, ``dispersion``) or object.
    conditions : sequence of str, optional
        Conditions to test (each must exist); default: every condition of the dataset.
    out : path, optional
        Folder for metrics.json, predictions.csv, table.md and Fig. 5/6.
    split : str
        ``test`` (default), ``val`` or ``train``.
    device : str
        Where a CNN estimator runs (``auto``, ``cpu``, ``cuda[:N]``, ``mps``).
    force : bool
        Replace the results already in ``out``; without it an ``out`` holding
        ``metrics.json`` is refused before any work.
    """

    if out is not None:
        check_output_folder(out, ("metrics.json",), force=force,
                            what="an evaluation (metrics.json)")
    ds = open_dataset(dataset)
    est = parse_estimator(estimator, ds, device=device) if isinstance(estimator, str) else estimator
    if isinstance(est, DispersionEstimator):
        est.bind(ds)
    # surface/ holds ground-truth heights (--save-surface), not frames to estimate from
    conds = list(conditions) if conditions else [c for c in ds.conditions if c != "surface"]
    if not conds:
        msg = "conditions must name at least one condition"
        raise ValueError(msg)
    for c in conds:
        ds.require_condition(c)
    records = ds.split(split)
    if not records:
        msg = f"dataset {ds.root} has no {split!r} sequences"
        raise ValueError(msg)
    true_m = np.array([r.altitude_m for r in records])
    metrics: dict[str, dict[str, Any]] = {}
    preds: dict[str, dict[str, np.ndarray]] = {}
    bar = tqdm(total=len(conds) * len(records), desc=f"evaluate {est.name}", disable=not progress,
               unit="seq")
    # estimators that grade their own fits (the dispersion altimeter) also get metrics on
    # the sequences they trust, and the count they flag
    graded = getattr(est, "estimate_graded", None)
    for c in conds:
        p = np.empty(len(records))
        q = np.full(len(records), np.nan)
        trusted = np.zeros(len(records), dtype=bool)
        std = np.full(len(records), np.nan)
        reasons: list[str | None] = [None] * len(records)
        for i, r in enumerate(records):
            if graded is not None:
                g = graded(ds, c, r)
                p[i], q[i], trusted[i] = g.altitude_m, g.quality, g.trusted
                std[i], reasons[i] = g.std_m, g.reason
            else:
                p[i] = est.estimate(ds, c, r)
            bar.update()
        metrics[c] = altitude_metrics(p, true_m)
        preds[c] = {"sequence_id": np.array([r.sequence_id for r in records]), "true_m": true_m,
                    "pred_m": p}
        if graded is not None:
            metrics[c]["flagged"] = int(np.count_nonzero(~trusted))
            metrics[c]["trusted"] = altitude_metrics(p[trusted], true_m[trusted])
            metrics[c].update(trust_summary(p, std, trusted, reasons, true_m))
            preds[c]["quality"] = q
            preds[c]["trusted"] = trusted
            preds[c]["std_m"] = std
            preds[c]["reason"] = np.array(["" if x is None else x for x in reasons],
                                          dtype=object)
    bar.close()
    base = _baseline_for(est, ds)
    base_metrics = altitude_metrics(np.full(len(records), base.altitude_m), true_m)
    result = EvaluationResult(est.name, metrics, preds, base_metrics,
                              f"constant {base.altitude_m:.2f} m ({base.source})")
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "metrics.json", json.dumps(metrics, indent=2) + "\n")
        atomic_write_text(out / "predictions.csv", predictions_csv(preds))
        atomic_write_text(out / "table.md", table_markdown(result))
        if figures:
            title = f"{est.name}, {split} split"
            figure_predicted_vs_actual(preds, out / "fig5_predicted_vs_actual.png", title=title)
            figure_error_distribution(preds, out / "fig6_error_distribution.png", title=title)
    return result


__all__ = ["evaluate"]
