"""The dispersion altimeter on a camera that yaws; prints one JSON object.

    python benchmarks/bench_yaw.py [--seeds 23,31] [--sequences 40] [--rates 10,30]
        [--frames 10] [--mode exact|blind] [--sea realistic|second] [--workers 1]
        [--max-tilt-deg T] [--out FILE.json] [--plot FILE.png]

Each sequence of the realistic renderer (256 px, altitude 1-15 m, wind 2-12 m/s, drift 0-1
m/s, clean frames) is the sea in the axes of the clip's middle frame; a camera whose nose
turns right at R deg/s sees its central 176 px (the square that stays inside the render
through a turn) sampled where the middle frame sees each point (MAVLink's axes:
:func:`wavealt.live.mavlink.ned_to_image`).  Every rate, including 0 (the reference: the
same crop, no turn), is fitted as it is (``untold``) and with ``yaw_rate_dps`` given
(``told``).  ``--mode exact`` gives the camera's velocity over the water; ``blind`` none.
Per rate and case: relative MAE, median, trusted share, trusted windows more than 10 % off,
3-sigma coverage; ``--plot`` draws the rates measured against those turned and each
window's error, rate given or not.  ``--sea second`` takes the sea of
``bench_foreign_sea.py``'s independent generator instead (its clip ``seed + index``, 256
px, its own frame rate and focal length, the camera's velocity over the water given in
exact mode; at most its 30 frames); ``--max-tilt-deg T`` tilts its camera from nadir by up
to T degrees (the generator's own tilt) before the camera turns about its optical axis.
Exit code 0: a report, not a gate.
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

RENDER_PX = 256
CAMERA_PX = 176  # inside the render through any turn: 256 / sqrt(2) = 181


def yawing_view(frames: np.ndarray, rate_dps: float, fps: float, side: int) -> np.ndarray:
    """The central ``side`` px of a camera whose nose turns right at ``rate_dps`` over
    ``frames`` (the sea in the middle frame's axes, ``(T, H, W)``): each pixel samples the sea
    where the middle frame sees the point this frame sees there."""
    import scipy.ndimage as ndi

    t, h, w = frames.shape
    yy, xx = np.mgrid[0:side, 0:side].astype(float)
    right, forward = xx - (side - 1) / 2, (side - 1) / 2 - yy
    out = []
    for i in range(t):
        d = math.radians(rate_dps * (i - (t - 1) / 2) / fps)
        north = forward * math.cos(d) - right * math.sin(d)
        east = forward * math.sin(d) + right * math.cos(d)
        out.append(ndi.map_coordinates(frames[i], [(h - 1) / 2 - north, (w - 1) / 2 + east],
                                       order=1, mode="reflect"))
    return np.stack(out).astype(np.float32)


def _realistic_sea(seed: int, index: int, frames: int) -> tuple[np.ndarray, dict[str, Any]]:
    """The realistic renderer's clean frames (grey) of sequence ``index`` of ``seed``, and
    the sea's truth: ``altitude_m``, ``fps``, ``focal_px``, ``velocity_mps``."""
    from wavealt.sim.config import preset_config
    from wavealt.sim.generate import generate_sequence

    cfg = preset_config("realistic", size=RENDER_PX, frames=frames, seed=seed,
                        altitude_m=(1.0, 15.0), wind_speed_mps=(2.0, 12.0),
                        camera_speed_mps=(0.0, 1.0))
    sc = cfg.sample_scenario(index)
    return generate_sequence(sc, cfg).clean.mean(axis=-1), {
        "altitude_m": sc.altitude_m, "fps": cfg.fps, "focal_px": cfg.focal_px,
        "velocity_mps": tuple(float(v) for v in sc.camera_velocity_mps)}


def _second_sea(seed: int, index: int, frames: int, max_tilt_deg: float = 0.0
                ) -> tuple[np.ndarray, dict[str, Any]]:
    """The independent generator's clip ``seed + index`` (``bench_foreign_sea.py``), its
    first ``frames`` frames scaled to [0, 1], and its truth (as :func:`_realistic_sea`,
    and ``tilt_deg``); ``max_tilt_deg``: the camera tilted from nadir by up to that, as
    ``bench_foreign_sea.py --max-tilt-deg`` tilts it."""
    gen = _generator()
    sc = gen.draw_scene(seed + index, max_tilt_deg=max_tilt_deg)
    clip, _ = gen.render_clip(sc)
    if frames > clip.shape[0]:
        msg = f"--frames must be at most {clip.shape[0]} with --sea second; got {frames}"
        raise ValueError(msg)
    return clip[:frames].astype(np.float32) / 255.0, {
        "altitude_m": sc.altitude_m, "fps": gen.FPS, "focal_px": sc.focal_px,
        "velocity_mps": tuple(float(v) for v in sc.over_water), "tilt_deg": sc.tilt_deg}


def _generator() -> Any:
    """``benchmarks/bench_foreign_sea.py``, imported once (registered as a module, which its
    dataclasses need)."""
    import importlib.util

    name = "bench_foreign_sea"
    if name not in sys.modules:
        path = Path(__file__).resolve().parent / f"{name}.py"
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        spec.loader.exec_module(mod)
    return sys.modules[name]


SEAS = {"realistic": _realistic_sea, "second": _second_sea}


def run_sequence(task: tuple[int, int], rates: tuple[float, ...], frames: int,
                 mode: str, sea_name: str = "realistic",
                 working_px: int | None = None, max_tilt_deg: float = 0.0
                 ) -> list[dict[str, Any]]:
    """The windows of sequence ``task = (seed, index)`` at each rate, told and untold;
    ``working_px``: the altimeter's working scale (None: its default; 88 bins the 176-px
    camera by 2, as frames twice the default scale are); ``max_tilt_deg``: the second
    sea's camera tilted (:func:`_second_sea`), and turning about its optical axis."""
    from wavealt.altimetry.dispersion import DispersionAltimeter

    seed, index = task
    tilt = {"max_tilt_deg": max_tilt_deg} if max_tilt_deg > 0.0 else {}
    sea, truth = SEAS[sea_name](seed, index, frames, **tilt)
    kw: dict[str, Any] = {"fps": truth["fps"], "focal_px": truth["focal_px"]}
    if mode == "exact":
        kw["velocity_mps"] = truth["velocity_mps"]
    scale = {} if working_px is None else {"working_px": working_px}
    est = DispersionAltimeter(dispersion="gravity-capillary", **scale)
    out = []
    for rate in (0.0, *rates):
        clip = np.clip(yawing_view(sea, rate, truth["fps"], CAMERA_PX), 0.0, 1.0)
        for case, given in (("untold", None), ("told", rate)):
            if rate == 0.0 and case == "told":
                continue
            t0 = time.perf_counter()
            res = est.estimate(clip, yaw_rate_dps=given, **kw)
            out.append({"seed": seed, "index": index, "rate_dps": rate, "case": case,
                        "altitude_m": truth["altitude_m"], "estimate_m": res.altitude_m,
                        "std_m": res.altitude_std_m, "trusted": bool(res.trusted),
                        "reason": res.reason, "yaw_rate_dps": res.yaw_rate_dps,
                        "signal": res.signal, "tilt_deg": truth.get("tilt_deg", 0.0),
                        "ms": 1e3 * (time.perf_counter() - t0)})
    return out


def summarise(rows: list[dict[str, Any]], key: str = "rate_dps",
              flags: tuple[str, ...] = ()) -> dict[str, Any]:
    """Per value of the rows' ``key`` and case (``"<value>/<case>"``): relative MAE, median,
    trusted share, trusted windows more than 10 % off, 3-sigma coverage, median latency;
    and for each boolean row field of ``flags`` the share of rows where it holds
    (``<flag>_share``)."""
    table: dict[str, Any] = {}
    keys = sorted({(r[key], r["case"]) for r in rows})
    for rate, case in keys:
        sel = [r for r in rows if r[key] == rate and r["case"] == case]
        h = np.array([r["altitude_m"] for r in sel])
        est = np.array([r["estimate_m"] for r in sel])
        sd = np.array([r["std_m"] for r in sel])
        tr = np.array([r["trusted"] for r in sel])
        rel = np.abs(est - h) / h
        table[f"{rate:g}/{case}"] = {
            "windows": len(sel), "rel_mae_pct": round(100 * float(rel.mean()), 2),
            "median_abs_rel_pct": round(100 * float(np.median(rel)), 2),
            "trusted_share": round(float(tr.mean()), 3),
            "trusted_off_10pct": int(np.sum(tr & (rel > 0.1))),
            "coverage_3sigma": round(float(np.mean(np.abs(est - h) <= 3 * sd)), 3),
            **{f"{flag}_share": round(float(np.mean([r[flag] for r in sel])), 3)
               for flag in flags},
            "latency_ms_median": round(float(np.median([r["ms"] for r in sel])), 1)}
    return table


def plot(rows: list[dict[str, Any]], path: Path, title: str) -> None:
    """Two panels: the rate each window was turned back at against the camera's, rate not
    given (the altimeter's own measurement); each window's relative error by rate, given and
    not given, trusted windows filled."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(0)
    rates = sorted({r["rate_dps"] for r in rows})
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    untold = [r for r in rows if r["case"] == "untold"]
    for trusted, style in ((False, {"facecolors": "none"}), (True, {})):
        sel = [r for r in untold if r["trusted"] == trusted]
        x = np.array([r["rate_dps"] for r in sel]) + rng.uniform(-0.6, 0.6, len(sel))
        left.scatter(x, [r["yaw_rate_dps"] for r in sel], s=14, edgecolors="C0", **style,
                     label="trusted" if trusted else "not trusted")
    top = max(rates) * 1.1 + 1.0
    left.plot([0, top], [0, top], color="0.5", lw=0.8, label="the camera's rate")
    left.set_xlabel("camera's yaw rate, deg/s")
    left.set_ylabel("rate turned back at (measured), deg/s")
    left.set_title("rate not given: the turn measured")
    left.legend(fontsize=8)
    for k, (case, colour) in enumerate((("told", "C2"), ("untold", "C3"))):
        for trusted in (False, True):
            sel = [r for r in rows if r["case"] == case and r["trusted"] == trusted
                   and (case == "untold" or r["rate_dps"] != 0.0)]
            pos = [rates.index(r["rate_dps"]) + (k - 0.5) * 0.3 for r in sel]
            x = np.array(pos) + rng.uniform(-0.08, 0.08, len(sel))
            err = [max(abs(r["estimate_m"] / r["altitude_m"] - 1.0), 1e-4) * 100 for r in sel]
            label = (f"rate {'given' if case == 'told' else 'not given'}"
                     f"{', trusted' if trusted else ''}")
            right.scatter(x, err, s=12, color=colour if trusted else "none",
                          edgecolors=colour, label=label)
    right.axhline(10.0, color="0.5", lw=0.8, ls="--")
    right.set_yscale("log")
    right.set_xticks(range(len(rates)), [f"{r:g}" for r in rates])
    right.set_xlabel("camera's yaw rate, deg/s")
    right.set_ylabel("|relative error|, %")
    right.set_title("each window's error (dashed: 10 %)")
    right.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def sea_parser(doc: str, frames: int, mode: str) -> argparse.ArgumentParser:
    """The options this benchmark and ``bench_shake.py`` share: seeds, sequences, frames,
    mode, sea, workers and the output file; described by the first paragraph of the
    benchmark's ``doc``."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--seeds", default="23,31")
    ap.add_argument("--sequences", type=int, default=40)
    ap.add_argument("--frames", type=int, default=frames)
    ap.add_argument("--mode", choices=("exact", "blind"), default=mode)
    ap.add_argument("--sea", choices=tuple(SEAS), default="realistic",
                    help="the realistic renderer's sea, or the independent generator's")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", type=Path)
    return ap


def check_sea_args(ap: argparse.ArgumentParser, a: argparse.Namespace, values: str,
                   name: str) -> tuple[float, ...]:
    """Parse ``a.seeds`` in place and return the numbers of the comma-separated option
    ``values`` (``--name``); exits with a one-line error where an option is out of range."""
    try:
        a.seeds = tuple(int(s) for s in a.seeds.split(","))
        numbers = tuple(float(r) for r in values.split(","))
    except ValueError:
        ap.error(f"--seeds and --{name} must be numbers separated by commas")
    if a.sequences < 1 or a.workers < 1 or a.frames < 3:
        ap.error("--sequences and --workers must be at least 1, --frames at least 3")
    if a.sea == "second" and a.frames > 30:
        ap.error(f"--frames must be at most 30 with --sea second; got {a.frames}")
    return numbers


def run_rows(a: argparse.Namespace, job: Any) -> tuple[list[dict[str, Any]], float]:
    """``job`` over every (seed, sequence) of ``a`` on its workers: the rows, in order, and
    the seconds it took."""
    tasks = [(s, i) for s in a.seeds for i in range(a.sequences)]
    t0 = time.perf_counter()
    with TaskRunner(runner_spec(workers=a.workers)) as runner:
        parts = list(tqdm(runner.map(job, tasks), total=len(tasks), desc="sequences",
                          file=sys.stderr))
    return [r for part in parts for r in part], round(time.perf_counter() - t0, 1)


def report(a: argparse.Namespace, summary: dict[str, Any], rows: list[dict[str, Any]]) -> None:
    """Print ``summary`` as JSON; with ``--out``, write it with the ``rows`` too."""
    print(json.dumps(summary, indent=1))
    if a.out is not None:
        from wavealt.io import atomic_write_text

        atomic_write_text(a.out, json.dumps({**summary, "rows": rows}, indent=1) + "\n")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = sea_parser(__doc__, frames=10, mode="exact")
    ap.add_argument("--rates", default="10,30", help="yaw rates, deg/s, comma-separated")
    ap.add_argument("--plot", type=Path, help="a PNG of the rates measured and the errors")
    ap.add_argument("--working-px", type=int, default=None,
                    help=f"the altimeter's working scale (default its own); {CAMERA_PX // 2} "
                         f"bins the {CAMERA_PX}-px camera by 2, as larger frames are")
    ap.add_argument("--max-tilt-deg", type=float, default=0.0,
                    help="with --sea second: the camera tilted from nadir by up to this "
                         "(0-30), turning about its optical axis")
    a = ap.parse_args(argv)
    a.rates = check_sea_args(ap, a, a.rates, "rates")
    if not 0.0 <= a.max_tilt_deg <= 30.0:
        ap.error(f"--max-tilt-deg must be within 0-30; got {a.max_tilt_deg:g}")
    if a.max_tilt_deg > 0.0 and a.sea != "second":
        ap.error("--max-tilt-deg needs --sea second (the realistic renderer looks straight "
                 "down)")
    if a.working_px is not None and a.working_px < 0:
        ap.error(f"--working-px must be >= 0; got {a.working_px}")
    if any(not (math.isfinite(r) and 0 < abs(r) <= 180) for r in a.rates):
        ap.error(f"--rates must be non-zero and within +-180 deg/s; got {a.rates}")
    return a


def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    job = partial(run_sequence, rates=a.rates, frames=a.frames, mode=a.mode, sea_name=a.sea,
                  working_px=a.working_px, max_tilt_deg=a.max_tilt_deg)
    rows, seconds = run_rows(a, job)
    summary = {"benchmark": "yaw", "command": " ".join(["python", *sys.argv]),
               "seeds": list(a.seeds), "sequences": a.sequences, "rates_dps": list(a.rates),
               "frames": a.frames, "mode": a.mode, "sea": a.sea, "camera_px": CAMERA_PX,
               "working_px": a.working_px, "max_tilt_deg": a.max_tilt_deg,
               "by_rate": summarise(rows), "seconds": seconds}
    report(a, summary, rows)
    if a.plot is not None:
        plot(rows, a.plot, f"{a.sea} sea, {a.mode}, {a.frames} frames, seeds "
             f"{','.join(map(str, a.seeds))}, {a.sequences} sequences each")
    return 0


if __name__ == "__main__":
    sys.exit(main())
