"""Training the CNN altimeter (paper §3.2, Table 1) and predicting with a trained run.

Protocol (Table 1): Adam (lr 1e-4), cosine annealing over the epochs, 30 epochs, batch 32,
augmentation by random crop, horizontal/vertical flip and colour jitter; the 70/15/15 split
(seed 42) is the manifest's, *by sequence*: no frame of a validation or test sequence is ever
seen in training.

Frame sampling.  A sequence has ``T`` frames (10 in the paper) of one altitude.  Each epoch
visits every training sequence ``frames_per_sequence`` times, each time with a different frame
drawn without replacement (``frames_per_sequence=0``, the default, means all ``T`` frames).
Frames of one sequence are strongly correlated, so they are not independent samples; but they
do show different wave states (the waves move between frames), which acts like augmentation,
and using all of them matches an image-level reading of the paper's protocol.  Evaluation
predicts every frame of a sequence and reports the mean over frames as the sequence's altitude,
so ``n`` in the metrics is the number of *sequences*, as in the paper's Table 2 (n = 30).

Augmentations keep the altitude signal.  The altitude is carried by the pixel scale of the
wave texture (ground sampling distance ``gsd_m = altitude_m / focal_px``), so the random crop
cuts a ``crop_px`` window *without resizing* (a resize would change the apparent altitude),
flips are scale-free, and the colour jitter changes brightness, contrast and saturation only.
Validation and evaluation use the deterministic centre crop of the same size.

Temporal variant (``temporal=True``, beyond the paper).  The input is the whole sequence: its
``T`` frames converted to grayscale and stacked as ``T`` channels, so the first convolution
sees the wave motion between frames, which carries absolute scale through the dispersion
relation ``omega^2 = g k`` (a single frame of a near power-law spectrum carries little).  Crop,
flip and jitter are the same for every frame of a sample; time reversal is added (waves from
the opposite direction, which the uniform wind direction makes equally likely).

Reproducibility.  Every augmentation draw comes from a NumPy generator seeded by
``(seed, epoch, sample index)`` and the batch order from a torch generator seeded by
``(seed, epoch)``: the stream is independent of worker count and of interruptions, so
``resume`` continues a run exactly.  ``random``, NumPy and torch global states are seeded too,
saved in every checkpoint and restored on resume, and each DataLoader worker is seeded.

The run folder and the predictor are :mod:`wavealt.altimetry.predict`; the data pipeline
(sampling, augmentation, model input) :mod:`wavealt.altimetry.data`.
"""

from __future__ import annotations

import json
import math
import random
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn
from tqdm.auto import tqdm

from wavealt.altimetry.cnn import MIN_INPUT_PX, ResNetRegressor, load_pretrained
from wavealt.altimetry.data import (
    LUMA,
    TrainConfig,
    _collate,
    _derived_seed,
    _seed_worker,
    _TrainItems,
    load_sequences,
    seed_everything,
    set_num_threads,
    to_model_input,
)
from wavealt.altimetry.device import (
    autocast,
    describe_device,
    prepare_model,
    resolve_device,
    to_device,
)
from wavealt.altimetry.distributed import (
    DistContext,
    OrderSampler,
    all_sum,
    barrier,
    context_from_env,
    gather,
    local_threads,
    per_rank_batch,
    shuffled_order,
    start,
    stop,
    sync_buffers,
    wrap,
)
from wavealt.altimetry.predict import (
    CHECKPOINT_BEST,
    CHECKPOINT_LAST,
    CONFIG_NAME,
    HISTORY_NAME,
    AltitudePredictor,
    _build_model,
)
from wavealt.dataset import open_dataset
from wavealt.io import atomic_path, atomic_write_text


# -- training ---------------------------------------------------------------------------
def _atomic_torch_save(obj: Any, path: Path) -> None:
    with atomic_path(path) as tmp:
        torch.save(obj, tmp)


def _write_json(path: Path, obj: Any) -> None:
    atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=True) + "\n")


def _rng_states() -> dict[str, Any]:
    return {"python": random.getstate(), "numpy": np.random.get_state(),
            "torch": torch.get_rng_state()}


def _set_rng_states(s: dict[str, Any]) -> None:
    random.setstate(s["python"])
    np.random.set_state(s["numpy"])
    torch.set_rng_state(s["torch"])


def _stats(frames: np.ndarray, targets: np.ndarray, cfg: TrainConfig) -> dict[str, Any]:
    x = frames.astype(np.float32) / 255.0
    if cfg.temporal:
        g = x @ LUMA
        mean, std = [float(g.mean())], [float(g.std())]
    else:
        mean = [float(v) for v in x.mean(axis=(0, 1, 2, 3))]
        std = [float(v) for v in x.std(axis=(0, 1, 2, 3))]
    std = [max(s, 1e-3) for s in std]
    size = int(frames.shape[2])
    crop = cfg.crop_px if cfg.crop_px is not None else size - size // 8
    if crop > min(frames.shape[2], frames.shape[3]):
        msg = f"crop_px {crop} is larger than the images ({frames.shape[2]}x{frames.shape[3]} px)"
        raise ValueError(msg)
    if crop < MIN_INPUT_PX:
        msg = (f"image size {size} px is too small for the model (crop {crop} px); "
               f"expected a crop of at least {MIN_INPUT_PX} px")
        raise ValueError(msg)
    return {
        "input_mean": mean, "input_std": std,
        "target_mean_m": float(targets.mean()), "target_std_m": float(max(targets.std(), 1e-3)),
        "crop_px": int(crop), "in_channels": int(frames.shape[1]) if cfg.temporal else 3,
        "frames_per_sequence_on_disk": int(frames.shape[1]), "image_px": size,
    }


def _validate(model: ResNetRegressor, frames: np.ndarray, targets: np.ndarray,
              info: dict[str, Any], ctx: DistContext) -> float:
    """Sequence-level validation MAE (m), deterministic centre crop; the sequences are shared
    out over the ranks and their errors gathered in order, so every rank gets the mean one
    process would."""
    pred = AltitudePredictor(model, info)
    mine = {i: abs(pred.predict_sequence(frames[i]) - float(targets[i]))
            for i in range(ctx.rank, len(frames), ctx.world_size)}
    model.train()
    errs: dict[int, float] = {}
    for part in gather(mine, ctx):
        errs.update(part)
    return float(np.mean([errs[i] for i in range(len(frames))]))


def train(dataset: Path | str, out: Path | str, config: TrainConfig | None = None, *,
          resume: bool = False, progress: bool = True, device: str = "auto") -> dict[str, Any]:
    """Train the altitude regressor on ``dataset`` into run folder ``out``.

    Parameters
    ----------
    dataset : path or str
        A wavealt dataset holding ``config.condition``: a folder, or shards at a path or an
        fsspec URL (read as a stream, each shard once).
    out : path
        Run folder (created).  It must not hold a run unless ``resume``.
    config : TrainConfig, optional
        Defaults: paper Table 1.
    resume : bool
        Continue the run in ``out`` from its last finished epoch (the config must match; only
        ``epochs`` may differ, to extend a finished run).  A run with no checkpoint starts fresh.
    progress : bool
        Show a progress bar with the training loss and the validation MAE.
    device : str
        ``auto`` (CUDA, then MPS, then CPU), ``cpu``, ``cuda[:N]`` or ``mps``; recorded in
        ``config.json``. Not part of the config: a run may resume on another device.

    Under ``torchrun`` (``WORLD_SIZE`` > 1) the processes train one model with DDP
    (:mod:`wavealt.altimetry.distributed`): each takes ``batch_size / WORLD_SIZE`` samples
    of every batch, rank 0 writes the run folder and shows progress, and each returns the
    same result.

    Returns
    -------
    dict
        ``{"best_epoch", "best_val_mae_m", "epochs", "history", "seconds", "rank"}``.
    """
    cfg = config or TrainConfig()
    ctx = context_from_env()
    dev = start(ctx, resolve_device(device))
    try:
        res = _train(dataset, Path(out), cfg, resume=resume, progress=progress and ctx.is_main,
                     dev=dev, ctx=ctx)
        # The ranks leave the group together (destroying it is collective) once rank 0 has
        # written the run.  The abort some gloo workers met at exit came later, in the
        # interpreter's teardown; the command line's workers skip it (cli/pipeline.py).
        barrier(ctx)
        return res
    finally:
        stop(ctx)


def _train(dataset: Path | str, out: Path, cfg: TrainConfig, *, resume: bool, progress: bool,
           dev: torch.device, ctx: DistContext) -> dict[str, Any]:
    ds = open_dataset(dataset)
    ds.require_condition(cfg.condition)
    rank_batch = per_rank_batch(cfg.batch_size, ctx)
    last_path = out / CHECKPOINT_LAST
    if last_path.is_file() and not resume:
        msg = f"run folder {out} already holds a training run; continue it with --resume or use a new folder"
        raise ValueError(msg)
    train_recs, val_recs = ds.split("train"), ds.split("val")
    if not train_recs or not val_recs:
        msg = (f"dataset {ds.root} needs train and val sequences; got {len(train_recs)} train, "
               f"{len(val_recs)} val")
        raise ValueError(msg)
    ids_train = {r.sequence_id for r in train_recs}
    if ids_train & {r.sequence_id for r in val_recs + ds.split("test")}:
        msg = "split leakage: a sequence is in train and in val/test"
        raise ValueError(msg)

    n_threads = set_num_threads(cfg.threads or local_threads(ctx))
    seed_everything(cfg.seed)
    tr_frames = load_sequences(ds, cfg.condition, train_recs, progress=progress)
    va_frames = load_sequences(ds, cfg.condition, val_recs, progress=progress)
    tr_y = np.array([r.altitude_m for r in train_recs], np.float64)
    va_y = np.array([r.altitude_m for r in val_recs], np.float64)
    stats = _stats(tr_frames, tr_y, cfg)
    root = ds.root if isinstance(ds.root, str) else str(ds.root.resolve())
    info = {"train": cfg.to_dict(), "stats": stats, "dataset": root,
            "dataset_config": ds.config.to_dict(),
            "splits": {"train": len(train_recs), "val": len(val_recs),
                       "test": len(ds.split("test"))},
            "train_sequence_ids": sorted(ids_train), "torch": torch.__version__,
            "threads": n_threads, "objective": f"{cfg.loss} on (altitude_m - mean) / std",
            "device": describe_device(dev), "world_size": ctx.world_size}

    model = _build_model(cfg, stats["in_channels"])
    if cfg.pretrained:
        load_pretrained(model, cfg.pretrained)
    model = prepare_model(model, dev)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=cfg.epochs)
    history: list[dict[str, float]] = []
    best = {"epoch": -1, "val_mae_m": math.inf}
    start_epoch = 0
    seconds = 0.0

    if resume and last_path.is_file():
        old = json.loads((out / CONFIG_NAME).read_text(encoding="utf-8"))
        old_cfg = dict(old["train"])
        new_cfg = cfg.to_dict()
        diff = sorted(k for k in new_cfg if k != "epochs" and old_cfg.get(k) != new_cfg[k])
        if diff:
            msg = f"cannot resume {out}: config differs in {', '.join(diff)}"
            raise ValueError(msg)
        ck = torch.load(last_path, map_location="cpu", weights_only=False)
        model.load_state_dict(ck["model"])
        opt.load_state_dict(ck["optimizer"])
        if old_cfg["epochs"] == cfg.epochs:
            sched.load_state_dict(ck["scheduler"])
        else:  # extending a run: keep the position, stretch the cosine to the new length
            sched.last_epoch = ck["epoch"] + 1
        _set_rng_states(ck["rng"])
        history = ck["history"]
        best = ck["best"]
        start_epoch = ck["epoch"] + 1
        seconds = ck.get("seconds", 0.0)
        stats = old["stats"]
        info["stats"] = stats

    barrier(ctx)  # every rank has read the run folder before rank 0 writes to it
    if ctx.is_main:
        out.mkdir(parents=True, exist_ok=True)
        _write_json(out / CONFIG_NAME, info)
    net = wrap(model, ctx, dev)
    loss_fn = nn.MSELoss() if cfg.loss == "mse" else nn.L1Loss()
    y_norm = (tr_y - stats["target_mean_m"]) / stats["target_std_m"]

    bar = tqdm(range(start_epoch, cfg.epochs), desc=f"train {cfg.model} on {cfg.condition}",
               disable=not progress, unit="epoch", initial=start_epoch, total=cfg.epochs)
    for epoch in bar:
        t0 = time.perf_counter()
        model.train()
        items = _TrainItems(tr_frames, y_norm, cfg, stats["crop_px"], epoch)
        shuffle_seed = _derived_seed(cfg.seed, epoch, 3)
        order: dict[str, Any] = {"shuffle": True,
                                 "generator": torch.Generator().manual_seed(shuffle_seed)}
        per_rank = len(items)
        if ctx.active:  # this rank's share of the same order (see distributed.py)
            order = {"sampler": OrderSampler(items, shuffled_order(len(items), shuffle_seed), ctx)}
            per_rank = len(order["sampler"])
        # BatchNorm cannot train on a last batch of one sample: drop it when it happens.
        loader = torch.utils.data.DataLoader(
            items, batch_size=rank_batch, **order, num_workers=cfg.num_workers,
            worker_init_fn=_seed_worker, collate_fn=_collate,
            drop_last=per_rank % rank_batch == 1, pin_memory=dev.type == "cuda")
        total, count = 0.0, 0
        data_s, t_data = 0.0, time.perf_counter()  # the input pipeline's share of the epoch
        for xb, yb in tqdm(loader, desc=f"epoch {epoch + 1}", disable=not progress,
                           leave=False, unit="batch"):
            inp = to_model_input(xb, temporal=cfg.temporal, mean=stats["input_mean"],
                                 std=stats["input_std"])
            data_s += time.perf_counter() - t_data
            target = to_device(torch.from_numpy(yb), dev)
            with autocast(dev):
                pred = net(to_device(inp, dev))
            loss = loss_fn(pred.float(), target)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(yb)  # also waits for the device
            count += len(yb)
            t_data = time.perf_counter()
        lr = float(opt.param_groups[0]["lr"])
        sched.step()
        total, count = all_sum([total, count], ctx)
        count = int(count)
        sync_buffers(model, ctx)  # BatchNorm's running statistics: rank 0's, on every rank
        val_mae = _validate(model, va_frames, va_y, info, ctx)
        dt = time.perf_counter() - t0
        seconds += dt
        history.append({"epoch": epoch + 1, "train_loss": total / max(count, 1),
                        "val_mae_m": val_mae, "lr": lr, "seconds": dt,
                        "input_seconds": data_s, "images": count})
        improved = val_mae < best["val_mae_m"]
        if improved:
            best = {"epoch": epoch + 1, "val_mae_m": val_mae}
        if ctx.is_main:
            if improved:
                _atomic_torch_save({"model": model.state_dict(), "epoch": epoch + 1,
                                    "val_mae_m": val_mae}, out / CHECKPOINT_BEST)
            _atomic_torch_save({"model": model.state_dict(), "optimizer": opt.state_dict(),
                                "scheduler": sched.state_dict(), "rng": _rng_states(),
                                "epoch": epoch, "history": history, "best": best,
                                "seconds": seconds}, last_path)
            _write_json(out / HISTORY_NAME, history)
        bar.set_postfix(loss=f"{total / max(count, 1):.3f}", val_mae=f"{val_mae:.2f}m",
                        best=f"{best['val_mae_m']:.2f}m")
    bar.close()
    return {"best_epoch": best["epoch"], "best_val_mae_m": best["val_mae_m"],
            "epochs": cfg.epochs, "history": history, "seconds": seconds, "rank": ctx.rank}


__all__ = ["train"]
