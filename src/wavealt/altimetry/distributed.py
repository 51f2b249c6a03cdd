"""Training on several processes with DistributedDataParallel, as ``torchrun`` starts them.

``torchrun --nproc_per_node N -m wavealt train …`` runs N copies of the trainer with
``RANK``, ``WORLD_SIZE``, ``LOCAL_RANK`` and ``LOCAL_WORLD_SIZE`` set; the trainer reads them
here (:func:`context_from_env`), joins the process group (``gloo`` on the CPU, ``nccl`` on
CUDA, one GPU per process: ``cuda:LOCAL_RANK``) and wraps the model in DDP.

The batches are those of one process. Each epoch's sample order is the single-process one
(:func:`shuffled_order`) and rank r takes every W-th sample of it (:class:`OrderSampler`,
a :class:`~torch.utils.data.distributed.DistributedSampler`), so with ``--batch-size B``
and W processes of ``B / W`` samples each, global batch j holds the samples of the
single-process batch j, and DDP's mean of the W gradients is the gradient of the batch
mean. BatchNorm normalises over the global batch (``SyncBatchNorm`` on CUDA,
:class:`GlobalBatchNorm2d` on the CPU). What still differs from one process: the order of
floating-point sums, and an epoch whose length W does not divide, which the sampler pads
with up to W - 1 repeated samples. Validation is split over the ranks and gathered, so
every rank keeps the same history; rank 0 alone writes the run folder and shows progress.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import torch
import torch.distributed as dist
from tqdm.auto import tqdm

_ENV = ("RANK", "WORLD_SIZE", "LOCAL_RANK", "LOCAL_WORLD_SIZE")


@dataclass(frozen=True)
class DistContext:
    """This process's place among the ``world_size`` training processes."""

    rank: int = 0
    world_size: int = 1
    local_rank: int = 0
    local_world_size: int = 1

    @property
    def active(self) -> bool:
        return self.world_size > 1

    @property
    def is_main(self) -> bool:
        return self.rank == 0


def context_from_env(environ: Mapping[str, str] | None = None) -> DistContext:
    """The context torchrun's variables describe; one process when ``WORLD_SIZE`` is unset."""
    env = os.environ if environ is None else environ
    if "WORLD_SIZE" not in env:
        return DistContext()
    try:
        vals = {k: int(env.get(k, "0" if k != "LOCAL_WORLD_SIZE" else env["WORLD_SIZE"]))
                for k in _ENV}
    except ValueError:
        got = ", ".join(f"{k}={env.get(k)!r}" for k in _ENV)
        msg = f"torchrun's variables must be integers; got {got}"
        raise ValueError(msg) from None
    ctx = DistContext(vals["RANK"], vals["WORLD_SIZE"], vals["LOCAL_RANK"],
                      vals["LOCAL_WORLD_SIZE"])
    if not (ctx.world_size >= 1 and 0 <= ctx.rank < ctx.world_size
            and 0 <= ctx.local_rank < max(ctx.local_world_size, 1)):
        msg = (f"inconsistent torchrun variables: RANK {ctx.rank}, WORLD_SIZE {ctx.world_size}, "
               f"LOCAL_RANK {ctx.local_rank}, LOCAL_WORLD_SIZE {ctx.local_world_size}")
        raise ValueError(msg)
    return ctx


def start(ctx: DistContext, device: torch.device) -> torch.device:
    """Join the process group (when there is more than one process); returns this
    process's device (``cuda:LOCAL_RANK`` on CUDA)."""
    if not ctx.active:
        return device
    if device.type == "mps":
        msg = "--device mps: distributed training runs on CUDA (nccl) or the CPU (gloo)"
        raise ValueError(msg)
    if device.type == "cuda":
        device = torch.device("cuda", ctx.local_rank)
        torch.cuda.set_device(device)
    if not dist.is_initialized():
        dist.init_process_group("nccl" if device.type == "cuda" else "gloo")
    return device


def stop(ctx: DistContext) -> None:
    if ctx.active and dist.is_initialized():
        dist.destroy_process_group()


class _AllReduceSum(torch.autograd.Function):
    """The sum of a tensor over the ranks; its gradient is the sum of theirs."""

    @staticmethod
    def forward(ctx: Any, x: torch.Tensor) -> torch.Tensor:
        out = x.clone()
        dist.all_reduce(out)
        return out

    @staticmethod
    def backward(ctx: Any, grad: torch.Tensor) -> torch.Tensor:
        out = grad.clone()
        dist.all_reduce(out)
        return out


class GlobalBatchNorm2d(torch.nn.BatchNorm2d):
    """BatchNorm whose training statistics are those of the whole batch over every rank,
    on the CPU (torch's ``SyncBatchNorm`` runs on GPUs only).

    The batch mean, then the mean squared deviation from it (two passes, as BatchNorm
    computes them), are summed over the ranks with a differentiable all-reduce, so W
    processes of B / W samples normalise, and back-propagate, as one process of B. The
    running statistics follow BatchNorm's rule (momentum; unbiased variance), so they are
    the same on every rank. Evaluation is plain BatchNorm.
    """

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if not (self.training and dist.is_initialized()):
            return super().forward(x)
        all_reduce = _AllReduceSum.apply
        dims, shape = (0, 2, 3), (1, -1, 1, 1)
        count = torch.tensor(float(x.numel() // x.shape[1]), dtype=x.dtype)
        dist.all_reduce(count)
        mean = all_reduce(x.sum(dims)) / count
        xc = x - mean.view(shape)
        var = all_reduce((xc * xc).sum(dims)) / count
        if self.track_running_stats:
            with torch.no_grad():
                self.num_batches_tracked += 1
                m = (self.momentum if self.momentum is not None
                     else 1.0 / float(self.num_batches_tracked))
                n = float(count)
                self.running_mean.mul_(1 - m).add_(mean.detach(), alpha=m)
                self.running_var.mul_(1 - m).add_(var.detach() * (n / max(n - 1.0, 1.0)),
                                                  alpha=m)
        y = xc * torch.rsqrt(var + self.eps).view(shape)
        return y * self.weight.view(shape) + self.bias.view(shape) if self.affine else y


def _global_batchnorm(module: torch.nn.Module) -> None:
    """Replace every ``BatchNorm2d`` of ``module`` by a :class:`GlobalBatchNorm2d` holding
    the same parameter and buffer tensors (the state dict keeps its keys)."""
    for name, child in module.named_children():
        if type(child) is torch.nn.BatchNorm2d:
            new = GlobalBatchNorm2d(child.num_features, child.eps, child.momentum,
                                    child.affine, child.track_running_stats)
            # the very tensors, as convert_sync_batchnorm does: the optimizer holds them
            new.weight, new.bias = child.weight, child.bias
            new.running_mean, new.running_var = child.running_mean, child.running_var
            new.num_batches_tracked = child.num_batches_tracked
            setattr(module, name, new)
        else:
            _global_batchnorm(child)


def wrap(model: torch.nn.Module, ctx: DistContext, device: torch.device) -> torch.nn.Module:
    """``model`` in DDP, its BatchNorm over the global batch (``SyncBatchNorm`` on CUDA,
    :class:`GlobalBatchNorm2d` on the CPU; the model is changed in place on the CPU);
    unchanged for one process."""
    if not ctx.active:
        return model
    if device.type == "cuda":
        model = torch.nn.SyncBatchNorm.convert_sync_batchnorm(model)
        return torch.nn.parallel.DistributedDataParallel(model, device_ids=[device.index])
    _global_batchnorm(model)
    return torch.nn.parallel.DistributedDataParallel(model)


def per_rank_batch(batch_size: int, ctx: DistContext) -> int:
    if batch_size % ctx.world_size:
        msg = (f"--batch-size {batch_size} must be a multiple of the {ctx.world_size} training "
               "processes (each takes an equal part of every batch)")
        raise ValueError(msg)
    return batch_size // ctx.world_size


def shuffled_order(n: int, seed: int) -> list[int]:
    """The order in which one process's training loop visits ``n`` items: a
    ``DataLoader(shuffle=True)`` whose generator is seeded with ``seed``, iterated through
    ``tqdm.auto`` as the loop does, replayed over the indices.

    Replayed rather than drawn with ``randperm``: the loader takes a worker seed from the
    generator each time an iterator is made, and ``tqdm.auto`` makes one of its own before
    the loop's, so the permutation is the one after two such draws.
    """
    loader = torch.utils.data.DataLoader(range(n), batch_size=None, shuffle=True,
                                         generator=torch.Generator().manual_seed(seed))
    return [int(i) for i in tqdm(loader, disable=True)]


class OrderSampler(torch.utils.data.distributed.DistributedSampler):
    """A ``DistributedSampler`` over a given ``order`` of the items: rank r takes
    ``order[r::W]``, the order padded with its head to a multiple of W as
    ``DistributedSampler`` pads. Global batch j of ``B / W`` samples per rank is then
    ``order[j B:(j + 1) B]``, one process's batch j."""

    def __init__(self, items: Any, order: list[int], ctx: DistContext) -> None:
        super().__init__(items, num_replicas=ctx.world_size, rank=ctx.rank, shuffle=False,
                         drop_last=False)
        if sorted(order) != list(range(len(items))):
            msg = "order must be a permutation of the items"
            raise ValueError(msg)
        self.order = list(order)

    def __iter__(self) -> Any:
        padded = (self.order * (1 + self.total_size // max(len(self.order), 1)))[:self.total_size]
        return iter(padded[self.rank::self.num_replicas])


def all_sum(values: list[float], ctx: DistContext) -> list[float]:
    """Element-wise sum of ``values`` over the ranks (float64)."""
    if not ctx.active:
        return list(values)
    t = torch.tensor(values, dtype=torch.float64)
    dist.all_reduce(t)
    return t.tolist()


def gather(obj: Any, ctx: DistContext) -> list[Any]:
    """Every rank's ``obj``, in rank order."""
    if not ctx.active:
        return [obj]
    out: list[Any] = [None] * ctx.world_size
    dist.all_gather_object(out, obj)
    return out


def sync_buffers(model: torch.nn.Module, ctx: DistContext) -> None:
    """Give every rank rank 0's buffers (BatchNorm's running statistics, which each rank
    updates from its own part of the batch), as DDP does before each forward."""
    if ctx.active:
        for b in model.buffers():
            dist.broadcast(b, 0)


def barrier(ctx: DistContext) -> None:
    if ctx.active:
        dist.barrier()


def local_threads(ctx: DistContext) -> int:
    """This process's share of the machine's cores (0: all of them, for one process)."""
    if not ctx.active:
        return 0
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, cores // max(ctx.local_world_size, 1))


__all__ = ["DistContext", "all_sum", "barrier", "context_from_env", "gather", "local_threads",
           "per_rank_batch", "OrderSampler", "shuffled_order", "start", "stop", "sync_buffers", "wrap"]
