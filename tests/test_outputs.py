"""Outputs: files get the permissions the umask gives, and nothing written earlier is
replaced without being asked to."""

from __future__ import annotations

import os
import shutil
import stat

import numpy as np
import pytest

from wavealt.io import atomic_save_npz, atomic_write_text, write_frames_folder


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
    # a frame folder is written under a temporary name (mkdtemp: 0o700) and renamed
    write_frames_folder(tmp_path / "seq", np.zeros((2, 4, 4, 3), np.float32))
    assert stat.S_IMODE((tmp_path / "seq").stat().st_mode) == mode | (0o111 & ~mask)
    assert stat.S_IMODE((tmp_path / "seq" / "frame_000.png").stat().st_mode) == mode


def test_a_commands_outputs_respect_the_umask(tiny_dataset, tmp_path, umask, run_cli) -> None:
    umask(0o027)
    out = tmp_path / "eval"
    assert run_cli(["evaluate", str(tiny_dataset), "--estimator", "constant", "--out", str(out),
                    "--conditions", "clean"])[0] == 0
    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in out.iterdir()}
    assert {"metrics.json", "predictions.csv", "table.md",
            "fig5_predicted_vs_actual.png"} <= set(modes)
    assert set(modes.values()) == {0o640}, modes



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
    assert code == 2 and err.count("\n") == 1
    assert err == (f"wavealt: error: --resume: {run} holds no training run to continue "
                   "(drop --resume to start one)\n")
    assert "resume=True" not in err and not run.exists()


def test_deglint_refuses_another_window_and_a_window_longer_than_the_sequences(
        tiny_dataset, tmp_path, run_cli) -> None:
    ds = tmp_path / "ds"
    shutil.copytree(tiny_dataset, ds)
    base = ["deglint", str(ds), "--method", "tmf-min", "--no-figures"]
    assert run_cli([*base, "--window", "3"])[0] == 0
    before = sorted((ds / "tmf-min").rglob("*.png"))
    stamp = [p.stat().st_mtime_ns for p in before]
    code, _, err = run_cli([*base, "--window", "2"])
    assert code == 2 and err.count("\n") == 1
    assert "condition tmf-min was made with method tmf-min, window 3; --force rewrites it" in err
    assert [p.stat().st_mtime_ns for p in before] == stamp  # nothing replaced
    code, _, err = run_cli([*base, "--window", "50"])
    assert code == 2 and err.count("\n") == 1
    assert "window 50 is longer than the sequences (4 frames); use --window <= 4" in err
    assert run_cli([*base, "--window", "2", "--force"])[0] == 0
    assert run_cli([*base, "--window", "2"])[0] == 0  # the same settings: resumed, not refused
