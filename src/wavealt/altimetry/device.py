"""Where the CNN runs: ``--device auto|cpu|cuda[:N]|mps`` resolved once, described for the
run's ``config.json``, and the per-device training settings in one place.

``auto`` takes CUDA, then Apple's MPS, then the CPU. On CUDA the trainer uses bf16 autocast
and channels-last tensors (the tensor cores' formats) and pinned host memory; on the CPU and
MPS it runs float32 exactly as before, so a CPU run gives the same numbers as one made
before devices existed.
"""

from __future__ import annotations

import contextlib
import platform
import re
from typing import Any

import torch

DEVICE_CHOICES = "auto, cpu, cuda, cuda:N or mps"


def _mps_available() -> bool:
    mps = getattr(torch.backends, "mps", None)
    return bool(mps is not None and mps.is_available())


def resolve_device(spec: str = "auto") -> torch.device:
    """The torch device named by ``spec``; a one-line ``ValueError`` when it is unknown or
    not available on this machine."""
    s = str(spec).strip().lower()
    if s == "auto":
        if torch.cuda.is_available():
            return torch.device("cuda", torch.cuda.current_device())
        return torch.device("mps") if _mps_available() else torch.device("cpu")
    if s == "cpu":
        return torch.device("cpu")
    if s == "mps":
        if not _mps_available():
            msg = "--device mps: Apple's MPS is not available on this machine (use auto or cpu)"
            raise ValueError(msg)
        return torch.device("mps")
    m = re.fullmatch(r"cuda(?::(\d+))?", s)
    if m is None:
        msg = f"--device must be {DEVICE_CHOICES}; got {spec!r}"
        raise ValueError(msg)
    if not torch.cuda.is_available():
        msg = (f"--device {spec}: CUDA is not available to this torch {torch.__version__} "
               "(no GPU, or a CPU-only build; use auto or cpu)")
        raise ValueError(msg)
    index = int(m.group(1) or torch.cuda.current_device())
    if index >= torch.cuda.device_count():
        msg = f"--device {spec}: this machine has {torch.cuda.device_count()} CUDA device(s)"
        raise ValueError(msg)
    return torch.device("cuda", index)


def describe_device(device: torch.device) -> dict[str, Any]:
    """What a run's ``config.json`` and report record about ``device``."""
    if device.type == "cuda":
        name = torch.cuda.get_device_name(device)
    elif device.type == "mps":
        name = f"Apple MPS ({platform.machine()})"
    else:
        name = platform.processor() or platform.machine() or "cpu"
    return {"device": str(device), "name": name, "precision": precision(device),
            "torch": torch.__version__}


def precision(device: torch.device) -> str:
    """``bf16-autocast`` on CUDA, ``float32`` elsewhere."""
    return "bf16-autocast" if device.type == "cuda" else "float32"


def autocast(device: torch.device) -> contextlib.AbstractContextManager[Any]:
    """bf16 autocast on CUDA; a no-op elsewhere (float32, unchanged CPU results)."""
    if device.type == "cuda":
        return torch.autocast("cuda", dtype=torch.bfloat16)
    return contextlib.nullcontext()


def to_device(x: torch.Tensor, device: torch.device) -> torch.Tensor:
    """Move a model input to ``device`` (channels-last 4-D on CUDA; untouched on the CPU)."""
    if device.type == "cpu":
        return x
    x = x.to(device, non_blocking=True)
    if device.type == "cuda" and x.ndim == 4:
        x = x.contiguous(memory_format=torch.channels_last)
    return x


def prepare_model(model: torch.nn.Module, device: torch.device) -> torch.nn.Module:
    """``model`` on ``device`` (channels-last on CUDA)."""
    model = model.to(device)
    if device.type == "cuda":
        model = model.to(memory_format=torch.channels_last)
    return model


__all__ = ["DEVICE_CHOICES", "autocast", "describe_device", "precision", "prepare_model",
           "resolve_device", "to_device"]
