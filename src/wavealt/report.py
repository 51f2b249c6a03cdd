"""``wavealt reproduce``: the paper end to end (simulate -> deglint -> train -> evaluate) and
its report (``report.md`` and a self-contained ``report.html`` with the figures embedded).

Every stage records itself in ``OUT/stages.json`` when it finishes; a re-run skips the stages
already done (and each stage is itself resumable: the simulator and deglinter complete missing
sequences, training resumes from its last epoch), so an interrupted ``reproduce`` loses at most
the current epoch.  A stage that cannot run yet (say, a training condition the dataset lacks)
is recorded as skipped and retried next time.

Scales (``SCALES``):

``quick``  120 sequences of 128x128 px (the CNNs see 64x64 px windows, cut without resizing),
           the small registered ResNet (``resnet-small``, 0.5 M parameters), 16 epochs, lr
           1e-3, 4 frames per sequence per epoch: a few minutes on 2 CPU cores.  *Not* the
           paper's protocol; labelled as such in the report.
``paper``  the paper's protocol: 200 sequences of 224x224 px (30 test sequences), ResNet-50,
           30 epochs, batch 32, Adam 1e-4 with cosine annealing.
"""

from __future__ import annotations

import base64
import dataclasses
import html
import json
import math
import platform
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from wavealt._checks import check_choice

DEGLINT_METHODS = ("tmf", "tmf-min", "median", "percentile", "glint-mask", "achromatic")


@dataclass(frozen=True)
class ReproduceScale:
    """Sizes of one ``reproduce`` scale."""

    name: str
    sequences: int
    size: int
    frames: int
    model: str
    epochs: int
    batch_size: int
    lr: float
    frames_per_sequence: int
    train_conditions: tuple[str, ...]
    temporal_conditions: tuple[str, ...]
    note: str
    deglint_methods: tuple[str, ...] = DEGLINT_METHODS
    threads: int = 0  # torch threads (0 = every core)
    crop_px: int | None = None  # CNN input window (no resize); None: the trainer's default


SCALES: dict[str, ReproduceScale] = {
    "quick": ReproduceScale(
        name="quick", sequences=120, size=128, frames=10, model="resnet-small", epochs=16,
        batch_size=32, lr=1e-3, frames_per_sequence=4, threads=1, crop_px=64,
        train_conditions=("clean", "glinty", "residual", "tmf-min"),
        temporal_conditions=("clean", "glinty"),
        note=("QUICK SCALE — not the paper's protocol: 120 sequences of 128x128 px (18 test "
              "sequences; the CNNs see 64x64 px windows cut without resizing, random in "
              "training and central in evaluation), the small registered ResNet (`resnet-small`, Bottleneck (1,1,1,1), "
              "width 16, 0.5 M parameters) instead of ResNet-50, 16 epochs at lr 1e-3, 4 frames "
              "per sequence per epoch, one torch thread; CNNs trained on clean, glinty, residual "
              "and tmf-min only "
              "(every deglint method is still tested). Run `wavealt reproduce OUT --scale paper` "
              "for the paper's protocol.")),
    "paper": ReproduceScale(
        name="paper", sequences=200, size=224, frames=10, model="resnet50", epochs=30,
        batch_size=32, lr=1e-4, frames_per_sequence=0,
        train_conditions=("clean", "glinty", "residual", "tmf-min"),
        temporal_conditions=("clean", "glinty"),
        note=("PAPER SCALE — the paper's protocol (Table 1): 200 sequences of 224x224 px, "
              "ResNet-50 trained from scratch, Adam 1e-4, cosine annealing, 30 epochs, batch 32, "
              "70/15/15 split with seed 42.")),
}


class _Stages:
    """``OUT/stages.json``: which stages are done, with their wall times."""

    def __init__(self, out: Path) -> None:
        self.path = out / "stages.json"
        self.data: dict[str, dict[str, Any]] = (
            json.loads(self.path.read_text(encoding="utf-8")) if self.path.is_file() else {})

    def done(self, name: str) -> bool:
        return self.data.get(name, {}).get("status") == "done"

    def run(self, name: str, fn: Callable[[], Any]) -> Any:
        """Run stage ``fn`` unless done; record its result and wall time."""
        if self.done(name):
            return self.data[name].get("result")
        t0 = time.perf_counter()
        result = fn()
        entry = {"status": "done", "result": result}
        entry["seconds"] = round(time.perf_counter() - t0, 2)
        self.data[name] = entry
        self._write()
        return result

    def _write(self) -> None:
        from wavealt.io import atomic_write_text

        atomic_write_text(self.path, json.dumps(self.data, indent=2) + "\n")


def reproduce(out: Path | str, *, scale: str = "quick", progress: bool = True,
              device: str = "auto", train_conditions: Sequence[str] | None = None,
              threads: int | None = None) -> list[Path]:
    """Run the whole pipeline into ``out`` and write ``report.md`` and ``report.html``.

    Parameters
    ----------
    out : path
        Output folder: ``dataset/``, ``runs/<name>/``, ``eval/<name>/``, ``figures/``,
        ``stages.json``, ``report.md``, ``report.html``.
    scale : {"quick", "paper"}
        See the module docstring.
    progress : bool
        Progress bars.
    device : str
        Where the CNNs train and run: ``auto`` (CUDA, then MPS, then CPU), ``cpu``,
        ``cuda[:N]`` or ``mps``.
    train_conditions : sequence of str, optional
        CNN runs to train, by name (``clean``, ``glinty``, ``temporal-clean``, ...); default:
        the scale's. ``["clean"]`` is the paper's own experiment, the CPU-sized run.
    threads : int, optional
        torch threads (0 = every core); default: the scale's.

    Returns
    -------
    list of Path
        The two report files.
    """
    from wavealt.altimetry.device import resolve_device

    check_choice("scale", scale, SCALES)
    sc = SCALES[scale]
    resolve_device(device)  # an unavailable device fails before anything is written
    runs_all = [*sc.train_conditions, *(f"temporal-{c}" for c in sc.temporal_conditions)]
    wanted = list(train_conditions) if train_conditions else runs_all
    for name in wanted:
        check_choice("train condition", name, runs_all)
    if threads is not None:
        sc = dataclasses.replace(sc, threads=int(threads))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    stages = _Stages(out)
    ds_path = out / "dataset"
    t_start = time.perf_counter()

    def simulate() -> dict[str, Any]:
        from wavealt.dataset import simulate_dataset
        from wavealt.sim.config import preset_config

        cfg = preset_config("paper", sequences=sc.sequences, size=sc.size, frames=sc.frames)
        simulate_dataset(ds_path, cfg, progress=progress)
        return {"sequences": sc.sequences}

    stages.run("simulate", simulate)

    def figures_dataset() -> list[str]:
        from wavealt.plots import dataset_figures

        return [str(p) for p in dataset_figures(ds_path, out / "figures")]

    stages.run("figures:dataset", figures_dataset)

    for method in sc.deglint_methods:
        def deglint(method: str = method) -> dict[str, Any]:
            from wavealt.deglint import deglint_dataset

            cond = deglint_dataset(ds_path, method=method, window=sc.frames, progress=progress)
            return {"condition": cond}

        stages.run(f"deglint:{method}", deglint)
    stages.run("figures:deglint", lambda: _deglint_figures(ds_path, out / "figures", sc.frames))

    from wavealt.dataset import Dataset

    conditions = Dataset(ds_path).conditions
    runs: dict[str, Path] = {}
    for cond in sc.train_conditions + tuple(f"temporal:{c}" for c in sc.temporal_conditions):
        temporal = cond.startswith("temporal:")
        c = cond.split(":")[-1]
        name = f"{'temporal-' if temporal else ''}{c}"
        if name not in wanted:
            continue
        if c not in conditions:
            stages.data[f"train:{name}"] = {"status": f"skipped: condition {c!r} not in dataset",
                                            "seconds": 0.0}
            continue

        def train_one(c: str = c, name: str = name, temporal: bool = temporal) -> dict[str, Any]:
            from wavealt.altimetry.data import TrainConfig
            from wavealt.altimetry.train import train

            cfg = TrainConfig(condition=c, model=sc.model, epochs=sc.epochs,
                              batch_size=sc.batch_size, lr=sc.lr,
                              frames_per_sequence=0 if temporal else sc.frames_per_sequence,
                              temporal=temporal, threads=sc.threads, crop_px=sc.crop_px)
            res = train(ds_path, out / "runs" / name, cfg, resume=True, progress=progress,
                        device=device)
            return {"best_epoch": res["best_epoch"], "best_val_mae_m": res["best_val_mae_m"],
                    "train_seconds": res["seconds"]}

        if stages.run(f"train:{name}", train_one) is not None or stages.done(f"train:{name}"):
            runs[name] = out / "runs" / name

    from wavealt.altimetry.data import set_num_threads

    set_num_threads(sc.threads)  # inference too (load_run does not set threads)
    evals: dict[str, dict[str, Any]] = {}
    specs = {f"cnn-{n}": f"cnn:{p}" for n, p in runs.items()}
    specs["dispersion"] = "dispersion"
    specs["dispersion-aided"] = "dispersion-aided"
    specs["constant"] = "constant"
    for name, spec in specs.items():
        def eval_one(spec: str = spec, name: str = name) -> dict[str, Any]:
            from wavealt.evaluation import evaluate

            res = evaluate(ds_path, spec, conditions=conditions, out=out / "eval" / name,
                           progress=progress, device=device, force=True)
            return {"estimator": res.estimator, "metrics": res.metrics,
                    "baseline": res.baseline, "baseline_label": res.baseline_label}

        key = f"evaluate:{name}"
        prev = stages.data.get(key, {}).get("result") or {}
        if stages.done(key) and sorted(prev.get("metrics", {})) != sorted(conditions):
            del stages.data[key]  # new conditions appeared (e.g. deglinting landed): redo
        r = stages.run(key, eval_one)
        if r is not None:
            evals[name] = r
    stages.data["total"] = {"status": "done",
                            "seconds": round(time.perf_counter() - t_start, 2)}
    stages._write()
    md = build_report_markdown(out, sc, stages.data, evals, runs)
    from wavealt.io import atomic_write_text

    atomic_write_text(out / "report.md", md)
    atomic_write_text(out / "report.html", markdown_to_html(md, base=out))
    return [out / "report.md", out / "report.html"]


def _deglint_figures(ds_path: Path, fig_dir: Path, window: int) -> list[str]:
    """Fig. 4 (TMF decomposition) and Fig. 7 (pixel trace) of the first test sequence."""
    from wavealt.plots import deglint_figures

    return [str(p) for p in deglint_figures(ds_path, fig_dir, window=window)]


# -- the report -------------------------------------------------------------------------
def _f(x: Any, signed: bool = False) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return f"{x:+.2f}" if signed else f"{x:.2f}"


def _label(c: str) -> str:
    from wavealt.evaluation import CONDITION_LABELS

    return CONDITION_LABELS.get(c, c)


def build_report_markdown(out: Path, sc: ReproduceScale, stages: dict[str, Any],
                          evals: dict[str, dict[str, Any]], runs: dict[str, Path]) -> str:
    """The report text (markdown); figures are referenced relative to ``out``."""
    import numpy as np
    import torch

    from wavealt import __version__
    from wavealt.evaluation import PAPER_TABLE2

    L: list[str] = [f"# wavealt reproduce — scale `{sc.name}`", "", f"> {sc.note}", "",
                    f"wavealt {__version__}, torch {torch.__version__}, numpy {np.__version__}, "
                    f"python {platform.python_version()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}. "
                    f"Total wall time of this invocation: {_f(stages.get('total', {}).get('seconds'))} s "
                    "(stages done by an earlier invocation are not re-timed; see the stage table). "
                    f"Sum of all stage times: {_f(sum(v.get('seconds') or 0.0 for k, v in stages.items() if k != 'total' and isinstance(v, dict)))} s.",
                    "",
                    "Protocol notes: splits are the manifest's 70/15/15 by sequence (seed 42), so no "
                    "frame of a test sequence is seen in training. Training augments by a random crop "
                    "*without resize* (the altitude lives in the pixel scale of the waves), H/V flips "
                    "and brightness/contrast/saturation jitter; evaluation uses the deterministic centre "
                    "crop of the same size and reports, per test sequence, the mean of its per-frame "
                    "predictions (the temporal CNN sees all frames at once, stacked as grayscale "
                    "channels). n counts sequences, as in the paper's Table 2.",
                    ""]
    # run folders inside OUT are named relative to it (the report travels with OUT)
    evals = {k: {**e, "baseline_label": str(e.get("baseline_label", "")).replace(f"{out}/", "")}
             for k, e in evals.items()}
    from wavealt.evaluation import read_abs_errors

    errors = {name: read_abs_errors(out / "eval" / name / "predictions.csv") for name in evals
              if (out / "eval" / name / "predictions.csv").is_file()}
    L += verdict_paragraph(evals, errors)
    main = evals.get("cnn-clean")
    L += ["## Table 2 — CNN trained on clean, tested per condition (ours vs the paper)", ""]
    if main:
        m = main["metrics"]
        n = sorted({v["n"] for v in m.values()})
        L += [f"Ours: n = {', '.join(map(str, n))} test sequences per condition; the paper: n = 30.",
              "", "| Condition | MAE ours | MAE paper | RMSE ours | RMSE paper | Bias ours | Bias paper | Max ours | Max paper | Rel. MAE ours (%) |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for c in [c for c in ("clean", "glinty", "residual") if c in m] + \
                 [c for c in m if c not in ("clean", "glinty", "residual")]:
            v, p = m[c], PAPER_TABLE2.get(c, {})
            L.append(f"| {_label(c)} | {_f(v['mae_m'])} | {_f(p.get('mae_m'))} | {_f(v['rmse_m'])} | "
                     f"{_f(p.get('rmse_m'))} | {_f(v['bias_m'], True)} | {_f(p.get('bias_m'), True)} | "
                     f"{_f(v['max_abs_err_m'])} | {_f(p.get('max_abs_err_m'))} | "
                     f"{_f(v.get('rel_mae_pct'))} |")
        if "clean" in m and "glinty" in m:
            L.append(f"| Glint penalty | {_f(m['glinty']['mae_m'] - m['clean']['mae_m'], True)} | +0.67 | | | | | | | |")
        b = main["baseline"]
        L.append(f"| Constant baseline ({main['baseline_label']}) | {_f(b['mae_m'])} | — | {_f(b['rmse_m'])} | — | "
                 f"{_f(b['bias_m'], True)} | — | {_f(b['max_abs_err_m'])} | — | {_f(b.get('rel_mae_pct'))} |")
        L += ["", "![Fig. 5](eval/cnn-clean/fig5_predicted_vs_actual.png)", "",
              "![Fig. 6](eval/cnn-clean/fig6_error_distribution.png)", ""]
    else:
        L += ["(not available: the CNN trained on clean did not run; see the stage table)", ""]

    # every method side by side
    L += side_by_side_markdown(evals, stages, errors)
    L += _deglint_quality_markdown(out / "dataset")

    # figures
    L += ["", "## Figures", ""]
    figs = [("Fig. 2 — clean vs glinty frames", "figures/fig2_examples.png"),
            ("Fig. 3 — generation steps", "figures/fig3_generation.png"),
            ("Fig. 4 — TMF decomposition", "figures/fig4_tmf_decomposition.png"),
            ("Fig. 7 — per-pixel trace and rolling minimum", "figures/fig7_pixel_trace.png")]
    for name in evals:
        figs += [(f"Fig. 5 — {evals[name]['estimator']}", f"eval/{name}/fig5_predicted_vs_actual.png"),
                 (f"Fig. 6 — {evals[name]['estimator']}", f"eval/{name}/fig6_error_distribution.png")]
    for title, rel in figs:
        if (out / rel).is_file():
            L += [f"### {title}", "", f"![{title}]({rel})", ""]
        else:
            L += [f"### {title}", "", "(not produced: its stage did not run)", ""]

    # training curves summary
    L += ["## Training runs", "", "| Run | Model | Train condition | Temporal | Best epoch | Best val MAE (m) | Train time (s) | s / epoch | Device |",
          "|---|---|---|---|---:|---:|---:|---:|---|"]
    for name, path in runs.items():
        try:
            info = json.loads((path / "config.json").read_text(encoding="utf-8"))
            hist = json.loads((path / "history.json").read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            continue
        best = min(hist, key=lambda h: h["val_mae_m"])
        t = info["train"]
        dev = info.get("device", {})
        dev_txt = f"{dev.get('name', 'cpu')} ({dev.get('device', 'cpu')}, {dev.get('precision', 'float32')}, {info.get('threads', '?')} threads)"
        total_s = sum(h["seconds"] for h in hist)
        L.append(f"| {name} | {t['model']} | {t['condition']} | {t['temporal']} | {best['epoch']} | "
                 f"{_f(best['val_mae_m'])} | {_f(total_s)} | {_f(total_s / len(hist))} | {dev_txt} |")

    # stage times and configs
    L += ["", "## Run times", "", "| Stage | Status | Seconds |", "|---|---|---:|"]
    for k, v in stages.items():
        if isinstance(v, dict):
            L.append(f"| {k} | {v.get('status', '')} | {_f(v.get('seconds'))} |")
    L += ["", "## Exact configs", "", "Dataset (`dataset/dataset.json`):", "", "```json",
          json.dumps(json.loads((out / "dataset" / "dataset.json").read_text(encoding="utf-8"))["config"],
                     indent=2) if (out / "dataset" / "dataset.json").is_file() else "{}", "```", ""]
    for name, path in runs.items():
        cfg = path / "config.json"
        if cfg.is_file():
            info = json.loads(cfg.read_text(encoding="utf-8"))
            show = {k: info[k] for k in ("train", "stats", "splits", "objective", "threads") if k in info}
            L += [f"Run `{name}` (`runs/{name}/config.json`, abridged):", "", "```json",
                  json.dumps(show, indent=2), "```", ""]
    return "\n".join(L) + "\n"



def _ordered_conditions(evals: dict[str, dict[str, Any]]) -> list[str]:
    conds: list[str] = []
    for e in evals.values():
        conds += [c for c in e["metrics"] if c not in conds]
    first = [c for c in ("clean", "glinty", "residual") if c in conds]
    return first + [c for c in conds if c not in first]


def _method_label(name: str, e: dict[str, Any]) -> str:
    if name == "constant":
        return f"constant baseline ({e['baseline_label'].removeprefix('constant ')})"
    return str(e["estimator"])


def side_by_side_markdown(evals: dict[str, dict[str, Any]],
                          stages: dict[str, Any] | None = None,
                          errors: dict[str, dict[str, dict[str, float]]] | None = None
                          ) -> list[str]:
    """Every evaluated method against every test condition (MAE, relative MAE) and the honest
    verdict against the constant baseline, as markdown lines.

    Parameters
    ----------
    evals : dict
        ``name -> {"estimator", "metrics", "baseline", "baseline_label"}`` as ``reproduce``
        records them; ``"constant"`` is the baseline.
    stages : dict, optional
        ``stages.json``; skipped stages are listed.
    errors : dict, optional
        ``name -> condition -> {sequence_id: absolute error}`` (the evaluations'
        ``predictions.csv``, :func:`wavealt.evaluation.read_abs_errors`) for the verdict's
        paired test; without them no method is judged.
    """
    conds = _ordered_conditions(evals)
    L = ["## Every method × every test condition", "",
         "Rows: the CNN per training condition (beyond the paper: its conclusion proposes "
         "training on deglinted images), the temporal CNN (all frames of a sequence stacked as "
         "channels), the physics-based dispersion altimeter (no training; the dispersion "
         "relation of the simulator's renderer), blind (it searches the camera's velocity over "
         "the water too) and with the velocity known (as a vehicle's navigation gives it), "
         "each followed by a *trusted only* row (the same estimates less those the altimeter "
         "flags itself as not trusted; n counts what is left), "
         "and the constant baseline (training-set mean "
         "altitude). Columns: the test condition (`residual` is the paper's eq. (6) glint "
         "estimate; `tmf-min`, `median`, `percentile`, `glint-mask`, `achromatic` are "
         "deglinted frames, see the deglint table below).", ""]
    for title, key, fmt in (("MAE (m) [bias (m)]", "mae_m", None),
                            ("Relative MAE (% of the true altitude)", "rel_mae_pct", "pct")):
        L += [f"### {title}", "",
              "| Method | " + " | ".join(_label(c) for c in conds) + " |",
              "|---|" + "---:|" * len(conds)]
        for name, e in evals.items():
            m = e["metrics"]
            n0 = next(iter(m.values()))["n"] if m else 0
            rows = [(_method_label(name, e), m, False)]
            if any("trusted" in v for v in m.values()):
                # the same estimates, less those the estimator flagged itself
                rows.append((f"{_method_label(name, e)}, trusted only",
                             {c: v["trusted"] for c, v in m.items() if "trusted" in v}, True))
            for label, mm, always_n in rows:
                cells = []
                for c in conds:
                    v = mm.get(c)
                    if v is None:
                        cells.append("—")
                        continue
                    val = v.get(key, math.nan)
                    if not math.isfinite(val):
                        cell = "—"
                    elif fmt is None:
                        cell = f"{_f(val)} [{_f(v['bias_m'], True)}]"
                    else:
                        cell = f"{val:.1f}"
                    if always_n or v["n"] != n0:
                        cell += f" (n={v['n']})"
                    cells.append(cell)
                L.append(f"| {label} | " + " | ".join(cells) + " |")
        L.append("")
    if stages:
        skipped = {k: v["status"] for k, v in stages.items()
                   if isinstance(v, dict) and str(v.get("status", "")).startswith("skipped")}
        if skipped:
            L += ["Not run: " + "; ".join(f"`{k}` {v}" for k, v in skipped.items()), ""]
    L += ["## What beats the constant baseline", ""]
    const = evals.get("constant")
    if not const or not conds:
        return L + ["The constant baseline was not evaluated.", ""]
    cm = const["metrics"]
    L.append("The constant baseline (always the training-set mean altitude) scores MAE "
             + ", ".join(f"{_f(cm[c]['mae_m'])} m ({_f(cm[c]['rel_mae_pct'])} %) on {_label(c)}"
                         for c in conds[:1] if c in cm)
             + " (the same on every condition: it does not look at the frames). A method "
             "beats it on a condition when the 95 % paired bootstrap interval of the "
             "difference of MAEs over the same test sequences lies wholly below zero, and "
             "is worse when it lies wholly above; otherwise this test split cannot tell them "
             "apart.")
    L.append("")
    for name, judged in baseline_verdicts(evals, errors).items():
        e = evals[name]
        parts = {k: [f"{_label(c)} ({txt})" if txt else _label(c)
                     for c, status, txt in judged if status == k]
                 for k in ("beats", "worse", "tie", "untested", "failed")}
        line = (("**beats it on " + ", ".join(parts["beats"]) + "**") if parts["beats"]
                else "**beats it nowhere**")
        for key, words in (("tie", "no clear difference on"), ("worse", "worse on"),
                           ("untested", "no per-sequence predictions to test on"),
                           ("failed", "no estimate on")):
            if parts[key]:
                line += f"; {words} {', '.join(parts[key])}"
        L.append(f"- {_method_label(name, e)}: {line}.")
    L += ["", "MAE differences are (method − constant) in metres with their 95 % interval. A "
          "model that does not beat the constant has not learnt altitude, whatever its MAE "
          "looks like next to the paper's. The dispersion altimeter measures the waves' "
          "motion from frame to frame: a temporal filter over the whole window (`median`, "
          "`percentile`, `tmf-min`) freezes that motion, so it cannot work on those "
          "conditions.", ""]
    return L


def baseline_verdicts(evals: dict[str, dict[str, Any]],
                      errors: dict[str, dict[str, dict[str, float]]] | None
                      ) -> dict[str, list[tuple[str, str, str]]]:
    """Per method (the constant baseline aside), per test condition: ``(condition, status,
    text)`` with status ``beats``, ``worse``, ``tie`` (the paired bootstrap interval of the
    MAE difference against the constant, :func:`wavealt.evaluation.paired_mae_difference`,
    holds zero), ``untested`` (no per-sequence errors) or ``failed`` (no estimate)."""
    from wavealt.evaluation import paired_mae_difference

    errors = errors or {}
    conds = _ordered_conditions(evals)
    base = errors.get("constant", {})
    cm = evals["constant"]["metrics"]
    out: dict[str, list[tuple[str, str, str]]] = {}
    for name, e in evals.items():
        if name == "constant":
            continue
        judged = []
        for c in conds:
            v = e["metrics"].get(c)
            if v is None or c not in cm:
                continue
            if not math.isfinite(v["mae_m"]) or v["n"] == 0:
                judged.append((c, "failed", ""))
                continue
            mine, theirs = errors.get(name, {}).get(c), base.get(c)
            shared = sorted(set(mine or ()) & set(theirs or ()))
            if len(shared) < 2:
                judged.append((c, "untested", f"{_f(v['mae_m'])} m"))
                continue
            d = paired_mae_difference([mine[k] for k in shared], [theirs[k] for k in shared])
            status = "beats" if d["hi_m"] < 0 else "worse" if d["lo_m"] > 0 else "tie"
            judged.append((c, status, f"{_f(v['mae_m'])} m, {_f(d['diff_m'], True)} "
                                      f"[{_f(d['lo_m'], True)}, {_f(d['hi_m'], True)}] m, "
                                      f"n={d['n']}"))
        out[name] = judged
    return out


def verdict_paragraph(evals: dict[str, dict[str, Any]],
                      errors: dict[str, dict[str, dict[str, float]]] | None) -> list[str]:
    """The report's opening verdict: which methods beat the constant baseline where
    (:func:`baseline_verdicts`), in a few sentences."""
    if "constant" not in evals:
        return []
    L = ["## Verdict", ""]
    for name, judged in baseline_verdicts(evals, errors).items():
        beats = [_label(c) for c, status, _ in judged if status == "beats"]
        worse = [_label(c) for c, status, _ in judged if status == "worse"]
        n_tested = sum(status in ("beats", "worse", "tie") for _, status, _ in judged)
        text = (f"beats the constant baseline on {', '.join(beats)}" if beats
                else "does not beat the constant baseline on any condition")
        if worse:
            text += f", and is worse than it on {', '.join(worse)}"
        L.append(f"- **{_method_label(name, evals[name])}** {text} "
                 f"({n_tested} condition(s) tested, 95 % paired bootstrap).")
    return [*L, ""]


def _deglint_quality_markdown(ds_path: Path) -> list[str]:
    """The measured deglint quality table of the dataset (``deglint_table.md``), if any."""
    table = ds_path / "deglint_table.md"
    if not table.is_file():
        return []
    return ["## Deglint quality (every frame of the dataset vs `clean/`)", "",
            "Written by `wavealt deglint` into `dataset/deglint_table.md`; `glinty` is the "
            "untouched input. `residual` (the paper's eq. (6)) is the glint estimate, not a "
            "clean-frame estimate, so its scores against clean are low by design.", "",
            *table.read_text(encoding="utf-8").rstrip("\n").split("\n"), ""]


_IMG = re.compile(r"!\[([^\]]*)\]\(([^)]+)\)")


def _inline(text: str) -> str:
    t = html.escape(text, quote=False)
    t = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", t)
    return re.sub(r"`([^`]+)`", r"<code>\1</code>", t)


def markdown_to_html(md: str, *, base: Path) -> str:
    """A self-contained HTML page from the report's small markdown subset (headings, tables,
    paragraphs, quotes, code blocks, images embedded as base64 PNG)."""
    body: list[str] = []
    lines = md.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("```"):
            j = i + 1
            while j < len(lines) and not lines[j].startswith("```"):
                j += 1
            body.append("<pre>" + html.escape("\n".join(lines[i + 1:j])) + "</pre>")
            i = j + 1
            continue
        if line.startswith("|"):
            rows = []
            while i < len(lines) and lines[i].startswith("|"):
                rows.append([c.strip() for c in lines[i].strip().strip("|").split("|")])
                i += 1
            head, data = rows[0], [r for r in rows[1:] if not all(set(c) <= set("-:") for c in r)]
            body.append("<table><tr>" + "".join(f"<th>{_inline(c)}</th>" for c in head) + "</tr>"
                        + "".join("<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in r) + "</tr>"
                                  for r in data) + "</table>")
            continue
        m = _IMG.fullmatch(line.strip())
        if m:
            p = base / m.group(2)
            if p.is_file():
                data = base64.b64encode(p.read_bytes()).decode("ascii")
                body.append(f'<figure><img alt="{html.escape(m.group(1))}" '
                            f'src="data:image/png;base64,{data}"></figure>')
        elif line.startswith("#"):
            level = len(line) - len(line.lstrip("#"))
            body.append(f"<h{level}>{_inline(line[level:].strip())}</h{level}>")
        elif line.startswith("> "):
            body.append(f"<blockquote>{_inline(line[2:])}</blockquote>")
        elif line.strip():
            body.append(f"<p>{_inline(line)}</p>")
        i += 1
    style = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}"
             "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
             "padding:3px 8px;text-align:right}td:first-child,th:first-child{text-align:left}"
             "img{max-width:100%}pre{background:#f4f4f4;padding:8px;overflow:auto}"
             "blockquote{background:#fff4d6;border-left:4px solid #e0a000;padding:6px 12px}")
    return ("<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>wavealt reproduce</title>"
            f"<style>{style}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")


__all__ = ["SCALES", "ReproduceScale", "build_report_markdown", "markdown_to_html", "reproduce",
           "side_by_side_markdown", "baseline_verdicts", "verdict_paragraph"]
