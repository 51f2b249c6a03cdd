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

import dataclasses
import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from wavealt._checks import check_choice
from wavealt.altimetry.data import TrainConfig, set_num_threads
from wavealt.altimetry.device import resolve_device
from wavealt.altimetry.train import train
from wavealt.dataset import Dataset, simulate_dataset
from wavealt.deglint import deglint_dataset
from wavealt.evaluation import evaluate
from wavealt.io import atomic_write_text
from wavealt.plots import dataset_figures, deglint_figures
from wavealt.report.html import markdown_to_html
from wavealt.report.markdown import build_report_markdown
from wavealt.report.scales import SCALES, ReproduceScale
from wavealt.sim.config import preset_config

#: What a ``reproduce`` folder was made with: a re-run resumes it only at the same scale.
RUN_FILE = "reproduce.json"


def _check_out(out: Path, sc: ReproduceScale) -> None:
    """The overwrite rule: ``out`` is new, or a ``reproduce`` run of the same scale (resumed);
    anything else is refused before any work."""
    if out.exists() and not out.is_dir():
        msg = f"OUT {out} is a file; give a folder"
        raise ValueError(msg)
    run_file = out / RUN_FILE
    if run_file.is_file():
        try:
            scale = json.loads(run_file.read_text(encoding="utf-8")).get("scale")
        except json.JSONDecodeError:
            scale = None
        if scale != sc.name:
            msg = (f"OUT {out} holds a `reproduce --scale {scale}` run; resume it with that "
                   f"scale or give another folder for --scale {sc.name}")
            raise ValueError(msg)
    elif out.is_dir() and any(out.iterdir()) and not (out / "stages.json").is_file():
        msg = f"OUT {out} is a non-empty folder that holds no reproduce run; give another folder"
        raise ValueError(msg)


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
    check_choice("scale", scale, SCALES)
    sc = SCALES[scale]
    resolve_device(device)  # an unavailable device fails before anything is written
    runs_all = [*sc.train_conditions, *(f"temporal-{c}" for c in sc.temporal_conditions)]
    # "all" (what the command line's help shows as the default) names every run
    wanted = (runs_all if not train_conditions or list(train_conditions) == ["all"]
              else list(train_conditions))
    for name in wanted:
        check_choice("train condition", name, runs_all)
    if threads is not None:
        sc = dataclasses.replace(sc, threads=int(threads))
    out = Path(out)
    _check_out(out, sc)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / RUN_FILE, json.dumps({"scale": sc.name}, indent=2) + "\n")
    stages = _Stages(out)
    ds_path = out / "dataset"
    t_start = time.perf_counter()

    def simulate() -> dict[str, Any]:
        cfg = preset_config("paper", sequences=sc.sequences, size=sc.size, frames=sc.frames)
        simulate_dataset(ds_path, cfg, progress=progress)
        return {"sequences": sc.sequences}

    stages.run("simulate", simulate)

    def figures_dataset() -> list[str]:
        return [str(p) for p in dataset_figures(ds_path, out / "figures")]

    stages.run("figures:dataset", figures_dataset)

    for method in sc.deglint_methods:
        def deglint(method: str = method) -> dict[str, Any]:
            cond = deglint_dataset(ds_path, method=method, window=sc.frames, progress=progress)
            return {"condition": cond}

        stages.run(f"deglint:{method}", deglint)
    stages.run("figures:deglint", lambda: _deglint_figures(ds_path, out / "figures", sc.frames))

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

    set_num_threads(sc.threads)  # inference too (load_run does not set threads)
    evals: dict[str, dict[str, Any]] = {}
    specs = {f"cnn-{n}": f"cnn:{p}" for n, p in runs.items()}
    specs["dispersion"] = "dispersion"
    specs["dispersion-aided"] = "dispersion-aided"
    specs["constant"] = "constant"
    for name, spec in specs.items():
        def eval_one(spec: str = spec, name: str = name) -> dict[str, Any]:
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
    atomic_write_text(out / "report.md", md)
    atomic_write_text(out / "report.html", markdown_to_html(md, base=out))
    return [out / "report.md", out / "report.html"]


def _deglint_figures(ds_path: Path, fig_dir: Path, window: int) -> list[str]:
    """Fig. 4 (TMF decomposition) and Fig. 7 (pixel trace) of the first test sequence."""
    return [str(p) for p in deglint_figures(ds_path, fig_dir, window=window)]


__all__ = ["reproduce"]
