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

Run folder::

    RUN/config.json    the fully resolved config (+ normalisation statistics, split sizes)
    RUN/last.pt        model, optimizer, scheduler, RNG states, epoch, history (every epoch)
    RUN/best.pt        the weights with the lowest validation MAE so far
    RUN/history.json   per-epoch train loss, validation MAE (m), learning rate, seconds
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import random
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn
from tqdm.auto import tqdm

from wavealt._checks import check_known_keys
from wavealt.altimetry.cnn import (
    MIN_INPUT_PX,
    ResNetRegressor,
    create_model,
    load_pretrained,
)
from wavealt.altimetry.device import (
    autocast,
    describe_device,
    prepare_model,
    resolve_device,
    to_device,
)
from wavealt.io import atomic_path, atomic_write_text

CHECKPOINT_LAST = "last.pt"
CHECKPOINT_BEST = "best.pt"
CONFIG_NAME = "config.json"
HISTORY_NAME = "history.json"
#: ITU-R BT.601 luma weights, for the temporal variant's grayscale frames.
LUMA = np.array([0.299, 0.587, 0.114], dtype=np.float32)


def set_num_threads(threads: int = 0) -> int:
    """Set torch's intra-op threads: ``threads``, or every CPU core this process may run on
    when 0; return the count.

    On a shared machine fewer threads than cores can be much faster: torch's threads wait on
    each other at every operation, so one descheduled thread stalls them all (measured: a
    0.5 M-parameter ResNet at 64 px took 30 s per epoch on 2 threads beside one busy process,
    0.5 s alone).
    """
    if threads:
        n = int(threads)
    else:
        try:
            n = len(os.sched_getaffinity(0))
        except AttributeError:  # not on Linux
            n = os.cpu_count() or 1
    torch.set_num_threads(max(1, n))
    return n


def seed_everything(seed: int) -> None:
    """Seed ``random``, NumPy's global generator and torch."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)


def _seed_worker(worker_id: int) -> None:
    # torch seeds each worker's torch RNG from the loader's generator; pass it on to the
    # others (timm / PyTorch reproducibility notes).
    s = torch.initial_seed() % 2**32
    random.seed(s)
    np.random.seed(s)


def _derived_seed(*parts: int) -> int:
    return int(np.random.SeedSequence([int(p) for p in parts]).generate_state(1)[0])


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run (written as RUN/config.json).

    Defaults are the paper's Table 1.  ``crop_px=None`` means ``size - size // 8`` of the
    dataset's images (196 px at 224).  ``frames_per_sequence=0`` uses every frame each epoch.
    ``threads=0`` gives torch every CPU core (see :func:`set_num_threads`).
    """

    condition: str = "clean"
    model: str = "resnet50"
    epochs: int = 30
    batch_size: int = 32
    lr: float = 1e-4
    weight_decay: float = 0.0
    seed: int = 42
    crop_px: int | None = None
    frames_per_sequence: int = 0
    temporal: bool = False
    jitter: float = 0.2
    loss: str = "mse"
    num_workers: int = 0
    pretrained: str | None = None
    threads: int = 0

    def __post_init__(self) -> None:
        ints = {"epochs": 1, "batch_size": 1, "frames_per_sequence": 0, "num_workers": 0,
                "threads": 0}
        for name, low in ints.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < low:
                msg = f"{name} must be an integer >= {low}; got {v!r}"
                raise ValueError(msg)
        if not (isinstance(self.lr, (int, float)) and math.isfinite(self.lr) and self.lr > 0):
            msg = f"lr must be a positive number; got {self.lr!r}"
            raise ValueError(msg)
        if not (0.0 <= self.jitter < 1.0):
            msg = f"jitter must be in [0, 1); got {self.jitter!r}"
            raise ValueError(msg)
        if self.crop_px is not None and (not isinstance(self.crop_px, int)
                                         or self.crop_px < MIN_INPUT_PX):
            msg = f"crop_px must be an integer >= {MIN_INPUT_PX}; got {self.crop_px!r}"
            raise ValueError(msg)
        if self.loss not in ("mse", "l1"):
            msg = f"loss must be 'mse' or 'l1'; got {self.loss!r}"
            raise ValueError(msg)
        create_model(self.model, in_channels=1)  # validates the name early

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TrainConfig:
        """Build from a dict; unknown keys are an error."""
        check_known_keys(d, {f.name for f in dataclasses.fields(cls)}, what="train config")
        return cls(**d)


# -- data -------------------------------------------------------------------------------
def load_sequences(dataset: Any, condition: str, records: Sequence[Any], *,
                   progress: bool = False) -> np.ndarray:
    """Frames of ``records`` in ``condition`` as uint8 ``(N, T, H, W, 3)`` (PNG values exact)."""
    dataset.require_condition(condition)
    out = []
    for r in tqdm(records, desc=f"load {condition}", disable=not progress, leave=False):
        f = dataset.read_frames(condition, r.sequence_id)
        out.append(np.round(f * 255.0).astype(np.uint8))
    shapes = {a.shape for a in out}
    if len(shapes) != 1:
        msg = f"sequences of {condition!r} differ in shape: {sorted(shapes)}"
        raise ValueError(msg)
    return np.stack(out)


def to_model_input(batch: np.ndarray, *, temporal: bool, mean: Sequence[float],
                   std: Sequence[float]) -> torch.Tensor:
    """The one place frames become torch input.

    Parameters
    ----------
    batch : ndarray
        float32 in [0, 1]: ``(B, H, W, 3)`` frames, or ``(B, T, H, W, 3)`` sequences when
        ``temporal`` (their ``T`` grayscale frames become the channels).
    temporal : bool
        Stack frames as channels.
    mean, std : sequence of float
        Per-channel normalisation (3 values, or 1 for temporal grayscale).

    Returns
    -------
    torch.Tensor
        ``(B, C, H, W)`` float32, C = 3 or T.
    """
    batch = np.asarray(batch, dtype=np.float32)
    if temporal:
        if batch.ndim != 5 or batch.shape[-1] != 3:
            msg = f"temporal batch must be (B, T, H, W, 3); got shape {batch.shape}"
            raise ValueError(msg)
        x = batch @ LUMA  # (B, T, H, W)
        x = (x - np.float32(mean[0])) / np.float32(std[0])
        return torch.from_numpy(np.ascontiguousarray(x))
    if batch.ndim != 4 or batch.shape[-1] != 3:
        msg = f"frame batch must be (B, H, W, 3); got shape {batch.shape}"
        raise ValueError(msg)
    x = (batch - np.asarray(mean, np.float32)) / np.asarray(std, np.float32)
    return torch.from_numpy(np.ascontiguousarray(x.transpose(0, 3, 1, 2)))


def centre_crop(frames: np.ndarray, crop_px: int) -> np.ndarray:
    """Centre ``crop_px`` window of ``(..., H, W, 3)``, no resize (keeps the pixel scale)."""
    h, w = frames.shape[-3], frames.shape[-2]
    c = min(crop_px, h, w)
    y0, x0 = (h - c) // 2, (w - c) // 2
    return frames[..., y0:y0 + c, x0:x0 + c, :]


def augment(frames: np.ndarray, crop_px: int, jitter: float, rng: np.random.Generator, *,
            time_reverse: bool = False) -> np.ndarray:
    """Random crop (no resize), H/V flips and colour jitter of ``(..., H, W, 3)`` uint8/float.

    One draw applies to all leading (time) axes alike.  Returns float32 in [0, 1].
    """
    h, w = frames.shape[-3], frames.shape[-2]
    c = min(crop_px, h, w)
    y0 = int(rng.integers(0, h - c + 1))
    x0 = int(rng.integers(0, w - c + 1))
    x = frames[..., y0:y0 + c, x0:x0 + c, :].astype(np.float32)
    if frames.dtype == np.uint8:
        x /= 255.0
    if rng.random() < 0.5:
        x = x[..., :, ::-1, :]
    if rng.random() < 0.5:
        x = x[..., ::-1, :, :]
    if time_reverse and rng.random() < 0.5:
        x = x[::-1]
    if jitter > 0:
        b, k, s = 1.0 + jitter * (2.0 * rng.random(3) - 1.0)
        x = x * np.float32(b)
        gray = (x @ LUMA)[..., None]
        x = gray + (x - gray) * np.float32(s)
        m = x.mean(axis=(-3, -2, -1), keepdims=True)
        x = m + (x - m) * np.float32(k)
    return np.clip(x, 0.0, 1.0).astype(np.float32)


class _TrainItems(torch.utils.data.Dataset):
    """One epoch of training samples; sample ``i`` is a pure function of (seed, epoch, i)."""

    def __init__(self, frames: np.ndarray, targets: np.ndarray, cfg: TrainConfig,
                 crop_px: int, epoch: int) -> None:
        self.frames = frames
        self.targets = targets
        self.cfg = cfg
        self.crop_px = crop_px
        self.epoch = epoch
        n, t = frames.shape[:2]
        if cfg.temporal:
            self.items = [(s, -1) for s in range(n)]
        elif cfg.frames_per_sequence == 0 or cfg.frames_per_sequence >= t:
            self.items = [(s, k) for s in range(n) for k in range(t)]
        else:
            rng = np.random.default_rng(_derived_seed(cfg.seed, epoch, 1))
            self.items = [(s, int(k)) for s in range(n)
                          for k in rng.choice(t, cfg.frames_per_sequence, replace=False)]

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, i: int) -> tuple[np.ndarray, np.float32]:
        s, k = self.items[i]
        rng = np.random.default_rng(_derived_seed(self.cfg.seed, self.epoch, 2, i))
        src = self.frames[s] if k < 0 else self.frames[s, k]
        x = augment(src, self.crop_px, self.cfg.jitter, rng, time_reverse=self.cfg.temporal)
        return x, np.float32(self.targets[s])


def _collate(batch: list[tuple[np.ndarray, np.float32]]) -> tuple[np.ndarray, np.ndarray]:
    return np.stack([b[0] for b in batch]), np.array([b[1] for b in batch], np.float32)


# -- the predictor ----------------------------------------------------------------------
class AltitudePredictor:
    """A trained model with its normalisation: frames in, altitude in metres out.

    Parameters
    ----------
    model : ResNetRegressor
    info : dict
        The run's ``config.json`` content (train config + statistics).
    """

    def __init__(self, model: ResNetRegressor, info: dict[str, Any]) -> None:
        self.model = model.eval()
        self.device = next(model.parameters()).device
        self.info = info
        self.config = TrainConfig.from_dict(info["train"])
        self.stats = info["stats"]

    @torch.no_grad()
    def predict_sequence(self, frames: np.ndarray, *, batch_size: int = 64) -> float:
        """Altitude (m) of one sequence ``(T, H, W, 3)`` float in [0, 1] (or uint8).

        Per-frame model: the mean over the centre-cropped frames; temporal model: one pass
        over the stacked sequence (its frame count must be the training one).
        """
        frames = np.asarray(frames)
        if frames.ndim != 4 or frames.shape[-1] != 3:
            msg = f"frames must be (T, H, W, 3); got shape {frames.shape}"
            raise ValueError(msg)
        if frames.dtype == np.uint8:
            frames = frames.astype(np.float32) / 255.0
        x = centre_crop(frames, self.stats["crop_px"])
        if self.config.temporal:
            t_need = self.model.in_channels
            if x.shape[0] != t_need:
                msg = f"the temporal model needs {t_need} frames per sequence; got {x.shape[0]}"
                raise ValueError(msg)
            out = self._forward(x[None])
        else:
            out = torch.cat([self._forward(x[i:i + batch_size])
                             for i in range(0, x.shape[0], batch_size)])
        return float(out.mean())

    def _forward(self, batch: np.ndarray) -> torch.Tensor:
        inp = to_model_input(batch, temporal=self.config.temporal, mean=self.stats["input_mean"],
                             std=self.stats["input_std"])
        with autocast(self.device):
            y = self.model(to_device(inp, self.device)).float().cpu()
        return y * self.stats["target_std_m"] + self.stats["target_mean_m"]


def load_run(run: Path | str, *, which: str = "best", device: str = "cpu") -> AltitudePredictor:
    """The predictor of a training run folder (``best`` or ``last`` checkpoint) on ``device``
    (see :func:`wavealt.altimetry.device.resolve_device`)."""
    run = Path(run)
    name = {"best": CHECKPOINT_BEST, "last": CHECKPOINT_LAST}.get(which)
    if name is None:
        msg = f"which must be 'best' or 'last'; got {which!r}"
        raise ValueError(msg)
    dev = resolve_device(device)
    ckpt_path = run / name
    cfg_path = run / CONFIG_NAME
    if not ckpt_path.is_file() or not cfg_path.is_file():
        msg = f"run folder {run} has no {name} / {CONFIG_NAME} (train it with `wavealt train`)"
        raise FileNotFoundError(msg)
    info = json.loads(cfg_path.read_text(encoding="utf-8"))
    model = _build_model(TrainConfig.from_dict(info["train"]), info["stats"]["in_channels"])
    state = torch.load(ckpt_path, map_location="cpu", weights_only=False)
    model.load_state_dict(state["model"])
    return AltitudePredictor(prepare_model(model, dev), info)


def _build_model(cfg: TrainConfig, in_channels: int) -> ResNetRegressor:
    return create_model(cfg.model, in_channels=in_channels)


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
              info: dict[str, Any]) -> float:
    """Sequence-level validation MAE (m), deterministic centre crop."""
    pred = AltitudePredictor(model, info)
    errs = [abs(pred.predict_sequence(frames[i]) - float(targets[i])) for i in range(len(frames))]
    model.train()
    return float(np.mean(errs))


def train(dataset: Path | str, out: Path | str, config: TrainConfig | None = None, *,
          resume: bool = False, progress: bool = True, device: str = "auto") -> dict[str, Any]:
    """Train the altitude regressor on ``dataset`` into run folder ``out``.

    Parameters
    ----------
    dataset : path
        A wavealt dataset folder holding ``config.condition``.
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

    Returns
    -------
    dict
        ``{"best_epoch", "best_val_mae_m", "epochs", "history", "seconds"}``.
    """
    from wavealt.dataset import Dataset

    cfg = config or TrainConfig()
    dev = resolve_device(device)
    ds = Dataset(dataset)
    ds.require_condition(cfg.condition)
    out = Path(out)
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

    n_threads = set_num_threads(cfg.threads)
    seed_everything(cfg.seed)
    tr_frames = load_sequences(ds, cfg.condition, train_recs, progress=progress)
    va_frames = load_sequences(ds, cfg.condition, val_recs, progress=progress)
    tr_y = np.array([r.altitude_m for r in train_recs], np.float64)
    va_y = np.array([r.altitude_m for r in val_recs], np.float64)
    stats = _stats(tr_frames, tr_y, cfg)
    info = {"train": cfg.to_dict(), "stats": stats, "dataset": str(ds.root.resolve()),
            "dataset_config": ds.config.to_dict(),
            "splits": {"train": len(train_recs), "val": len(val_recs),
                       "test": len(ds.split("test"))},
            "train_sequence_ids": sorted(ids_train), "torch": torch.__version__,
            "threads": n_threads, "objective": f"{cfg.loss} on (altitude_m - mean) / std",
            "device": describe_device(dev)}

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

    out.mkdir(parents=True, exist_ok=True)
    _write_json(out / CONFIG_NAME, info)
    loss_fn = nn.MSELoss() if cfg.loss == "mse" else nn.L1Loss()
    y_norm = (tr_y - stats["target_mean_m"]) / stats["target_std_m"]

    bar = tqdm(range(start_epoch, cfg.epochs), desc=f"train {cfg.model} on {cfg.condition}",
               disable=not progress, unit="epoch", initial=start_epoch, total=cfg.epochs)
    for epoch in bar:
        t0 = time.perf_counter()
        model.train()
        items = _TrainItems(tr_frames, y_norm, cfg, stats["crop_px"], epoch)
        gen = torch.Generator().manual_seed(_derived_seed(cfg.seed, epoch, 3))
        # BatchNorm cannot train on a last batch of one sample: drop it when it happens.
        drop_last = len(items) % cfg.batch_size == 1
        loader = torch.utils.data.DataLoader(
            items, batch_size=cfg.batch_size, shuffle=True, generator=gen,
            num_workers=cfg.num_workers, worker_init_fn=_seed_worker, collate_fn=_collate,
            drop_last=drop_last, pin_memory=dev.type == "cuda")
        total, count = 0.0, 0
        data_s, t_data = 0.0, time.perf_counter()  # the input pipeline's share of the epoch
        for xb, yb in tqdm(loader, desc=f"epoch {epoch + 1}", disable=not progress,
                           leave=False, unit="batch"):
            inp = to_model_input(xb, temporal=cfg.temporal, mean=stats["input_mean"],
                                 std=stats["input_std"])
            data_s += time.perf_counter() - t_data
            target = to_device(torch.from_numpy(yb), dev)
            with autocast(dev):
                pred = model(to_device(inp, dev))
            loss = loss_fn(pred.float(), target)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(yb)  # also waits for the device
            count += len(yb)
            t_data = time.perf_counter()
        lr = float(opt.param_groups[0]["lr"])
        sched.step()
        val_mae = _validate(model, va_frames, va_y, info)
        dt = time.perf_counter() - t0
        seconds += dt
        history.append({"epoch": epoch + 1, "train_loss": total / max(count, 1),
                        "val_mae_m": val_mae, "lr": lr, "seconds": dt,
                        "input_seconds": data_s, "images": count})
        if val_mae < best["val_mae_m"]:
            best = {"epoch": epoch + 1, "val_mae_m": val_mae}
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
            "epochs": cfg.epochs, "history": history, "seconds": seconds}


__all__ = ["AltitudePredictor", "TrainConfig", "augment", "centre_crop", "load_run",
           "load_sequences", "seed_everything", "set_num_threads", "to_model_input", "train"]
