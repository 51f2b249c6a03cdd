"""The pipeline's commands: simulate, figures, deglint, train, evaluate, reproduce."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import click

from wavealt.cli.parse import number_range, part

# Each command imports its stage when it runs, not at the top: the whole library imports in
# 2.7 s (torch alone 1.8 s), `wavealt --help` in 0.06 s (measured on 2 CPU cores, 2026-11-23).


@click.command(short_help="Generate a paired clean/glinty dataset into OUT.")
@click.argument("out")
@click.option("--preset", default="paper", show_default=True, help="Scenario preset.")
@click.option("--sequences", type=int, default=None, help="Number of sequences (preset's by default).")
@click.option("--frames", type=int, default=None, help="Frames per sequence [preset: 10].")
@click.option("--size", type=int, default=None, help="Image side in pixels [preset: 224].")
@click.option("--fps", type=float, default=None, help="Frame rate [preset: 30].")
@click.option("--fov-deg", type=float, default=None, help="Horizontal field of view [preset: 60].")
@click.option("--seed", type=int, default=None, help="Dataset seed [preset: 42].")
@click.option("--altitude-m", default=None, help="Altitude range LO,HI in metres (max 15).")
@click.option("--wind-speed-mps", default=None, help="Wind speed range LO,HI.")
@click.option("--glint-severity", default=None, help="Glint severity range LO,HI (full-scale units).")
@click.option("--camera-speed-mps", default=None, help="Camera drift speed range LO,HI.")
@click.option("--workers", type=int, default=1, show_default=True, help="Parallel local processes.")
@click.option("--cluster", default=None, metavar="local:N",
              help="Run on a Dask LocalCluster of N worker processes.")
@click.option("--scheduler", default=None, metavar="tcp://HOST:PORT",
              help="Run on an existing Dask cluster (OUT must be shared with its workers).")
@click.option("--format", "fmt", type=click.Choice(["folder", "shards"]), default="folder",
              show_default=True, help="folder: PNG frame folders; shards: WebDataset tar "
              "shards, OUT may then be any fsspec URL (s3://, gs://, ...).")
@click.option("--shard-size", type=int, default=None,
              help="Sequences per tar shard with --format shards [64].")
@click.option("--part", "part_of", default=None, metavar="I/N",
              help="Write only part I of N (a job array; 0 <= I < N).")
@click.option("--save-surface", is_flag=True, help="Also write each sequence's surface ground truth.")
@click.option("--figures/--no-figures", default=True, show_default=True,
              help="Write paper Fig. 2 and Fig. 3 into OUT/figures (a local OUT only).")
def simulate(out: str, preset: str, sequences: int | None, frames: int | None,
             size: int | None, fps: float | None, fov_deg: float | None, seed: int | None,
             altitude_m: str | None, wind_speed_mps: str | None, glint_severity: str | None,
             camera_speed_mps: str | None, workers: int, cluster: str | None,
             scheduler: str | None, fmt: str, shard_size: int | None, part_of: str | None,
             save_surface: bool, figures: bool) -> None:
    """Generate a paired clean/glinty dataset into OUT (a folder; with --format shards, a
    folder or any fsspec URL). A run interrupted resumes where it stopped."""
    from wavealt.dataset import DEFAULT_SHARD_SIZE, simulate_dataset
    from wavealt.dataset.location import is_url
    from wavealt.sim.config import preset_config

    if shard_size is not None and fmt != "shards":
        msg = "--shard-size is for --format shards"
        raise ValueError(msg)
    config = preset_config(
        preset, sequences=sequences, frames=frames, size=size, fps=fps, fov_deg=fov_deg,
        seed=seed, altitude_m=number_range(altitude_m, "altitude-m"),
        wind_speed_mps=number_range(wind_speed_mps, "wind-speed-mps"),
        glint_severity=number_range(glint_severity, "glint-severity"),
        camera_speed_mps=number_range(camera_speed_mps, "camera-speed-mps"))
    if shard_size is None:
        shard_size = DEFAULT_SHARD_SIZE
    simulate_dataset(out, config, workers=workers, cluster=cluster, scheduler=scheduler,
                     format=fmt, shard_size=shard_size, save_surface=save_surface,
                     part=part(part_of))
    click.echo(f"dataset: {out} ({config.sequences} sequences x {config.frames} frames, "
               f"{config.size}x{config.size} px, {fmt})")
    if part_of is not None:
        click.echo(f"part {part_of} done; `wavealt simulate` without --part checks the whole")
    elif figures and is_url(out):
        click.echo(f"figures: skipped for a URL (draw them with `wavealt figures {out} --out DIR`)")
    elif figures:
        from wavealt.plots import dataset_figures
        for p in dataset_figures(out, Path(out) / "figures"):
            click.echo(f"figure: {p}")


@click.command(short_help="Draw the dataset figures (paper Fig. 2 and Fig. 3).")
@click.argument("dataset")
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Folder for the figures [DATASET/figures].")
@click.option("--sequence", "seq_id", default=None, help="Sequence to show [first test sequence].")
def figures(dataset: str, out: Path | None, seq_id: str | None) -> None:
    """Draw the dataset figures (paper Fig. 2 and Fig. 3) of DATASET (a folder or shards)."""
    from wavealt.dataset.location import is_url
    from wavealt.plots import dataset_figures

    if out is None and is_url(dataset):
        msg = f"--out is needed for a dataset at a URL ({dataset})"
        raise ValueError(msg)
    for p in dataset_figures(dataset, out or Path(dataset) / "figures", sequence_id=seq_id):
        click.echo(f"figure: {p}")


@click.command(short_help="Deglint the glinty frames of DATASET, rank the methods.")
@click.argument("dataset")
@click.option("--method", default="tmf", show_default=True,
              help="tmf (paper eq. (6) residual), tmf-min, median, percentile, glint-mask, "
                   "achromatic, or all.")
@click.option("--window", type=int, default=10, show_default=True,
              help="Temporal window w of paper eq. (5), in frames (frame t sees t-w//2..t+w//2).")
@click.option("--figures/--no-figures", default=True, show_default=True,
              help="Write paper Fig. 4 and Fig. 7 into DATASET/figures.")
@click.option("--force", is_flag=True,
              help="Rewrite a condition made earlier with another window.")
def deglint(dataset: str, method: str, window: int, figures: bool, force: bool) -> None:
    """Deglint the glinty frames of DATASET (a folder) and rank the methods against clean/."""
    from wavealt.deglint import condition_name, deglint_dataset, method_names

    methods = method_names() if method == "all" else [method]
    for m in methods:
        condition_name(m)  # unknown names fail before anything is written
    for m in methods:
        cond = deglint_dataset(dataset, method=m, window=window, force=force)
        click.echo(f"condition: {Path(dataset) / cond}")
    folder = Path(dataset)
    table = folder / "deglint_table.md"
    if table.is_file():
        click.echo(table.read_text(encoding="utf-8"), nl=False)
    if figures:
        from wavealt.plots import deglint_figures
        for p in deglint_figures(folder, folder / "figures", window=window):
            click.echo(f"figure: {p}")


@click.command(short_help="Train the CNN altimeter on DATASET (paper Table 1).")
@click.argument("dataset")
@click.option("--out", "run", type=click.Path(path_type=Path), required=True,
              help="Run folder for checkpoints, config.json and history.json.")
@click.option("--condition", default="clean", show_default=True,
              help="Condition to train on (clean, glinty, residual, ...).")
@click.option("--model", default="resnet50", show_default=True,
              help="Registered model: resnet50, resnet18, resnet-small, resnet-tiny.")
@click.option("--epochs", type=int, default=30, show_default=True)
@click.option("--batch-size", type=int, default=32, show_default=True)
@click.option("--lr", type=float, default=1e-4, show_default=True, help="Adam learning rate.")
@click.option("--seed", type=int, default=42, show_default=True)
@click.option("--crop-px", type=int, default=None,
              help="Random/centre crop side, no resize [image size - size // 8].")
@click.option("--frames-per-sequence", type=int, default=0, show_default=True,
              help="Frames drawn per training sequence each epoch (0 = all).")
@click.option("--temporal", is_flag=True, help="Temporal variant: the sequence's frames as channels.")
@click.option("--workers", type=int, default=0, show_default=True, help="DataLoader workers.")
@click.option("--threads", type=int, default=0, show_default=True,
              help="torch threads (0 = every core; 1 is faster for small models on a busy machine).")
@click.option("--pretrained", type=click.Path(path_type=Path), default=None,
              help="Local torchvision-style state dict to start from (nothing is downloaded).")
@click.option("--resume", is_flag=True, help="Continue the run in --out from its last epoch.")
@click.option("--device", default="auto", show_default=True,
              help="auto (CUDA, then MPS, then CPU), cpu, cuda, cuda:N or mps.")
def train(dataset: str, run: Path, condition: str, model: str, epochs: int, batch_size: int,
          lr: float, seed: int, crop_px: int | None, frames_per_sequence: int, temporal: bool,
          workers: int, threads: int, pretrained: Path | None, resume: bool, device: str) -> None:
    """Train the CNN altimeter on DATASET (paper Table 1)."""
    from wavealt.altimetry.data import TrainConfig
    from wavealt.altimetry.distributed import context_from_env
    from wavealt.altimetry.predict import CHECKPOINT_LAST
    from wavealt.altimetry.train import train as train_run

    cfg = TrainConfig(condition=condition, model=model, epochs=epochs, batch_size=batch_size,
                      lr=lr, seed=seed, crop_px=crop_px, frames_per_sequence=frames_per_sequence,
                      temporal=temporal, num_workers=workers, threads=threads,
                      pretrained=str(pretrained) if pretrained else None)
    if resume and not (run / CHECKPOINT_LAST).is_file():
        msg = f"--resume: {run} holds no training run to continue (drop --resume to start one)"
        raise ValueError(msg)
    res = train_run(dataset, run, cfg, resume=resume, device=device)
    if res["rank"] == 0:  # one line from a torchrun of N processes
        click.echo(f"run: {run} (best epoch {res['best_epoch']}, validation MAE "
                   f"{res['best_val_mae_m']:.3f} m)")
    if context_from_env().active:
        # A torchrun worker whose run is written and whose process group is gone ends
        # here, without the interpreter's teardown: there, gloo's transport threads made
        # about 1 exit in 25 abort ("terminate called without an active exception",
        # SIGABRT), failing the whole run after it had finished.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)


@click.command(short_help="Evaluate an altimeter per condition (Table 2, Fig. 5, 6).")
@click.argument("dataset")
@click.option("--estimator", required=True,
              help="cnn:RUN, constant:RUN, constant (dataset train mean), dispersion (blind), "
                   "dispersion-aided (the manifest's camera velocity, exact) or "
                   "dispersion-prior[:SIGMA] (the manifest's camera velocity give or take SIGMA "
                   "m/s, default 1); a further :gravity or :gravity-capillary forces the "
                   "dispersion relation.")
@click.option("--conditions", default=None,
              help="Comma-separated test conditions [all conditions of the dataset].")
@click.option("--split", default="test", show_default=True, help="Split to evaluate.")
@click.option("--out", type=click.Path(path_type=Path), required=True,
              help="Folder for metrics.json, table.md, predictions.csv and Fig. 5/6.")
@click.option("--device", default="auto", show_default=True,
              help="auto (CUDA, then MPS, then CPU), cpu, cuda, cuda:N or mps.")
@click.option("--force", is_flag=True, help="Replace the results already in --out.")
def evaluate(dataset: str, estimator: str, conditions: str | None, split: str, out: Path,
             device: str, force: bool) -> None:
    """Evaluate an altimeter on DATASET per condition (paper Table 2, Fig. 5, Fig. 6)."""
    from wavealt.evaluation import evaluate as run_eval

    conds = [c.strip() for c in conditions.split(",") if c.strip()] if conditions else None
    res = run_eval(dataset, estimator, conditions=conds, out=out, split=split, device=device,
                   force=force)
    click.echo((out / "table.md").read_text(encoding="utf-8").rstrip())
    click.echo(f"metrics: {out / 'metrics.json'} ({len(res.metrics)} conditions)")


@click.command(short_help="Run the paper end to end into OUT, with its report.")
@click.argument("out", type=click.Path(path_type=Path))
@click.option("--scale", type=click.Choice(["quick", "paper"]), default="quick",
              show_default=True, help="quick: small images, small model (~10 min on 2 cores); "
              "paper: the paper's protocol.")
@click.option("--device", default="auto", show_default=True,
              help="auto (CUDA, then MPS, then CPU), cpu, cuda, cuda:N or mps.")
@click.option("--train", "train_runs", default=None, metavar="RUNS",
              help="CNN runs to train, comma-separated (clean, glinty, residual, tmf-min, "
                   "temporal-clean, temporal-glinty), or all [all]; 'clean' alone is the paper's own "
                   "experiment, the CPU-sized paper run.")
@click.option("--threads", type=int, default=None,
              help="torch threads (0 = every core) [the scale's: quick 1, paper 0].")
def reproduce(out: Path, scale: str, device: str, train_runs: str | None,
              threads: int | None) -> None:
    """Run the paper end to end into OUT and write report.md / report.html (resumable)."""
    from wavealt.report import reproduce as run_reproduce

    names = [c.strip() for c in train_runs.split(",") if c.strip()] if train_runs else None
    paths = run_reproduce(out, scale=scale, device=device, train_conditions=names,
                          threads=threads)
    for p in paths:
        click.echo(f"report: {p}")


COMMANDS = (simulate, figures, deglint, train, evaluate, reproduce)
