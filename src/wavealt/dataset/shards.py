"""A sharded dataset: the frames in tar shards of N sequences, in the WebDataset layout, at a
local path or any fsspec URL.

```
DATASET/                          a folder, or a URL such as s3://bucket/ds
  dataset.json                    as a folder's, plus "storage": {"format": "shards",
                                  "shard_size": N, "shards": K, "surface": bool}
  manifest.csv                    one row per sequence, as a folder's
  shards/shard-000000.tar         sequences 0 .. N-1
  shards/shard-000001.tar         sequences N .. 2N-1, ...
```

A shard holds one WebDataset *key* per sequence (its id), whose members are
``<id>.json`` (its manifest row), ``<id>.clean.000.png`` … and ``<id>.glinty.000.png`` …
(the very bytes of a folder dataset's PNGs) and, with ``--save-surface``,
``<id>.surface.npz``. Members of a key are consecutive and sorted by name; tar headers are
fixed (mtime 0, owner ``wavealt``, mode 0444), so a shard is a pure function of the config.
A shard is written whole or not at all (:func:`wavealt.dataset.location.atomic_output`):
an interrupted run resumes at the first missing shard.

The tar is read and written with the standard library's :mod:`tarfile` as a stream
(members in order, no seeking), which is what the WebDataset convention asks; the
``webdataset`` package reads these shards as they are (the tests check it), but importing it
imports torch, 1.5 s in every simulating process, and it does not open fsspec URLs.
"""

from __future__ import annotations

import io
import json
import tarfile
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

import numpy as np

from wavealt._checks import check_integer
from wavealt.dataset.folder import (
    BASE_CONDITIONS,
    Dataset,
    SequenceRecord,
    manifest_row,
    read_info,
    read_manifest,
    records_of_split,
    storage_of,
)
from wavealt.dataset.location import (
    Location,
    as_location,
    atomic_output,
    join,
    open_binary,
)
from wavealt.io import decode_png, encode_png, to_uint8
from wavealt.sim.base import SequenceData
from wavealt.sim.config import SimConfig

#: The default number of sequences per shard: about 100 MB at 224 px, 10 frames (1.5 MB a
#: sequence; WebDataset advises shards of 100 MB to 1 GB: few files, small enough to stream
#: and to write again).
DEFAULT_SHARD_SIZE = 64
SURFACE_FIELDS = ("height_m", "slope_x", "slope_y")
_OWNER = "wavealt"


def shard_count(sequences: int, shard_size: int) -> int:
    return -(-int(sequences) // int(shard_size))


def shard_name(k: int) -> str:
    return f"shards/shard-{k:06d}.tar"


def shard_location(root: Location, k: int) -> Location:
    return join(root, *shard_name(k).split("/"))


def shard_storage(sequences: int, shard_size: int, save_surface: bool) -> dict[str, Any]:
    """The ``storage`` entry of a sharded dataset's ``dataset.json``."""
    check_integer("--shard-size", shard_size, low=1)
    return {"format": "shards", "shard_size": int(shard_size),
            "shards": shard_count(sequences, shard_size), "surface": bool(save_surface)}


# -- writing ------------------------------------------------------------------------------
def sample_of(record: SequenceRecord, data: SequenceData, *,
              save_surface: bool) -> dict[str, bytes]:
    """One sequence as a WebDataset sample: member suffix -> bytes (the key is its id)."""
    out = {"json": (json.dumps(manifest_row(record), sort_keys=True) + "\n").encode("utf-8")}
    for cond in BASE_CONDITIONS:
        for t, frame in enumerate(getattr(data, cond)):
            out[f"{cond}.{t:03d}.png"] = encode_png(to_uint8(frame))
    if save_surface:
        buf = io.BytesIO()
        np.savez_compressed(buf, **{k: getattr(data, k) for k in SURFACE_FIELDS})
        out["surface.npz"] = buf.getvalue()
    return out


def write_shard(location: Location, samples: Iterable[tuple[str, dict[str, bytes]]]) -> None:
    """Write ``(key, sample)`` pairs as one tar shard at ``location``, atomically."""
    with atomic_output(location) as fh, tarfile.open(fileobj=fh, mode="w|",
                                                     format=tarfile.USTAR_FORMAT) as tar:
        for key, sample in samples:
            for suffix in sorted(sample):
                data = sample[suffix]
                info = tarfile.TarInfo(f"{key}.{suffix}")
                info.size, info.mtime, info.mode = len(data), 0, 0o444
                info.uname = info.gname = _OWNER
                tar.addfile(info, io.BytesIO(data))


# -- reading ------------------------------------------------------------------------------
def iter_shard(location: Location, *,
               select: Callable[[str], bool] | None = None) -> Iterator[tuple[str, dict[str, bytes]]]:
    """``(key, {suffix: bytes})`` of each key of a shard, streamed in order; ``select``
    keeps the member suffixes it accepts (the others are skipped unread)."""
    key, sample = None, {}
    try:
        with open_binary(location) as fh, tarfile.open(fileobj=fh, mode="r|") as tar:
            for member in tar:
                if not member.isreg():
                    continue
                name = member.name.rsplit("/", 1)[-1]
                k, _, suffix = name.partition(".")
                if k != key:
                    if key is not None:
                        yield key, sample
                    key, sample = k, {}
                if select is None or select(suffix):
                    sample[suffix] = tar.extractfile(member).read()
    except tarfile.TarError as exc:
        msg = f"shard {location} is not a readable tar file ({exc})"
        raise ValueError(msg) from None
    if key is not None:
        yield key, sample


def frames_of(sample: dict[str, bytes], condition: str, where: str) -> np.ndarray:
    """The ``(T, H, W, 3)`` uint8 frames of one condition of a sample, in frame order."""
    names = sorted((s for s in sample if s.startswith(condition + ".") and s.endswith(".png")),
                   key=lambda s: int(s.split(".")[1]))
    if not names:
        msg = f"{where} holds no {condition} frames"
        raise ValueError(msg)
    frames = [decode_png(sample[n], f"{where}.{n}") for n in names]
    if len({f.shape for f in frames}) > 1:
        msg = f"{condition} frames of {where} differ in size"
        raise ValueError(msg)
    return np.stack(frames)


class ShardDataset:
    """A sharded dataset (this module's layout) at a local path or an fsspec URL.

    It reads like a :class:`~wavealt.dataset.Dataset` (``records``, ``split``,
    ``conditions``, ``read_frames``, ``iter_sequences``) but holds only the simulated
    conditions and cannot be written to: ``deglint`` needs a dataset folder.
    """

    storage = "shards"

    def __init__(self, root: Location) -> None:
        self.root = as_location(root)
        self.info = read_info(self.root)
        st = storage_of(self.info)
        if st.get("format") != "shards":
            msg = f"dataset {self.root} is a dataset folder, not a sharded dataset"
            raise ValueError(msg)
        self.shard_size = int(st["shard_size"])
        self.config = SimConfig.from_dict(self.info["config"])
        self.records = read_manifest(join(self.root, "manifest.csv"))
        self._position = {r.sequence_id: i for i, r in enumerate(self.records)}
        self._cache: tuple[tuple[int, str], dict[str, np.ndarray]] | None = None

    def __len__(self) -> int:
        return len(self.records)

    @property
    def shards(self) -> list[Location]:
        return [shard_location(self.root, k)
                for k in range(shard_count(len(self.records), self.shard_size))]

    def record(self, seq_id: str) -> SequenceRecord:
        if seq_id not in self._position:
            msg = f"no sequence {seq_id!r} in dataset {self.root}"
            raise ValueError(msg)
        return self.records[self._position[seq_id]]

    def split(self, name: str) -> list[SequenceRecord]:
        return records_of_split(self.records, name)

    @property
    def conditions(self) -> list[str]:
        return list(self.info.get("conditions", {}))

    def is_complete(self, condition: str) -> bool:
        return condition in self.conditions

    def require_condition(self, condition: str) -> str:
        if condition not in self.conditions:
            msg = (f"dataset {self.root} has no condition {condition!r} (has: "
                   f"{', '.join(self.conditions)}); a sharded dataset holds the simulated "
                   "conditions only (deglinted ones need a dataset folder)")
            raise FileNotFoundError(msg)
        return condition

    def shard_of(self, seq_id: str) -> int:
        self.record(seq_id)
        return self._position[seq_id] // self.shard_size

    def _read_shard(self, k: int, condition: str,
                    wanted: set[str] | None = None) -> Iterator[tuple[str, np.ndarray]]:
        loc = shard_location(self.root, k)
        try:
            for key, sample in iter_shard(loc, select=lambda s: s.startswith(condition + ".")):
                if wanted is None or key in wanted:
                    yield key, frames_of(sample, condition, f"{loc}:{key}")
        except FileNotFoundError:
            msg = (f"shard {loc} of dataset {self.root} is missing (an interrupted `wavealt "
                   "simulate`? run it again to finish)")
            raise FileNotFoundError(msg) from None

    def iter_sequences(self, condition: str, records: Sequence[SequenceRecord] | None = None
                       ) -> Iterator[tuple[SequenceRecord, np.ndarray]]:
        """``(record, frames)`` of ``records`` (default: all) in ``condition``, streamed shard
        by shard in manifest order; frames are ``(T, H, W, 3)`` uint8, the PNGs' values.
        Each shard holding one of ``records`` is read once, from start to end."""
        self.require_condition(condition)
        recs = self.records if records is None else list(records)
        by_shard: dict[int, set[str]] = {}
        for r in recs:
            by_shard.setdefault(self.shard_of(r.sequence_id), set()).add(r.sequence_id)
        for k in sorted(by_shard):
            got = 0
            for key, frames in self._read_shard(k, condition, by_shard[k]):
                got += 1
                yield self.record(key), frames
            if got != len(by_shard[k]):
                msg = f"shard {shard_location(self.root, k)} lacks {len(by_shard[k]) - got} of its sequences"
                raise ValueError(msg)

    def read_frames(self, condition: str, seq_id: str) -> np.ndarray:
        """Frames of one sequence as ``(T, H, W, 3)`` float32 in [0, 1]. The last shard read
        is kept decoded, so reading the sequences of a condition in manifest order reads each
        shard once."""
        self.require_condition(condition)
        k = self.shard_of(seq_id)
        if self._cache is None or self._cache[0] != (k, condition):
            self._cache = ((k, condition), dict(self._read_shard(k, condition)))
        frames = self._cache[1].get(seq_id)
        if frames is None:
            msg = f"shard {shard_location(self.root, k)} lacks sequence {seq_id}"
            raise ValueError(msg)
        return frames.astype(np.float32) / 255.0


def open_dataset(root: Location) -> Any:
    """The dataset at ``root``: a :class:`~wavealt.dataset.Dataset` for a folder, a
    :class:`ShardDataset` for shards (at a path or a URL)."""
    root = as_location(root)
    if storage_of(read_info(root)).get("format") == "shards":
        return ShardDataset(root)
    return Dataset(root)


def require_folder(dataset: Any, command: str) -> None:
    """A one-line error when ``dataset`` is sharded and ``command`` needs a folder."""
    if getattr(dataset, "storage", "folder") != "folder":
        msg = (f"`wavealt {command}` needs a dataset folder; {dataset.root} is sharded "
               "(--format shards): simulate the dataset again with --format folder")
        raise ValueError(msg)


__all__ = ["DEFAULT_SHARD_SIZE", "ShardDataset", "frames_of", "iter_shard", "open_dataset",
           "require_folder", "sample_of", "shard_count", "shard_location", "shard_name",
           "shard_storage", "write_shard"]
