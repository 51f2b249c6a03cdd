"""Accuracy, calibration and latency of the dispersion altimeter against the "blind altimeter"
targets; prints one JSON object.

    python benchmarks/bench_dispersion.py [--rows realistic-30-blind,paper-10-exact,...]
        [--seeds 23,31] [--sequences 200] [--workers 2] [--out FILE.json] [--quick] [--no-cache]
        [--compression none|jpeg|h264] [--jpeg-quality 90] [--h264-crf 23]
        [--h264-preset ultrafast|medium|...]

Each row is one (preset, frames, mode) combination (:data:`ROWS`), run on ``--sequences``
simulated 256^2 sequences per seed (altitude 1-15 m, wind 2-12 m/s, the camera drifting
0-1 m/s over the water in any direction), on both the clean and the glinty frames.  A row of
F frames generates its sequences with ``frames=F`` directly (the first F frames of a 30-frame
clip are not the same frames: up to 0.1 apart in intensity on both presets).  Modes:

* ``blind``: no velocity given;
* ``prior``: the vehicle's velocity is known and the water moves by an unknown current
  (uniform direction, magnitude uniform in 0-1 m/s, its own seeded draw per sequence):
  ``velocity_mps`` = the camera's true velocity over the water minus that current,
  ``velocity_sigma_mps`` = 1;
* ``exact``: ``velocity_mps`` = the camera's true velocity over the water.

The realistic preset's camera encodes its frames as JPEG at quality 90; ``--compression``,
``--jpeg-quality``, ``--h264-crf`` and ``--h264-preset`` change its encoder (the paper
renderer has no camera model, and its rows are unchanged), so that the rows can be read
against the coder.

Per row, seed and condition: relative MAE, median and bias, the trusted share and the error
of the trusted estimates, 3-sigma coverage, half/double-altitude confusions, latency per
``estimate`` call (single-threaded torch and BLAS), and relative MAE by altitude, wind and
drift band; per row a ``met`` dict of booleans against :data:`ROWS`' targets.

Generated frames are cached under ``benchmarks/cache/`` (``--no-cache`` to skip it) as uint8
when they hold exact k/255 values, else as float16; the estimator always sees the frames as
stored, so a cached and a fresh run give the same numbers.  Folders that an older
simulator's source made are counted in one line at the start (``--prune-cache`` removes
them).  The default run (six rows, two seeds, 200 sequences) caches about 21 GB (realistic
8.6 GB, paper 12.6 GB) and takes about an hour on one core with the estimator at ~0.7 s per
blind call.  With ``--out FILE.json`` the
per-window records go to ``FILE.csv`` beside it.
"""

from __future__ import annotations

import os

# before NumPy / torch load: one thread each, so latency is per core and workers do not fight
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import csv  # noqa: E402
import functools  # noqa: E402
import gzip  # noqa: E402
import hashlib  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import multiprocessing  # noqa: E402
import platform  # noqa: E402
import re  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Iterable, Sequence  # noqa: E402
from concurrent.futures import ProcessPoolExecutor, as_completed  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from wavealt.io import atomic_path, atomic_write_text  # noqa: E402
from wavealt.sim.config import COMPRESSIONS, H264_PRESETS  # noqa: E402

# -- settings (one place) -------------------------------------------------------------------
HERE = Path(__file__).resolve().parent
REPO = HERE.parent
CACHE_DIR = HERE / "cache"
#: The simulator's modules (package-relative globs): their source is part of the cache key,
#: so an edit to the simulator regenerates the frames.
SIM_SOURCES = ("_checks.py", "camera.py", "sim/*.py", "sim/sea/*.py", "sim/light/*.py")
SIZE_PX = 256
DEFAULT_SEEDS = (23, 31)
DEFAULT_SEQUENCES = 200
QUICK_SEQUENCES = 6
CONDITIONS = ("clean", "glinty")
#: The realistic camera's encoder settings (``sim_config``'s ``sensor``), which the paper
#: renderer does not have.
ENCODER_FIELDS = ("compression", "jpeg_quality", "h264_crf", "h264_preset")
#: Scenario ranges of the issue, the same for both presets.
SCENARIO_OVERRIDES: dict[str, tuple[float, float]] = {
    "altitude_m": (1.0, 15.0),
    "wind_speed_mps": (2.0, 12.0),
    "camera_speed_mps": (0.0, 1.0),  # the simulator's water is still: this is the drift
}
#: The paper renderer moves its waves with omega = sqrt(g k); the realistic one (and real
#: water) adds the capillary term.
DISPERSION_OF_PRESET = {"paper": "gravity", "realistic": "gravity-capillary"}
PRIOR_SIGMA_MPS = 1.0
MAX_CURRENT_MPS = 1.0
#: Stream of the prior row's current, beside the simulator's own ([seed, 1]: the waves).
CURRENT_STREAM = 12
ALT_BANDS_M = (1.0, 3.0, 6.0, 10.0, 15.0)
WIND_BANDS_MPS = (2.0, 4.0, 7.0, 10.0, 12.0)
DRIFT_BANDS_MPS = (0.0, 0.25, 0.5, 0.75, 1.0)
NEAR_HALF = (0.4, 0.6)  # est / true: the half-altitude confusion
NEAR_DOUBLE = (1.7, 2.3)  # est / true: the double-altitude confusion
OFF_LIMIT = 0.10  # a trusted estimate off by more than this (relative) is a failure
COVERAGE_SIGMAS = 3.0
TARGET_COVERAGE = 0.97
TARGET_TRUSTED_SHARE = 0.90


@dataclass(frozen=True)
class RowSpec:
    """One benchmark row and its targets (percent; latency in ms, median per call)."""

    name: str
    preset: str
    frames: int
    mode: str  # "blind" | "prior" | "exact"
    clean_mae_pct: float | None  # None: a row of --rows PRESET-FRAMES-MODE, no MAE target
    glinty_mae_pct: float | None
    median_pct: float | None = None  # median |rel err|, each condition
    latency_ms: float | None = None  # median latency, each condition

    @property
    def dispersion(self) -> str:
        return DISPERSION_OF_PRESET[self.preset]


#: The rows of the "blind altimeter" issue with its targets (30 frames at 30 fps = a 1-s clip).
ROWS: tuple[RowSpec, ...] = (
    RowSpec("realistic-30-blind", "realistic", 30, "blind", 2.0, 2.0, median_pct=1.0,
            latency_ms=50.0),
    RowSpec("realistic-15-blind", "realistic", 15, "blind", 5.0, 5.0),
    RowSpec("realistic-10-prior", "realistic", 10, "prior", 3.0, 3.0),
    RowSpec("realistic-10-exact", "realistic", 10, "exact", 1.0, 2.0, latency_ms=15.0),
    RowSpec("paper-30-blind", "paper", 30, "blind", 1.0, 1.5, latency_ms=50.0),
    RowSpec("paper-10-exact", "paper", 10, "exact", 1.0, 2.0, latency_ms=15.0),
)
ROW_BY_NAME = {r.name: r for r in ROWS}
#: Any other row, ``PRESET-FRAMES-MODE`` (``--rows realistic-60-blind --fps 60``: a second
#: at 60 fps), is judged against the contract alone (no MAE target).
OTHER_ROW = re.compile(r"(realistic|paper)-([0-9]+)-(blind|prior|exact)")
OTHER_ROW_FRAMES = (3, 600)


def known_rows_and_seeds(ap: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``args.rows`` (comma-separated names of :data:`ROWS`) as :class:`RowSpec` entries,
    ``args.seeds`` as integers, and ``args.sequences`` at least 1, in place: for the scripts
    that read this one's rows (``bench_bound.py``, ``bench_ridge.py``); an unknown row or a
    bad number is ``ap.error``'s one line."""
    names = [n for n in args.rows.split(",") if n]
    unknown = [n for n in names if n not in ROW_BY_NAME]
    if unknown:
        ap.error(f"unknown row(s) {', '.join(unknown)}; known: {', '.join(ROW_BY_NAME)}")
    args.rows = [ROW_BY_NAME[n] for n in dict.fromkeys(names)]
    try:
        args.seeds = [int(s) for s in args.seeds.split(",") if s]
    except ValueError:
        ap.error(f"--seeds must be comma-separated integers; got {args.seeds!r}")
    if args.sequences < 1:
        ap.error(f"--sequences must be >= 1; got {args.sequences}")


def print_and_write(result: dict[str, Any], windows: list[dict[str, Any]],
                    columns: Sequence[str], out: Path | None) -> None:
    """Print ``result`` as JSON; with ``out``, write it there and each window's ``columns``
    beside it (``.csv``): for the scripts that read this one's rows (``bench_bound.py``,
    ``bench_ridge.py``)."""
    text = json.dumps(result, indent=2)
    print(text)
    if out is not None:
        atomic_write_text(out, text + "\n")
        lines = [",".join(columns)]
        lines += [",".join(str(r[k]) for k in columns) for r in windows]
        atomic_write_text(out.with_suffix(".csv"), "\n".join(lines) + "\n")


def row_of(name: str) -> RowSpec | None:
    """The row named ``name``: one of :data:`ROWS`, or :data:`OTHER_ROW` with
    ``OTHER_ROW_FRAMES`` frames and no MAE target; None for neither."""
    if name in ROW_BY_NAME:
        return ROW_BY_NAME[name]
    m = OTHER_ROW.fullmatch(name)
    lo, hi = OTHER_ROW_FRAMES
    if m is None or not lo <= int(m.group(2)) <= hi:
        return None
    return RowSpec(name, m.group(1), int(m.group(2)), m.group(3), None, None)

CSV_FIELDS = ("row", "preset", "frames", "seed", "index", "condition", "status",
              "altitude_m", "est_altitude_m", "est_std_m", "rel_err", "trusted", "reason",
              "mode", "quality", "wind_speed_mps", "drift_mps", "current_mps",
              "true_vx_mps", "true_vy_mps", "given_vx_mps", "given_vy_mps",
              "est_vx_mps", "est_vy_mps", "latency_ms", "signal", "yaw_rate_dps")


# -- per process ------------------------------------------------------------------------------
_ESTIMATORS: dict[str, Any] = {}
_WARMED: set[tuple[str, int, str]] = set()


def init_process() -> None:
    """Single-threaded torch (NumPy's BLAS is held by the environment set at import), and the
    dispersion altimeter's compiled loops loaded (:func:`~wavealt.altimetry.dispersion.
    warm_up`), as the live path loads them: every row's latency is then the compiled path's
    (the same bits as the array forms), not whichever a blind row before it in the same
    process happened to load."""
    import torch

    from wavealt.altimetry.dispersion import warm_up

    torch.set_num_threads(1)
    warm_up()


def estimator(dispersion: str, attitude: str = "estimate",
              attitude_sigma_deg: float | None = None) -> Any:
    from wavealt.altimetry.dispersion import DispersionAltimeter

    key = (dispersion, attitude, attitude_sigma_deg)
    if key not in _ESTIMATORS:
        _ESTIMATORS[key] = DispersionAltimeter(dispersion=dispersion, attitude=attitude,
                                               attitude_sigma_deg=attitude_sigma_deg)
    return _ESTIMATORS[key]


# -- sequences and their cache ----------------------------------------------------------------
def sim_config(preset: str, frames: int, seed: int, sequences: int, size: int,
               sensor: tuple[tuple[str, Any], ...] = ()) -> Any:
    """The simulator's config of a row's sequences; ``sensor``: ``(field, value)`` pairs of
    the camera: its frame rate and field of view (``--fps``, ``--fov-deg``, both presets) and
    the realistic camera's encoder (``--compression``, ``--jpeg-quality``,
    :data:`ENCODER_FIELDS`), which the paper renderer does not have."""
    from wavealt.sim.config import preset_config

    overrides = {k: v for k, v in sensor if preset == "realistic" or k not in ENCODER_FIELDS}
    return preset_config(preset, sequences=sequences, size=size, frames=frames, seed=seed,
                         **SCENARIO_OVERRIDES, **overrides)


@functools.cache
def simulator_digest() -> str:
    """Hash of the simulator's source (:data:`SIM_SOURCES`)."""
    import wavealt

    root = Path(wavealt.__file__).parent
    h = hashlib.sha1()
    for path in sorted(p for pattern in SIM_SOURCES for p in root.glob(pattern)):
        h.update(path.relative_to(root).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def cache_folder(cfg: Any) -> Path:
    """Folder of a config's sequences: preset, seed, frames, size and a hash of the rest of
    the config (the overrides) and of the simulator's source."""
    d = cfg.to_dict()
    d.pop("sequences")  # sequence i does not depend on how many there are
    blob = json.dumps({"config": d, "simulator": simulator_digest()}, sort_keys=True)
    digest = hashlib.sha1(blob.encode()).hexdigest()[:10]
    return CACHE_DIR / f"{cfg.preset}-seed{cfg.seed}-f{cfg.frames}-{cfg.size}px-{digest}"


def stale_cache_folders(cache_dir: Path = CACHE_DIR) -> list[Path]:
    """The cache's folders of frames that an older simulator made: their name's digest is not
    the one their ``config.json`` and the simulator's current source give
    (:func:`cache_folder`).  A folder without a ``config.json`` is not judged."""
    stale = []
    for folder in sorted(cache_dir.iterdir()) if cache_dir.is_dir() else []:
        config = folder / "config.json"
        if not (folder.is_dir() and config.is_file()):
            continue
        d = json.loads(config.read_text())
        d.pop("sequences", None)
        blob = json.dumps({"config": d, "simulator": simulator_digest()}, sort_keys=True)
        if not folder.name.endswith("-" + hashlib.sha1(blob.encode()).hexdigest()[:10]):
            stale.append(folder)
    return stale


def folder_bytes(folder: Path) -> int:
    return sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())


def check_cache(prune: bool, cache_dir: Path = CACHE_DIR) -> None:
    """Remove the stale cache folders (``prune``), or say in one line how much they hold
    where it is a gigabyte or more (a full disk stops a run mid-way)."""
    stale = stale_cache_folders(cache_dir)
    size = sum(folder_bytes(f) for f in stale)
    if prune:
        for folder in stale:
            shutil.rmtree(folder)
        print(f"removed {len(stale)} stale cache folders ({size / 1e9:.1f} GB) from "
              f"{cache_dir}", file=sys.stderr)
    elif size >= 1e9:
        print(f"note: {cache_dir} holds {size / 1e9:.1f} GB of frames from older simulator "
              f"code ({len(stale)} folders); --prune-cache removes them", file=sys.stderr)


def encode(frames: np.ndarray) -> np.ndarray:
    """uint8 when ``frames`` are exactly k/255 (decoding gives them back bit for bit), else
    float16."""
    q = np.round(frames * 255.0)
    if q.min() >= 0 and q.max() <= 255:
        u8 = q.astype(np.uint8)
        if np.array_equal(decode(u8), frames):
            return u8
    return frames.astype(np.float16)


def decode(stored: np.ndarray) -> np.ndarray:
    if stored.dtype == np.uint8:
        return stored.astype(np.float32) / np.float32(255.0)
    return stored.astype(np.float32)


def save_npy(path: Path, arr: np.ndarray) -> None:
    with atomic_path(path, suffix=".npy") as tmp:  # np.save appends .npy to other names
        np.save(tmp, arr)


def load_frames(cfg: Any, sc: Any, index: int, use_cache: bool) -> dict[str, np.ndarray]:
    """Clean and glinty frames of sequence ``index`` as stored (float32), from the cache when
    there; raises ``ValueError`` when the renderer rejects the scenario."""
    from wavealt.sim.generate import generate_sequence

    folder = cache_folder(cfg)
    paths = {c: folder / f"{index:04d}-{c}.npy" for c in CONDITIONS}
    if use_cache and all(p.exists() for p in paths.values()):
        return {c: decode(np.load(p)) for c, p in paths.items()}
    data = generate_sequence(sc, cfg)
    stored = {c: encode(getattr(data, c)) for c in CONDITIONS}
    if use_cache:
        config_file = folder / "config.json"
        if not config_file.exists():
            text = json.dumps(cfg.to_dict(), indent=2, sort_keys=True) + "\n"
            atomic_write_text(config_file, text)
        for c, p in paths.items():
            save_npy(p, stored[c])
    return {c: decode(s) for c, s in stored.items()}


# -- one sequence of one row -------------------------------------------------------------------
def given_velocity(row: RowSpec, sc: Any) -> tuple[tuple[float, float] | None, float, float]:
    """``(velocity_mps, velocity_sigma_mps, current magnitude)`` passed in ``row.mode``."""
    true_v = tuple(float(v) for v in sc.camera_velocity_mps)
    if row.mode == "blind":
        return None, 0.0, 0.0
    if row.mode == "exact":
        return true_v, 0.0, 0.0
    rng = np.random.default_rng([sc.seed, CURRENT_STREAM])
    direction = rng.uniform(0.0, 2.0 * math.pi)
    speed = rng.uniform(0.0, MAX_CURRENT_MPS)
    cx, cy = speed * math.cos(direction), speed * math.sin(direction)
    return (true_v[0] - cx, true_v[1] - cy), PRIOR_SIGMA_MPS, float(speed)


def timed_estimate(row: RowSpec, frames: np.ndarray, cfg: Any,
                   velocity: tuple[float, float] | None, sigma: float,
                   attitude: str = "estimate",
                   attitude_sigma_deg: float | None = None) -> tuple[Any, float]:
    """``(result or the ValueError it raised, seconds)`` of one ``estimate`` call; the first
    call of a row in a process is repeated untimed first (imports, FFT plans)."""
    est = estimator(row.dispersion, attitude, attitude_sigma_deg)

    def call() -> Any:
        return est.estimate(frames, fps=cfg.fps, focal_px=cfg.focal_px, velocity_mps=velocity,
                            velocity_sigma_mps=sigma)

    key = (row.dispersion, row.frames, row.mode, attitude)
    if key not in _WARMED:
        _WARMED.add(key)
        try:
            call()
        except ValueError:
            pass
    t0 = time.perf_counter()
    try:
        res = call()
    except ValueError as exc:
        res = exc
    return res, time.perf_counter() - t0


def base_record(row: RowSpec, seed: int, index: int, sc: Any, current: float,
                velocity: tuple[float, float] | None) -> dict[str, Any]:
    vx, vy = sc.camera_velocity_mps
    return {"row": row.name, "preset": row.preset, "frames": row.frames, "seed": seed,
            "index": index, "altitude_m": sc.altitude_m, "wind_speed_mps": sc.wind_speed_mps,
            "drift_mps": sc.camera_speed_mps, "current_mps": current,
            "true_vx_mps": vx, "true_vy_mps": vy,
            "given_vx_mps": None if velocity is None else velocity[0],
            "given_vy_mps": None if velocity is None else velocity[1]}


def result_fields(res: Any, altitude_m: float) -> dict[str, Any]:
    if isinstance(res, Exception):
        return {"status": "estimate-error", "est_altitude_m": math.nan, "est_std_m": math.nan,
                "rel_err": math.nan, "trusted": False, "reason": f"ValueError: {res}",
                "mode": None, "quality": 0.0, "est_vx_mps": math.nan, "est_vy_mps": math.nan,
                "signal": None, "yaw_rate_dps": math.nan}
    return {"status": "ok", "est_altitude_m": float(res.altitude_m),
            "est_std_m": float(res.altitude_std_m),
            "rel_err": (float(res.altitude_m) - altitude_m) / altitude_m,
            "trusted": bool(res.trusted), "reason": res.reason, "mode": res.mode,
            "quality": float(res.quality), "est_vx_mps": float(res.camera_velocity_mps[0]),
            "est_vy_mps": float(res.camera_velocity_mps[1]), "signal": res.signal,
            "yaw_rate_dps": math.nan if res.yaw_rate_dps is None else float(res.yaw_rate_dps)}


def run_sequence(task: tuple) -> list[dict[str, Any]]:
    """Window records (one per condition) of sequence ``index`` of a row and seed: ``task``
    is ``(row, seed, index, sequences, size, use_cache, sensor, attitude,
    attitude_sigma_deg, aspect)`` (:func:`tasks_of`; ``sensor``: :func:`sim_config`'s, the
    attitude's :class:`DispersionAltimeter`'s; ``aspect``: the frames cropped to this width :
    height, ``bench_foreign_sea.crop_to_aspect``, None: square)."""
    name, seed, index, sequences, size, use_cache, sensor, attitude, attitude_sd, aspect = task
    row = row_of(name)
    cfg = sim_config(row.preset, row.frames, seed, sequences, size, sensor)
    sc = cfg.sample_scenario(index)
    velocity, sigma, current = given_velocity(row, sc)
    base = base_record(row, seed, index, sc, current, velocity)
    try:
        frames = load_frames(cfg, sc, index, use_cache)
    except ValueError as exc:
        return [{**base, "condition": c, "status": "generation-error", "reason": str(exc)}
                for c in CONDITIONS]
    if aspect is not None:
        from bench_foreign_sea import crop_to_aspect

        frames = {c: crop_to_aspect(frames[c], aspect) for c in CONDITIONS}
    out = []
    for c in CONDITIONS:
        res, dt = timed_estimate(row, frames[c], cfg, velocity, sigma, attitude, attitude_sd)
        out.append({**base, "condition": c, **result_fields(res, sc.altitude_m),
                    "latency_ms": 1e3 * dt})
    return out


# -- metrics -----------------------------------------------------------------------------------
def pct(x: float | None, digits: int = 3) -> float | None:
    return None if x is None or not np.isfinite(x) else round(100.0 * float(x), digits)


def share(mask: np.ndarray, of: np.ndarray | None = None) -> float | None:
    of = np.ones_like(mask) if of is None else of
    return round(float(mask[of].mean()), 4) if of.any() else None


def by_band(key: np.ndarray, rel: np.ndarray, trusted: np.ndarray,
            edges: Sequence[float]) -> dict[str, dict[str, Any]]:
    """Relative MAE (finite estimates) and trusted share per band; the last band is closed."""
    out = {}
    for j, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
        last = j == len(edges) - 2
        s = (key >= lo) & ((key <= hi) if last else (key < hi))
        if s.any():
            ok = s & np.isfinite(rel)
            out[f"{lo:g}-{hi:g}"] = {
                "n": int(s.sum()),
                "rel_mae_pct": pct(rel[ok].mean()) if ok.any() else None,
                "trusted_share": share(trusted, s)}
    return out


def column(recs: list[dict[str, Any]], key: str, dtype: Any = float) -> np.ndarray:
    return np.array([r[key] for r in recs], dtype=dtype)


def condition_metrics(recs: list[dict[str, Any]]) -> dict[str, Any]:
    """Metrics of one row, seed and condition.  Estimates the altimeter refused (ValueError)
    count as untrusted and uncovered, and drop out of the error averages."""
    from wavealt.altimetry.dispersion.result import reason_counts

    skipped = [r for r in recs if r["status"] == "generation-error"]
    recs = [r for r in recs if r["status"] != "generation-error"]
    if not recs:
        return {"n": 0, "n_skipped": len(skipped)}
    h = column(recs, "altitude_m")
    est = column(recs, "est_altitude_m")
    std = column(recs, "est_std_m")
    trusted = column(recs, "trusted", bool)
    lat = column(recs, "latency_ms")
    err = (est - h) / h
    rel = np.abs(err)
    ok = np.isfinite(err)
    ratio = est / h
    covered = ok & (np.abs(est - h) <= COVERAGE_SIGMAS * std)
    tr = trusted & ok
    return {
        "n": len(recs),
        "n_skipped": len(skipped),
        "n_refused": int((~ok).sum()),
        "rel_mae_pct": pct(rel[ok].mean()) if ok.any() else None,
        "median_abs_rel_pct": pct(np.median(rel[ok])) if ok.any() else None,
        "bias_pct": pct(err[ok].mean()) if ok.any() else None,
        "trusted_share": share(trusted),
        "trusted_rel_mae_pct": pct(rel[tr].mean()) if tr.any() else None,
        "trusted_off_10pct": int((tr & (rel > OFF_LIMIT)).sum()),
        "trusted_max_abs_rel_pct": pct(rel[tr].max()) if tr.any() else None,
        "coverage_3sigma_all": share(covered),
        "coverage_3sigma_trusted": share(covered, trusted),
        "near_half_altitude": int((ok & (ratio >= NEAR_HALF[0]) & (ratio <= NEAR_HALF[1])).sum()),
        "near_double_altitude": int((ok & (ratio >= NEAR_DOUBLE[0])
                                     & (ratio <= NEAR_DOUBLE[1])).sum()),
        "latency_ms_median": round(float(np.median(lat)), 2),
        "latency_ms_p90": round(float(np.percentile(lat, 90)), 2),
        # the kinds of reason (figures as N), most frequent first; each window's own in the CSV
        "untrusted_reasons": reason_counts(r["reason"] for r in recs if not r["trusted"]),
        "by_altitude_m": by_band(h, rel, trusted, ALT_BANDS_M),
        "by_wind_mps": by_band(column(recs, "wind_speed_mps"), rel, trusted, WIND_BANDS_MPS),
        "by_drift_mps": by_band(column(recs, "drift_mps"), rel, trusted, DRIFT_BANDS_MPS),
    }


def at_most(x: float | None, limit: float) -> bool:
    return x is not None and x <= limit


def at_least(x: float | None, limit: float) -> bool:
    return x is not None and x >= limit


def met_of(row: RowSpec, m: dict[str, dict[str, Any]]) -> dict[str, bool]:
    """Each target of ``row`` against the metrics ``m[condition]`` of one seed."""
    both = [m[c] for c in CONDITIONS]
    met = {}
    if row.clean_mae_pct is not None:
        met["clean_rel_mae"] = at_most(m["clean"].get("rel_mae_pct"), row.clean_mae_pct)
        met["glinty_rel_mae"] = at_most(m["glinty"].get("rel_mae_pct"), row.glinty_mae_pct)
    if row.median_pct is not None:
        met["median_abs_rel"] = all(at_most(x.get("median_abs_rel_pct"), row.median_pct)
                                    for x in both)
    met["no_trusted_off_10pct"] = all(x.get("n", 0) > 0 and x["trusted_off_10pct"] == 0
                                      for x in both)
    met["coverage_3sigma"] = all(at_least(x.get("coverage_3sigma_all"), TARGET_COVERAGE)
                                 for x in both)
    met["trusted_share_aim"] = all(at_least(x.get("trusted_share"), TARGET_TRUSTED_SHARE)
                                   for x in both)
    if row.latency_ms is not None:
        met["latency_median"] = all(at_most(x.get("latency_ms_median"), row.latency_ms)
                                    for x in both)
    return met


def row_report(row: RowSpec, seeds: Sequence[int],
               recs: list[dict[str, Any]]) -> dict[str, Any]:
    per_seed: dict[str, Any] = {}
    for seed in seeds:
        m = {c: condition_metrics([r for r in recs if r["seed"] == seed and r["condition"] == c])
             for c in CONDITIONS}
        per_seed[str(seed)] = {**m, "met": met_of(row, m)}
    names = next(iter(per_seed.values()))["met"].keys()
    return {"preset": row.preset, "frames": row.frames, "mode": row.mode,
            "dispersion": row.dispersion,
            "met": {k: all(s["met"][k] for s in per_seed.values()) for k in names},
            "seeds": per_seed}


def summary(rows: dict[str, Any]) -> dict[str, Any]:
    """The headline numbers, row by row and seed by seed."""
    keys = ("rel_mae_pct", "median_abs_rel_pct", "trusted_share", "trusted_off_10pct",
            "coverage_3sigma_all", "latency_ms_median")
    return {name: {seed: {c: {k: s[c].get(k) for k in keys} for c in CONDITIONS}
                   for seed, s in rep["seeds"].items()}
            for name, rep in rows.items()}


def targets() -> dict[str, Any]:
    return {
        "rows": {r.name: {"clean_rel_mae_pct": r.clean_mae_pct,
                          "glinty_rel_mae_pct": r.glinty_mae_pct,
                          "median_abs_rel_pct_each_condition": r.median_pct,
                          "latency_ms_median": r.latency_ms} for r in ROWS},
        "every_row": {"trusted_off_10pct": 0, "coverage_3sigma_all_min": TARGET_COVERAGE,
                      "trusted_share_aim_min": TARGET_TRUSTED_SHARE},
        "met_rule": "a row's met[k] is true when every seed meets k; conditions that the "
                    "target names apply to both clean and glinty",
    }


# -- running -----------------------------------------------------------------------------------
def tasks_of(rows: Iterable[RowSpec], seeds: Sequence[int], sequences: int, size: int,
             use_cache: bool, sensor: tuple[tuple[str, Any], ...] = (),
             attitude: str = "estimate", attitude_sigma_deg: float | None = None,
             aspect: tuple[int, int] | None = None) -> list[tuple]:
    return [(r.name, s, i, sequences, size, use_cache, sensor, attitude, attitude_sigma_deg,
             aspect) for r in rows for s in seeds for i in range(sequences)]


def run_tasks(tasks: list[tuple], workers: int) -> list[dict[str, Any]]:
    recs: list[dict[str, Any]] = []
    bar = tqdm(total=len(tasks), desc="sequences", unit="seq", file=sys.stderr)
    if workers == 1:
        for t in tasks:
            bar.set_postfix_str(f"{t[0]} seed {t[1]}", refresh=False)
            recs.extend(run_sequence(t))
            bar.update()
    else:
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(workers, mp_context=ctx, initializer=init_process) as pool:
            for fut in as_completed([pool.submit(run_sequence, t) for t in tasks]):
                recs.extend(fut.result())
                bar.update()
    bar.close()
    return recs


def git_state() -> dict[str, Any]:
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True,
                              check=False).stdout.strip()

    return {"commit": git("rev-parse", "HEAD") or None,
            "dirty": bool(git("status", "--porcelain", "--untracked-files=no"))}


def environment() -> dict[str, Any]:
    import torch

    import wavealt

    return {"python": platform.python_version(), "numpy": np.__version__,
            "torch": torch.__version__, "wavealt": wavealt.__version__,
            "cpu_count": os.cpu_count(), "machine": platform.machine(),
            "simulator_sha1": simulator_digest(), **git_state()}


def realistic_camera(sensor: tuple[tuple[str, Any], ...], size: int) -> dict[str, Any]:
    """The realistic rows' encoder as run (the preset's, with ``sensor`` applied)."""
    cam = sim_config("realistic", 30, 0, 1, size, sensor).sensor
    return {"compression": cam.compression, "jpeg_quality": cam.jpeg_quality,
            "h264_crf": cam.h264_crf, "h264_preset": cam.h264_preset}


def write_outputs(result: dict[str, Any], recs: list[dict[str, Any]], out: Path) -> None:
    atomic_write_text(out, json.dumps(result, indent=2) + "\n")
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=CSV_FIELDS, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in sorted(recs, key=lambda r: (r["row"], r["seed"], r["index"], r["condition"])):
        w.writerow(r)
    atomic_write_text(out.with_suffix(".csv"), buf.getvalue())


def read_windows(path: Path) -> list[dict[str, Any]]:
    """The windows of a run's CSV (:func:`write_outputs`; gzipped where it ends in ``.gz``,
    as ``docs/results`` keeps the large ones) as records: the row, the truth, the estimate,
    its standard deviation and trust; a ``ValueError`` naming what is missing for a file
    that is not one."""
    opener = gzip.open if path.suffix == ".gz" else open
    try:
        with opener(path, "rt", newline="") as fh:
            reader = csv.DictReader(fh)
            need = {"row", "status", "altitude_m", "est_altitude_m", "est_std_m", "trusted"}
            missing = sorted(need - set(reader.fieldnames or ()))
            if missing:
                raise ValueError(f"{path} is not a bench_dispersion window CSV (no {missing})")
            recs = []
            for line, r in enumerate(reader, start=2):
                try:
                    recs.append({"row": r["row"], "status": r["status"],
                                 "altitude_m": float(r["altitude_m"]),
                                 "est_altitude_m": float(r["est_altitude_m"] or "nan"),
                                 "est_std_m": float(r["est_std_m"] or "nan"),
                                 "trusted": r["trusted"] == "True"})
                except ValueError:
                    msg = f"{path}, line {line}: not a number where one belongs"
                    raise ValueError(msg) from None
    except (gzip.BadGzipFile, EOFError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path} is not a readable CSV ({exc.__class__.__name__})") from None
    if not recs:
        raise ValueError(f"{path} holds no windows")
    return recs


def draw_windows(recs: list[dict[str, Any]], path: Path) -> Path:
    """:func:`wavealt.plots.figure_altimeter_windows` of windows ``recs``, one line a row
    (its seeds and conditions together, the targets' rows first; windows the renderer
    refused left out)."""
    from wavealt.plots import figure_altimeter_windows, windows_by_row

    kept = [r for r in recs if r["status"] != "generation-error"]
    return figure_altimeter_windows(
        windows_by_row(kept, ("altitude_m", "est_altitude_m", "est_std_m", "trusted"),
                       tuple(ROW_BY_NAME)), path)


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", default=",".join(r.name for r in ROWS),
                    help="comma-separated rows (default: all): " + ", ".join(ROW_BY_NAME)
                         + "; or PRESET-FRAMES-MODE (e.g. realistic-60-blind), judged "
                           "against the contract alone")
    ap.add_argument("--seeds", default=None,
                    help="comma-separated dataset seeds (default "
                         f"{','.join(map(str, DEFAULT_SEEDS))}; "
                         "--quick: the first)")
    ap.add_argument("--sequences", type=int, default=None,
                    help=f"sequences per row and seed (default {DEFAULT_SEQUENCES}; "
                         f"--quick: {QUICK_SEQUENCES})")
    ap.add_argument("--size", type=int, default=SIZE_PX, help="frame side, px (the targets: 256)")
    ap.add_argument("--aspect", metavar="W:H",
                    help="crop each frame's middle to this width : height, the longer side "
                         "(--size) and the focal length kept (16:9 of 512 px: 512 x 288, a "
                         "video camera's frame); default square")
    ap.add_argument("--workers", type=int, default=1, help="processes, one thread each")
    ap.add_argument("--out", type=Path, default=None,
                    help="also write the JSON here (atomically) and the windows to .csv beside")
    ap.add_argument("--quick", action="store_true", help="a smoke run: few sequences, one seed")
    ap.add_argument("--no-cache", action="store_true", help="neither read nor write the cache")
    ap.add_argument("--prune-cache", action="store_true",
                    help="first remove the cache's folders of frames from older simulator code")
    ap.add_argument("--compression", choices=COMPRESSIONS, default=None,
                    help="the realistic camera's encoder (default: the preset's, jpeg)")
    ap.add_argument("--h264-crf", type=int, default=None,
                    help="the realistic camera's H.264 constant rate factor, 0-51 (lower: "
                         "better; default 23, libx264's); needs --compression h264")
    ap.add_argument("--h264-preset", choices=H264_PRESETS, default=None,
                    help="the realistic camera's libx264 preset (default ultrafast: no B-frames, "
                         "whole-pixel motion; medium: libx264's default); needs --compression "
                         "h264")
    ap.add_argument("--jpeg-quality", type=int, default=None,
                    help="the realistic camera's JPEG quality, 1-100 (default: the preset's, 90)")
    ap.add_argument("--fps", type=float, default=None,
                    help="frames per second of the simulated clips (default: the presets', 30); "
                         "a row keeps its frame count, so its clip lasts frames / FPS s")
    ap.add_argument("--attitude", choices=("estimate", "level"), default="estimate",
                    help="what the altimeter is told of the camera's attitude: nothing (it "
                         "measures a tilt from the frame's corners), or that it looks straight "
                         "down (a gimbal; DispersionAltimeter(attitude='level'))")
    ap.add_argument("--attitude-sigma-deg", type=float, default=None, metavar="S",
                    help="with --attitude estimate: the camera looks straight down within S "
                         "degrees a side, one sigma (a gimbal; DispersionAltimeter("
                         "attitude_sigma_deg=S)); default: its attitude is not known")
    ap.add_argument("--fov-deg", type=float, default=None,
                    help="the camera's horizontal field of view, degrees (default: the "
                         "presets', 60)")
    ap.add_argument("--figure", type=Path, default=None, metavar="PNG",
                    help="also draw each row's windows here: estimate against truth, and the "
                         "share within k stated sigmas against k (plots."
                         "figure_altimeter_windows)")
    ap.add_argument("--redraw", type=Path, default=None, metavar="CSV",
                    help="with --figure: draw the windows of a run's .csv (written by --out; "
                         "or its .csv.gz) instead of running")
    args = ap.parse_args(argv)
    if args.redraw is not None:
        if args.figure is None:
            ap.error("--redraw needs --figure (the PNG to draw)")
        try:
            args.redrawn = read_windows(args.redraw)
        except (OSError, ValueError) as exc:
            ap.error(f"--redraw: {exc}")
        return args
    names = [s.strip() for s in args.rows.split(",") if s.strip()]
    unknown = [n for n in names if row_of(n) is None]
    if unknown or not names:
        lo, hi = OTHER_ROW_FRAMES
        ap.error(f"--rows: unknown {unknown or args.rows!r}; expected some of "
                 f"{', '.join(ROW_BY_NAME)}, or PRESET-FRAMES-MODE ({lo}-{hi} frames)")
    args.rows = [row_of(n) for n in dict.fromkeys(names)]
    try:
        seeds = (DEFAULT_SEEDS if args.seeds is None
                 else tuple(int(s) for s in args.seeds.split(",") if s.strip()))
    except ValueError:
        ap.error(f"--seeds must be comma-separated integers; got {args.seeds!r}")
    if not seeds:
        ap.error("--seeds: no seed given")
    args.seeds = seeds[:1] if args.quick and args.seeds is None else tuple(dict.fromkeys(seeds))
    if args.sequences is None:
        args.sequences = QUICK_SEQUENCES if args.quick else DEFAULT_SEQUENCES
    if args.sequences < 1:
        ap.error(f"--sequences must be >= 1; got {args.sequences}")
    if args.workers < 1:
        ap.error(f"--workers must be >= 1; got {args.workers}")
    if args.jpeg_quality is not None:
        if not 1 <= args.jpeg_quality <= 100:
            ap.error(f"--jpeg-quality must be in 1-100; got {args.jpeg_quality}")
        if args.compression not in (None, "jpeg"):
            ap.error(f"--jpeg-quality needs the jpeg encoder; got --compression "
                     f"{args.compression}")
    if args.h264_crf is not None:
        if not 0 <= args.h264_crf <= 51:
            ap.error(f"--h264-crf must be in 0-51; got {args.h264_crf}")
    for flag, value in (("--h264-crf", args.h264_crf), ("--h264-preset", args.h264_preset)):
        if value is not None and args.compression != "h264":
            ap.error(f"{flag} needs --compression h264; got --compression {args.compression}")
    if args.fps is not None and not 5.0 <= args.fps <= 240.0:
        ap.error(f"--fps must be within 5-240; got {args.fps:g}")
    if args.attitude_sigma_deg is not None:
        if args.attitude != "estimate":
            ap.error("--attitude-sigma-deg goes with --attitude estimate")
        from wavealt.altimetry.dispersion.levelling import check_attitude_sigma

        try:
            check_attitude_sigma("--attitude-sigma-deg", args.attitude_sigma_deg)
        except ValueError as exc:
            ap.error(str(exc))
    if args.aspect is not None:
        from bench_foreign_sea import parse_aspect

        try:
            args.aspect = parse_aspect(args.aspect)
        except ValueError as exc:
            ap.error(str(exc))
    if args.fov_deg is not None and not 10.0 <= args.fov_deg <= 150.0:
        ap.error(f"--fov-deg must be within 10-150; got {args.fov_deg:g}")
    args.sensor = tuple((k, v) for k, v in (("compression", args.compression),
                                            ("jpeg_quality", args.jpeg_quality),
                                            ("h264_crf", args.h264_crf),
                                            ("h264_preset", args.h264_preset),
                                            ("fps", args.fps), ("fov_deg", args.fov_deg))
                        if v is not None)
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.redraw is not None:
        print(draw_windows(args.redrawn, args.figure))
        return 0
    init_process()
    t0 = time.perf_counter()
    if not args.no_cache:
        check_cache(args.prune_cache)
    tasks = tasks_of(args.rows, args.seeds, args.sequences, args.size, not args.no_cache,
                     args.sensor, args.attitude, args.attitude_sigma_deg, args.aspect)
    recs = run_tasks(tasks, args.workers)
    rows = {r.name: row_report(r, args.seeds, [x for x in recs if x["row"] == r.name])
            for r in args.rows}
    cores = os.cpu_count()
    camera = sim_config("paper", 10, 0, 1, args.size, args.sensor)  # --fps, --fov-deg
    result = {
        "benchmark": "dispersion",
        "issue": "blind altimeter",
        "command": ["python", "benchmarks/bench_dispersion.py",
                    *(sys.argv[1:] if argv is None else argv)],
        "settings": {
            "rows": [r.name for r in args.rows], "seeds": list(args.seeds),
            "sequences_per_seed": args.sequences, "size_px": args.size,
            "aspect": None if args.aspect is None else "{}:{}".format(*args.aspect),
            "scenario_overrides": {k: list(v) for k, v in SCENARIO_OVERRIDES.items()},
            "workers": args.workers, "cache": not args.no_cache,
            "attitude": args.attitude, "attitude_sigma_deg": args.attitude_sigma_deg,
            "realistic_camera": realistic_camera(args.sensor, args.size),
            "fps": camera.fps, "fov_deg": camera.fov_deg,
            "frames": "each row generates its sequences with frames=F directly",
            "frames_as_stored": "uint8 when exact k/255 (realistic: lossless), else float16 "
                                "(paper); the estimator sees them so, cache or not",
            "prior": {"velocity_mps": "true camera velocity over the water minus a current c",
                      "current": f"uniform direction, |c| uniform 0-{MAX_CURRENT_MPS:g} m/s, "
                                 f"rng [scenario seed, {CURRENT_STREAM}]",
                      "velocity_sigma_mps": PRIOR_SIGMA_MPS},
            "latency": ("per estimate call, torch and BLAS on one thread, the compiled "
                        "loops loaded (warm_up), after one untimed warm-up call per process "
                        "and row"
                        + (f"; {args.workers} workers share the machine's {cores} cores"
                           if args.workers > 1 else "")),
            "coverage": f"|est - true| <= {COVERAGE_SIGMAS:g} altitude_std_m",
            "near_half_altitude": f"est/true in {list(NEAR_HALF)}",
            "near_double_altitude": f"est/true in {list(NEAR_DOUBLE)}",
        },
        "environment": environment(),
        "targets": targets(),
        "summary": summary(rows),
        "rows": rows,
        "elapsed_s": round(time.perf_counter() - t0, 1),
    }
    if args.out is not None:
        write_outputs(result, recs, args.out)
    if args.figure is not None:
        draw_windows(recs, args.figure)
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
