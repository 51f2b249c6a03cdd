"""Input validation shared by every stage: one clear message naming what was wrong."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np


def as_rng(rng: Any) -> np.random.Generator:
    """Turn ``rng`` (a ``numpy.random.Generator``, an int seed or None) into a Generator."""
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, (int, np.integer)):
        return np.random.default_rng(rng)
    msg = f"rng must be a numpy.random.Generator or an int seed; got {type(rng).__name__}"
    raise ValueError(msg)


def check_finite_number(name: str, value: Any, *, low: float | None = None,
                        high: float | None = None, low_open: bool = False,
                        high_open: bool = False) -> float:
    """Check a scalar is finite and in range; return it as float.

    ``low_open`` / ``high_open`` make the bound exclusive.
    """
    try:
        x = float(value)
    except (TypeError, ValueError):
        msg = f"{name} must be a number; got {value!r}"
        raise ValueError(msg) from None
    if not math.isfinite(x):
        msg = f"{name} must be finite; got {value!r}"
        raise ValueError(msg)
    if low is not None and (x < low or (low_open and x == low)):
        op = ">" if low_open else ">="
        msg = f"{name} must be {op} {low:g}; got {x:g}"
        raise ValueError(msg)
    if high is not None and (x > high or (high_open and x == high)):
        op = "<" if high_open else "<="
        msg = f"{name} must be {op} {high:g}; got {x:g}"
        raise ValueError(msg)
    return x


def check_integer(name: str, value: Any, *, low: int | None = None,
                  high: int | None = None) -> int:
    """Check a scalar is a whole number (an int, or a finite float without a fraction; not a
    bool) within ``[low, high]``; return it as int."""
    whole = (not isinstance(value, (bool, np.bool_))
             and isinstance(value, (int, float, np.integer, np.floating))
             and math.isfinite(value) and float(value).is_integer())
    if (not whole or (low is not None and value < low)
            or (high is not None and value > high)):
        bound = (f" in [{low}, {high}]" if low is not None and high is not None
                 else f" >= {low}" if low is not None else f" <= {high}" if high is not None
                 else "")
        msg = f"{name} must be an integer{bound}; got {value!r}"
        raise ValueError(msg)
    return int(value)


def check_frames(frames: Any, *, name: str = "frames", min_frames: int = 1,
                 allow_gray: bool = False, check_range: bool = True) -> np.ndarray:
    """Validate a frame sequence and return it as a NumPy array (no copy when possible).

    Accepts ``(T, H, W, 3)`` (and ``(T, H, W)`` when ``allow_gray``).  Float frames must be
    finite and in ``[0, 1]``; ``uint8`` frames are accepted as they are.
    """
    arr = np.asarray(frames)
    shape_ok = (arr.ndim == 4 and arr.shape[-1] == 3) or (allow_gray and arr.ndim == 3)
    if not shape_ok:
        want = "(T, H, W, 3) or (T, H, W)" if allow_gray else "(T, H, W, 3)"
        msg = f"{name} must be {want}; got shape {arr.shape}"
        raise ValueError(msg)
    if arr.shape[0] < min_frames:
        msg = f"{name} must hold at least {min_frames} frames; got {arr.shape[0]}"
        raise ValueError(msg)
    if arr.shape[1] < 1 or arr.shape[2] < 1:
        msg = f"{name} must have non-empty frames; got shape {arr.shape}"
        raise ValueError(msg)
    if arr.dtype == np.uint8:
        return arr
    if not np.issubdtype(arr.dtype, np.floating):
        msg = f"{name} must be float32 in [0, 1] or uint8; got dtype {arr.dtype}"
        raise ValueError(msg)
    if check_range:
        # min and max propagate NaN and reach +-inf: one pass each instead of three
        lo, hi = float(arr.min()), float(arr.max())
        if not (math.isfinite(lo) and math.isfinite(hi)):
            msg = f"{name} holds NaN or infinite values"
            raise ValueError(msg)
        if lo < 0.0 or hi > 1.0:
            msg = f"{name} must be in [0, 1]; got values in [{lo:.4g}, {hi:.4g}]"
            raise ValueError(msg)
    return arr


def check_rgb(name: str, value: Any) -> tuple[float, float, float]:
    """Three finite non-negative numbers (R, G, B); return them as a tuple of floats."""
    if len(value) != 3:
        msg = f"{name} must have 3 components (R, G, B); got {value!r}"
        raise ValueError(msg)
    r, g, b = (check_finite_number(name, x, low=0.0) for x in value)
    return r, g, b


def check_known_keys(d: dict[str, Any], names: set[str], *, what: str = "config") -> None:
    """Reject keys of ``d`` outside ``names``: a typo in a config must fail loudly."""
    unknown = sorted(set(d) - names)
    if unknown:
        msg = f"unknown {what} key(s): {', '.join(unknown)}; expected some of {', '.join(sorted(names))}"
        raise ValueError(msg)


def check_choice(name: str, value: Any, choices: Any) -> Any:
    """Check ``value`` is one of ``choices``; return it."""
    if value not in choices:
        msg = f"{name} must be one of {', '.join(map(str, choices))}; got {value!r}"
        raise ValueError(msg)
    return value


def read_csv_rows(path: Any, columns: tuple[str, ...], what: str) -> list[dict[str, str]]:
    """The rows of a CSV file with a header that holds ``columns``; a missing file or column
    is a one-line error naming ``what`` the file is (e.g. ``"attitude file"``)."""
    path = Path(path)
    if not path.is_file():
        msg = f"{what} not found: {path}"
        raise FileNotFoundError(msg)
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        missing = [c for c in columns if c not in (reader.fieldnames or [])]
        if missing:
            msg = (f"{what} {path} needs a header with the column(s) {', '.join(columns)}; "
                   f"missing: {', '.join(missing)}")
            raise ValueError(msg)
        return list(reader)


def read_number_columns(path: Any, columns: tuple[str, ...], what: str) -> Any:
    """The ``columns`` of a CSV file with a header (:func:`read_csv_rows`), as a ``(rows,
    len(columns))`` float64 array; a cell that is not a number is a one-line error."""
    rows = read_csv_rows(path, columns, what)
    try:
        return np.array([[float(row[c]) for c in columns] for row in rows],
                        np.float64).reshape(-1, len(columns))
    except (TypeError, ValueError):
        msg = f"{what} {path}: every {', '.join(columns)} must be a number"
        raise ValueError(msg) from None
