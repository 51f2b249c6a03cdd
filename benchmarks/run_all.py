"""Run every ``benchmarks/bench_*.py`` and collect their JSON into ``benchmarks/results/``.

Each script prints one JSON object on stdout; this runner saves it as
``results/<name>.json`` and prints a one-line summary per benchmark.
Run: ``python benchmarks/run_all.py [--full] [NAME ...]`` (names without ``bench_`` / ``.py``).

By default every script runs with the small settings of :data:`QUICK_ARGS` (each ends within
about two minutes on one core); ``--full`` runs each with its own defaults (the sizes the
issues ask for; minutes to tens of minutes each).
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: Small settings per benchmark for ``make bench``; the JSON records them as run.
QUICK_ARGS: dict[str, list[str]] = {
    "cnn": ["--batches", "1", "--batch-size", "8"],
    "deglint": ["--frames-1080p", "10", "--frames-224", "100", "--repeat", "1"],
    # six sequences of one seed per row; no cache, so ``make bench`` leaves no frames behind
    "dispersion": ["--quick", "--no-cache"],
    "foreign_sea": ["--clips", "4"],
    "nulls": ["--clips", "4"],
    "yaw": ["--sequences", "4"],
    "shake": ["--sequences", "3", "--amplitudes", "0.5"],
    "latency": ["--sequences", "3", "--amplitudes", "0.5", "--delays-ms", "0,100"],
    "live_shake": ["--sequences", "1", "--amplitudes", "1", "--frames", "50"],
    "realistic": ["--size", "128", "--sequences", "2"],
    "resample": ["--clips", "4"],
    "scale": ["--sequences", "4", "--size", "64", "--repeats", "1"],
    "simulate": ["--sequences", "4"],
    "tiles": ["--sequences", "3", "--seeds", "101", "--no-cache"],
}


def main(argv: list[str]) -> int:
    full = "--full" in argv
    argv = [a for a in argv if a != "--full"]
    scripts = sorted(HERE.glob("bench_*.py"))
    if argv:
        wanted = set(argv)
        unknown = wanted - {p.stem.removeprefix("bench_") for p in scripts}
        if unknown:
            print(f"run_all: unknown benchmark(s): {', '.join(sorted(unknown))}", file=sys.stderr)
            return 2
        scripts = [p for p in scripts if p.stem.removeprefix("bench_") in wanted]
    out_dir = HERE / "results"
    out_dir.mkdir(exist_ok=True)
    failed = 0
    for script in scripts:
        name = script.stem.removeprefix("bench_")
        t0 = time.perf_counter()
        extra = [] if full else QUICK_ARGS.get(name, [])
        proc = subprocess.run([sys.executable, str(script), *extra], capture_output=True,
                              text=True)
        dt = time.perf_counter() - t0
        if proc.returncode != 0:
            failed += 1
            print(f"{name}: FAILED after {dt:.0f} s\n{proc.stderr.strip()[-2000:]}", file=sys.stderr)
            continue
        try:
            result = json.loads(proc.stdout)
        except json.JSONDecodeError:
            failed += 1
            print(f"{name}: printed no JSON", file=sys.stderr)
            continue
        if isinstance(result, dict):
            result.setdefault("run_all_args", extra)
        (out_dir / f"{name}.json").write_text(json.dumps(result, indent=2) + "\n")
        print(f"{name}: {dt:.0f} s -> {out_dir / (name + '.json')}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
