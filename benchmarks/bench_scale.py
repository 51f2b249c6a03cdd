"""Scale-out: simulating on Dask workers, and writing shards beside folders, JSON out.

    python benchmarks/bench_scale.py [--sequences 24] [--size 256] [--repeats 2] [--out FILE]

In one run, on the ``paper`` preset (10 frames a sequence):

- ``simulate`` (synthesis, rendering, PNG encoding, writing a dataset folder) on one
  process, today's ``--workers 2`` process pool, and Dask LocalClusters of 1 and 2 workers
  (``--cluster local:N``): end to end (``simulate_dataset``, the cluster's start-up
  included) and steady (the same sequences through a runner already started and warmed
  up: the rate a long run settles to). The best of ``--repeats`` runs, the configurations
  interleaved so that a drift in the machine's load hits them alike.
- writing alone: the same sequences, already rendered in memory, written as frame folders and
  as tar shards (PNG encoding included: both formats hold the same PNG bytes).
- files and folders per sequence in each format (and for shards, bytes per shard).

Targets (issue 20): 2 Dask workers >= 1.8 x one worker, within 10 % of ``--workers 2``;
shards written no slower than folders. The machine's core count and load average are
recorded: on 2 cores with one busy with something else, two workers cannot run at 2 x.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from wavealt.dataset import records_of_index, simulate_dataset
from wavealt.dataset.shards import sample_of, shard_location, write_shard
from wavealt.dataset.simulate import _write_one
from wavealt.io import atomic_write_text, write_frames_folder
from wavealt.sim.cluster import TaskRunner, runner_spec
from wavealt.sim.config import preset_config
from wavealt.sim.generate import generate_sequence

RUNNERS = {"workers_1": {}, "workers_2": {"workers": 2},
           "dask_local_1": {"cluster": "local:1"}, "dask_local_2": {"cluster": "local:2"}}


def _simulate_s(cfg, tmp: Path, name: str, kw: dict) -> float:
    """``simulate_dataset`` end to end, the cluster's start-up included."""
    out = tmp / f"sim-{name}-{time.monotonic_ns()}"
    t0 = time.perf_counter()
    simulate_dataset(out, cfg, progress=False, **kw)
    dt = time.perf_counter() - t0
    subprocess.run(["rm", "-rf", str(out)], check=True)
    return dt


def _steady_s(cfg, tmp: Path, name: str, kw: dict) -> float:
    """The same sequences written by a runner already started and warmed up (every worker
    has imported wavealt): the rate a long run settles to."""
    out = tmp / f"steady-{name}-{time.monotonic_ns()}"
    spec = runner_spec(**kw)
    with TaskRunner(spec) as runner:
        warm = preset_config("paper", size=32, frames=2, sequences=max(2, spec.workers * 2))
        list(runner.map_unordered(_write_one, [(str(out / "warm"), warm.to_dict(), i, False)
                                               for i in range(warm.sequences)]))
        tasks = [(str(out / "ds"), cfg.to_dict(), i, False) for i in range(cfg.sequences)]
        t0 = time.perf_counter()
        for _ in runner.map_unordered(_write_one, tasks):
            pass
        dt = time.perf_counter() - t0
    subprocess.run(["rm", "-rf", str(out)], check=True)
    return dt


def _files(root: Path) -> tuple[int, int]:
    paths = list(root.rglob("*"))
    return sum(p.is_file() for p in paths), sum(p.is_dir() for p in paths)


def simulate_rates(cfg, tmp: Path, repeats: int) -> dict:
    frames = cfg.sequences * cfg.frames
    walls: dict[str, list[float]] = {k: [] for k in RUNNERS}
    steady: dict[str, list[float]] = {k: [] for k in RUNNERS}
    for _ in range(repeats):
        for name, kw in RUNNERS.items():
            walls[name].append(_simulate_s(cfg, tmp, name, kw))
            steady[name].append(_steady_s(cfg, tmp, name, kw))
    out = {}
    for name in RUNNERS:
        w, s = min(walls[name]), min(steady[name])
        out[name] = {"end_to_end_s": round(w, 2),
                     "end_to_end_paired_frames_per_s": round(frames / w, 1),
                     "steady_s": round(s, 2), "steady_paired_frames_per_s": round(frames / s, 1),
                     "runs_end_to_end_s": [round(x, 2) for x in walls[name]],
                     "runs_steady_s": [round(x, 2) for x in steady[name]]}
    return out


def writing_rates(cfg, tmp: Path, repeats: int) -> dict:
    recs = [records_of_index(cfg, i) for i in range(cfg.sequences)]
    data = [generate_sequence(r.scenario, cfg) for r in recs]
    frames = cfg.sequences * cfg.frames
    best = {"folder": np.inf, "shards": np.inf}
    for rep in range(repeats):
        root = tmp / f"write-{rep}"
        t0 = time.perf_counter()
        for r, d in zip(recs, data):
            for cond in ("clean", "glinty"):
                write_frames_folder(root / "folder" / cond / r.sequence_id, getattr(d, cond))
        best["folder"] = min(best["folder"], time.perf_counter() - t0)
        t0 = time.perf_counter()
        write_shard(shard_location(root / "shards", 0),
                    ((r.sequence_id, sample_of(r, d, save_surface=False)) for r, d in zip(recs, data)))
        best["shards"] = min(best["shards"], time.perf_counter() - t0)
        subprocess.run(["rm", "-rf", str(root)], check=True)
    return {k: {"wall_s": round(v, 3), "paired_frames_per_s": round(frames / v, 1)}
            for k, v in best.items()}


def files_per_sequence(cfg, tmp: Path, shard_size: int) -> dict:
    out = {}
    for fmt, kw in (("folder", {}), ("shards", {"format": "shards", "shard_size": shard_size})):
        root = tmp / f"files-{fmt}"
        simulate_dataset(root, cfg, progress=False, **kw)
        files, dirs = _files(root)
        out[fmt] = {"files": files, "folders": dirs, "files_per_sequence": round(files / cfg.sequences, 3),
                    "folders_per_sequence": round(dirs / cfg.sequences, 3)}
        if fmt == "shards":
            sizes = [p.stat().st_size for p in (root / "shards").iterdir()]
            out[fmt]["shard_size"] = shard_size
            out[fmt]["mb_per_full_shard"] = round(max(sizes) / 1e6, 2)
        subprocess.run(["rm", "-rf", str(root)], check=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sequences", type=int, default=24)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--shard-size", type=int, default=8)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import dask
    import distributed

    cfg = preset_config("paper", size=args.size, sequences=args.sequences)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=Path(__file__).parent).stdout.strip()
    res: dict = {"benchmark": "scale", "commit": commit, "preset": "paper", "size_px": args.size,
                 "sequences": args.sequences, "frames_per_sequence": cfg.frames,
                 "repeats": args.repeats, "cpu_count": os.cpu_count(),
                 "cores_usable": len(os.sched_getaffinity(0)),
                 "load_average_before": [round(x, 2) for x in os.getloadavg()],
                 "python": platform.python_version(), "numpy": np.__version__,
                 "dask": dask.__version__, "distributed": distributed.__version__}
    with tempfile.TemporaryDirectory(prefix="bench-scale-") as tmp:
        sim = simulate_rates(cfg, Path(tmp), args.repeats)
        res["simulate_folder"] = sim
        res["write_only"] = writing_rates(cfg, Path(tmp), args.repeats)
        res["files"] = files_per_sequence(cfg, Path(tmp), args.shard_size)
    res["load_average_after"] = [round(x, 2) for x in os.getloadavg()]
    rate = lambda name, kind: sim[name][f"{kind}_paired_frames_per_s"]  # noqa: E731
    fw, sw = res["write_only"]["folder"]["wall_s"], res["write_only"]["shards"]["wall_s"]
    res["ratios"] = {f"{a}_over_{b}_{kind}": round(rate(a, kind) / rate(b, kind), 3)
                     for kind in ("end_to_end", "steady")
                     for a, b in (("dask_local_2", "dask_local_1"), ("dask_local_2", "workers_2"),
                                  ("workers_2", "workers_1"))}
    res["ratios"]["shards_write_speed_over_folders"] = round(fw / sw, 3)
    r = res["ratios"]
    res["targets"] = {
        "dask_2_at_least_1.8x_dask_1 (steady)": r["dask_local_2_over_dask_local_1_steady"] >= 1.8,
        "dask_2_at_least_1.8x_dask_1 (end to end)":
            r["dask_local_2_over_dask_local_1_end_to_end"] >= 1.8,
        "dask_2_within_10pct_of_workers_2 (steady)": r["dask_local_2_over_workers_2_steady"] >= 0.9,
        "dask_2_within_10pct_of_workers_2 (end to end)":
            r["dask_local_2_over_workers_2_end_to_end"] >= 0.9,
        "shards_written_no_slower_than_folders": sw <= fw}
    text = json.dumps(res, indent=2)
    print(text)
    if args.out is not None:
        atomic_write_text(args.out, text + "\n")


if __name__ == "__main__":
    main()
