"""The figures stay readable at page width, whatever the number of conditions; the
altimeter's coverage curve counts what it says."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from wavealt.plots import (
    MAX_COLUMNS,
    coverage_curve,
    figure_altimeter_windows,
    figure_error_distribution,
    figure_predicted_vs_actual,
    windows_by_row,
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


def test_the_coverage_curve_counts_the_windows_within_k_stated_sigmas() -> None:
    """``|est - true| <= k std``, boundary included; a window without an estimate is never
    covered; normal errors of the stated size cover 68.3 % at one sigma and 99.7 % at three;
    lengths that differ are refused, and no windows give NaN."""
    got = coverage_curve([10.0] * 4, [10.0, 11.0, 12.0, math.nan], [1.0] * 4,
                         np.array([0.0, 1.0, 1.5, 2.0, 3.0]))
    np.testing.assert_array_equal(got, [0.25, 0.5, 0.5, 0.75, 0.75])
    rng = np.random.default_rng(3)
    true = rng.uniform(1.0, 15.0, 40000)
    std = 0.03 * true
    normal = coverage_curve(true, true + std * rng.standard_normal(true.size), std, [1.0, 3.0])
    np.testing.assert_allclose(normal, [0.6827, 0.9973], atol=0.006)
    with pytest.raises(ValueError, match="one length"):
        coverage_curve([1.0, 2.0], [1.0], [0.1, 0.1], [1.0])
    assert np.isnan(coverage_curve([], [], [], [1.0, 2.0])).all()


def test_the_altimeter_figure_is_a_line_of_two_panels_a_row(tmp_path) -> None:
    """Each row adds one line of the same height (estimates, coverage); a row without a
    trusted window or with windows that have no estimate still draws."""
    rng = np.random.default_rng(1)
    t = rng.uniform(1.0, 15.0, 50)
    row = {"true_m": t, "est_m": t * (1.0 + 0.02 * rng.standard_normal(t.size)),
           "std_m": 0.02 * t, "trusted": rng.random(t.size) < 0.5}
    bare = {**row, "est_m": np.where(np.arange(t.size) % 5, row["est_m"], np.nan),
            "trusted": np.zeros(t.size, dtype=bool)}
    sizes = [_size(figure_altimeter_windows(dict(list({"a": row, "b": bare}.items())[:n]),
                                            tmp_path / f"{n}.png")) for n in (1, 2)]
    (w1, h1), (w2, h2) = sizes
    assert w1 == w2 and w1 > h1 and 1.7 < h2 / h1 < 2.2


def test_windows_are_grouped_by_row_in_the_order_asked() -> None:
    """Each row keeps its windows in their order, read from the fields named; the rows
    named in ``order`` come first in that order, the rest after by name."""
    recs = [{"row": r, "h": h, "e": h + 1, "s": 0.1, "t": h > 2}
            for r, h in (("z", 1.0), ("b", 2.0), ("a", 3.0), ("b", 4.0))]
    rows = windows_by_row(recs, ("h", "e", "s", "t"), order=("b", "q"))
    assert list(rows) == ["b", "a", "z"]
    assert rows["b"] == {"true_m": [2.0, 4.0], "est_m": [3.0, 5.0], "std_m": [0.1, 0.1],
                         "trusted": [False, True]}
