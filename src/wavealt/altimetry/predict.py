"""A trained run: frames in, altitude in metres out.

Run folder::

    RUN/config.json    the fully resolved config (+ normalisation statistics, split sizes)
    RUN/last.pt        model, optimizer, scheduler, RNG states, epoch, history (every epoch)
    RUN/best.pt        the weights with the lowest validation MAE so far
    RUN/history.json   per-epoch train loss, validation MAE (m), learning rate, seconds
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import torch

from wavealt.altimetry.cnn import ResNetRegressor, create_model
from wavealt.altimetry.data import TrainConfig, centre_crop, to_model_input
from wavealt.altimetry.device import autocast, prepare_model, resolve_device, to_device

CHECKPOINT_LAST = "last.pt"
CHECKPOINT_BEST = "best.pt"
CONFIG_NAME = "config.json"
HISTORY_NAME = "history.json"


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


__all__ = ["CHECKPOINT_BEST", "CHECKPOINT_LAST", "CONFIG_NAME", "HISTORY_NAME", "AltitudePredictor",
           "load_run"]
