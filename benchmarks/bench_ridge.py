"""What a velocity prior can add to a clip's altitude: the dispersion fit's ridge through the
truth, per window of ``bench_dispersion.py``'s rows; prints one JSON object.

    python benchmarks/bench_ridge.py [--rows realistic-10-prior,...] [--seeds 23,31]
        [--sequences 100] [--out FILE.json] [--no-cache]
    python benchmarks/bench_ridge.py --square 0,0.3,1 [--frames 15,30] [--clips 24]
        [--seed 5000] [--out FILE.json]

Without the camera's velocity the fit maximises the periodogram score over altitude and
velocity together (:meth:`~wavealt.altimetry.dispersion.profile._Profile._profile_fit`).
Altitude and velocity trade along a ridge: a higher camera sees a slower shell, which more
drift makes up.  This script follows the ridge that passes through the truth: at each
altitude of a grid about the true one (``BLIND_PROFILE_STEP_LOG`` apart, within
``SPAN_FACTOR``), the velocity of highest score found from the true velocity and carried from
altitude to altitude, as the estimator's profile carries it
(:meth:`~wavealt.altimetry.dispersion.profile._Profile._best_velocity`).  So it measures the
clip and the score, not the estimator's start or its choice among peaks.  Per window:

* ``peak_err``: the relative error of the ridge's highest point (a parabola through the
  grid's best three): where the score itself puts the altitude once the search is perfect;
* ``path_err_mps``: how far the ridge's velocity at the true altitude lies from the true
  velocity (the ridge passes through the truth);
* ``slope_mps``: how fast the ridge's velocity (m/s, the camera's over the water) changes with
  log altitude at the truth (``|dv / d log h|``, over two grid steps each side);
* ``prior_pct``: the relative altitude error a velocity prior of the row's sigma
  (``PRIOR_SIGMA_MPS``) allows on its own, ``100 sigma / slope``; and ``sigma_for_target_mps``:
  the prior sigma that alone would pin the altitude to the row's clean target;
* ``drop_sd``: how far the score falls from the truth to 10 % above and below it along the
  ridge (their mean), in units of the score's noise (:func:`~wavealt.altimetry.dispersion.
  search.null_sd`): negative where the ridge rises away from the truth.

``--square``: instead of the rows, the ridge on clips of the independent generator's sea
(``bench_foreign_sea.py``: its scenes, amplitudes and slopes, the camera level) seen by an
ideal camera, whose image is the slope along one direction plus ``W`` times the squared
slope (both in units of that slope's standard deviation), for each weight ``W`` given, and
by the generator's own optics (Fresnel reflection of its sky, its sensor; ``optics``): how
the square that a real camera's optics add to its linear response flattens the ridge.

The frames are ``bench_dispersion.py``'s (its cache); the periodogram is the one the
estimator's blind fit is made of (:func:`fitted_periodogram`: its signal, the corner tiles'
normal scores, the optics' continuum taken out).  The frames are not levelled or turned back
first, and no carried pattern is removed.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_dispersion as bench  # noqa: E402

from wavealt._checks import check_frames  # noqa: E402
from wavealt.altimetry.dispersion.constants import BLIND_PROFILE_STEP_LOG, MIN_FRAMES  # noqa: E402
from wavealt.altimetry.dispersion.kernel import use_compiled  # noqa: E402
from wavealt.altimetry.dispersion.search import null_sd  # noqa: E402

#: The ridge is followed from the truth up to this factor above and below it.
SPAN_FACTOR = 2.0
#: The first step of each velocity search along the ridge, px/frame (the profile's).
SEARCH_STEP_PX = 0.02
#: The ridge's fall is read this far (relative) above and below the truth.
DROP_AT = 0.10
#: Grid steps on each side of the truth over which the ridge's slope is read.
SLOPE_STEPS = 2
#: At most this many modes score each velocity (an even subsample, as the profile's).
SCORED_MODES = 1500


def ridge(est: Any, p: dict[str, Any], altitude_m: float, velocity_mps: Sequence[float],
          fps: float, focal_px: float) -> dict[str, np.ndarray]:
    """The ridge through the truth of periodogram ``p``: ``log_h`` (the grid), ``score`` and
    ``velocity_mps`` (``(n, 2)``, the camera's over the water) at each altitude, and the
    score's noise ``noise`` (module docstring)."""
    lo, hi = (math.log(a) for a in est.altitude_range_m)
    lt = math.log(altitude_m)
    n_side = int(math.floor(math.log(SPAN_FACTOR) / BLIND_PROFILE_STEP_LOG + 1e-9))
    steps = np.arange(-n_side, n_side + 1)
    grid = lt + steps * BLIND_PROFILE_STEP_LOG
    keep = (grid >= lo - 1e-12) & (grid <= hi + 1e-12)
    grid, steps = grid[keep], steps[keep]
    n = p["kappa"].size
    sub = np.arange(0, n, max(1, n // SCORED_MODES))
    score = np.full(grid.size, np.nan)
    path = np.full((grid.size, 2), np.nan)
    j0 = int(np.flatnonzero(steps == 0)[0]) if np.any(steps == 0) else None
    if j0 is not None:
        for order in (range(j0, grid.size), range(j0 - 1, -1, -1)):
            u = np.asarray(velocity_mps, dtype=np.float64) * focal_px / (altitude_m * fps)
            for j in order:  # carried from altitude to altitude, as the profile carries it
                score[j], u = est._best_velocity(p, fps, focal_px, float(grid[j]), u, sub,
                                                 SEARCH_STEP_PX)
                path[j] = u
    velocity = path * (fps * np.exp(grid)[:, None] / focal_px)  # px/frame -> m/s
    return {"log_h": grid, "score": score, "velocity_mps": velocity,
            "noise": null_sd(p, sub), "truth": j0}


#: The measures of a window whose ridge cannot be read (no periodogram, the truth off the
#: range, a score that is not finite).
NO_MEASURES = {"peak_err": math.nan, "path_err_mps": math.nan, "slope_mps": math.nan,
               "prior_pct": math.nan, "sigma_for_target_mps": math.nan, "drop_sd": math.nan}


def ridge_measures(r: dict[str, np.ndarray], altitude_m: float,
                   velocity_mps: Sequence[float], prior_sigma_mps: float,
                   target_pct: float) -> dict[str, float]:
    """The per-window measures of the module docstring from a :func:`ridge`."""
    grid, score, vel, j0 = r["log_h"], r["score"], r["velocity_mps"], r["truth"]
    if j0 is None or grid.size < 3 or not np.all(np.isfinite(score)):
        return dict(NO_MEASURES)
    k = int(np.argmax(score))
    peak = float(grid[k])  # at an end of the grid, the end
    if 0 < k < grid.size - 1:  # a parabola through the best three
        y0, y1, y2 = score[k - 1:k + 2]
        den = y0 - 2.0 * y1 + y2
        if den < 0:
            peak += float(0.5 * (y0 - y2) / den) * BLIND_PROFILE_STEP_LOG
    a, b = max(j0 - SLOPE_STEPS, 0), min(j0 + SLOPE_STEPS, grid.size - 1)
    slope = float(np.hypot(*(vel[b] - vel[a])) / (grid[b] - grid[a])) if b > a else math.nan
    lt = math.log(altitude_m)
    side = [float(np.interp(lt + s * math.log1p(DROP_AT), grid, score)) for s in (-1, 1)]
    return {
        "peak_err": math.expm1(peak - lt),
        "path_err_mps": float(np.hypot(*(vel[j0] - np.asarray(velocity_mps, dtype=float)))),
        "slope_mps": slope,
        "prior_pct": 100.0 * prior_sigma_mps / slope if slope > 0 else math.inf,
        "sigma_for_target_mps": target_pct / 100.0 * slope,
        "drop_sd": (float(score[j0]) - 0.5 * sum(side)) / max(float(r["noise"]), 1e-30),
    }


def fitted_periodogram(est: Any, frames: np.ndarray, fps: float,
                       focal_px: float) -> dict[str, Any] | None:
    """The periodogram of the signal the estimator's blind fit ends on
    (:meth:`~wavealt.altimetry.dispersion.DispersionAltimeter._fit`: the chroma of glinty
    colour frames where its fit is trusted or stands better, else the luminance), None where
    none can be fitted."""
    arr = check_frames(frames, min_frames=MIN_FRAMES, allow_gray=True)
    return est._fit(arr, fps, focal_px, None)[2]


def window_ridges(row: bench.RowSpec, seed: int, sequences: int,
                  use_cache: bool) -> list[dict[str, Any]]:
    """One record per window of ``row`` and ``seed``: the truth and its ridge's measures."""
    cfg = bench.sim_config(row.preset, row.frames, seed, sequences, bench.SIZE_PX)
    est = bench.estimator(row.dispersion)
    use_compiled()
    recs = []
    for i in tqdm(range(sequences), desc=f"{row.name} {seed}", unit="seq", file=sys.stderr):
        sc = cfg.sample_scenario(i)
        try:
            frames = bench.load_frames(cfg, sc, i, use_cache)
        except ValueError:
            continue
        for cond, target in zip(bench.CONDITIONS, (row.clean_mae_pct, row.glinty_mae_pct)):
            p = fitted_periodogram(est, frames[cond], cfg.fps, cfg.focal_px)
            rec = {"row": row.name, "seed": seed, "index": i, "condition": cond,
                   "altitude_m": float(sc.altitude_m)}
            if p is None:
                rec.update(NO_MEASURES)
            else:
                r = ridge(est, p, float(sc.altitude_m), sc.camera_velocity_mps, cfg.fps,
                          cfg.focal_px)
                rec.update(ridge_measures(r, float(sc.altitude_m), sc.camera_velocity_mps,
                                          bench.PRIOR_SIGMA_MPS, target))
            recs.append(rec)
    return recs


def square_clip(seed: int, frames: int, square: float | None) -> tuple[np.ndarray, Any]:
    """Clip ``seed`` of the independent generator (``bench_foreign_sea.py``) with ``frames``
    frames, uint8, and its scene: seen by an ideal camera whose image is ``s / sd(s) +
    square |grad eta|^2 / sd(s)^2`` (``s`` the slope along a direction drawn from the seed),
    scaled to 30 grey levels a standard deviation about 128; ``square`` None: by the
    generator's own optics and sensor."""
    fs = _foreign_sea()
    sc = fs.draw_scene(seed)
    rng = np.random.default_rng((sc.seed, 1))
    amp = fs.random_amplitudes(sc, rng)
    sx, sy = fs.slope_frames(sc, amp, frames)
    if square is None:
        return fs.capture(sc, fs.radiance(sc, sx, sy, None), rng)[0], sc
    angle = np.random.default_rng((seed, 7)).uniform(0.0, 2.0 * math.pi)
    lin = sx * math.cos(angle) + sy * math.sin(angle)
    sd = float(lin.std())
    img = lin / sd + square * (sx * sx + sy * sy) / (sd * sd)
    img = 128.0 + 30.0 * (img - img.mean()) / img.std()
    return np.clip(np.rint(img), 0, 255).astype(np.uint8), sc


def _foreign_sea() -> Any:
    import bench_foreign_sea

    return bench_foreign_sea


def square_ridges(squares: Sequence[float | None], frame_counts: Sequence[int], clips: int,
                  seed: int) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Per square weight (None: the generator's optics) and frame count: the ridge's
    measures on ``clips`` clips (seeds ``seed ..``), their summary and every window."""
    from wavealt.altimetry.dispersion import DispersionAltimeter

    est = DispersionAltimeter(dispersion="gravity-capillary")
    use_compiled()
    fs = _foreign_sea()
    summary: dict[str, Any] = {}
    recs = []
    for square in squares:
        name = "optics" if square is None else f"square {square:g}"
        for frames in frame_counts:
            sel = []
            for i in tqdm(range(clips), desc=f"{name}, {frames} frames", unit="clip",
                          file=sys.stderr):
                clip, sc = square_clip(seed + i, frames, square)
                p = fitted_periodogram(est, clip, fs.FPS, sc.focal_px)
                rec = {"row": name, "seed": seed + i, "index": frames, "condition": "-",
                       "altitude_m": sc.altitude_m}
                if p is None:
                    rec.update(NO_MEASURES)
                else:
                    r = ridge(est, p, sc.altitude_m, sc.over_water, fs.FPS, sc.focal_px)
                    rec.update(ridge_measures(r, sc.altitude_m, sc.over_water,
                                              bench.PRIOR_SIGMA_MPS, 1.0))
                sel.append(rec)
            err = np.abs(np.array([r["peak_err"] for r in sel], dtype=float))
            err = err[np.isfinite(err)]
            summary[f"{name}, {frames} frames"] = {
                "clips": clips, "measured": int(err.size),
                "peak_mae_pct": round(100 * float(np.mean(err)), 3) if err.size else None,
                "peak_median_pct": round(100 * float(np.median(err)), 3) if err.size else None,
                **{f"{k}_q25_50_75": _quantiles(np.array([r[k] for r in sel], dtype=float))
                   for k in ("path_err_mps", "slope_mps", "drop_sd")}}
            recs += sel
    return summary, recs


def _quantiles(values: np.ndarray) -> list[float | None]:
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return [None] * 3
    return [round(float(np.quantile(finite, q)), 4) for q in (0.25, 0.5, 0.75)]


def summarise(recs: list[dict[str, Any]], row: bench.RowSpec) -> dict[str, Any]:
    """Per condition: the ridge peak's relative MAE and median (percent), and the quartiles
    of the other measures."""
    out: dict[str, Any] = {}
    for cond, target in zip(bench.CONDITIONS, (row.clean_mae_pct, row.glinty_mae_pct)):
        sel = [r for r in recs if r["condition"] == cond]
        err = np.abs(np.array([r["peak_err"] for r in sel], dtype=float))
        measured = err[np.isfinite(err)]
        out[cond] = {
            "windows": len(sel), "measured": int(measured.size),
            "peak_mae_pct": round(100 * float(np.mean(measured)), 3) if measured.size else None,
            "peak_median_pct": (round(100 * float(np.median(measured)), 3)
                                if measured.size else None),
            "target_mae_pct": target,
            **{f"{k}_q25_50_75": _quantiles(np.array([r[k] for r in sel], dtype=float))
               for k in ("path_err_mps", "slope_mps", "prior_pct", "sigma_for_target_mps",
                         "drop_sd")},
        }
    return out


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", default="realistic-30-blind,realistic-15-blind,realistic-10-prior",
                    help="comma-separated rows of bench_dispersion.py")
    ap.add_argument("--seeds", default="23,31", help="comma-separated seeds")
    ap.add_argument("--sequences", type=int, default=100)
    ap.add_argument("--out", type=Path, default=None, help="write the JSON here too")
    ap.add_argument("--no-cache", action="store_true")
    ap.add_argument("--square", default=None,
                    help="comma-separated square weights W (module docstring; 'optics' for "
                         "the generator's own): the ideal camera's clips instead of the rows")
    ap.add_argument("--frames", default="15,30", help="with --square: frames per clip")
    ap.add_argument("--clips", type=int, default=24, help="with --square: clips per case")
    ap.add_argument("--seed", type=int, default=5000, help="with --square: the first clip's")
    args = ap.parse_args(argv)
    if args.square is not None:
        try:
            args.square = [None if w == "optics" else float(w)
                           for w in args.square.split(",") if w]
            args.frames = [int(f) for f in args.frames.split(",") if f]
        except ValueError:
            ap.error(f"--square takes numbers or 'optics' and --frames integers; got "
                     f"{args.square!r}, {args.frames!r}")
        if (not args.square or not args.frames or min(args.frames) < MIN_FRAMES
                or any(w is not None and not (math.isfinite(w) and w >= 0)
                       for w in args.square)):
            ap.error("--square needs finite weights >= 0 and --frames at least "
                     f"{MIN_FRAMES} frames")
        if args.clips < 1:
            ap.error(f"--clips must be >= 1; got {args.clips}")
    bench.known_rows_and_seeds(ap, args)
    return args


COLUMNS = ("row", "seed", "index", "condition", "altitude_m", "peak_err", "path_err_mps",
           "slope_mps", "prior_pct", "sigma_for_target_mps", "drop_sd")


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.out is not None and args.out.suffix != ".json":
        raise SystemExit(f"--out must name a .json file; got {args.out}")
    bench.init_process()
    if args.square is not None:
        summary, windows = square_ridges(args.square, args.frames, args.clips, args.seed)
        result = {"git": bench.git_state(), "seed": args.seed, "clips": args.clips,
                  "cases": summary}
        bench.print_and_write(result, windows, COLUMNS, args.out)
        return 0
    result: dict[str, Any] = {"git": bench.git_state(), "seeds": args.seeds,
                              "sequences": args.sequences,
                              "prior_sigma_mps": bench.PRIOR_SIGMA_MPS, "rows": {}}
    windows = []
    for row in args.rows:
        result["rows"][row.name] = {}
        for seed in args.seeds:
            recs = window_ridges(row, seed, args.sequences, not args.no_cache)
            windows += recs
            result["rows"][row.name][str(seed)] = summarise(recs, row)
    bench.print_and_write(result, windows, COLUMNS, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
