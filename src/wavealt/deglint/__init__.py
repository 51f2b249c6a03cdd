"""Temporal deglinting (paper §3.3): the methods, their measured quality, and the dataset
command.

``temporal`` (eq. (5) and (6), streamed or in memory) -> ``methods`` (every method by name)
-> ``metrics`` (MAE, PSNR, SSIM against the clean frames) -> ``command``
(:func:`deglint_dataset`, behind ``wavealt deglint``).
"""

from wavealt.deglint.command import deglint_dataset
from wavealt.deglint.methods import (
    METHOD_DESCRIPTIONS,
    METHODS,
    PAPER_METHOD,
    achromatic,
    apply_method,
    condition_name,
    glint_mask,
    glint_masked,
    method_names,
    temporal_median,
    temporal_min_estimate,
    temporal_percentile,
)
from wavealt.deglint.metrics import mae, psnr_db, quality_table, ssim
from wavealt.deglint.temporal import (
    DEFAULT_WINDOW,
    sliding_min_stream,
    temporal_minimum,
    tmf_residual,
    window_bounds,
)

__all__ = ["DEFAULT_WINDOW", "METHODS", "METHOD_DESCRIPTIONS", "PAPER_METHOD", "achromatic",
           "apply_method", "condition_name", "deglint_dataset", "glint_mask", "glint_masked",
           "mae", "method_names", "psnr_db", "quality_table", "sliding_min_stream", "ssim",
           "temporal_median", "temporal_min_estimate", "temporal_minimum", "temporal_percentile",
           "tmf_residual", "window_bounds"]
