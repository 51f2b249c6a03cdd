"""Training with DDP: a real 2-process torchrun (gloo, CPU) trains as one process does,
writes its run folder from rank 0 alone and resumes; the distributed helpers' contracts."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import wavealt
from wavealt.altimetry.data import TrainConfig
from wavealt.altimetry.distributed import (
    DistContext,
    OrderSampler,
    context_from_env,
    per_rank_batch,
    shuffled_order,
)
from wavealt.altimetry.train import train

TINY = ["--condition", "bright", "--model", "resnet-tiny", "--batch-size", "8", "--lr", "3e-3",
        "--device", "cpu"]
#: DDP against one process: the same batches, BatchNorm over the global batch, gradients
#: averaged in another order; measured differences are ~1e-7 relative (float32 sums).
RTOL = 1e-4


def _torchrun(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(Path(wavealt.__file__).parents[1]), OMP_NUM_THREADS="1")
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2",
           "-m", "wavealt", "train", *args]
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)


def _history(run: Path) -> list[dict]:
    return json.loads((run / "history.json").read_text())


def _close(a: list[dict], b: list[dict]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x["images"] == y["images"] and x["lr"] == y["lr"]
        assert y["train_loss"] == pytest.approx(x["train_loss"], rel=RTOL)
        assert y["val_mae_m"] == pytest.approx(x["val_mae_m"], rel=RTOL)


@pytest.fixture(scope="module")
def single(tiny_dataset, tmp_path_factory):
    run = tmp_path_factory.mktemp("single") / "run"
    cfg = TrainConfig(condition="bright", model="resnet-tiny", epochs=2, batch_size=8, lr=3e-3,
                      threads=1)
    train(tiny_dataset, run, cfg, progress=False, device="cpu")
    return run


def test_torchrun_two_processes_train_as_one(tiny_dataset, single, tmp_path):
    run = tmp_path / "ddp"
    res = _torchrun(str(tiny_dataset), "--out", str(run), "--epochs", "2", *TINY)
    assert res.returncode == 0, res.stderr[-3000:]
    assert res.stdout.count("run: ") == 1  # rank 0 alone reports
    _close(_history(single), _history(run))
    info = json.loads((run / "config.json").read_text())
    assert info["world_size"] == 2 and info["threads"] == 1
    assert sorted(p.name for p in run.iterdir()) == ["best.pt", "config.json", "history.json",
                                                     "last.pt"]


def test_torchrun_resumes_a_run(tiny_dataset, single, tmp_path, interrupt_training):
    """A run cut after its first epoch (here by one process) is finished by two."""
    interrupt_training()
    cfg = TrainConfig(condition="bright", model="resnet-tiny", epochs=2, batch_size=8, lr=3e-3,
                      threads=1)
    with pytest.raises(KeyboardInterrupt):
        train(tiny_dataset, tmp_path / "cut", cfg, progress=False, device="cpu")
    assert len(_history(tmp_path / "cut")) == 1
    res = _torchrun(str(tiny_dataset), "--out", str(tmp_path / "cut"), "--epochs", "2",
                    "--resume", "--threads", "1", *TINY)
    assert res.returncode == 0, res.stderr[-3000:]
    _close(_history(single), _history(tmp_path / "cut"))


def test_torchrun_bad_batch_size_is_refused_before_any_write(tiny_dataset, tmp_path):
    res = _torchrun(str(tiny_dataset), "--out", str(tmp_path / "r"), "--epochs", "1",
                    *TINY[:4], "--batch-size", "7", "--device", "cpu")
    assert res.returncode != 0
    assert "wavealt: error: --batch-size 7 must be a multiple of the 2 training processes" in res.stderr
    assert not (tmp_path / "r").exists()


def test_the_ranks_share_one_process_order():
    n, seed = 37, 1234
    order = shuffled_order(n, seed)
    assert sorted(order) == list(range(n))
    parts = [list(OrderSampler(range(n), order, DistContext(r, 2, r, 2))) for r in range(2)]
    assert [len(p) for p in parts] == [19, 19]  # padded with the order's head, as DDP pads
    batches = [sorted(parts[0][j:j + 2] + parts[1][j:j + 2]) for j in range(0, 18, 2)]
    assert batches == [sorted(order[4 * j:4 * j + 4]) for j in range(9)]  # global batch j
    assert parts[0][-1] == order[36] and parts[1][-1] == order[0]


def test_distributed_contracts():
    assert context_from_env({}) == DistContext()
    env = {"RANK": "1", "WORLD_SIZE": "2", "LOCAL_RANK": "1", "LOCAL_WORLD_SIZE": "2"}
    ctx = context_from_env(env)
    assert (ctx.rank, ctx.world_size, ctx.active, ctx.is_main) == (1, 2, True, False)
    with pytest.raises(ValueError, match="inconsistent torchrun variables"):
        context_from_env({**env, "RANK": "2"})
    with pytest.raises(ValueError, match="must be integers"):
        context_from_env({**env, "RANK": "one"})
    assert per_rank_batch(8, ctx) == 4
    with pytest.raises(ValueError, match="--batch-size 7 must be a multiple of the 2 training"):
        per_rank_batch(7, ctx)
    with pytest.raises(ValueError, match="order must be a permutation"):
        OrderSampler(range(3), [0, 0, 1], ctx)
    assert np.isfinite(per_rank_batch(1, DistContext()))
