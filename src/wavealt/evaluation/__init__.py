"""Evaluation: estimators side by side on a dataset, their altitude metrics per condition,
the paper's Table 2, the figures.

``estimators`` (spec strings of ``--estimator``) -> ``command`` (:func:`evaluate`) -> ``metrics``
and ``tables`` (what it writes).
"""

from wavealt.evaluation.command import evaluate
from wavealt.evaluation.estimators import (
    PRIOR_SIGMA_MPS,
    CnnEstimator,
    ConstantEstimator,
    DispersionEstimator,
    Estimator,
    GradedEstimate,
    dispersion_of,
    dispersion_of_input,
    parse_estimator,
    train_split_mean_m,
)
from wavealt.evaluation.metrics import (
    METRIC_KEYS,
    EvaluationResult,
    altitude_metrics,
    fmt,
    paired_mae_difference,
    trust_summary,
)
from wavealt.evaluation.tables import (
    CONDITION_LABELS,
    PAPER_TABLE2,
    predictions_csv,
    read_abs_errors,
    table_markdown,
)

__all__ = ["CONDITION_LABELS", "METRIC_KEYS", "PAPER_TABLE2", "PRIOR_SIGMA_MPS", "CnnEstimator",
           "ConstantEstimator", "DispersionEstimator", "Estimator", "EvaluationResult",
           "GradedEstimate", "altitude_metrics", "dispersion_of", "dispersion_of_input",
           "evaluate", "fmt", "paired_mae_difference", "parse_estimator", "predictions_csv",
           "read_abs_errors", "table_markdown", "train_split_mean_m", "trust_summary"]
