"""The dataset folder, its description (``dataset.json``) and its manifest.

```
DATASET/
  dataset.json     generator config, package version, what each condition folder holds
  manifest.csv     one row per sequence
  clean/<sequence_id>/frame_000.png ...
  glinty/<sequence_id>/frame_000.png ...
  surface/<sequence_id>.npz           (``--save-surface``) height_m, slope_x, slope_y
```

Every write is atomic (:mod:`wavealt.io`): a sequence folder is written under a temporary
name and renamed, ``dataset.json`` / ``manifest.csv`` are written to a temporary file and
replaced. A sharded dataset (:mod:`wavealt.dataset.shards`) has the same ``dataset.json``
and ``manifest.csv``, with its frames in tar shards instead of folders.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from wavealt import __version__
from wavealt._checks import read_csv_rows
from wavealt.dataset.location import Location, is_url, join, read_bytes, write_bytes
from wavealt.io import read_frames_folder, write_frames_folder
from wavealt.sim.config import Scenario, SimConfig

FORMAT = "wavealt-dataset"
#: 2: the config's renderer and sensor settings are nested objects (1: flat; still read)
FORMAT_VERSION = 2
MANIFEST_COLUMNS = ("sequence_id", "split", "altitude_m", "wind_speed_mps", "wind_dir_deg",
                    "sun_zenith_deg", "sun_azimuth_deg", "glint_severity", "fps", "focal_px",
                    "frames", "seed", "camera_speed_mps", "camera_dir_deg")
BASE_CONDITIONS = {
    "clean": "rendered frames without glint (paper eq. (3) with g = clean_glint_severity)",
    "glinty": "the same waves and exposure with the glint lobe added (g = glint_severity)",
}


def sequence_id(index: int) -> str:
    return f"seq_{index:05d}"


# -- manifest ---------------------------------------------------------------------------
@dataclass(frozen=True)
class SequenceRecord:
    """One manifest row."""

    sequence_id: str
    split: str
    scenario: Scenario

    @property
    def altitude_m(self) -> float:
        return self.scenario.altitude_m


def _fmt(x: Any) -> str:
    if isinstance(x, float):
        return repr(round(x, 6))
    return str(x)


def manifest_text(records: Sequence[SequenceRecord]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(MANIFEST_COLUMNS)
    for r in records:
        s = r.scenario
        w.writerow([r.sequence_id, r.split] + [_fmt(getattr(s, c)) for c in MANIFEST_COLUMNS[2:]])
    return buf.getvalue()


def _records_of_rows(rows: Iterable[dict[str, str]]) -> list[SequenceRecord]:
    out = []
    for row in rows:
        kw: dict[str, Any] = {}
        for c in MANIFEST_COLUMNS[2:]:
            kw[c] = int(row[c]) if c in ("frames", "seed") else float(row[c])
        out.append(SequenceRecord(row["sequence_id"], row["split"], Scenario(**kw)))
    return out


def read_manifest(path: Location) -> list[SequenceRecord]:
    """The rows of a ``manifest.csv`` at a path or a URL."""
    if not is_url(path):
        return _records_of_rows(read_csv_rows(path, MANIFEST_COLUMNS, "manifest"))
    try:
        text = read_bytes(path).decode("utf-8")
    except FileNotFoundError:
        msg = f"manifest not found: {path}"
        raise FileNotFoundError(msg) from None
    reader = csv.DictReader(io.StringIO(text, newline=""))
    missing = [c for c in MANIFEST_COLUMNS if c not in (reader.fieldnames or [])]
    if missing:
        msg = f"manifest {path} lacks the column(s) {', '.join(missing)}"
        raise ValueError(msg)
    return _records_of_rows(reader)


def manifest_row(record: SequenceRecord) -> dict[str, Any]:
    """One manifest row as a dict of typed values, the numbers its CSV line holds."""
    row: dict[str, Any] = {"sequence_id": record.sequence_id, "split": record.split}
    for c in MANIFEST_COLUMNS[2:]:
        v = getattr(record.scenario, c)
        row[c] = int(v) if c in ("frames", "seed") else round(float(v), 6)
    return row


def records_of(config: SimConfig) -> list[SequenceRecord]:
    """Manifest rows of a config: a pure function of it."""
    splits = config.splits()
    return [SequenceRecord(sequence_id(i), splits[i], config.sample_scenario(i))
            for i in range(config.sequences)]


# -- the dataset ------------------------------------------------------------------------
def records_of_split(records: Iterable[SequenceRecord], name: str) -> list[SequenceRecord]:
    """The records of split ``name`` (train, val or test), in manifest order."""
    if name not in ("train", "val", "test"):
        msg = f"split must be train, val or test; got {name!r}"
        raise ValueError(msg)
    return [r for r in records if r.split == name]


class Dataset:
    """A dataset folder on disk.

    Parameters
    ----------
    root : path
        The folder holding ``dataset.json`` and ``manifest.csv``.
    """

    #: how the frames are stored (``"shards"`` for :class:`~wavealt.dataset.shards.ShardDataset`)
    storage = "folder"

    def __init__(self, root: Path | str) -> None:
        if is_url(root):
            msg = (f"{root}: a dataset folder is read from a local path (only a sharded dataset, "
                   "--format shards, is read from a URL)")
            raise ValueError(msg)
        self.root = Path(root)
        self.info = read_info(self.root)
        if storage_of(self.info).get("format") == "shards":
            msg = (f"dataset {self.root} is sharded (--format shards); this needs a dataset "
                   "folder (simulate one with --format folder)")
            raise ValueError(msg)
        self.config = SimConfig.from_dict(self.info["config"])
        self.records = read_manifest(self.root / "manifest.csv")
        self._by_id = {r.sequence_id: r for r in self.records}

    def __len__(self) -> int:
        return len(self.records)

    def record(self, seq_id: str) -> SequenceRecord:
        try:
            return self._by_id[seq_id]
        except KeyError:
            msg = f"no sequence {seq_id!r} in dataset {self.root}"
            raise ValueError(msg) from None

    def split(self, name: str) -> list[SequenceRecord]:
        return records_of_split(self.records, name)

    @property
    def conditions(self) -> list[str]:
        """Complete condition folders: described in dataset.json, present on disk, and not
        flagged ``"complete": false`` (a deglint run that was interrupted or is running)."""
        return [c for c, e in self.info.get("conditions", {}).items()
                if (self.root / c).is_dir() and self.is_complete(c)]

    def is_complete(self, condition: str) -> bool:
        """False when dataset.json flags ``condition`` as ``"complete": false``."""
        entry = self.info.get("conditions", {}).get(condition)
        return not (isinstance(entry, dict) and entry.get("complete", True) is False)

    def require_condition(self, condition: str) -> Path:
        folder = self.root / condition
        if condition in self.info.get("conditions", {}) and not self.is_complete(condition):
            method = self.info["conditions"][condition].get("method", condition)
            msg = (f"condition {condition!r} of dataset {self.root} is incomplete (an interrupted "
                   f"or running `wavealt deglint --method {method}`; run it again to finish)")
            raise ValueError(msg)
        if condition not in self.conditions:
            have = ", ".join(self.conditions) or "none"
            hint = " (run `wavealt deglint` first)" if condition not in BASE_CONDITIONS else ""
            msg = f"dataset {self.root} has no condition {condition!r} (has: {have}){hint}"
            raise FileNotFoundError(msg)
        return folder

    def sequence_dir(self, condition: str, seq_id: str) -> Path:
        return self.root / condition / seq_id

    def has_sequence(self, condition: str, seq_id: str) -> bool:
        return self.sequence_dir(condition, seq_id).is_dir()

    def read_frames(self, condition: str, seq_id: str) -> np.ndarray:
        """Frames of one sequence as ``(T, H, W, 3)`` float32 in [0, 1]."""
        self.require_condition(condition)
        self.record(seq_id)
        return read_frames_folder(self.sequence_dir(condition, seq_id))

    def iter_sequences(self, condition: str, records: Sequence[SequenceRecord] | None = None
                       ) -> Iterator[tuple[SequenceRecord, np.ndarray]]:
        """``(record, frames)`` of ``records`` (default: all) in ``condition``, in the order
        given; frames are ``(T, H, W, 3)`` uint8, the PNGs' exact values."""
        self.require_condition(condition)
        for r in self.records if records is None else records:
            f = self.read_frames(condition, r.sequence_id)
            yield r, np.round(f * 255.0).astype(np.uint8)

    def write_frames(self, condition: str, seq_id: str, frames: np.ndarray) -> None:
        """Write one sequence of a condition atomically."""
        self.record(seq_id)
        write_frames_folder(self.sequence_dir(condition, seq_id), frames)

    def register_condition(self, name: str, description: str, **extra: Any) -> None:
        """Record a condition folder (and how it was made) in dataset.json, atomically."""
        conds = dict(self.info.get("conditions", {}))
        entry: dict[str, Any] = {"description": description}
        entry.update(extra)
        conds[name] = entry
        self.info["conditions"] = conds
        write_info(self.root, self.info)


def read_info(root: Location) -> dict[str, Any]:
    """The ``dataset.json`` of the dataset at ``root`` (a folder or a URL), checked to be one."""
    info_path = join(root, "dataset.json")
    try:
        text = read_bytes(info_path).decode("utf-8")
    except (FileNotFoundError, IsADirectoryError, NotADirectoryError):
        msg = f"not a wavealt dataset: {root} has no dataset.json"
        raise FileNotFoundError(msg) from None
    try:
        info = json.loads(text)
    except json.JSONDecodeError as exc:
        msg = f"corrupt dataset.json in {root}: {exc}"
        raise ValueError(msg) from None
    if not isinstance(info, dict) or info.get("format") != FORMAT:
        msg = f"{info_path} is not a wavealt dataset description"
        raise ValueError(msg)
    return info


def storage_of(info: dict[str, Any]) -> dict[str, Any]:
    """How a dataset stores its frames: ``{"format": "folder"}`` (no ``storage`` entry) or
    ``{"format": "shards", "shard_size": N, "shards": K}``."""
    return dict(info.get("storage") or {"format": "folder"})


def write_info(root: Location, info: dict[str, Any]) -> None:
    text = json.dumps(info, indent=2, sort_keys=True) + "\n"
    write_bytes(join(root, "dataset.json"), text.encode("utf-8"))


def new_info(config: SimConfig) -> dict[str, Any]:
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "wavealt_version": __version__,
        "config": config.to_dict(),
        "conditions": {k: {"description": v} for k, v in BASE_CONDITIONS.items()},
    }


def ids_missing(root: Path, records: Iterable[SequenceRecord], conditions: Iterable[str],
                save_surface: bool) -> list[int]:
    """Indices of sequences not yet complete on disk."""
    conds = list(conditions)
    out = []
    for i, r in enumerate(records):
        done = all((root / c / r.sequence_id).is_dir() for c in conds)
        if save_surface:
            done = done and (root / "surface" / f"{r.sequence_id}.npz").is_file()
        if not done:
            out.append(i)
    return out


def records_of_index(config: SimConfig, index: int) -> SequenceRecord:
    """Manifest row ``index`` of a config, without building the others."""
    return SequenceRecord(sequence_id(index), config.splits()[index], config.sample_scenario(index))


__all__ = ["BASE_CONDITIONS", "FORMAT", "FORMAT_VERSION", "MANIFEST_COLUMNS", "Dataset",
           "SequenceRecord", "ids_missing", "manifest_row", "manifest_text", "new_info",
           "read_info", "read_manifest", "records_of", "records_of_index", "sequence_id",
           "storage_of", "write_info"]
