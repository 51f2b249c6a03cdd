"""Altitude error metrics, and the paired test of two estimators on the same sequences."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

METRIC_KEYS = ("n", "mae_m", "rmse_m", "bias_m", "max_abs_err_m", "rel_mae_pct")


def altitude_metrics(predicted_m: Sequence[float], true_m: Sequence[float]) -> dict[str, Any]:
    """MAE, RMSE, bias (mean of predicted - true) and max absolute error, in metres, and the
    relative MAE ``mean(|predicted - true| / true)`` in percent of the true altitude.

    Non-finite predictions (an estimator that gave up) are left out; ``n`` counts the rest.

    Parameters
    ----------
    predicted_m, true_m : sequence of float, shape (N,)
        Estimated and true altitudes.
    """
    p = np.asarray(predicted_m, dtype=np.float64).ravel()
    t = np.asarray(true_m, dtype=np.float64).ravel()
    if p.shape != t.shape:
        msg = f"predicted_m and true_m must have the same length; got {p.size} and {t.size}"
        raise ValueError(msg)
    if not np.all(np.isfinite(t)):
        msg = "true_m must be finite"
        raise ValueError(msg)
    ok = np.isfinite(p)
    err = p[ok] - t[ok]
    if err.size == 0:
        return {"n": 0, "mae_m": math.nan, "rmse_m": math.nan, "bias_m": math.nan,
                "max_abs_err_m": math.nan, "rel_mae_pct": math.nan}
    return {"n": int(err.size), "mae_m": float(np.mean(np.abs(err))),
            "rmse_m": float(np.sqrt(np.mean(err**2))), "bias_m": float(np.mean(err)),
            "max_abs_err_m": float(np.max(np.abs(err))),
            "rel_mae_pct": float(100.0 * np.mean(np.abs(err) / np.abs(t[ok])))}


def trust_summary(predicted_m: Sequence[float], std_m: Sequence[float],
                  trusted: Sequence[bool], reasons: Sequence[str | None],
                  true_m: Sequence[float]) -> dict[str, Any]:
    """What an estimator that grades itself says of its own errors: the share of the
    sequences with an estimate whose 3-sigma interval ``predicted +- 3 std`` holds the
    truth (``coverage_3sigma``; NaN with none), and the kinds of reason it gave for the
    ones it did not trust, most frequent first (``flag_reasons``; the figures in a reason
    replaced by ``N``, :func:`wavealt.altimetry.dispersion.result.reason_counts`)."""
    from wavealt.altimetry.dispersion.result import reason_counts

    p, s, t = (np.asarray(a, dtype=np.float64).ravel() for a in (predicted_m, std_m, true_m))
    ok = np.isfinite(p) & np.isfinite(s)
    covered = np.abs(p[ok] - t[ok]) <= 3.0 * s[ok]
    flagged = [why for flag, why in zip(trusted, reasons, strict=True) if not flag]
    return {"coverage_3sigma": float(covered.mean()) if covered.size else math.nan,
            "flag_reasons": reason_counts(flagged)}


def paired_mae_difference(err_a: Sequence[float], err_b: Sequence[float], *,
                          n_boot: int = 10000, level: float = 0.95,
                          seed: int = 0) -> dict[str, float]:
    """``MAE(a) - MAE(b)`` over the same test sequences, with its percentile bootstrap
    interval at ``level`` (the sequences resampled with their pairs of errors, so what the
    two methods share — hard sequences — does not widen it).  Pairs with a non-finite error
    are left out; ``n`` counts the rest (NaN interval below 2)."""
    a = np.abs(np.asarray(err_a, np.float64))
    b = np.abs(np.asarray(err_b, np.float64))
    if a.shape != b.shape:
        msg = f"paired errors need the same sequences; got {a.size} and {b.size}"
        raise ValueError(msg)
    d = (a - b)[np.isfinite(a) & np.isfinite(b)]
    if d.size < 2:
        return {"n": int(d.size), "diff_m": float(d.mean()) if d.size else math.nan,
                "lo_m": math.nan, "hi_m": math.nan}
    rng = np.random.default_rng(seed)
    boots = d[rng.integers(0, d.size, (int(n_boot), d.size))].mean(axis=1)
    lo, hi = np.quantile(boots, [(1 - level) / 2, (1 + level) / 2])
    return {"n": int(d.size), "diff_m": float(d.mean()), "lo_m": float(lo), "hi_m": float(hi)}


def fmt(x: float | None, *, signed: bool = False, digits: int = 2) -> str:
    """A number for a table or a sentence: ``—`` when missing or not finite, never ``-0.00``
    (a value that rounds to zero prints unsigned, or ``+0.00`` when ``signed``)."""
    if x is None or not math.isfinite(x):
        return "—"
    v = round(float(x), digits)
    if v == 0:
        v = 0.0  # drops the sign of -0.0
    return f"{v:+.{digits}f}" if signed else f"{v:.{digits}f}"


@dataclass
class EvaluationResult:
    """Per-condition metrics and predictions of one estimator."""

    estimator: str
    metrics: dict[str, dict[str, Any]]
    predictions: dict[str, dict[str, np.ndarray]]  # cond -> {"sequence_id", "true_m", "pred_m"}
    baseline: dict[str, Any] | None = None
    baseline_label: str = ""



__all__ = ["METRIC_KEYS", "EvaluationResult", "altitude_metrics", "fmt", "paired_mae_difference",
           "trust_summary"]
