"""One figure of the dispersion altimeter across the independent generator's conditions.

    python benchmarks/plot_conditions.py --out docs/conditions.png [--rows blind30,exact10] \
        "LABEL=RUN.json[.gz]" "LABEL=RUN.json[.gz]" ...

Each argument is a ``bench_foreign_sea.py`` run (its ``--out`` file, gzipped or not) and
the label it is drawn under; runs that share a label (several seeds) are pooled.  Two
panels per row (``blind30``, ``exact10``, ...; ``--rows``, default those every label
holds): the share of windows trusted, and the relative error of every window (trusted ones
dark, untrusted ones light; log scale).  The cost of a condition (fewer windows trusted)
and the trust test's hold on it (no dark point far off) show at once.  Prints one JSON
object: per label and row, the windows, the trusted share, the MAE of all and of the
trusted windows, and how many trusted windows lie more than 10 % off.
"""

from __future__ import annotations

import argparse
import gzip
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np


def load_run(path: Path) -> list[dict[str, Any]]:
    """The window records of a ``bench_foreign_sea.py`` run; a one-line ``ValueError`` naming
    the file when it is not one."""
    try:
        raw = gzip.decompress(path.read_bytes()) if path.suffix == ".gz" else path.read_bytes()
        records = json.loads(raw)["records"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        msg = f"{path}: not a bench_foreign_sea.py run with records ({exc.__class__.__name__})"
        raise ValueError(msg) from None
    return records


def parse_runs(specs: list[str]) -> dict[str, list[dict[str, Any]]]:
    """``{label: records}`` of ``LABEL=PATH`` arguments, in the order the labels first come."""
    runs: dict[str, list[dict[str, Any]]] = {}
    for spec in specs:
        label, sep, path = spec.partition("=")
        if not sep or not label or not path:
            msg = f"expected LABEL=RUN.json, got {spec!r}"
            raise ValueError(msg)
        runs.setdefault(label, []).extend(load_run(Path(path)))
    return runs


def window_errors(recs: list[dict[str, Any]], row: str) -> tuple[np.ndarray, np.ndarray]:
    """``(|relative error|, trusted)`` of every window of ``row`` in ``recs`` that has an
    estimate."""
    sel = [r for r in recs if r["row"] == row and r.get("est") is not None]
    err = np.array([abs(r["est"] / r["altitude_m"] - 1) for r in sel], dtype=np.float64)
    return err, np.array([bool(r["trusted"]) for r in sel], dtype=bool)


def summary(runs: dict[str, list[dict[str, Any]]]) -> dict[str, dict[str, dict[str, Any]]]:
    """Per label and row: windows, trusted share, MAE of all and of trusted windows, and the
    trusted windows more than 10 % off."""
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for label, recs in runs.items():
        for row in dict.fromkeys(r["row"] for r in recs):
            err, trusted = window_errors(recs, row)
            out.setdefault(label, {})[row] = {
                "windows": int(err.size),
                "trusted_share": float(trusted.mean()) if err.size else None,
                "mae": float(err.mean()) if err.size else None,
                "trusted_mae": float(err[trusted].mean()) if trusted.any() else None,
                "trusted_over_10pct": int(np.sum(err[trusted] > 0.1)),
            }
    return out


def common_rows(runs: dict[str, list[dict[str, Any]]]) -> list[str]:
    """The rows every label's runs hold, in the order they first come."""
    held = [{r["row"] for r in recs} for recs in runs.values()]
    return [row for row in dict.fromkeys(r["row"] for recs in runs.values() for r in recs)
            if all(row in h for h in held)]


def plot(runs: dict[str, list[dict[str, Any]]], out: Path, rows: list[str]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = list(runs)
    fig, axes = plt.subplots(2, len(rows), figsize=(4.2 * len(rows), 6.4), squeeze=False)
    stats = summary(runs)
    x = np.arange(len(labels))
    rng = np.random.default_rng(0)  # the points' horizontal jitter only
    for j, row in enumerate(rows):
        share = [stats[lb].get(row, {}).get("trusted_share") or 0.0 for lb in labels]
        ax = axes[0, j]
        ax.bar(x, share, color="tab:blue")
        ax.set_ylim(0, 1)
        ax.set_title(row)
        ax.set_ylabel("share of windows trusted" if j == 0 else "")
        ax.set_xticks(x, labels, rotation=30, ha="right", fontsize=8)
        ax = axes[1, j]
        for i, lb in enumerate(labels):
            err, trusted = window_errors(runs[lb], row)
            err = np.maximum(err, 1e-4)  # on the log axis
            jit = i + rng.uniform(-0.3, 0.3, err.size)
            ax.scatter(jit[~trusted], err[~trusted], s=4, color="0.75", label=None)
            ax.scatter(jit[trusted], err[trusted], s=5, color="tab:blue", label=None)
        ax.axhline(0.1, color="tab:red", lw=0.8, ls="--")
        ax.set_yscale("log")
        ax.set_ylim(1e-4, 10)
        ax.set_ylabel("|relative error| (blue: trusted)" if j == 0 else "")
        ax.set_xticks(x, labels, rotation=30, ha="right", fontsize=8)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", metavar="LABEL=RUN.json")
    ap.add_argument("--out", type=Path, required=True, help="the figure (PNG)")
    ap.add_argument("--rows", default=None,
                    help="comma list of the rows drawn (default: those every label holds)")
    a = ap.parse_args(argv)
    try:
        runs = parse_runs(a.runs)
    except ValueError as exc:
        ap.error(str(exc))
    rows = common_rows(runs) if a.rows is None else [r for r in a.rows.split(",") if r]
    missing = [r for r in rows if not any(x["row"] == r for recs in runs.values() for x in recs)]
    if missing or not rows:
        ap.error(f"--rows: no run holds {missing or 'any row'}")
    plot(runs, a.out, rows)
    json.dump({"figure": str(a.out), "conditions": summary(runs)}, sys.stdout, indent=1)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
