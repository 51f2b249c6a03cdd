"""A dataset's sequences as a torch stream: the adapter for training loops of your own over
datasets larger than memory (``wavealt train`` holds its split in memory).

Each reader (a DDP rank times a ``DataLoader`` worker) takes its own part of the split: of
a sharded dataset, every J-th shard holding the split's sequences (reader j of J reads shards
j, j + J, … each once, from start to end, which is how tar shards are meant to be read);
of a dataset folder, every J-th sequence. Together the readers see each sequence once.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.distributed as dist

from wavealt.dataset import open_dataset


class SequenceStream(torch.utils.data.IterableDataset):
    """The sequences of one split and condition of a dataset, as
    ``{"sequence_id": str, "frames": (T, H, W, 3) uint8, "altitude_m": float32}``.

    Parameters
    ----------
    dataset : path or str
        A dataset folder, or a sharded dataset at a path or an fsspec URL.
    condition : str
        ``clean``, ``glinty``, …
    split : str
        ``train``, ``val`` or ``test``.
    rank, world_size : int, optional
        This process's share of the readers; by default those of the initialised
        ``torch.distributed`` process group (one process when there is none).
    """

    def __init__(self, dataset: Path | str, *, condition: str = "clean", split: str = "train",
                 rank: int | None = None, world_size: int | None = None) -> None:
        super().__init__()
        self.dataset = dataset
        self.condition = condition
        self.split = split
        if (rank is None) != (world_size is None):
            msg = "give both rank and world_size, or neither"
            raise ValueError(msg)
        if world_size is not None and not (world_size >= 1 and 0 <= rank < world_size):
            msg = f"rank must be in [0, world_size); got rank {rank}, world_size {world_size}"
            raise ValueError(msg)
        self.rank, self.world_size = rank, world_size
        ds = open_dataset(dataset)  # checks the dataset, the condition and the split now
        ds.require_condition(condition)
        self._n = len(ds.split(split))

    def __len__(self) -> int:
        """Sequences in the split (over all readers)."""
        return self._n

    def _reader(self) -> tuple[int, int]:
        if self.world_size is not None:
            rank, world = int(self.rank), int(self.world_size)
        elif dist.is_available() and dist.is_initialized():
            rank, world = dist.get_rank(), dist.get_world_size()
        else:
            rank, world = 0, 1
        info = torch.utils.data.get_worker_info()
        workers, worker = (info.num_workers, info.id) if info is not None else (1, 0)
        return rank * workers + worker, world * workers

    def __iter__(self) -> Iterator[dict[str, Any]]:
        ds = open_dataset(self.dataset)
        records = ds.split(self.split)
        reader, readers = self._reader()
        if ds.storage == "shards":
            by_shard: dict[int, list[Any]] = {}
            for r in records:
                by_shard.setdefault(ds.shard_of(r.sequence_id), []).append(r)
            mine = [r for k in sorted(by_shard)[reader::readers] for r in by_shard[k]]
        else:
            mine = records[reader::readers]
        for rec, frames in ds.iter_sequences(self.condition, mine):
            yield {"sequence_id": rec.sequence_id, "frames": frames,
                   "altitude_m": np.float32(rec.altitude_m)}


__all__ = ["SequenceStream"]
