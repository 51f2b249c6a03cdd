"""Accuracy and latency of the dispersion altimeter on simulated sequences; prints JSON.

    python benchmarks/bench_dispersion.py [--quick] [--sequences N] [--size 256]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from wavealt.altimetry.dispersion import DispersionAltimeter
from wavealt.scenario import preset_config
from wavealt.simulate import generate_sequence


def _bands(true: np.ndarray, rel: np.ndarray, edges: list[float]) -> dict[str, dict]:
    out = {}
    for lo, hi in zip(edges[:-1], edges[1:]):
        s = (true >= lo) & (true < hi)
        if s.any():
            out[f"{lo:g}-{hi:g}"] = {"n": int(s.sum()), "rel_mae": float(np.mean(rel[s]))}
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="12 sequences at 128 px")
    ap.add_argument("--sequences", type=int, default=100)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--deglint", default="clip")
    args = ap.parse_args()
    n, size = (12, 128) if args.quick else (args.sequences, args.size)
    cfg = preset_config("paper", sequences=n, size=size, frames=args.frames,
                        altitude_m=(1.0, 15.0), wind_speed_mps=(2.0, 12.0),
                        camera_speed_mps=(0.0, 1.0), seed=7)
    est = DispersionAltimeter(dispersion="gravity", deglint=args.deglint)
    rec: dict[str, list] = {"alt": [], "wind": [], "clean": [], "glinty": [], "linear": [],
                            "q_clean": [], "q_glinty": [], "t": []}
    for i in range(n):
        sc = cfg.sample_scenario(i)
        data = generate_sequence(sc, cfg)
        lin = data.slope_x + 0.7 * data.slope_y
        lin = ((lin - lin.min()) / (lin.max() - lin.min())).astype(np.float32)
        rec["alt"].append(sc.altitude_m)
        rec["wind"].append(sc.wind_speed_mps)
        for name, frames in (("clean", data.clean), ("glinty", data.glinty), ("linear", lin)):
            t0 = time.perf_counter()
            r = est.estimate(frames, fps=cfg.fps, focal_px=cfg.focal_px)
            if name == "clean":
                rec["t"].append(time.perf_counter() - t0)
                rec["q_clean"].append(r.quality)
            if name == "glinty":
                rec["q_glinty"].append(r.quality)
            rec[name].append(r.altitude_m)
    alt = np.array(rec["alt"])
    wind = np.array(rec["wind"])
    result: dict = {"sequences": n, "size": size, "frames": args.frames,
                    "deglint": args.deglint,
                    "latency_ms_median": 1e3 * float(np.median(rec["t"]))}
    for name in ("clean", "glinty", "linear"):
        est_a = np.array(rec[name])
        err = (est_a - alt) / alt
        rel = np.abs(err)
        result[name] = {
            "rel_mae": float(rel.mean()), "rel_bias": float(err.mean()),
            "rel_median_abs": float(np.median(rel)),
            "by_altitude_m": {k: {**v, "rel_bias": float(err[(alt >= float(k.split('-')[0]))
                                                             & (alt < float(k.split('-')[1]))].mean())}
                              for k, v in _bands(alt, rel, [1, 3, 6, 10, 15.01]).items()},
            "by_wind_mps": _bands(wind, rel, [2, 4, 7, 10, 12.01]),
        }
    result["quality_median"] = {"clean": float(np.median(rec["q_clean"])),
                                "glinty": float(np.median(rec["q_glinty"]))}
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
