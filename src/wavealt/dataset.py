"""The dataset folder: read, write (a simulated one), resume, and the manifest.

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
replaced.
"""

from __future__ import annotations

import csv
import io
import json
import multiprocessing as mp
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from wavealt import __version__
from wavealt._checks import read_csv_rows
from wavealt.io import (
    atomic_save_npz,
    atomic_write_text,
    read_frames_folder,
    write_frames_folder,
)
from wavealt.sim.config import Scenario, SimConfig
from wavealt.sim.generate import generate_sequence

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


def read_manifest(path: Path) -> list[SequenceRecord]:
    out = []
    for row in read_csv_rows(path, MANIFEST_COLUMNS, "manifest"):
        kw: dict[str, Any] = {}
        for c in MANIFEST_COLUMNS[2:]:
            kw[c] = int(row[c]) if c in ("frames", "seed") else float(row[c])
        out.append(SequenceRecord(row["sequence_id"], row["split"], Scenario(**kw)))
    return out


def records_of(config: SimConfig) -> list[SequenceRecord]:
    """Manifest rows of a config: a pure function of it."""
    splits = config.splits()
    return [SequenceRecord(sequence_id(i), splits[i], config.sample_scenario(i))
            for i in range(config.sequences)]


# -- the dataset ------------------------------------------------------------------------
class Dataset:
    """A dataset folder on disk.

    Parameters
    ----------
    root : path
        The folder holding ``dataset.json`` and ``manifest.csv``.
    """

    def __init__(self, root: Path | str) -> None:
        self.root = Path(root)
        info_path = self.root / "dataset.json"
        if not info_path.is_file():
            msg = f"not a wavealt dataset: {self.root} has no dataset.json"
            raise FileNotFoundError(msg)
        try:
            self.info = json.loads(info_path.read_text(encoding="utf-8"))
        except json.JSONDecodeError as exc:
            msg = f"corrupt dataset.json in {self.root}: {exc}"
            raise ValueError(msg) from None
        if self.info.get("format") != FORMAT:
            msg = f"{info_path} is not a wavealt dataset description"
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
        if name not in ("train", "val", "test"):
            msg = f"split must be train, val or test; got {name!r}"
            raise ValueError(msg)
        return [r for r in self.records if r.split == name]

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


def write_info(root: Path, info: dict[str, Any]) -> None:
    atomic_write_text(Path(root) / "dataset.json", json.dumps(info, indent=2, sort_keys=True) + "\n")


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


# -- a simulated dataset to disk --------------------------------------------------------
def _write_one(args: tuple[str, dict, int, bool]) -> int:
    root_s, cfg_dict, index, save_surface = args
    root = Path(root_s)
    config = SimConfig.from_dict(cfg_dict)
    rec = records_of_index(config, index)
    need = [c for c in ("clean", "glinty") if not (root / c / rec.sequence_id).is_dir()]
    surf_path = root / "surface" / f"{rec.sequence_id}.npz"
    need_surface = save_surface and not surf_path.is_file()
    if not need and not need_surface:
        return index
    data = generate_sequence(rec.scenario, config, with_height=need_surface)
    for c in need:
        write_frames_folder(root / c / rec.sequence_id, getattr(data, c))
    if need_surface:
        atomic_save_npz(surf_path, height_m=data.height_m, slope_x=data.slope_x,
                        slope_y=data.slope_y)
    return index


def _flat(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """A nested config dict as ``{"sensor.compression": ..., ...}`` (for messages)."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def simulate_dataset(out: Path | str, config: SimConfig, *, workers: int = 1,
                     save_surface: bool = False, progress: bool = True) -> Path:
    """Write the dataset of ``config`` to ``out`` (the layout in this module's docstring).

    Resumes: sequences already complete are kept; a folder holding a dataset of another
    config is refused untouched.  ``workers`` processes give the same bytes as one.
    """
    out = Path(out)
    if int(workers) != workers or workers < 1:
        msg = f"workers must be a positive integer; got {workers!r}"
        raise ValueError(msg)
    if out.exists() and not out.is_dir():
        msg = f"OUT {out} is an existing file; give a folder for the dataset"
        raise ValueError(msg)
    if (out / "dataset.json").is_file():
        existing = Dataset(out).config
        if existing != config:
            a, b = _flat(existing.to_dict()), _flat(config.to_dict())
            diff = ", ".join(f"{k}: {a.get(k, '-')!r} -> {b.get(k, '-')!r}"
                             for k in sorted(a.keys() | b.keys()) if a.get(k) != b.get(k))
            msg = f"OUT {out} holds a dataset made with a different config ({diff}); choose another folder"
            raise ValueError(msg)
    elif out.is_dir() and any(out.iterdir()):
        msg = f"OUT {out} is a non-empty folder that holds no wavealt dataset; choose another folder"
        raise ValueError(msg)
    out.mkdir(parents=True, exist_ok=True)
    records = records_of(config)
    if not (out / "dataset.json").is_file():
        write_info(out, new_info(config))
    atomic_write_text(out / "manifest.csv", manifest_text(records))
    todo = ids_missing(out, records, ("clean", "glinty"), save_surface)
    if save_surface:
        (out / "surface").mkdir(exist_ok=True)
    tasks = [(str(out), config.to_dict(), i, save_surface) for i in todo]
    bar = tqdm(total=len(records), initial=len(records) - len(todo), desc="simulate",
               unit="seq", disable=not progress)
    try:
        if workers == 1 or len(tasks) <= 1:
            for t in tasks:
                _write_one(t)
                bar.update()
        else:
            ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
            with ctx.Pool(int(workers)) as pool:
                for _ in pool.imap_unordered(_write_one, tasks):
                    bar.update()
    finally:
        bar.close()
    if save_surface:
        info = Dataset(out).info
        info["conditions"]["surface"] = {"description": "ground truth per sequence: surface/<id>.npz "
                                         "with height_m, slope_x, slope_y (T, H, W) float32"}
        write_info(out, info)
    return out
