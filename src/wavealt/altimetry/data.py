"""The CNN's data pipeline (paper §3.2, Table 1): its config, seeding, sequence loading,
augmentation and the model input; see :mod:`wavealt.altimetry.train` for the protocol."""

from __future__ import annotations

import dataclasses
import math
import os
import random
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from tqdm.auto import tqdm

from wavealt._checks import check_integer, check_known_keys
from wavealt.altimetry.cnn import MIN_INPUT_PX, create_model

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
            object.__setattr__(self, name, check_integer(name, getattr(self, name), low=low))
        if not (isinstance(self.lr, (int, float)) and math.isfinite(self.lr) and self.lr > 0):
            msg = f"lr must be a positive number; got {self.lr!r}"
            raise ValueError(msg)
        if not (0.0 <= self.jitter < 1.0):
            msg = f"jitter must be in [0, 1); got {self.jitter!r}"
            raise ValueError(msg)
        if self.crop_px is not None:
            object.__setattr__(self, "crop_px",
                               check_integer("crop_px", self.crop_px, low=MIN_INPUT_PX))
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
    """Frames of ``records`` in ``condition`` as uint8 ``(N, T, H, W, 3)`` (PNG values exact),
    in the order of ``records``; a sharded dataset is read as a stream, each shard once."""
    dataset.require_condition(condition)
    got = {}
    for r, f in tqdm(dataset.iter_sequences(condition, records), total=len(records),
                     desc=f"load {condition}", disable=not progress, leave=False):
        got[r.sequence_id] = f
    out = [got[r.sequence_id] for r in records]
    shapes = {a.shape for a in out}
    if len(shapes) > 1:
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


__all__ = ["LUMA", "TrainConfig", "augment", "centre_crop", "load_sequences", "seed_everything",
           "set_num_threads", "to_model_input"]
