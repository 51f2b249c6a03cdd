"""How precisely a clip can tell its altitude at all: the Cramér-Rao bound of the dispersion
fit, per window of ``bench_dispersion.py``'s rows, beside the rows' targets; prints one JSON
object.

    python benchmarks/bench_bound.py [--rows realistic-30-blind,...] [--seeds 23,31]
        [--sequences 100] [--out FILE.json] [--no-cache]

The fit reads each spatial mode's phase step per frame ``psi`` from the periodogram of its
series in the corner tiles (:meth:`~wavealt.altimetry.dispersion.DispersionAltimeter.
_fit_periodogram`, the table the estimator scores) and finds the altitude and velocity whose
shell ``psi = s omega(kappa f / h) / fps - kappa . u`` passes through them.  For one complex
sinusoid of amplitude ``a`` in white noise of variance ``sigma^2``, ``T`` frames measure its
frequency to ``var psi >= 6 / (SNR T (T^2 - 1))`` at best, ``SNR = |a|^2 / sigma^2`` (Rife &
Boorstyn, IEEE Trans. Inf. Theory 1974), and ``N`` tiles that share the step add their
SNRs.  A sea is not one sinusoid per mode: the tile's window admits the waves of about
1.5 bins of wavenumber a dimension, whose phase steps differ by the step's gradient over
that width, so each tile's peak lies at a random place within that spread (variance
``|grad psi . Delta|^2 / 12``, divided by the tiles, which see different waters), added to
the noise's.  A mode's SNR follows from its explained share ``q`` at the true phase step (the
better of the two directions): the table's expectation
``q = (T A + N sigma^2) / (T A + N (T - 1) sigma^2)`` gives
``A / sigma^2 = N (q (T - 1) - 1) / (T (1 - q))``, 0 where ``q`` is at the noise's
``1 / (T - 1)``.  The modes' Fisher information on ``theta = (log h, v_x, v_y)`` (m/s) is
``J = sum_m g_m g_m^T / var psi_m / 1.5^2``, ``g_m = d psi_m / d theta`` (the tiles' Hann
window spreads a wave and the noise over neighbouring modes: its equivalent noise bandwidth
is 1.5 bins a dimension, so the modes hold about ``1 / 1.5^2`` of the independent
information their number suggests), and the bound on
``sd(log h)`` is ``sqrt(1 / J_hh)`` with the velocity known (exact), ``sqrt((J^-1)_hh)``
blind, and ``sqrt(((J + diag(0, 1, 1) / s_v^2)^-1)_hh)`` with a prior of ``s_v`` m/s.

The share at the truth counts whatever lies there as signal (the optics' products, foam), so
the SNR is, if anything, too high and the bound too low: an unbiased estimator cannot do
better than it on these frames, whatever it does.  For Gaussian errors of ``sd = b`` the mean
absolute error is ``sqrt(2 / pi) b``; per row the JSON gives the quantiles of ``b``, the
mean absolute error a bound-attaining estimator would have (``b`` capped at 1 in log
altitude: a window without information still reads inside the range), and the share of
windows whose expected error at the bound exceeds the row's target.
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

from wavealt.altimetry.dispersion.spectra import sharpness_at  # noqa: E402

#: Highest share at the truth taken as such (a share of 1 is a noiseless mode).
MAX_SHARE = 0.99
#: The Hann window's equivalent noise bandwidth, bins per dimension of the plane.
HANN_ENBW = 1.5
#: A window's bound is capped at this sd of log altitude when its MAE is formed.
CAP_LOG = 1.0
MEAN_ABS_OF_SD = math.sqrt(2.0 / math.pi)


def mode_snr(share: np.ndarray, frames: int, tiles: int) -> np.ndarray:
    """Each mode's summed SNR ``A / sigma^2`` over ``tiles`` tiles from its explained share
    at the true phase step (module docstring); 0 at or below the noise's share."""
    q = np.clip(share, 0.0, MAX_SHARE)
    return np.maximum(tiles * (q * (frames - 1) - 1.0) / (frames * (1.0 - q)), 0.0)


def bounds(p: dict[str, Any], est: Any, altitude_m: float, velocity_mps: Sequence[float],
           fps: float, focal_px: float, tiles: int,
           prior_sigma_mps: float) -> dict[str, float]:
    """Bounds on ``sd(log h)`` (exact, prior, blind) of the periodogram ``p`` at the true
    altitude and camera velocity over the water (the periodogram's convention)."""
    t = int(p["frames"])
    kx, ky, kappa = (np.asarray(p[k], dtype=np.float64) for k in ("kx", "ky", "kappa"))
    share = np.asarray(p["q"], dtype=np.float64) ** (1.0 / sharpness_at(est.sharpness, t))
    n_psi = share.shape[1]
    om, dom = est._omega_and_dlog(kappa, focal_px, altitude_m)
    scale = focal_px / (altitude_m * fps)  # m/s -> px/frame
    vx, vy = (float(v) for v in velocity_mps)
    dop = (kx * vx + ky * vy) * scale
    rows = np.arange(kappa.size)
    best = np.full(kappa.size, -np.inf)
    sign = np.ones(kappa.size)
    for s in (1.0, -1.0):
        pos = np.mod(s * om / fps - dop, 2.0 * math.pi) * (n_psi / (2.0 * math.pi))
        j = np.floor(pos).astype(np.int64)
        frac = pos - j
        val = share[rows, j % n_psi] * (1.0 - frac) + share[rows, (j + 1) % n_psi] * frac
        sign = np.where(val > best, s, sign)
        best = np.maximum(best, val)
    # 1 / var psi per mode, the modes' shared information discounted
    with np.errstate(divide="ignore"):
        var_noise = 6.0 / (mode_snr(best, t, tiles) * t * (t * t - 1.0))
    # the sea within a mode's bin: waves of the wavenumbers the window admits, whose steps
    # differ by the step's gradient over the bin (each tile its own draw)
    grad = -sign * dom / (np.maximum(kappa, 1e-12) * fps)  # d psi / d kappa along kappa
    gx = grad * kx / np.maximum(kappa, 1e-12) - vx * scale
    gy = grad * ky / np.maximum(kappa, 1e-12) - vy * scale
    th, tw = p["tile"]
    var_bin = ((gx * HANN_ENBW * 2.0 * math.pi / tw) ** 2
               + (gy * HANN_ENBW * 2.0 * math.pi / th) ** 2) / 12.0 / tiles
    # 1 / var psi per mode, the modes' shared information discounted
    info = np.where(np.isfinite(var_noise), 1.0 / (var_noise + var_bin), 0.0) / HANN_ENBW ** 2
    # d psi / d (log h, vx, vy): the velocity in m/s is fixed, its px/frame goes as 1 / h
    g = np.stack([sign * dom / fps + dop, -kx * scale, -ky * scale])
    fisher = (g * info) @ g.T
    out = {"exact": 1.0 / math.sqrt(fisher[0, 0]) if fisher[0, 0] > 0 else math.inf}
    for name, extra in (("prior", 1.0 / prior_sigma_mps ** 2), ("blind", 0.0)):
        f = fisher + np.diag([0.0, extra, extra])
        try:
            cov = np.linalg.inv(f)
            out[name] = math.sqrt(cov[0, 0]) if cov[0, 0] > 0 else math.inf
        except np.linalg.LinAlgError:
            out[name] = math.inf
    out["snr_modes"] = int(np.count_nonzero(info))
    return out


def window_bounds(row: bench.RowSpec, seed: int, sequences: int,
                  use_cache: bool) -> list[dict[str, Any]]:
    """One record per window of ``row`` and ``seed``: the truth and its three bounds."""
    cfg = bench.sim_config(row.preset, row.frames, seed, sequences, bench.SIZE_PX)
    est = bench.estimator(row.dispersion)
    recs = []
    for i in tqdm(range(sequences), desc=f"{row.name} {seed}", unit="seq", file=sys.stderr):
        sc = cfg.sample_scenario(i)
        try:
            frames = bench.load_frames(cfg, sc, i, use_cache)
        except ValueError:
            continue
        for cond in bench.CONDITIONS:
            signal = est._signal(frames[cond])[0]
            p = est._fit_periodogram(signal)
            rec = {"row": row.name, "seed": seed, "index": i, "condition": cond,
                   "altitude_m": float(sc.altitude_m)}
            if p is None:
                rec.update(exact=math.inf, prior=math.inf, blind=math.inf, snr_modes=0)
            else:
                tiles = 4 if p["corners"] else 1  # the parts the periodogram sums
                rec.update(bounds(p, est, float(sc.altitude_m), sc.camera_velocity_mps,
                                  cfg.fps, cfg.focal_px, tiles, bench.PRIOR_SIGMA_MPS))
            recs.append(rec)
    return recs


def summarise(recs: list[dict[str, Any]], row: bench.RowSpec) -> dict[str, Any]:
    """Per condition: the bound's quantiles (percent of the altitude, for ``row.mode``
    and the other modes), the bound-attaining MAE and the share of windows whose expected
    error at the bound is over the row's target."""
    out: dict[str, Any] = {}
    for cond, target in zip(bench.CONDITIONS, (row.clean_mae_pct, row.glinty_mae_pct)):
        sel = [r for r in recs if r["condition"] == cond]
        per: dict[str, Any] = {"windows": len(sel)}
        for mode in ("exact", "prior", "blind"):
            b = np.array([r[mode] for r in sel])
            capped = np.minimum(b, CAP_LOG)
            per[mode] = {
                "bound_pct_q25_50_75": [round(100 * float(np.quantile(b, q)), 3)
                                        for q in (0.25, 0.5, 0.75)],
                "bound_mae_pct": round(100 * MEAN_ABS_OF_SD * float(np.mean(capped)), 3),
                "share_over_target": round(float(np.mean(
                    100 * MEAN_ABS_OF_SD * capped > target)), 3),
            }
        per["target_mae_pct"] = target
        per["row_mode"] = row.mode
        out[cond] = per
    return out


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", default=",".join(bench.ROW_BY_NAME),
                    help="comma-separated rows of bench_dispersion.py")
    ap.add_argument("--seeds", default="23,31", help="comma-separated seeds")
    ap.add_argument("--sequences", type=int, default=100)
    ap.add_argument("--out", type=Path, default=None, help="write the JSON here too")
    ap.add_argument("--no-cache", action="store_true")
    args = ap.parse_args(argv)
    bench.known_rows_and_seeds(ap, args)
    return args


#: Each window's fields in the CSV beside ``--out``.
COLUMNS = ("row", "seed", "index", "condition", "altitude_m", "exact", "prior", "blind",
           "snr_modes")


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.out is not None and args.out.suffix != ".json":
        raise SystemExit(f"--out must name a .json file; got {args.out}")
    bench.init_process()
    result: dict[str, Any] = {"git": bench.git_state(), "seeds": args.seeds,
                              "sequences": args.sequences, "rows": {}}
    windows = []
    for row in args.rows:
        result["rows"][row.name] = {}
        for seed in args.seeds:
            recs = window_bounds(row, seed, args.sequences, not args.no_cache)
            windows += recs
            result["rows"][row.name][str(seed)] = summarise(recs, row)
    bench.print_and_write(result, windows, COLUMNS, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
