"""Training: learning, exact checkpoints and resume, split hygiene, augmentation, bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from wavealt.altimetry import train as train_mod
from wavealt.altimetry.data import TrainConfig, augment, centre_crop, to_model_input
from wavealt.altimetry.predict import load_run
from wavealt.altimetry.train import train
from wavealt.dataset import Dataset

TINY = dict(model="resnet-tiny", batch_size=8, lr=3e-3, jitter=0.0)


def _states_equal(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_loss_falls_when_altitude_is_learnable(tiny_dataset, tmp_path) -> None:
    res = train(tiny_dataset, tmp_path / "run", TrainConfig(condition="bright", epochs=4, **TINY),
                progress=False)
    losses = [h["train_loss"] for h in res["history"]]
    assert len(losses) == 4
    assert losses[-1] < 0.7 * losses[0]
    assert (tmp_path / "run" / "best.pt").is_file()
    assert res["best_val_mae_m"] == min(h["val_mae_m"] for h in res["history"])


def test_checkpoint_roundtrip_bit_for_bit(tiny_dataset, tmp_path) -> None:
    run = tmp_path / "run"
    train(tiny_dataset, run, TrainConfig(condition="bright", epochs=1, **TINY), progress=False)
    saved = torch.load(run / "last.pt", weights_only=False)["model"]
    loaded = load_run(run, which="last").model.state_dict()
    assert _states_equal(saved, loaded)
    torch.save(loaded, tmp_path / "again.pt")
    assert _states_equal(saved, torch.load(tmp_path / "again.pt", weights_only=True))


def test_resume_after_interrupt_equals_uninterrupted(tiny_dataset, tmp_path, monkeypatch,
                                                      interrupt_training) -> None:
    cfg = TrainConfig(condition="bright", epochs=3, **TINY)
    train(tiny_dataset, tmp_path / "full", cfg, progress=False)

    real = interrupt_training()
    with pytest.raises(KeyboardInterrupt):
        train(tiny_dataset, tmp_path / "cut", cfg, progress=False)
    monkeypatch.setattr(train_mod, "_validate", real)
    assert torch.load(tmp_path / "cut" / "last.pt", weights_only=False)["epoch"] == 0
    train(tiny_dataset, tmp_path / "cut", cfg, resume=True, progress=False)
    a = torch.load(tmp_path / "full" / "last.pt", weights_only=False)
    b = torch.load(tmp_path / "cut" / "last.pt", weights_only=False)
    assert _states_equal(a["model"], b["model"])
    assert [h["train_loss"] for h in a["history"]] == [h["train_loss"] for h in b["history"]]


def test_split_has_no_sequence_leakage(tiny_dataset, tmp_path) -> None:
    run = tmp_path / "run"
    train(tiny_dataset, run, TrainConfig(condition="bright", epochs=1, **TINY), progress=False)
    info = json.loads((run / "config.json").read_text())
    ds = Dataset(tiny_dataset)
    used = set(info["train_sequence_ids"])
    assert used == {r.sequence_id for r in ds.split("train")}
    assert not used & {r.sequence_id for r in ds.split("val") + ds.split("test")}
    assert info["train"]["condition"] == "bright"
    assert TrainConfig.from_dict(info["train"]) == TrainConfig(condition="bright", epochs=1, **TINY)


def test_temporal_variant_trains_and_predicts(tiny_dataset, tmp_path) -> None:
    run = tmp_path / "run"
    train(tiny_dataset, run, TrainConfig(condition="bright", epochs=1, temporal=True, **TINY),
          progress=False)
    pred = load_run(run)
    assert pred.model.conv1.in_channels == 4
    frames = Dataset(tiny_dataset).read_frames("bright", "seq_00000")
    assert np.isfinite(pred.predict_sequence(frames))
    with pytest.raises(ValueError, match="needs 4 frames"):
        pred.predict_sequence(frames[:3])


def test_to_model_input_is_the_layout_conversion() -> None:
    x = np.random.default_rng(0).random((2, 5, 6, 3)).astype(np.float32)
    t = to_model_input(x, temporal=False, mean=[0, 0, 0], std=[1, 1, 1])
    assert t.shape == (2, 3, 5, 6)
    assert t[1, 2, 4, 5] == x[1, 4, 5, 2]
    seq = np.random.default_rng(1).random((2, 4, 5, 6, 3)).astype(np.float32)
    ts = to_model_input(seq, temporal=True, mean=[0.5], std=[2.0])
    assert ts.shape == (2, 4, 5, 6)
    np.testing.assert_allclose(ts[0, 3], (seq[0, 3] @ train_mod.LUMA - 0.5) / 2.0, rtol=1e-6)
    with pytest.raises(ValueError, match=r"\(B, H, W, 3\)"):
        to_model_input(seq, temporal=False, mean=[0, 0, 0], std=[1, 1, 1])


def test_augment_keeps_pixel_scale_and_is_seeded() -> None:
    rng = np.random.default_rng(0)
    frames = (rng.random((3, 40, 40, 3)) * 255).astype(np.uint8)
    a = augment(frames, 32, 0.0, np.random.default_rng(5))
    b = augment(frames, 32, 0.0, np.random.default_rng(5))
    assert a.shape == (3, 32, 32, 3)
    np.testing.assert_array_equal(a, b)
    # no resize: the crop is an exact (possibly flipped) window of the input
    src = frames.astype(np.float32) / 255.0
    windows = [src[:, y:y + 32, x:x + 32] for y in range(9) for x in range(9)]
    flips = [w for win in windows for w in (win, win[:, ::-1], win[:, :, ::-1], win[:, ::-1, ::-1])]
    assert any(np.array_equal(a, w) for w in flips)
    assert centre_crop(src, 32).shape == (3, 32, 32, 3)
    np.testing.assert_array_equal(centre_crop(src, 32), src[:, 4:36, 4:36])


def test_bad_input(tiny_dataset, tmp_path) -> None:
    with pytest.raises(FileNotFoundError, match="no condition 'residual'"):
        train(tiny_dataset, tmp_path / "r0", TrainConfig(condition="residual", **TINY),
              progress=False)
    with pytest.raises(ValueError, match="crop_px 60 is larger than the images"):
        train(tiny_dataset, tmp_path / "r1", TrainConfig(condition="bright", crop_px=60, **TINY),
              progress=False)
    with pytest.raises(ValueError, match="crop_px must be an integer >= 32"):
        TrainConfig(crop_px=16)
    with pytest.raises(ValueError, match="unknown model"):
        TrainConfig(model="vgg")
    with pytest.raises(ValueError, match="unknown train config key"):
        TrainConfig.from_dict({"epochz": 3})
    with pytest.raises(FileNotFoundError, match="has no best.pt"):
        load_run(tmp_path)
    run = tmp_path / "r2"
    train(tiny_dataset, run, TrainConfig(condition="bright", epochs=1, **TINY), progress=False)
    with pytest.raises(ValueError, match="already holds a training run"):
        train(tiny_dataset, run, TrainConfig(condition="bright", epochs=1, **TINY), progress=False)
    with pytest.raises(ValueError, match="config differs in lr"):
        train(tiny_dataset, run, TrainConfig(condition="bright", epochs=1, **{**TINY, "lr": 1e-2}),
              resume=True, progress=False)
