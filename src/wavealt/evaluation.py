"""Evaluation: altitude metrics per condition, the paper's Table 2, estimators and figures.

An *estimator* turns the frames of a test sequence into one altitude (m).  Spec strings (the
``--estimator`` of ``wavealt evaluate``):

``cnn:RUN``       the trained CNN of run folder RUN (best checkpoint)
``constant:RUN``  always the training-set mean altitude of RUN (the baseline to beat)
``constant``      always the mean altitude of the dataset's own train split
``dispersion``    the physics-based dispersion-relation altimeter (``wavealt.altimetry.dispersion``)
                  with the dispersion relation of the dataset's renderer (``gravity`` for the
                  ``paper`` renderer, ``gravity-capillary`` for ``realistic``);
                  ``dispersion:gravity`` / ``dispersion:gravity-capillary`` force one;
                  blind: the camera's velocity over the water is searched too
``dispersion-aided``  the same, given the camera's true velocity from the manifest (as a
                  vehicle's navigation would give it) as exact: only the altitude is searched
``dispersion-prior[:SIGMA]``  the same velocity as a prior: the camera's velocity over the
                  water may lie about SIGMA m/s (one sigma, default 1.0) from it; a further
                  ``:gravity`` / ``:gravity-capillary`` forces the dispersion relation

``evaluate`` writes into its output folder:

``metrics.json``    ``{"<condition>": {"n", "mae_m", "rmse_m", "bias_m", "max_abs_err_m"}}``
                    (bias = mean of predicted - true; n = sequences with a finite estimate)
``predictions.csv`` one row per (condition, sequence); for the dispersion altimeter also its
                    ``quality`` and whether it ``trusted`` the estimate (1 / 0)
``table.md``        laid out like the paper's Table 2, with the glint-penalty row and the
                    constant baseline
``fig5_predicted_vs_actual.png``, ``fig6_error_distribution.png``
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from tqdm.auto import tqdm

from wavealt._checks import check_finite_number
from wavealt.altimetry.dispersion import DISPERSIONS, DispersionAltimeter

METRIC_KEYS = ("n", "mae_m", "rmse_m", "bias_m", "max_abs_err_m", "rel_mae_pct")

#: Default one-sigma spread (m/s) of ``dispersion-prior``: the camera's velocity over the
#: water may differ from the navigation's by about a strong tidal current.
PRIOR_SIGMA_MPS = 1.0

#: The paper's Table 2 (ResNet-50 trained on clean, n = 30 test sequences each).
PAPER_TABLE2: dict[str, dict[str, float]] = {
    "clean": {"mae_m": 1.82, "rmse_m": 2.06, "bias_m": -0.06, "max_abs_err_m": 3.47},
    "glinty": {"mae_m": 2.49, "rmse_m": 2.80, "bias_m": -1.94, "max_abs_err_m": 3.88},
    "residual": {"mae_m": 3.12, "rmse_m": 4.36, "bias_m": -2.58, "max_abs_err_m": 9.92},
}

CONDITION_LABELS = {"clean": "Clean", "glinty": "Glinty", "residual": "Residual (TMF)"}


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


# -- estimators -------------------------------------------------------------------------
class Estimator(Protocol):
    name: str

    def estimate(self, dataset: Any, condition: str, record: Any) -> float:
        """Altitude (m) of one sequence of ``dataset`` in ``condition``; NaN if it gives up."""


@dataclass
class ConstantEstimator:
    """Always answers ``altitude_m`` (the training-set mean): the baseline to beat."""

    altitude_m: float
    source: str = ""
    name: str = "constant"

    def estimate(self, dataset: Any, condition: str, record: Any) -> float:
        return float(self.altitude_m)


class CnnEstimator:
    """The CNN of a training run folder (best checkpoint), mean over a sequence's frames."""

    def __init__(self, run: Path | str, *, device: str = "auto") -> None:
        from wavealt.altimetry.predict import load_run

        self.run = Path(run)
        self.predictor = load_run(self.run, device=device)
        cfg = self.predictor.config
        kind = "temporal " if cfg.temporal else ""
        self.name = f"cnn ({kind}{cfg.model}, trained on {cfg.condition})"

    @property
    def train_mean_m(self) -> float:
        return float(self.predictor.stats["target_mean_m"])

    def estimate(self, dataset: Any, condition: str, record: Any) -> float:
        frames = dataset.read_frames(condition, record.sequence_id)
        return self.predictor.predict_sequence(frames)


def dispersion_of(config: Any) -> str:
    """The dispersion relation a dataset's waves obey: ``"gravity"`` or ``"gravity-capillary"``.

    The ``paper`` renderer moves its waves with the deep-water relation ``omega = sqrt(g k)``
    only (paper §3.1); the ``realistic`` renderer with ``omega^2 = g k + (sigma/rho) k^3``.

    Parameters
    ----------
    config : SimConfig or None
        The dataset's generator config; None (unknown data) gives the real-water relation.
    """
    if config is None:
        return "gravity-capillary"
    renderer = getattr(config, "renderer", "paper")
    return "gravity" if renderer == "paper" else "gravity-capillary"


def dispersion_of_input(path: Path | str) -> str:
    """The dispersion relation for the frames at ``path`` (``wavealt altitude --dispersion
    auto``).

    A sequence folder of a wavealt dataset (``DATASET/<condition>/<sequence_id>/`` with
    ``DATASET/dataset.json``) takes the relation of the dataset's renderer
    (:func:`dispersion_of` of its config); anything else is taken for real water
    (``"gravity-capillary"``).

    Parameters
    ----------
    path : path
        A frame folder or a video file.
    """
    folder = Path(path)
    if folder.is_dir():
        root = folder.resolve().parent.parent
        if (root / "dataset.json").is_file():
            from wavealt.dataset import Dataset

            return dispersion_of(Dataset(root).config)
    return dispersion_of(None)


@dataclass(frozen=True)
class GradedEstimate:
    """An altitude with the estimator's own verdict on it.

    Attributes
    ----------
    altitude_m : float
        Estimated altitude, metres (NaN when the estimator gave up).
    quality : float
        The fit's quality in [0, 1].
    trusted : bool
        Whether the estimator vouches for it (``DispersionResult.trusted``).
    """

    altitude_m: float
    quality: float
    trusted: bool


class DispersionEstimator:
    """Physics-based: fit of the wave dispersion relation (``wavealt.altimetry.dispersion``).

    Parameters
    ----------
    dispersion : {"gravity-capillary", "gravity"} or None
        Dispersion relation; None picks the one of the dataset evaluated (:func:`dispersion_of`).
    aided : bool
        Give the altimeter the camera's true velocity over the water (the manifest's
        ``camera_speed_mps`` / ``camera_dir_deg``; ``(0, 0)`` for a hovering camera), as a
        vehicle's navigation would, so it searches the altitude only ("exact" mode, or
        "prior" with ``velocity_sigma_mps > 0``).  Otherwise ("blind") it searches the
        velocity too.
    velocity_sigma_mps : float
        With ``aided``: how far (m/s, one sigma) the camera's velocity over the water may lie
        from the one given; 0 for exact.
    """

    def __init__(self, *, dispersion: str | None = None, aided: bool = False,
                 velocity_sigma_mps: float = 0.0) -> None:
        self.aided = bool(aided)
        self.velocity_sigma_mps = check_finite_number("velocity_sigma_mps", velocity_sigma_mps,
                                                      low=0.0)
        if self.velocity_sigma_mps > 0 and not self.aided:
            msg = (f"velocity_sigma_mps needs aided=True (a velocity to be uncertain about); "
                   f"got {velocity_sigma_mps!r} without it")
            raise ValueError(msg)
        self.dispersion = dispersion
        self.altimeter = None if dispersion is None else DispersionAltimeter(dispersion=dispersion)

    @property
    def name(self) -> str:
        if not self.aided:
            velocity = "blind"
        elif self.velocity_sigma_mps > 0:
            velocity = f"velocity prior ±{self.velocity_sigma_mps:g} m/s"
        else:
            velocity = "velocity known"
        parts = [p for p in (self.dispersion, velocity) if p]
        return f"dispersion ({', '.join(parts)})"

    def bind(self, dataset: Any) -> None:
        """Fix the dispersion relation to the one of ``dataset``'s renderer, if not given."""
        if self.altimeter is None:
            self.dispersion = dispersion_of(getattr(dataset, "config", None))
            self.altimeter = DispersionAltimeter(dispersion=self.dispersion)

    def estimate_graded(self, dataset: Any, condition: str, record: Any) -> GradedEstimate:
        """Altitude of one sequence (NaN if it gives up), the fit's quality and whether the
        altimeter trusts it."""
        self.bind(dataset)
        frames = dataset.read_frames(condition, record.sequence_id)
        try:
            velocity = record.scenario.camera_velocity_mps if self.aided else None
            res = self.altimeter.estimate(frames, fps=record.scenario.fps,
                                          focal_px=record.scenario.focal_px,
                                          velocity_mps=velocity,
                                          velocity_sigma_mps=self.velocity_sigma_mps)
        except ValueError:
            return GradedEstimate(math.nan, 0.0, False)
        return GradedEstimate(float(res.altitude_m), float(res.quality), bool(res.trusted))

    def estimate(self, dataset: Any, condition: str, record: Any) -> float:
        return self.estimate_graded(dataset, condition, record).altitude_m


def train_split_mean_m(dataset: Any) -> float:
    """Mean true altitude (m) of the dataset's train split."""
    recs = dataset.split("train")
    if not recs:
        msg = f"dataset {dataset.root} has no train split to take a mean from"
        raise ValueError(msg)
    return float(np.mean([r.altitude_m for r in recs]))


def parse_estimator(spec: str, dataset: Any = None, *, device: str = "auto") -> Estimator:
    """Build an estimator from its spec string (see the module docstring); a CNN runs on
    ``device``."""
    kind, _, arg = str(spec).partition(":")
    if kind == "cnn" and arg:
        return CnnEstimator(arg, device=device)
    if kind == "constant" and arg:
        from wavealt.altimetry.predict import CONFIG_NAME

        cfg = Path(arg) / CONFIG_NAME
        if not cfg.is_file():
            msg = f"run folder {arg} has no {CONFIG_NAME} (train it with `wavealt train`)"
            raise FileNotFoundError(msg)
        info = json.loads(cfg.read_text(encoding="utf-8"))
        return ConstantEstimator(float(info["stats"]["target_mean_m"]), source=str(arg))
    if kind == "constant" and dataset is not None:
        return ConstantEstimator(train_split_mean_m(dataset), source="dataset train split")
    if kind in ("dispersion", "dispersion-aided") and arg in ("", *DISPERSIONS):
        return DispersionEstimator(dispersion=arg or None, aided=kind == "dispersion-aided")
    if kind == "dispersion-prior":
        return _prior_estimator(spec, arg)
    msg = (f"unknown estimator {spec!r}; expected cnn:RUN, constant:RUN, constant, "
           "dispersion[:gravity|:gravity-capillary], dispersion-aided[:…] or "
           "dispersion-prior[:SIGMA][:…]")
    raise ValueError(msg)


def _prior_estimator(spec: str, arg: str) -> DispersionEstimator:
    """``dispersion-prior[:SIGMA][:gravity|:gravity-capillary]`` (``arg``: after the first
    colon)."""
    sigma, dispersion = PRIOR_SIGMA_MPS, None
    parts = arg.split(":") if arg else []
    if parts and parts[-1] in DISPERSIONS:
        dispersion = parts.pop()
    if len(parts) > 1:
        msg = (f"unknown estimator {spec!r}; expected "
               "dispersion-prior[:SIGMA][:gravity|:gravity-capillary]")
        raise ValueError(msg)
    if parts:
        try:
            sigma = float(parts[0])
        except ValueError:
            sigma = math.nan
        if not (math.isfinite(sigma) and sigma > 0):
            msg = (f"SIGMA of estimator {spec!r} must be a number > 0 (m/s; "
                   f"dispersion-aided for a velocity known exactly); got {parts[0]!r}")
            raise ValueError(msg)
    return DispersionEstimator(dispersion=dispersion, aided=True, velocity_sigma_mps=sigma)


# -- evaluation -------------------------------------------------------------------------
@dataclass
class EvaluationResult:
    """Per-condition metrics and predictions of one estimator."""

    estimator: str
    metrics: dict[str, dict[str, Any]]
    predictions: dict[str, dict[str, np.ndarray]]  # cond -> {"sequence_id", "true_m", "pred_m"}
    baseline: dict[str, Any] | None = None
    baseline_label: str = ""


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
    dataset : path
        Dataset folder.
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
    from wavealt.dataset import Dataset
    from wavealt.io import atomic_write_text, check_output_folder

    if out is not None:
        check_output_folder(out, ("metrics.json",), force=force,
                            what="an evaluation (metrics.json)")
    ds = Dataset(dataset)
    est = parse_estimator(estimator, ds, device=device) if isinstance(estimator, str) else estimator
    if isinstance(est, DispersionEstimator):
        est.bind(ds)
    conds = list(conditions) if conditions else ds.conditions
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
        for i, r in enumerate(records):
            if graded is not None:
                g = graded(ds, c, r)
                p[i], q[i], trusted[i] = g.altitude_m, g.quality, g.trusted
            else:
                p[i] = est.estimate(ds, c, r)
            bar.update()
        metrics[c] = altitude_metrics(p, true_m)
        preds[c] = {"sequence_id": np.array([r.sequence_id for r in records]), "true_m": true_m,
                    "pred_m": p}
        if graded is not None:
            metrics[c]["flagged"] = int(np.count_nonzero(~trusted))
            metrics[c]["trusted"] = altitude_metrics(p[trusted], true_m[trusted])
            preds[c]["quality"] = q
            preds[c]["trusted"] = trusted
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
            from wavealt.plots import (
                figure_error_distribution,
                figure_predicted_vs_actual,
            )

            title = f"{est.name}, {split} split"
            figure_predicted_vs_actual(preds, out / "fig5_predicted_vs_actual.png", title=title)
            figure_error_distribution(preds, out / "fig6_error_distribution.png", title=title)
    return result


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
               + (["quality", "trusted"] if graded else []))
    for c, d in preds.items():
        n = len(d["pred_m"])
        qs = d.get("quality", np.full(n, np.nan))
        ts = d.get("trusted", [None] * n)
        for sid, t, p, q, ok in zip(d["sequence_id"], d["true_m"], d["pred_m"], qs, ts):
            row = [c, sid, f"{t:.4f}", f"{p:.4f}", f"{abs(p - t):.4f}"]
            if graded:
                row += [f"{q:.3f}" if math.isfinite(q) else "", "" if ok is None else int(ok)]
            w.writerow(row)
    return buf.getvalue()


def _f(x: float, signed: bool = False, pct: bool = False) -> str:
    if x is None or not math.isfinite(x):
        return "—"
    if pct:
        return f"{x:.1f}"
    return f"{x:+.2f}" if signed else f"{x:.2f}"


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
        lines += ["", "The sequences it trusts (it flags the others itself: not trusted):", "",
                  "| Condition | flagged | MAE (m) | Bias (m) | Rel. MAE (%) |",
                  "|---|---:|---:|---:|---:|"]
        for c, v in graded.items():
            t = v["trusted"]
            lines.append(f"| {CONDITION_LABELS.get(c, c)} | {v['flagged']} of "
                         f"{v['flagged'] + t['n']} | {_f(t['mae_m'])} | {_f(t['bias_m'], True)} | "
                         f"{_f(t.get('rel_mae_pct', math.nan), pct=True)} |")
    failed = {c: int(np.sum(~np.isfinite(d["pred_m"]))) for c, d in result.predictions.items()}
    if any(failed.values()):
        lines += ["", "Sequences without an estimate (left out of n): "
                  + ", ".join(f"{c} {k}" for c, k in failed.items() if k)]
    return "\n".join(lines) + "\n"


__all__ = ["METRIC_KEYS", "PAPER_TABLE2", "PRIOR_SIGMA_MPS", "CnnEstimator", "ConstantEstimator",
           "DispersionEstimator", "EvaluationResult", "GradedEstimate", "altitude_metrics",
           "dispersion_of", "dispersion_of_input", "evaluate", "parse_estimator",
           "paired_mae_difference", "predictions_csv", "read_abs_errors", "table_markdown",
           "train_split_mean_m"]
