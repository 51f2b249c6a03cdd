"""The sizes ``wavealt reproduce`` runs at (``--scale``)."""

from __future__ import annotations

from dataclasses import dataclass

from wavealt.deglint import method_names

DEGLINT_METHODS = tuple(method_names())


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


__all__ = ["DEGLINT_METHODS", "SCALES", "ReproduceScale"]
