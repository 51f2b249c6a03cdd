"""What an evaluation writes: the predictions CSV and the paper's Table 2 layout."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from wavealt.evaluation.metrics import EvaluationResult, fmt

#: The paper's Table 2 (ResNet-50 trained on clean, n = 30 test sequences each).
PAPER_TABLE2: dict[str, dict[str, float]] = {
    "clean": {"mae_m": 1.82, "rmse_m": 2.06, "bias_m": -0.06, "max_abs_err_m": 3.47},
    "glinty": {"mae_m": 2.49, "rmse_m": 2.80, "bias_m": -1.94, "max_abs_err_m": 3.88},
    "residual": {"mae_m": 3.12, "rmse_m": 4.36, "bias_m": -2.58, "max_abs_err_m": 9.92},
}

CONDITION_LABELS = {"clean": "Clean", "glinty": "Glinty", "residual": "Residual (TMF)"}


def read_abs_errors(path: Path | str) -> dict[str, dict[str, float]]:
    """``condition -> {sequence_id: absolute error (m)}`` from an evaluation's
    ``predictions.csv`` (a failed prediction: NaN)."""
    out: dict[str, dict[str, float]] = {}
    with Path(path).open(newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            try:
                err = abs(float(row["predicted_m"]) - float(row["altitude_m"]))
            except ValueError:
                err = math.nan
            out.setdefault(row["condition"], {})[row["sequence_id"]] = err
    return out


def predictions_csv(preds: dict[str, dict[str, np.ndarray]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    graded = any("quality" in d for d in preds.values())
    w.writerow(["condition", "sequence_id", "altitude_m", "predicted_m", "abs_err_m"]
               + (["quality", "trusted", "std_m", "reason"] if graded else []))
    for c, d in preds.items():
        n = len(d["pred_m"])
        qs = d.get("quality", np.full(n, np.nan))
        ts = d.get("trusted", [None] * n)
        ss = d.get("std_m", np.full(n, np.nan))
        rs = d.get("reason", [""] * n)
        for sid, t, p, q, ok, sd, why in zip(d["sequence_id"], d["true_m"], d["pred_m"], qs, ts,
                                             ss, rs):
            row = [c, sid, f"{t:.4f}", f"{p:.4f}", f"{abs(p - t):.4f}"]
            if graded:
                row += [f"{q:.3f}" if math.isfinite(q) else "", "" if ok is None else int(ok),
                        f"{sd:.4f}" if math.isfinite(sd) else "", why or ""]
            w.writerow(row)
    return buf.getvalue()


def _f(x: float | None, signed: bool = False, pct: bool = False) -> str:
    return fmt(x, signed=signed, digits=1 if pct else 2)


def table_markdown(result: EvaluationResult) -> str:
    """The paper's Table 2 layout: one row per condition, the glint penalty, the baseline."""
    m = result.metrics
    n = sorted({v["n"] for v in m.values()})
    lines = [f"Altitude estimation error by image condition — {result.estimator} "
             f"(n = {', '.join(map(str, n))} test sequences each)", "",
             "| Condition | MAE (m) | RMSE (m) | Bias (m) | Max Err (m) | Rel. MAE (%) |",
             "|---|---:|---:|---:|---:|---:|"]
    for c, v in m.items():
        lines.append(f"| {CONDITION_LABELS.get(c, c)} | {_f(v['mae_m'])} | {_f(v['rmse_m'])} | "
                     f"{_f(v['bias_m'], True)} | {_f(v['max_abs_err_m'])} | "
                     f"{_f(v.get('rel_mae_pct', math.nan), pct=True)} |")
    if "clean" in m and "glinty" in m:
        pen = m["glinty"]["mae_m"] - m["clean"]["mae_m"]
        lines.append(f"| Glint penalty | {_f(pen, True)} m MAE from clean → glinty | | | | |")
    if result.baseline is not None:
        b = result.baseline
        lines.append(f"| Baseline: {result.baseline_label} | {_f(b['mae_m'])} | {_f(b['rmse_m'])} | "
                     f"{_f(b['bias_m'], True)} | {_f(b['max_abs_err_m'])} | "
                     f"{_f(b.get('rel_mae_pct', math.nan), pct=True)} |")
    graded = {c: v for c, v in m.items() if "trusted" in v}
    if graded:
        lines += ["", "The sequences it trusts (it flags the others itself: not trusted), and "
                  "how often its 3-sigma interval holds the truth (all sequences):", "",
                  "| Condition | flagged | MAE (m) | Bias (m) | Rel. MAE (%) | 3σ covers (%) |",
                  "|---|---:|---:|---:|---:|---:|"]
        for c, v in graded.items():
            t = v["trusted"]
            cover = 100.0 * v.get("coverage_3sigma", math.nan)
            lines.append(f"| {CONDITION_LABELS.get(c, c)} | {v['flagged']} of "
                         f"{v['flagged'] + t['n']} | {_f(t['mae_m'])} | {_f(t['bias_m'], True)} | "
                         f"{_f(t.get('rel_mae_pct', math.nan), pct=True)} | {_f(cover, pct=True)} |")
        why = [(c, v["flag_reasons"]) for c, v in graded.items() if v.get("flag_reasons")]
        if why:
            lines += ["", "Why it flagged them (figures in a reason shown as N):", ""]
            for c, kinds in why:
                lines += [f"- {CONDITION_LABELS.get(c, c)}: " + "; ".join(
                    f"{k} ({n})" for k, n in kinds.items())]
    failed = {c: int(np.sum(~np.isfinite(d["pred_m"]))) for c, d in result.predictions.items()}
    if any(failed.values()):
        lines += ["", "Sequences without an estimate (left out of n): "
                  + ", ".join(f"{c} {k}" for c, k in failed.items() if k)]
    return "\n".join(lines) + "\n"


__all__ = ["CONDITION_LABELS", "PAPER_TABLE2", "predictions_csv", "read_abs_errors",
           "table_markdown"]
