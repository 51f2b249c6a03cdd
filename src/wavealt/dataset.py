"""The dataset folder (DESIGN.md): read, write, resume, and the manifest.

```
DATASET/
  dataset.json     generator config, package version, what each condition folder holds
  manifest.csv     one row per sequence
  clean/<sequence_id>/frame_000.png ...
  glinty/<sequence_id>/frame_000.png ...
  surface/<sequence_id>.npz           (``--save-surface``) height_m, slope_x, slope_y
```

Every write is atomic: a sequence folder is written under a temporary name and renamed,
``dataset.json`` / ``manifest.csv`` are written to a temporary file and replaced.
"""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, UnidentifiedImageError

from wavealt import __version__
from wavealt._checks import check_frames, read_csv_rows
from wavealt.scenario import Scenario, SimConfig

FORMAT = "wavealt-dataset"
FORMAT_VERSION = 1
MANIFEST_COLUMNS = ("sequence_id", "split", "altitude_m", "wind_speed_mps", "wind_dir_deg",
                    "sun_zenith_deg", "sun_azimuth_deg", "glint_severity", "fps", "focal_px",
                    "frames", "seed", "camera_speed_mps", "camera_dir_deg")
BASE_CONDITIONS = {
    "clean": "rendered frames without glint (paper eq. (3) with g = clean_glint_severity)",
    "glinty": "the same waves and exposure with the glint lobe added (g = glint_severity)",
}


def sequence_id(index: int) -> str:
    return f"seq_{index:05d}"


# -- images -----------------------------------------------------------------------------
def to_uint8(frames: np.ndarray) -> np.ndarray:
    """Float frames in [0, 1] to uint8, rounding to nearest."""
    return np.round(np.clip(frames, 0.0, 1.0) * 255.0).astype(np.uint8)


def write_png(path: Path, image: np.ndarray) -> None:
    """Write one ``(H, W, 3)`` frame (float in [0, 1] or uint8) as an 8-bit RGB PNG."""
    img = image if image.dtype == np.uint8 else to_uint8(image)
    Image.fromarray(img, mode=None).save(path, format="PNG", compress_level=1)


def read_png(path: Path) -> np.ndarray:
    """Read an image file as ``(H, W, 3)`` float32 in [0, 1]."""
    path = Path(path)
    if not path.is_file():
        msg = f"image file not found: {path}"
        raise FileNotFoundError(msg)
    try:
        with Image.open(path) as im:
            arr = np.asarray(im.convert("RGB"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError) as exc:
        msg = f"cannot read image {path}: {exc}"
        raise ValueError(msg) from None
    return arr.astype(np.float32) / 255.0


def frame_files(folder: Path) -> list[Path]:
    """Image files of a frame folder in natural order (``frame_2`` before ``frame_10``)."""
    from natsort import natsorted

    exts = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"}
    return natsorted((p for p in Path(folder).iterdir()
                      if p.suffix.lower() in exts and p.is_file()), key=lambda p: p.name)


def read_frames_folder(folder: Path | str) -> np.ndarray:
    """Read every image of ``folder`` (natural order) as ``(T, H, W, 3)`` float32."""
    folder = Path(folder)
    if not folder.is_dir():
        msg = f"frame folder not found: {folder}"
        raise FileNotFoundError(msg)
    files = frame_files(folder)
    if not files:
        msg = f"frame folder {folder} holds no image files"
        raise ValueError(msg)
    frames = [read_png(p) for p in files]
    shapes = {f.shape for f in frames}
    if len(shapes) > 1:
        msg = f"frames in {folder} have different sizes: {sorted(shapes)}"
        raise ValueError(msg)
    return np.stack(frames)


def write_frames_folder(folder: Path | str, frames: np.ndarray) -> None:
    """Write ``(T, H, W, 3)`` frames as ``frame_000.png`` ... atomically.

    The frames go to a temporary sibling folder which is renamed to ``folder``; an existing
    ``folder`` is replaced only once the new one is complete.
    """
    frames = check_frames(frames)
    folder = Path(folder)
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.tmp-", dir=folder.parent))
    try:
        for t, frame in enumerate(frames):
            write_png(tmp / f"frame_{t:03d}.png", frame)
        if folder.exists():
            old = folder.with_name(f".{folder.name}.old-{os.getpid()}")
            folder.rename(old)
            tmp.rename(folder)
            shutil.rmtree(old)
        else:
            tmp.rename(folder)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def publish(tmp: Path | str, path: Path | str) -> None:
    """Move a finished temporary file onto ``path`` with the permissions a plain ``open``
    would give it (``0o666`` less the umask; ``mkstemp`` makes files ``0o600``)."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o666 & ~mask)
    os.replace(tmp, path)


def check_output_folder(out: Path | str, names: Iterable[str], *, force: bool = False,
                        what: str | None = None) -> Path:
    """The one overwrite rule of every command: ``out`` must be a folder (or not exist yet),
    and one that already holds any of ``names`` is refused unless ``force`` — before any
    work, so nothing written earlier is replaced silently. ``what`` names the earlier
    result in the message (default: the files found)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        msg = f"--out {out} is a file; give a folder"
        raise ValueError(msg)
    held = [n for n in names if (out / n).exists()]
    if held and not force:
        msg = f"--out {out} already holds {what or ', '.join(held)}; use another folder or --force"
        raise ValueError(msg)
    return out


def atomic_write_text(path: Path, text: str) -> None:
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
        publish(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_save_npz(path: Path, **arrays: np.ndarray) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".npz", dir=path.parent)
    os.close(fd)
    try:
        np.savez_compressed(tmp, **arrays)
        publish(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


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
