"""The dispersion altimeter's trust contract on clips without dispersion; prints one JSON object.

    python benchmarks/bench_nulls.py [--clips 40] [--seed 7] [--frames 10,30]
        [--kinds white,shuffled,frozen,carried,rotated] [--size 256] [--workers 1]
        [--out FILE.json]

A clip that holds no waves obeying the dispersion relation cannot be measured, and the
altimeter must say so: no window here may be trusted.  Each clip is made from one sequence of
the project's realistic renderer (clean frames, altitude 1-15 m, wind 2-12 m/s), ``--clips``
per kind:

* ``white``: Gaussian noise around a grey level, 8 bit (no sea at all);
* ``shuffled``: the sequence's own frames in a random order (the sea's texture, no motion);
* ``frozen``: its first frame with fresh sensor noise (1-4 DN) on every frame;
* ``carried``: its first frame moved by whole pixels, 0-3 a frame along each axis (not both
  0), noise 2 DN: advection without dispersion (a camera moving over a still texture);
* ``rotated``: its first frame turned about the centre by 0.3-2 degrees a frame (a camera
  yawing over a still texture), the inscribed square kept.

Every clip is fitted blind, exact and with a prior (sigma 0.3 m/s).  The velocity given is,
for ``carried``, the camera's velocity that moves the frame so at an altitude drawn
log-uniformly in 1-15 m (the adversarial case: the pattern moves exactly as the water at
that altitude would); for the other kinds, one drawn in +-1 m/s per axis.  Per kind, frame
count and mode: windows, trusted windows (the contract: 0) and their estimates.  Exit code
0: a report, not a gate.
"""

from __future__ import annotations

import os

# before NumPy loads: one thread each, so that workers do not fight
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from functools import partial  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from wavealt.sim.cluster import TaskRunner, runner_spec  # noqa: E402

KINDS = ("white", "shuffled", "frozen", "carried", "rotated")
MODES = ("blind", "exact", "prior")
PRIOR_SIGMA_MPS = 0.3
MAX_SHIFT_PX = 3
ROTATION_DEG = (0.3, 2.0)
ALTITUDE_M = (1.0, 15.0)
FRAMES = 30


def _uint8(x: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(x), 0, 255).astype(np.uint8)


def _rotated(frame: np.ndarray, deg_per_frame: float, n: int) -> np.ndarray:
    """``frame`` turned by ``deg_per_frame`` a frame about its centre, ``n`` frames, each
    cropped to the square inscribed in every turn (no border enters it)."""
    import scipy.ndimage as ndi

    side = int(min(frame.shape) / math.sqrt(2.0)) // 2 * 2
    y0, x0 = (frame.shape[0] - side) // 2, (frame.shape[1] - side) // 2
    return np.stack([ndi.rotate(frame, deg_per_frame * t, reshape=False, order=1,
                                mode="reflect")[y0:y0 + side, x0:x0 + side]
                     for t in range(n)])


def make_clip(kind: str, index: int, seed: int, frames: int, size: int
              ) -> tuple[np.ndarray, float, float, tuple[float, float], float]:
    """``(clip uint8 (T, H, W), fps, focal_px, velocity given (m/s), the altitude that
    velocity belongs to (carried; else NaN))`` of clip ``index`` of ``kind``."""
    from wavealt.sim.config import preset_config
    from wavealt.sim.generate import generate_sequence

    rng = np.random.default_rng([seed, KINDS.index(kind), index, frames])
    cfg = preset_config("realistic", sequences=max(index + 1, 1), size=size, frames=FRAMES,
                        seed=seed, altitude_m=ALTITUDE_M, wind_speed_mps=(2.0, 12.0),
                        camera_speed_mps=(0.0, 1.0))
    velocity = tuple(float(v) for v in rng.uniform(-1.0, 1.0, 2))
    altitude = math.nan
    if kind == "white":
        level, sd = rng.uniform(60.0, 180.0), rng.uniform(2.0, 12.0)
        return (_uint8(rng.normal(level, sd, (frames, size, size))), cfg.fps, cfg.focal_px,
                velocity, altitude)
    sea = generate_sequence(cfg.sample_scenario(index), cfg).clean
    gray = 255.0 * (sea.mean(axis=-1) if sea.ndim == 4 else sea)
    first = gray[0]
    if kind == "shuffled":
        clip = gray[rng.permutation(gray.shape[0])[:frames]]
    elif kind == "frozen":
        clip = first[None] + rng.normal(0.0, rng.uniform(1.0, 4.0), (frames, *first.shape))
    elif kind == "carried":
        sx, sy = 0, 0
        while (sx, sy) == (0, 0):
            sx, sy = (int(s) for s in rng.integers(-MAX_SHIFT_PX, MAX_SHIFT_PX + 1, 2))
        clip = np.stack([np.roll(first, (t * sy, t * sx), axis=(0, 1)) for t in range(frames)])
        clip = clip + rng.normal(0.0, 2.0, clip.shape)
        altitude = float(math.exp(rng.uniform(*(math.log(a) for a in ALTITUDE_M))))
        # the camera's velocity over the water that moves the image (sx, sy) px a frame there
        velocity = (-sx * cfg.fps * altitude / cfg.focal_px,
                    -sy * cfg.fps * altitude / cfg.focal_px)
    elif kind == "rotated":
        rate = float(rng.choice([-1.0, 1.0]) * rng.uniform(*ROTATION_DEG))
        clip = _rotated(first, rate, frames)
    else:
        raise ValueError(f"unknown kind {kind!r}")
    return _uint8(clip), cfg.fps, cfg.focal_px, velocity, altitude


def run_clip(task: tuple[str, int, int], seed: int, size: int) -> list[dict[str, Any]]:
    """One record per mode of clip ``task = (kind, index, frames)``."""
    from wavealt.altimetry.dispersion import DispersionAltimeter

    kind, index, frames = task
    clip, fps, focal_px, velocity, altitude = make_clip(kind, index, seed, frames, size)
    est = DispersionAltimeter()
    out = []
    for mode in MODES:
        kw: dict[str, Any] = {}
        if mode != "blind":
            kw = {"velocity_mps": velocity,
                  "velocity_sigma_mps": PRIOR_SIGMA_MPS if mode == "prior" else 0.0}
        t0 = time.perf_counter()
        res = est.estimate(clip, fps=fps, focal_px=focal_px, **kw)
        out.append({"kind": kind, "index": index, "frames": frames, "mode": mode,
                    "velocity_given_mps": list(velocity) if kw else None,
                    "altitude_of_velocity_m": None if math.isnan(altitude) else altitude,
                    "altitude_m": res.altitude_m, "altitude_std_m": res.altitude_std_m,
                    "quality": res.quality, "trusted": bool(res.trusted),
                    "reason": res.reason, "seconds": time.perf_counter() - t0})
    return out


def summarise(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Per kind, frame count and mode: windows, trusted, and the trusted estimates."""
    table: dict[str, Any] = {}
    for r in records:
        cell = table.setdefault(r["kind"], {}).setdefault(str(r["frames"]), {}).setdefault(
            r["mode"], {"windows": 0, "trusted": 0, "trusted_estimates": []})
        cell["windows"] += 1
        if r["trusted"]:
            cell["trusted"] += 1
            cell["trusted_estimates"].append(
                {"index": r["index"], "altitude_m": round(r["altitude_m"], 3),
                 "altitude_of_velocity_m": r["altitude_of_velocity_m"]})
    return table


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clips", type=int, default=40, help="clips per kind and frame count")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--frames", default="10,30", help="frames per clip, comma-separated")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--size", type=int, default=256, help="frame side, px")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", type=Path, help="write the summary and every window's record")
    a = ap.parse_args(argv)
    kinds = tuple(k for k in a.kinds.split(",") if k)
    unknown = [k for k in kinds if k not in KINDS]
    if unknown or not kinds:
        ap.error(f"--kinds: unknown {','.join(unknown) or '(none given)'}; "
                 f"choose from {','.join(KINDS)}")
    try:
        frames = tuple(int(f) for f in a.frames.split(","))
    except ValueError:
        ap.error(f"--frames must be whole numbers separated by commas; got {a.frames!r}")
    if any(not 3 <= f <= FRAMES for f in frames):
        ap.error(f"--frames must be within 3-{FRAMES}; got {a.frames}")
    if a.clips < 1 or a.workers < 1:
        ap.error("--clips and --workers must be at least 1")
    if not 64 <= a.size <= 1024:
        ap.error(f"--size must be within 64-1024 px; got {a.size}")
    a.kinds, a.frames = kinds, frames
    return a


def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    tasks = [(k, i, f) for k in a.kinds for f in a.frames for i in range(a.clips)]
    job = partial(run_clip, seed=a.seed, size=a.size)
    t0 = time.perf_counter()
    with TaskRunner(runner_spec(workers=a.workers)) as runner:
        parts = list(tqdm(runner.map(job, tasks), total=len(tasks), desc="null clips",
                          file=sys.stderr))
    records = [r for part in parts for r in part]
    trusted = sum(r["trusted"] for r in records)
    summary = {"benchmark": "nulls", "command": " ".join(["python", *sys.argv]),
               "clips": a.clips, "seed": a.seed, "size": a.size, "frames": list(a.frames),
               "kinds": list(a.kinds), "windows": len(records), "trusted_windows": trusted,
               "contract_met": trusted == 0, "by_kind": summarise(records),
               "seconds": round(time.perf_counter() - t0, 1)}
    print(json.dumps(summary, indent=1))
    if a.out is not None:
        from wavealt.io import atomic_write_text

        atomic_write_text(a.out, json.dumps({**summary, "records": records}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
