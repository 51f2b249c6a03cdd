"""Devices: ``auto`` resolves to what this machine has, an unavailable device fails in one
line before anything is written, and the run records where it trained."""

from __future__ import annotations

import json

import pytest
import torch

from wavealt.altimetry.data import TrainConfig
from wavealt.altimetry.device import autocast, precision, resolve_device, to_device
from wavealt.altimetry.predict import load_run
from wavealt.altimetry.train import train

TINY = dict(model="resnet-tiny", batch_size=8, lr=3e-3, jitter=0.0)
no_cuda = pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has CUDA")


def _has_mps() -> bool:
    mps = getattr(torch.backends, "mps", None)
    return bool(mps is not None and mps.is_available())


@no_cuda
def test_auto_resolves_to_what_is_here() -> None:
    assert resolve_device("auto").type == ("mps" if _has_mps() else "cpu")
    assert resolve_device("CPU") == torch.device("cpu")


@no_cuda
@pytest.mark.parametrize("spec", ["cuda", "cuda:0", "cuda:3"])
def test_cuda_without_cuda_is_a_one_line_error(spec: str) -> None:
    with pytest.raises(ValueError, match=r"CUDA is not available") as exc:
        resolve_device(spec)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("spec", ["gpu", "cuda:x", "cuda:-1", "", "tpu"])
def test_unknown_device_names_the_choices(spec: str) -> None:
    with pytest.raises(ValueError, match=r"--device must be auto, cpu, cuda, cuda:N or mps"):
        resolve_device(spec)


def test_cpu_keeps_float32_and_the_tensor_itself() -> None:
    cpu = torch.device("cpu")
    x = torch.rand(2, 3, 8, 8)
    assert to_device(x, cpu) is x
    assert precision(cpu) == "float32"
    with autocast(cpu):
        assert (x @ x.transpose(-1, -2)).dtype == torch.float32




@no_cuda
def test_cli_cuda_fails_before_writing(tiny_dataset, tmp_path, run_cli) -> None:
    run = tmp_path / "run"
    for args in (["train", str(tiny_dataset), "--out", str(run), "--device", "cuda",
                  "--model", "resnet-tiny", "--epochs", "1"],
                 ["reproduce", str(tmp_path / "rep"), "--device", "cuda"]):
        code, _, err = run_cli(args)
        assert code == 2, err
        assert "CUDA is not available" in err
        assert err.strip().count("\n") == 0
    assert not run.exists()
    assert not (tmp_path / "rep").exists()


def test_reproduce_rejects_an_unknown_training_run(tmp_path, run_cli) -> None:
    code, _, err = run_cli(["reproduce", str(tmp_path / "rep"), "--train", "clean,bogus"])
    assert code == 2
    assert "train condition must be one of" in err and "'bogus'" in err
    assert not (tmp_path / "rep").exists()


def test_reproduce_takes_all_for_every_training_run(tmp_path, run_cli) -> None:
    # validation passes "all" (the help's default) and stops at the next check: OUT a file
    out = tmp_path / "rep"
    out.write_text("keep me", encoding="utf-8")
    code, _, err = run_cli(["reproduce", str(out), "--train", "all"])
    assert code == 2
    assert "is a file" in err and "train condition" not in err
    assert out.read_text(encoding="utf-8") == "keep me"


def test_config_records_device_and_history_the_input_share(tiny_dataset, tmp_path) -> None:
    run = tmp_path / "run"
    train(tiny_dataset, run, TrainConfig(condition="bright", epochs=1, **TINY), progress=False,
          device="cpu")
    info = json.loads((run / "config.json").read_text(encoding="utf-8"))
    assert info["device"]["device"] == "cpu"
    assert info["device"]["precision"] == "float32"
    assert info["device"]["torch"] == torch.__version__
    assert info["device"]["name"]
    hist = json.loads((run / "history.json").read_text(encoding="utf-8"))
    assert 0.0 <= hist[0]["input_seconds"] <= hist[0]["seconds"]
    assert hist[0]["images"] > 0
    pred = load_run(run, device="auto")
    assert pred.device == resolve_device("auto")
