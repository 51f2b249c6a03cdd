"""The shared input checks: a whole number is an int, or a float without a fraction, within
its bounds, and anything else is a one-line ``ValueError`` naming the input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wavealt._checks import check_integer
from wavealt.altimetry.dispersion import DispersionAltimeter
from wavealt.io import sliding_windows


@pytest.mark.parametrize("value", [3, np.int64(3), 3.0, np.float32(3.0)])
def test_a_whole_number_comes_back_as_an_int(value: object) -> None:
    got = check_integer("frames", value, low=2, high=3)
    assert got == 3 and type(got) is int


@pytest.mark.parametrize(("value", "bounds", "match"), [
    (True, {}, "frames must be an integer; got True"),
    (np.bool_(True), {}, "frames must be an integer; got "),
    (2.5, {}, "frames must be an integer; got 2.5"),
    (math.nan, {"low": 2}, "frames must be an integer >= 2; got nan"),
    (math.inf, {"low": 2}, "frames must be an integer >= 2; got inf"),
    ("3", {"low": 2}, "frames must be an integer >= 2; got '3'"),
    (None, {"high": 9}, "frames must be an integer <= 9; got None"),
    (1, {"low": 2}, "frames must be an integer >= 2; got 1"),
    (101, {"low": 1, "high": 100}, "frames must be an integer in [1, 100]; got 101"),
])
def test_anything_else_is_one_line_naming_the_input(value: object, bounds: dict,
                                                      match: str) -> None:
    with pytest.raises(ValueError) as info:
        check_integer("frames", value, **bounds)
    assert str(info.value).startswith(match) and "\n" not in str(info.value)


def test_a_nan_or_infinite_count_is_named_where_int_would_not_name_it() -> None:
    """``int(nan)`` and ``int(inf)`` raise their own errors (a ValueError that names no
    input, an OverflowError): the checks name the input instead."""
    with pytest.raises(ValueError, match="max_modes must be an integer >= 8; got nan"):
        DispersionAltimeter(max_modes=math.nan)
    with pytest.raises(ValueError, match="window must be an integer >= 3; got inf"):
        list(sliding_windows(10, window=math.inf))
