"""How far the corner tiles' altitudes lie from the truth, in units of their own sigma;
prints one JSON object.

    python benchmarks/bench_tiles.py [--rows realistic-10-exact,realistic-30-blind]
        [--seeds 101,202] [--sequences 40] [--no-cache] [--out FILE.json]
    python benchmarks/bench_tiles.py --sea second [--rows exact10,blind30] [--seed 1000]
        [--clips 25] [--out FILE.json]

Every corner tile of a level camera over a level sea sees the true altitude: the realistic
renderer samples the sea on the nadir grid (its small roll and pitch change only the
light), and the independent generator's camera (``bench_foreign_sea.py``) looks straight
down unless tilted.  For each window, the tiles of the frames as given that hold the waves
(``_corner_fits``' first list; the weak tiles apart) give ``z = (log h_tile - log H) /
sd_tile`` against the truth ``H`` and against the fit's altitude (a blind fit's tiles share
its velocity, whose error the second cancels).  Per row: the tiles' count, the median of
``|z|`` and the shares beyond 1, 2, 3, 4 and 6, beside a normal's and those of a t with two
degrees of freedom at ``TILE_T_SCALE`` (what ``TILE_INFORMATION_SD_SCALE`` was set from,
``docs/dispersion.md``, forty-eighth session).  ``--sea realistic`` takes
``bench_dispersion.py``'s rows, frames and cache; ``--sea second`` the independent
generator's clips ``seed .. seed + clips - 1`` and its rows.
Exit code 0: a report, not a gate.
"""

from __future__ import annotations

import os

# before NumPy loads: one thread, as the other benchmarks
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402
from tqdm import tqdm  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

#: The |z| thresholds whose exceedance shares are reported.
THRESHOLDS = (1.0, 2.0, 3.0, 4.0, 6.0)
#: The scale, in units of a tile's sigma, of the t (two degrees of freedom) that the
#: realistic tuning tiles' errors follow (median |z| 0.31).
TILE_T_SCALE = 0.38


def z_summary(z: np.ndarray) -> dict[str, Any]:
    """``n``, the median of ``|z|`` and the share of ``|z|`` beyond each of ``THRESHOLDS``."""
    a = np.abs(np.asarray(z, dtype=float))
    out: dict[str, Any] = {"n": int(a.size),
                           "median_abs_z": round(float(np.median(a)), 3) if a.size else None}
    for x in THRESHOLDS:
        out[f"share_over_{x:g}"] = round(float(np.mean(a > x)), 4) if a.size else None
    return out


def reference(dist: Any, scale: float = 1.0) -> dict[str, Any]:
    """:func:`z_summary`'s numbers for ``scale`` times a variate of ``dist`` (scipy)."""
    out: dict[str, Any] = {"median_abs_z": round(scale * float(dist.ppf(0.75)), 3)}
    for x in THRESHOLDS:
        out[f"share_over_{x:g}"] = round(float(2.0 * dist.sf(x / scale)), 4)
    return out


def _recorder() -> Any:
    """A ``DispersionAltimeter`` class that keeps its first ``_corner_fits`` of each
    ``estimate`` (the frames as given; a levelled view's come later) in ``tiles``."""
    from wavealt.altimetry.dispersion import DispersionAltimeter

    class Recorder(DispersionAltimeter):
        tiles: tuple[list, float] | None = None

        def estimate(self, *a: Any, **kw: Any) -> Any:
            self.tiles = None
            return super().estimate(*a, **kw)

        def _corner_fits(self, signal: Any, res: Any, *a: Any, **kw: Any) -> Any:
            fits, weak = super()._corner_fits(signal, res, *a, **kw)
            if self.tiles is None:
                self.tiles = (list(fits), float(res.altitude_m))
            return fits, weak

    return Recorder


def window_z(tiles: tuple[list, float] | None, truth_m: float) -> tuple[list, list]:
    """The tiles' ``z`` against the truth and against the fit (:data:`_recorder`'s
    ``tiles``: the tiles ``(x, y, log h, sd_log)`` and the fit's altitude)."""
    if tiles is None:
        return [], []
    fits, fit_m = tiles
    return ([(lg - math.log(truth_m)) / sd for _, _, lg, sd in fits],
            [(lg - math.log(fit_m)) / sd for _, _, lg, sd in fits])


def realistic_rows(rows: list[Any], seeds: list[int], sequences: int,
                   use_cache: bool = True) -> dict[str, Any]:
    """Per row of ``bench_dispersion.py`` (its ``RowSpec`` entries): the tiles' ``z`` over
    its windows (its frames' cache read and written where ``use_cache``)."""
    import bench_dispersion as bench

    out = {}
    for row in rows:
        name = row.name
        est = _recorder()(dispersion=row.dispersion)
        vs_truth, vs_fit, windows = [], [], 0
        for seed in seeds:
            cfg = bench.sim_config(row.preset, row.frames, seed, sequences, bench.SIZE_PX, ())
            for i in tqdm(range(sequences), desc=f"{name} seed {seed}", unit="seq"):
                sc = cfg.sample_scenario(i)
                velocity, sigma, _ = bench.given_velocity(row, sc)
                frames = bench.load_frames(cfg, sc, i, use_cache)
                for cond in bench.CONDITIONS:
                    est.estimate(frames[cond], fps=cfg.fps, focal_px=cfg.focal_px,
                                 velocity_mps=velocity, velocity_sigma_mps=sigma)
                    a, b = window_z(est.tiles, sc.altitude_m)
                    vs_truth += a
                    vs_fit += b
                    windows += 1
        out[name] = {"windows": windows, "seeds": seeds, "against_truth": z_summary(vs_truth),
                     "against_fit": z_summary(vs_fit)}
    return out


def second_rows(rows: list[str], seed: int, clips: int) -> dict[str, Any]:
    """Per row of ``bench_foreign_sea.py``: the tiles' ``z`` over the clips' windows."""
    import bench_foreign_sea as gen

    for name in rows:
        if name not in gen.ROWS:
            raise SystemExit(f"error: unknown row {name!r} (rows: {', '.join(gen.ROWS)})")
    est = _recorder()()
    got = {name: ([], [], 0) for name in rows}
    for s in tqdm(range(seed, seed + clips), desc="clips", unit="clip"):
        sc = gen.draw_scene(s)
        frames, _ = gen.render_clip(sc)
        focal = gen.frame_focal_px(sc)
        for name in rows:
            mode, n = gen.ROWS[name]
            kw = gen.mode_velocity(sc)[mode]
            a_all, b_all, w = got[name]
            for start in range(0, gen.FRAMES - n + 1, n):
                try:
                    est.estimate(frames[start:start + n], fps=gen.FPS, focal_px=focal, **kw)
                except ValueError:
                    continue
                a, b = window_z(est.tiles, sc.altitude_m)
                a_all += a
                b_all += b
                w += 1
            got[name] = (a_all, b_all, w)
    return {name: {"windows": w, "seeds": [seed, seed + clips - 1],
                   "against_truth": z_summary(a), "against_fit": z_summary(b)}
            for name, (a, b, w) in got.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sea", choices=("realistic", "second"), default="realistic")
    ap.add_argument("--rows", default=None,
                    help="realistic: bench_dispersion rows (realistic-10-exact,"
                         "realistic-30-blind); second: exact10,blind30")
    ap.add_argument("--seeds", default="101,202", help="realistic: the seeds")
    ap.add_argument("--sequences", type=int, default=40, help="realistic: per seed")
    ap.add_argument("--seed", type=int, default=1000, help="second: the first clip's seed")
    ap.add_argument("--clips", type=int, default=25, help="second: how many clips")
    ap.add_argument("--no-cache", action="store_true",
                    help="realistic: neither read nor write bench_dispersion.py's cache")
    ap.add_argument("--out", type=Path, default=None, help="also write the JSON here")
    args = ap.parse_args()
    if args.out is not None and args.out.exists():
        raise SystemExit(f"error: {args.out} exists; give another --out (nothing written)")
    t0 = time.perf_counter()
    if args.sea == "realistic":
        import bench_dispersion

        args.rows = args.rows or "realistic-10-exact,realistic-30-blind"
        bench_dispersion.known_rows_and_seeds(ap, args)  # the same one-line errors
        result = realistic_rows(args.rows, args.seeds, args.sequences, not args.no_cache)
    else:
        rows = (args.rows or "exact10,blind30").split(",")
        result = second_rows(rows, args.seed, args.clips)
    from wavealt.altimetry.dispersion.constants import TILE_INFORMATION_SD_SCALE

    report = {"benchmark": "tiles", "sea": args.sea, "rows": result,
              "normal": reference(stats.norm),
              "t2_at_scale": {"scale": TILE_T_SCALE, **reference(stats.t(2), TILE_T_SCALE)},
              "tile_information_sd_scale": TILE_INFORMATION_SD_SCALE,
              "elapsed_s": round(time.perf_counter() - t0, 1)}
    text = json.dumps(report, indent=2)
    print(text)
    if args.out is not None:
        from wavealt.io import atomic_write_text

        atomic_write_text(args.out, text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
