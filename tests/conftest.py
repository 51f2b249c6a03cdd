"""Shared fixtures: a tiny generated dataset, with a condition where altitude is learnable."""

from __future__ import annotations

import numpy as np
import pytest

from wavealt.dataset import Dataset, simulate_dataset
from wavealt.sim.config import preset_config


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory: pytest.TempPathFactory):
    """12 sequences x 4 frames of 48x48 px, plus a ``bright`` condition whose mean intensity
    encodes the altitude (so a tiny CNN can learn it in a few epochs)."""
    root = tmp_path_factory.mktemp("data") / "ds"
    simulate_dataset(root, preset_config("paper", sequences=12, size=48, frames=4), progress=False)
    ds = Dataset(root)
    rng = np.random.default_rng(0)
    for r in ds.records:
        level = 0.1 + 0.15 * (r.altitude_m - 1.0)
        tex = rng.random((4, 48, 48, 1)) * 0.1
        ds.write_frames("bright", r.sequence_id,
                        np.clip(np.broadcast_to(level + tex, (4, 48, 48, 3)), 0, 1).astype(np.float32))
    ds.register_condition("bright", "test condition: intensity encodes altitude")
    return root


@pytest.fixture
def run_cli(capsys):
    """Run ``wavealt ARGV`` in-process as the console script does: ``(exit code, stdout,
    stderr)``."""
    from wavealt.cli import main

    def run(argv: list[str]) -> tuple[int, str, str]:
        try:
            main(argv)
            code = 0
        except SystemExit as exc:
            code = int(exc.code or 0)
        out = capsys.readouterr()
        return code, out.out, out.err

    return run


@pytest.fixture
def interrupt_training(monkeypatch):
    """``interrupt_training()``: the next training run stops with KeyboardInterrupt as its
    second validation begins (after one whole epoch, as Ctrl-C would); returns the real
    ``_validate`` to put back."""
    import wavealt.altimetry.train as train_mod

    real = train_mod._validate

    def arm():
        calls = {"n": 0}

        def interrupt_in_epoch_2(*args, **kwargs):
            calls["n"] += 1
            if calls["n"] == 2:
                raise KeyboardInterrupt
            return real(*args, **kwargs)

        monkeypatch.setattr(train_mod, "_validate", interrupt_in_epoch_2)
        return real

    return arm
