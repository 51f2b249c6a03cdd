"""What the water's orbital motion costs the dispersion fit, and what undoing it gives back.

    python benchmarks/bench_orbit.py [--seed 92000] [--clips 12] [--choppy 1]
        [--steps as-is,inframe,shell] [--max-fits 80] [--out run.json]

The independent generator's Lagrangian sea (``bench_foreign_sea.py --choppy``) seen by an
ideal camera, the slope itself (``I = sx + 0.7 sy``, 8 bits: no optics, no noise), each
clip 30 frames at 30 frames/s fitted blind, as it is and after each step:

* ``inframe``: the orbit of the waves longer than ``INFRAME_CUT_PX`` read from each frame
  itself: the long waves' height from the slope the frame records (the imaging known),
  ``eta = I conj(i k.g) / (|k.g|^2 + eps k^2)``, their displacement ``D = i k/|k| eta``,
  and the frame resampled at ``x + D(x)``, the particles' rest positions;
* ``shell``: after ``inframe``, the orbit of the waves longer than the frame, smooth over it
  but turning within the second, as an acceleration and a velocity gradient
  (``a t^2 / 2 + t G x``, six numbers; ``t`` from the middle frame, ``x`` from the centre)
  chosen to maximise the blind fit's own significance (Powell, at most ``--max-fits``
  whole fits a clip).

A probe of the method (``docs/dispersion.md``, fifty-fourth session), not the estimator:
the imaging is known here, and the shell step costs tens of fits a window.  Prints the
summary as one JSON object; ``--out`` gets it with every clip's record.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from scipy import ndimage, optimize  # noqa: E402
from tqdm import tqdm  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_foreign_sea as fs  # noqa: E402

STEPS = ("as-is", "inframe", "shell")
#: the ideal camera records this direction of slope (x, y)
SLOPE_DIRECTION = (1.0, 0.7)
#: waves longer than this (px) have their orbit read from the frame (``inframe``)
INFRAME_CUT_PX = 64.0
#: the height's regularisation where the slope direction is across the wave (``k.g`` ~ 0)
INFRAME_EPS = 0.05
#: the smooth orbit's six numbers are searched in these units: px/frame^2 (acceleration)
#: and 1/frame (velocity gradient)
SHELL_UNITS = np.array([0.01, 0.01, 0.001, 0.001, 0.001, 0.001])
FRAMES = 30


def ideal_clip(seed: int, choppy: float) -> tuple[np.ndarray, fs.Scene]:
    """The slope ``sx + 0.7 sy`` (float) of the generator's scene ``seed`` with the orbit's
    share ``choppy``, 30 frames, and the scene."""
    sc = replace(fs.draw_scene(seed), choppy=choppy)
    amp = fs.random_amplitudes(sc, np.random.default_rng((sc.seed, 1)))
    sx, sy = fs.slope_frames(sc, amp, FRAMES)
    return SLOPE_DIRECTION[0] * sx + SLOPE_DIRECTION[1] * sy, sc


def to_uint8(frames: np.ndarray) -> np.ndarray:
    """Frames scaled over their whole range to 8 bits."""
    lo, span = float(frames.min()), float(np.ptp(frames))
    return np.rint((frames - lo) / max(span, 1e-30) * 255.0).astype(np.uint8)


def undo_inframe(frames: np.ndarray, cut_px: float = INFRAME_CUT_PX,
                 direction: tuple[float, float] = SLOPE_DIRECTION) -> np.ndarray:
    """Each frame ``(T, N, N)`` (the slope along ``direction``) resampled at its particles'
    rest positions ``x + D(x)``, ``D`` the orbit of its waves longer than ``cut_px`` read
    from the frame itself (the module docstring); mirror-padded to twice its size."""
    t, n, m = frames.shape
    if n != m:
        raise ValueError(f"frames must be square; got {n}x{m}")
    size = 2 * n
    k = 2.0 * np.pi * np.fft.fftfreq(size)
    ky, kx = np.meshgrid(k, k, indexing="ij")
    kk = np.hypot(kx, ky)
    kk1 = np.where(kk > 0, kk, 1.0)
    g = direction[0] * kx + direction[1] * ky
    low = (kk > 0) & (kk < 2.0 * np.pi / cut_px)
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float64)
    cut = slice(n // 2, n // 2 + n)
    out = np.empty_like(frames, dtype=np.float64)
    for i in range(t):
        spec = np.fft.fft2(np.pad(frames[i], n // 2, mode="reflect"))
        eta = np.where(low, spec * np.conj(1j * g) / (np.abs(g) ** 2 + INFRAME_EPS * kk1**2), 0)
        dx = np.fft.ifft2(1j * kx / kk1 * eta).real[cut, cut]
        dy = np.fft.ifft2(1j * ky / kk1 * eta).real[cut, cut]
        out[i] = ndimage.map_coordinates(frames[i], [yy + dy, xx + dx], order=3, mode="reflect")
    return out


def warp_smooth(frames: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Frames resampled at ``x + a t^2 / 2 + t G x`` (``p``: ``ax, ay, Gxx, Gxy, Gyx, Gyy``
    in :data:`SHELL_UNITS`)."""
    t, n, _ = frames.shape
    ax, ay, gxx, gxy, gyx, gyy = np.asarray(p, dtype=np.float64) * SHELL_UNITS
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float64)
    xc, yc = xx - (n - 1) / 2, yy - (n - 1) / 2
    out = np.empty_like(frames, dtype=np.float64)
    for i, tt in enumerate(np.arange(t) - (t - 1) / 2):
        dx = 0.5 * ax * tt * tt + tt * (gxx * xc + gxy * yc)
        dy = 0.5 * ay * tt * tt + tt * (gyx * xc + gyy * yc)
        out[i] = ndimage.map_coordinates(frames[i], [yy + dy, xx + dx], order=1, mode="reflect")
    return out


def fit(altimeter, frames: np.ndarray, focal_px: float):  # noqa: ANN001, ANN201
    """The blind fit of float frames, scaled to 8 bits."""
    return altimeter.estimate(to_uint8(frames), fps=fs.FPS, focal_px=focal_px)


def shell_autofocus(altimeter, frames: np.ndarray, focal_px: float,  # noqa: ANN001
                    max_fits: int) -> tuple[np.ndarray, float]:
    """The smooth orbit (:func:`warp_smooth`'s six numbers) that maximises the blind fit's
    significance, and that significance."""
    best = optimize.minimize(lambda p: -fit(altimeter, warp_smooth(frames, p),
                                            focal_px).significance,
                             np.zeros(6), method="Powell",
                             options={"maxfev": max_fits, "xtol": 0.2})
    return best.x, float(-best.fun)


def evaluate(seed: int, choppy: float, steps: tuple[str, ...], max_fits: int) -> dict:
    """One clip's record: the truth and, per step, the fit's error, trust and
    significance."""
    from wavealt.altimetry.dispersion import DispersionAltimeter

    altimeter = DispersionAltimeter(dispersion="gravity-capillary")
    frames, sc = ideal_clip(seed, choppy)
    rec: dict = {"seed": seed, "altitude_m": sc.altitude_m, "u10": sc.u10, "choppy": choppy}
    inframe = undo_inframe(frames) if {"inframe", "shell"} & set(steps) else None
    for step in steps:
        t0 = time.perf_counter()
        if step == "as-is":
            res = fit(altimeter, frames, sc.focal_px)
        elif step == "inframe":
            res = fit(altimeter, inframe, sc.focal_px)
        else:
            p, _ = shell_autofocus(altimeter, inframe, sc.focal_px, max_fits)
            res = fit(altimeter, warp_smooth(inframe, p), sc.focal_px)
            rec["shell_params"] = [float(v) for v in p]
        rec[step] = {"rel_err": res.altitude_m / sc.altitude_m - 1.0,
                     "trusted": bool(res.trusted), "significance": float(res.significance),
                     "seconds": time.perf_counter() - t0}
    return rec


def summarize(records: list[dict], steps: tuple[str, ...]) -> dict:
    """Per step: relative MAE and median |error| (%), trusted count, trusted > 10 % off."""
    out = {}
    for step in steps:
        e = np.array([abs(r[step]["rel_err"]) for r in records])
        tr = np.array([r[step]["trusted"] for r in records])
        out[step] = {"clips": len(records), "mae_pct": round(100 * float(np.mean(e)), 2),
                     "median_pct": round(100 * float(np.median(e)), 2),
                     "trusted": int(tr.sum()), "trusted_over_10pct": int((tr & (e > 0.1)).sum())}
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=92000)
    ap.add_argument("--clips", type=int, default=12)
    ap.add_argument("--choppy", type=float, default=1.0,
                    help=f"the orbit's share (bench_foreign_sea.py --choppy), 0-{fs.MAX_CHOPPY:g}")
    ap.add_argument("--steps", default=",".join(STEPS), help=f"comma list of {', '.join(STEPS)}")
    ap.add_argument("--max-fits", type=int, default=80,
                    help="the shell step's blind fits a clip, at most")
    ap.add_argument("--out", type=Path, help="JSON with the summary and every clip's record")
    a = ap.parse_args()
    steps = tuple(s.strip() for s in a.steps.split(",") if s.strip())
    if not steps or set(steps) - set(STEPS):
        ap.error(f"--steps must be a comma list of {', '.join(STEPS)}; got {a.steps!r}")
    if not 0.0 <= a.choppy <= fs.MAX_CHOPPY:
        ap.error(f"--choppy must be within 0-{fs.MAX_CHOPPY:g}; got {a.choppy:g}")
    if a.clips < 1 or a.max_fits < 1:
        ap.error("--clips and --max-fits must be at least 1")
    fs.set_size(256, None, 30.0, choppy=a.choppy)
    t0 = time.perf_counter()
    records = [evaluate(s, a.choppy, steps, a.max_fits)
               for s in tqdm(range(a.seed, a.seed + a.clips), desc="clips", file=sys.stderr)]
    summary = {"benchmark": "bench_orbit", "seed": a.seed, "clips": a.clips,
               "choppy": a.choppy, "steps": list(steps), "max_fits": a.max_fits,
               "seconds": round(time.perf_counter() - t0, 1),
               "metrics": summarize(records, steps)}
    print(json.dumps(summary, indent=1))
    if a.out is not None:
        a.out.write_text(json.dumps({**summary, "records": records}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
