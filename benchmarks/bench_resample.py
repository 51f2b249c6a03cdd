"""What resampling the frames costs the dispersion altimeter; prints one JSON object.

    python benchmarks/bench_resample.py [--clips 100] [--seed 30000] [--shift-px 0.5]
        [--interpolation none|linear|cubic] [--rows blind30,exact10] [--workers 1]
        [--out FILE.json]

Each clip of ``bench_foreign_sea.py``'s independent generator (nadir, a pinhole) is read as
rendered (``--interpolation none``), or shifted by ``--shift-px`` in x and y first with
OpenCV's bilinear (``linear``) or bicubic (``cubic``) interpolation.  A shift changes no
geometry, so what changes is the resampling alone: a bilinear remap is a low-pass filter
(at a half-pixel offset it passes 71 % of the amplitude at half the Nyquist frequency, none
at the Nyquist), as :class:`wavealt.camera.NadirView`'s is, which turns a calibrated or
tilted camera's frames to a pinhole's view.  Per row: ``bench_foreign_sea.py``'s metrics.
Exit code 0: a report, not a gate.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from functools import partial  # noqa: E402
from multiprocessing import Pool  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_foreign_sea as gen  # noqa: E402

INTERPOLATIONS = ("none", "linear", "cubic")


def shifted(frames: np.ndarray, shift_px: float, interpolation: str) -> np.ndarray:
    """``frames`` ``(T, H, W)`` moved by ``shift_px`` px in x and y (``interpolation``:
    ``"linear"`` or ``"cubic"``, OpenCV's; edges reflected), same dtype; themselves for
    ``"none"``."""
    import cv2

    if interpolation == "none":
        return frames
    flag = cv2.INTER_LINEAR if interpolation == "linear" else cv2.INTER_CUBIC
    move = np.float32([[1, 0, shift_px], [0, 1, shift_px]])
    return np.stack([cv2.warpAffine(f, move, (f.shape[1], f.shape[0]), flags=flag,
                                    borderMode=cv2.BORDER_REFLECT) for f in frames])


def evaluate(seed: int, rows: tuple[str, ...], shift_px: float,
             interpolation: str) -> list[dict[str, Any]]:
    """``bench_foreign_sea.evaluate_clip``'s records of clip ``seed``, its frames resampled."""
    render = gen.render_clip

    def resampled(sc: Any, n_frames: int = gen.FRAMES) -> tuple[np.ndarray, dict]:
        frames, contrast = render(sc, n_frames)
        return shifted(frames, shift_px, interpolation), contrast

    gen.render_clip = resampled
    try:
        return gen.evaluate_clip(seed, rows, None)
    finally:
        gen.render_clip = render


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clips", type=int, default=100)
    ap.add_argument("--seed", type=int, default=30000)
    ap.add_argument("--shift-px", type=float, default=0.5)
    ap.add_argument("--interpolation", choices=INTERPOLATIONS, default="linear")
    ap.add_argument("--rows", default="blind30,exact10")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    rows = tuple(r for r in a.rows.split(",") if r)
    if not rows or any(r not in gen.ROWS for r in rows):
        ap.error(f"--rows must be a comma list of {', '.join(gen.ROWS)}; got {a.rows!r}")
    if a.clips < 1 or a.workers < 1:
        ap.error("--clips and --workers must be at least 1")
    if not 0.0 <= a.shift_px <= 8.0:
        ap.error(f"--shift-px must be within 0-8; got {a.shift_px:g}")
    job = partial(evaluate, rows=rows, shift_px=a.shift_px, interpolation=a.interpolation)
    seeds = range(a.seed, a.seed + a.clips)
    t0, records = time.perf_counter(), []
    with Pool(a.workers, initializer=gen.set_size, initargs=(gen.SIZE,)) as pool:
        for recs in tqdm(pool.imap(job, seeds), total=len(seeds), desc="clips",
                         file=sys.stderr):
            records.extend(recs)
    summary = {"benchmark": "bench_resample", "clips": a.clips, "seed": a.seed,
               "shift_px": a.shift_px, "interpolation": a.interpolation, "rows": list(rows),
               "seconds": round(time.perf_counter() - t0, 1),
               "metrics": gen.summarize(records, rows)}
    gen.report(summary, records, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
