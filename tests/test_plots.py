"""The figures stay readable at page width, whatever the number of conditions."""

from __future__ import annotations

import numpy as np
from PIL import Image

from wavealt.plots import (
    MAX_COLUMNS,
    figure_error_distribution,
    figure_predicted_vs_actual,
)

CONDITIONS = ("clean", "glinty", "residual", "tmf-min", "median", "percentile", "glint-mask",
              "achromatic")


def _size(path) -> tuple[int, int]:
    with Image.open(path) as im:
        return im.size


def _predictions(n_conditions: int) -> dict:
    rng = np.random.default_rng(0)
    t = rng.uniform(1.0, 5.0, 18)
    return {c: {"true_m": t, "pred_m": t + rng.normal(0.0, 0.5, t.size)}
            for c in CONDITIONS[:n_conditions]}


def test_fig5_and_fig6_wrap_eight_conditions_into_a_grid(tmp_path) -> None:
    preds = _predictions(8)
    for draw, name in ((figure_predicted_vs_actual, "fig5.png"),
                       (figure_error_distribution, "fig6.png")):
        w, h = _size(draw(preds, tmp_path / name))
        # 4 columns x 2 rows, not a 2759 x 427 strip: fits a page at the saved resolution
        assert w <= 1700 and w / h < 3.0, (name, w, h)


def test_one_condition_is_one_panel(tmp_path) -> None:
    w, h = _size(figure_predicted_vs_actual(_predictions(1), tmp_path / "f.png"))
    assert w / h < 1.6 and MAX_COLUMNS == 4
