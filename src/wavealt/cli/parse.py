"""Parsing of the command line's comma-separated values: one-line errors naming the option."""

from __future__ import annotations

import math
import re


def numbers(text: str, name: str, counts: tuple[int, ...], expected: str) -> list[float]:
    """Comma-separated finite numbers, as many as one of ``counts``; else a one-line error
    naming option ``--name`` and what it ``expected``."""
    msg = f"--{name} must be {expected}; got {text!r}"
    try:
        vals = [float(p) for p in text.split(",")]
    except ValueError:
        raise ValueError(msg) from None
    if len(vals) not in counts or not all(math.isfinite(v) for v in vals):
        raise ValueError(msg)
    return vals


def number_range(text: str | None, name: str) -> tuple[float, float] | None:
    """Parse ``LO,HI`` or a single value (``LO = HI``) into a range of finite numbers."""
    if text is None:
        return None
    vals = numbers(text, name, (1, 2), "a finite number or LO,HI")
    return vals[0], vals[-1]


def vector(text: str | None, name: str, metavar: str = "X,Y") -> tuple[float, float] | None:
    """Parse ``X,Y``: exactly two finite numbers (a single one is an error, not ``X,X``)."""
    if text is None:
        return None
    vals = numbers(text, name, (2,), f"two finite numbers {metavar}")
    return vals[0], vals[1]


def part(text: str | None) -> tuple[int, int] | None:
    """Parse ``--part I/N`` (0 <= I < N): this job's share of an array of N jobs."""
    if text is None:
        return None
    msg = f"--part must be I/N with 0 <= I < N (this job's index among N); got {text!r}"
    m = re.fullmatch(r"\s*(\d+)\s*/\s*(\d+)\s*", text)
    if m is None or not int(m.group(1)) < int(m.group(2)):
        raise ValueError(msg)
    return int(m.group(1)), int(m.group(2))
