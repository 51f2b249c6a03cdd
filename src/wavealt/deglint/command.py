"""``wavealt deglint``: deglint every glinty sequence of a dataset folder and measure it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image
from tqdm import tqdm

from wavealt.dataset import Dataset, open_dataset, require_folder
from wavealt.deglint.methods import (
    METHOD_DESCRIPTIONS,
    PAPER_METHOD,
    _check_method,
    apply_method,
    condition_name,
)
from wavealt.deglint.metrics import _QualityAccumulator, quality_table
from wavealt.deglint.temporal import DEFAULT_WINDOW, _half_window
from wavealt.io import atomic_write_text, frame_files, read_frames_folder, to_uint8


def _check_glinty_folders(ds: Any) -> None:
    """Every sequence has a glinty folder of >= 2 frames of one size (image headers only)."""


    ds.require_condition("glinty")
    for rec in ds.records:
        folder = ds.sequence_dir("glinty", rec.sequence_id)
        if not folder.is_dir():
            msg = f"glinty sequence folder missing: {folder}"
            raise FileNotFoundError(msg)
        files = frame_files(folder)
        if len(files) < 2:
            msg = f"{folder} holds {len(files)} frame(s); temporal deglinting needs at least 2"
            raise ValueError(msg)
        sizes = set()
        for p in files:
            try:
                with Image.open(p) as im:
                    sizes.add(im.size)
            except OSError as exc:
                msg = f"cannot read image {p}: {exc}"
                raise ValueError(msg) from None
        if len(sizes) > 1:
            msg = f"frames in {folder} have different sizes: {sorted(sizes)}"
            raise ValueError(msg)


def _quantised(frames: np.ndarray) -> np.ndarray:
    """What the PNG on disk will hold, back as float32."""

    return to_uint8(frames).astype(np.float32) / 255.0


def deglint_dataset(dataset: Path | str | Any, *, method: str = PAPER_METHOD,
                    window: int = DEFAULT_WINDOW, progress: bool = True,
                    force: bool = False) -> str:
    """Deglint every glinty sequence of a dataset folder and measure against ``clean/``.

    Writes ``DATASET/<condition>/<sequence_id>/frame_###.png`` (same layout as ``clean/``;
    ``residual`` for ``tmf``), atomically per sequence, and records the condition with its
    ``method`` and ``window`` in ``dataset.json``.  Resumes: sequences already written with the
    same method and window are kept; a condition made with other settings is refused unless
    ``force``, which rewrites it.
    When ``clean/`` exists, PSNR / SSIM / MAE of the (8-bit) output and of the untouched
    glinty frames against it are merged into ``DATASET/deglint_metrics.json`` (keyed by
    condition) and ranked in ``DATASET/deglint_table.md``.

    Input is checked before anything is written: ``window`` >= 1 and no longer than the
    shortest sequence, a ``glinty/`` folder with every sequence, at least 2 frames per
    sequence, one frame size per sequence.

    Returns
    -------
    str
        The condition name.
    """


    _check_method(method)
    _half_window(window)
    window = int(window)
    ds = dataset if isinstance(dataset, Dataset) else open_dataset(dataset)
    require_folder(ds, "deglint")  # it writes its condition as frame folders
    _check_glinty_folders(ds)
    cond = condition_name(method)
    settings = {"method": method, "window": window}
    shortest = min(r.scenario.frames for r in ds.records)
    if window > shortest:
        msg = f"window {window} is longer than the sequences ({shortest} frames); use --window <= {shortest}"
        raise ValueError(msg)
    old = ds.info.get("conditions", {}).get(cond, {})
    reuse = all(old.get(k) == v for k, v in settings.items())
    if old and not reuse and not force:
        was = ", ".join(f"{k} {old.get(k)}" for k in settings)
        msg = (f"condition {cond} was made with {was}; --force rewrites it with "
               f"{', '.join(f'{k} {v}' for k, v in settings.items())}")
        raise ValueError(msg)
    ds.register_condition(cond, METHOD_DESCRIPTIONS[method], complete=False, **settings)
    have_clean = "clean" in ds.conditions
    q_method, q_glinty = _QualityAccumulator(), _QualityAccumulator()
    metrics_path = ds.root / "deglint_metrics.json"
    metrics: dict[str, Any] = {}
    if metrics_path.is_file():
        try:
            metrics = json.loads(metrics_path.read_text(encoding="utf-8"))
        except json.JSONDecodeError:
            metrics = {}
    # glinty and clean never change for a dataset (a pure function of its config): a baseline
    # row measured over every sequence is kept rather than measured again
    n_total = sum(r.scenario.frames for r in ds.records)
    old_base = metrics.get("glinty", {})
    keep_base = (old_base.get("n_sequences") == len(ds.records)
                 and old_base.get("n_frames") == n_total)
    for rec in tqdm(ds.records, desc=f"deglint {cond}", unit="seq", disable=not progress):
        sid = rec.sequence_id
        if reuse and ds.has_sequence(cond, sid):
            if not have_clean:
                continue
            glinty = None
            # the condition is flagged incomplete while this runs: read its folder directly
            out = read_frames_folder(ds.sequence_dir(cond, sid))
        else:
            glinty = ds.read_frames("glinty", sid)
            out = _quantised(apply_method(glinty, method, window=window))
            ds.write_frames(cond, sid, out)
        if have_clean:
            clean = ds.read_frames("clean", sid)
            q_method.add(out, clean)
            if not keep_base:
                if glinty is None:
                    glinty = ds.read_frames("glinty", sid)
                q_glinty.add(glinty, clean)
    ds.register_condition(cond, METHOD_DESCRIPTIONS[method], complete=True, **settings)
    if have_clean and ds.records:
        if not keep_base:
            metrics["glinty"] = {"method": "none", "window": None, **q_glinty.result()}
        metrics[cond] = {**settings, **q_method.result()}
        atomic_write_text(metrics_path, json.dumps(metrics, indent=2, sort_keys=True) + "\n")
        atomic_write_text(ds.root / "deglint_table.md", quality_table(metrics))
    return cond
