"""ResNet regressors: torchvision names, parameter count, shapes, gradients, bad input."""

from __future__ import annotations

import pytest
import torch

from wavealt.altimetry.cnn import (
    MIN_INPUT_PX,
    MODELS,
    count_parameters,
    create_model,
    load_pretrained,
)


def test_resnet50_torchvision_names_and_parameter_count() -> None:
    m = create_model("resnet50")
    # ResNet-50 (25,557,032 with the 1000-way classifier) minus fc (2049000) plus Linear(2048, 1)
    assert count_parameters(m) == 25_557_032 - 2_049_000 + 2_049 == 23_510_081
    keys = set(m.state_dict())
    for k in ("conv1.weight", "bn1.running_mean", "bn1.num_batches_tracked",
              "layer1.0.conv3.weight", "layer1.0.downsample.0.weight",
              "layer1.0.downsample.1.running_var", "layer3.5.bn3.weight",
              "layer4.2.conv2.weight", "fc.weight", "fc.bias"):
        assert k in keys
    assert "layer3.6.conv1.weight" not in keys and "layer4.3.conv1.weight" not in keys
    blocks = {k.split(".")[0] + "." + k.split(".")[1] for k in keys if k.startswith("layer")}
    assert sorted(blocks) == sorted(f"layer{i + 1}.{j}" for i, n in enumerate((3, 4, 6, 3))
                                    for j in range(n))
    assert tuple(m.fc.weight.shape) == (1, 2048)
    assert len(keys) == 320  # torchvision resnet50 state dict: 320 entries (fc included)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_registry_models_build(name: str) -> None:
    m = create_model(name, in_channels=10)
    assert m.conv1.in_channels == 10


def test_forward_shapes_and_split() -> None:
    m = create_model("resnet-tiny").eval()
    x = torch.rand(2, 3, 40, 48)
    f = m.forward_features(x)
    assert f.shape == (2, m.num_features)
    y = m.forward_head(f)
    assert y.shape == (2,)
    torch.testing.assert_close(y, m(x))


def test_non_contiguous_input() -> None:
    m = create_model("resnet-tiny").eval()
    x = torch.rand(2, 40, 40, 3).permute(0, 3, 1, 2)
    assert not x.is_contiguous()
    torch.testing.assert_close(m(x), m(x.contiguous()))


def test_gradcheck_float64_tiny() -> None:
    torch.manual_seed(0)
    m = create_model("resnet-tiny").double().eval()
    x = torch.rand(1, 3, 32, 32, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda t: m(t), (x,), eps=1e-6, atol=1e-4, fast_mode=True)


def test_bad_input() -> None:
    m = create_model("resnet-tiny")
    with pytest.raises(ValueError, match="too small"):
        m(torch.rand(2, 3, MIN_INPUT_PX - 1, 64))
    with pytest.raises(ValueError, match=r"input must be \(B, 3, H, W\)"):
        m(torch.rand(2, 4, 64, 64))
    with pytest.raises(ValueError, match="unknown model 'resnet51'"):
        create_model("resnet51")


def test_load_pretrained_roundtrip_skips_fc_and_adapts_conv1(tmp_path) -> None:
    torch.manual_seed(1)
    src = create_model("resnet-tiny")
    state = {k: v for k, v in src.state_dict().items()}
    state["fc.weight"] = torch.zeros(1000, src.num_features)  # a classifier head is skipped
    state["fc.bias"] = torch.zeros(1000)
    path = tmp_path / "w.pt"
    torch.save(state, path)
    torch.manual_seed(2)
    dst = create_model("resnet-tiny")
    missing = load_pretrained(dst, path)
    assert missing == ["fc.bias", "fc.weight"]
    torch.testing.assert_close(dst.layer2[0].conv2.weight, src.layer2[0].conv2.weight)
    gray = create_model("resnet-tiny", in_channels=5)
    load_pretrained(gray, path)
    expect = src.conv1.weight.mean(1, keepdim=True).repeat(1, 5, 1, 1) * 3 / 5
    torch.testing.assert_close(gray.conv1.weight, expect)
    with pytest.raises(FileNotFoundError, match="not found"):
        load_pretrained(dst, tmp_path / "missing.pt")
    torch.save({"conv1.weight": torch.zeros(4, 3, 3, 3)}, tmp_path / "bad.pt")
    with pytest.raises(ValueError, match="conv1.weight has shape"):
        load_pretrained(dst, tmp_path / "bad.pt")
