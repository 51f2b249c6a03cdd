"""Outputs: files get the permissions the umask gives, and nothing written earlier is
replaced without being asked to."""

from __future__ import annotations

import os
import stat

import numpy as np
import pytest

from wavealt.io import atomic_save_npz, atomic_write_text


@pytest.fixture
def umask():
    old = os.umask(0o022)
    try:
        yield os.umask
    finally:
        os.umask(old)


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_atomic_writes_respect_the_umask(tmp_path, umask, mask, mode) -> None:
    umask(mask)
    atomic_write_text(tmp_path / "a.json", "{}")
    atomic_save_npz(tmp_path / "b.npz", x=np.zeros(3))
    for name in ("a.json", "b.npz"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == mode




def test_evaluate_refuses_to_replace_results(tiny_dataset, tmp_path, run_cli) -> None:
    out = tmp_path / "eval"
    argv = ["evaluate", str(tiny_dataset), "--estimator", "constant", "--out", str(out),
            "--conditions", "clean"]
    assert run_cli(argv)[0] == 0
    before = (out / "metrics.json").read_bytes()
    code, _, err = run_cli([*argv[:-2], "--conditions", "glinty"])
    assert code == 2 and "already holds an evaluation (metrics.json)" in err and "--force" in err
    assert (out / "metrics.json").read_bytes() == before
    assert run_cli([*argv[:-2], "--conditions", "glinty", "--force"])[0] == 0
    assert (out / "metrics.json").read_bytes() != before
    afile = tmp_path / "a.txt"
    afile.write_text("keep")
    code, _, err = run_cli([*argv[:-4], "--out", str(afile), "--conditions", "clean"])
    assert code == 2 and "is a file; give a folder" in err and afile.read_text() == "keep"


def test_train_resume_needs_a_run(tiny_dataset, tmp_path, run_cli) -> None:
    run = tmp_path / "run"
    code, _, err = run_cli(["train", str(tiny_dataset), "--out", str(run), "--resume",
                              "--model", "resnet-tiny", "--epochs", "1"])
    assert code == 2 and "holds no training run to continue" in err
    assert not run.exists()
