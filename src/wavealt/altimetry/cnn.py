"""ResNet altitude regressors in plain torch (paper §3.2), torchvision-compatible names.

The paper replaces ResNet-50's 1000-way classifier by one linear layer that outputs the
altitude.  The module names follow torchvision's ``resnet50`` exactly (``conv1``, ``bn1``,
``layer1`` .. ``layer4`` of ``Bottleneck`` blocks with ``conv1/bn1/conv2/bn2/conv3/bn3`` and
``downsample.0/downsample.1``, ``fc``), so a torchvision state dict loads with
:func:`load_pretrained` (its ``fc`` is skipped: the head here has one output).  Nothing is
ever downloaded.

Registered models (:data:`MODELS`):

``resnet50``     Bottleneck (3, 4, 6, 3), width 64: the paper's model, 23,510,081 parameters.
``resnet18``     BasicBlock (2, 2, 2, 2), width 64 (torchvision ``resnet18`` names).
``resnet-small`` Bottleneck (1, 1, 1, 1), width 16: the ``reproduce --scale quick`` model.
``resnet-tiny``  Bottleneck (1, 1, 1, 1), width 4: for tests.

Every model takes ``in_channels`` (3 for one RGB frame; ``T`` for the temporal variant that
stacks ``T`` grayscale frames as channels).  Inputs are ``(B, C, H, W)`` with ``H, W >= 32``
(five stride-2 stages; the global average pool makes any larger size work).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import torch
from torch import nn

#: Smallest image side the networks accept: five stride-2 stages leave a 1x1 map at 32 px.
MIN_INPUT_PX = 32


def _conv3x3(cin: int, cout: int, stride: int = 1) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, kernel_size=3, stride=stride, padding=1, bias=False)


def _conv1x1(cin: int, cout: int, stride: int = 1) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, kernel_size=1, stride=stride, bias=False)


class BasicBlock(nn.Module):
    """Two 3x3 convolutions with a residual connection (torchvision ``BasicBlock``)."""

    expansion = 1

    def __init__(self, cin: int, width: int, stride: int = 1,
                 downsample: nn.Module | None = None) -> None:
        super().__init__()
        self.conv1 = _conv3x3(cin, width, stride)
        self.bn1 = nn.BatchNorm2d(width)
        self.conv2 = _conv3x3(width, width)
        self.bn2 = nn.BatchNorm2d(width)
        self.relu = nn.ReLU(inplace=True)
        self.downsample = downsample

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        identity = x if self.downsample is None else self.downsample(x)
        out = self.relu(self.bn1(self.conv1(x)))
        out = self.bn2(self.conv2(out))
        return self.relu(out + identity)


class Bottleneck(nn.Module):
    """1x1 reduce, 3x3 (carrying the stride, as torchvision v1.5), 1x1 expand x4."""

    expansion = 4

    def __init__(self, cin: int, width: int, stride: int = 1,
                 downsample: nn.Module | None = None) -> None:
        super().__init__()
        self.conv1 = _conv1x1(cin, width)
        self.bn1 = nn.BatchNorm2d(width)
        self.conv2 = _conv3x3(width, width, stride)
        self.bn2 = nn.BatchNorm2d(width)
        self.conv3 = _conv1x1(width, width * self.expansion)
        self.bn3 = nn.BatchNorm2d(width * self.expansion)
        self.relu = nn.ReLU(inplace=True)
        self.downsample = downsample

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        identity = x if self.downsample is None else self.downsample(x)
        out = self.relu(self.bn1(self.conv1(x)))
        out = self.relu(self.bn2(self.conv2(out)))
        out = self.bn3(self.conv3(out))
        return self.relu(out + identity)


class ResNetRegressor(nn.Module):
    """ResNet trunk with a one-output linear head (altitude, in normalised units).

    Parameters
    ----------
    block : BasicBlock or Bottleneck
        Residual block type.
    layers : tuple of 4 int
        Blocks per stage.
    width : int
        Channels of the stem and of the first stage (64 in torchvision).
    in_channels : int
        Input channels ``C`` of ``(B, C, H, W)``.
    """

    def __init__(self, block: type[BasicBlock] | type[Bottleneck], layers: tuple[int, ...], *,
                 width: int = 64, in_channels: int = 3) -> None:
        super().__init__()
        if len(layers) != 4 or any(int(n) < 1 for n in layers):
            msg = f"layers must be four positive block counts; got {layers!r}"
            raise ValueError(msg)
        if int(in_channels) < 1:
            msg = f"in_channels must be >= 1; got {in_channels!r}"
            raise ValueError(msg)
        self.in_channels = int(in_channels)
        self.conv1 = nn.Conv2d(self.in_channels, width, kernel_size=7, stride=2, padding=3,
                               bias=False)
        self.bn1 = nn.BatchNorm2d(width)
        self.relu = nn.ReLU(inplace=True)
        self.maxpool = nn.MaxPool2d(kernel_size=3, stride=2, padding=1)
        self._cin = width
        self.layer1 = self._make_layer(block, width, layers[0], 1)
        self.layer2 = self._make_layer(block, width * 2, layers[1], 2)
        self.layer3 = self._make_layer(block, width * 4, layers[2], 2)
        self.layer4 = self._make_layer(block, width * 8, layers[3], 2)
        self.avgpool = nn.AdaptiveAvgPool2d((1, 1))
        self.num_features = width * 8 * block.expansion
        self.fc = nn.Linear(self.num_features, 1)
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            elif isinstance(m, nn.BatchNorm2d):
                nn.init.ones_(m.weight)
                nn.init.zeros_(m.bias)
        # Zero-init the last BN of each residual branch: every block starts as the identity,
        # which makes small-batch regression from scratch markedly more stable (Goyal et al. 2017).
        for m in self.modules():
            if isinstance(m, Bottleneck):
                nn.init.zeros_(m.bn3.weight)
            elif isinstance(m, BasicBlock):
                nn.init.zeros_(m.bn2.weight)

    def _make_layer(self, block: type[BasicBlock] | type[Bottleneck], width: int, blocks: int,
                    stride: int) -> nn.Sequential:
        cout = width * block.expansion
        downsample = None
        if stride != 1 or self._cin != cout:
            downsample = nn.Sequential(_conv1x1(self._cin, cout, stride), nn.BatchNorm2d(cout))
        mods = [block(self._cin, width, stride, downsample)]
        self._cin = cout
        mods += [block(self._cin, width) for _ in range(1, int(blocks))]
        return nn.Sequential(*mods)

    def check_input(self, x: torch.Tensor) -> None:
        """Raise ``ValueError`` unless ``x`` is ``(B, in_channels, H, W)`` with H, W >= 32."""
        if x.ndim != 4 or x.shape[1] != self.in_channels:
            msg = f"input must be (B, {self.in_channels}, H, W); got shape {tuple(x.shape)}"
            raise ValueError(msg)
        if min(x.shape[2], x.shape[3]) < MIN_INPUT_PX:
            msg = (f"image size {x.shape[2]}x{x.shape[3]} px is too small for the model; "
                   f"expected at least {MIN_INPUT_PX}x{MIN_INPUT_PX}")
            raise ValueError(msg)

    def forward_features(self, x: torch.Tensor) -> torch.Tensor:
        """``(B, C, H, W)`` -> pooled features ``(B, num_features)``."""
        self.check_input(x)
        x = self.maxpool(self.relu(self.bn1(self.conv1(x))))
        x = self.layer4(self.layer3(self.layer2(self.layer1(x))))
        return torch.flatten(self.avgpool(x), 1)

    def forward_head(self, features: torch.Tensor) -> torch.Tensor:
        """``(B, num_features)`` -> ``(B,)`` regression output."""
        return self.fc(features).squeeze(1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.forward_head(self.forward_features(x))


#: name -> (block, layers, width)
_SPECS: dict[str, tuple[type[BasicBlock] | type[Bottleneck], tuple[int, int, int, int], int]] = {
    "resnet50": (Bottleneck, (3, 4, 6, 3), 64),
    "resnet18": (BasicBlock, (2, 2, 2, 2), 64),
    "resnet-small": (Bottleneck, (1, 1, 1, 1), 16),
    "resnet-tiny": (Bottleneck, (1, 1, 1, 1), 4),
}

MODELS: dict[str, Callable[..., ResNetRegressor]] = {
    name: (lambda block, layers, width: (
        lambda *, in_channels=3: ResNetRegressor(block, layers, width=width,
                                                 in_channels=in_channels)))(*spec)
    for name, spec in _SPECS.items()
}


def create_model(name: str, *, in_channels: int = 3) -> ResNetRegressor:
    """Build registered model ``name`` (see :data:`MODELS`) for ``in_channels`` inputs."""
    if name not in MODELS:
        msg = f"unknown model {name!r}; expected one of {', '.join(sorted(MODELS))}"
        raise ValueError(msg)
    return MODELS[name](in_channels=in_channels)


def count_parameters(model: nn.Module) -> int:
    """Number of trainable parameters."""
    return sum(p.numel() for p in model.parameters() if p.requires_grad)


def load_pretrained(model: ResNetRegressor, path: Path | str) -> list[str]:
    """Load trunk weights from a local torchvision-style state dict file (``torch.save``).

    The ``fc`` of the file is skipped (torchvision's has 1000 outputs).  When the model takes
    ``C != 3`` input channels, ``conv1`` of a 3-channel file is adapted by averaging it over
    colour and repeating it ``C`` times, scaled by ``3 / C`` so the activations keep their size.

    Parameters
    ----------
    model : ResNetRegressor
        Model to fill in place.
    path : path
        A local file; nothing is downloaded.

    Returns
    -------
    list of str
        Keys of the model that the file did not provide (``fc.weight``, ``fc.bias`` normally).
    """
    path = Path(path)
    if not path.is_file():
        msg = f"pretrained weights file not found: {path}"
        raise FileNotFoundError(msg)
    state = torch.load(path, map_location="cpu", weights_only=True)
    if isinstance(state, dict) and "model" in state and isinstance(state["model"], dict):
        state = state["model"]
    if not isinstance(state, dict):
        msg = f"{path} does not hold a state dict; got {type(state).__name__}"
        raise ValueError(msg)
    state = {k: v for k, v in state.items() if not k.startswith("fc.")}
    w = state.get("conv1.weight")
    if w is not None and w.shape[1] != model.in_channels:
        c = model.in_channels
        state["conv1.weight"] = w.mean(dim=1, keepdim=True).repeat(1, c, 1, 1) * (3.0 / c)
    own = model.state_dict()
    unexpected = sorted(set(state) - set(own))
    if unexpected:
        msg = f"{path} has keys the model lacks: {', '.join(unexpected[:5])}"
        raise ValueError(msg)
    for k, v in state.items():
        if own[k].shape != v.shape:
            msg = f"{path}: {k} has shape {tuple(v.shape)}; the model expects {tuple(own[k].shape)}"
            raise ValueError(msg)
    result = model.load_state_dict(state, strict=False)
    return sorted(result.missing_keys)


__all__ = ["MIN_INPUT_PX", "MODELS", "BasicBlock", "Bottleneck", "ResNetRegressor",
           "count_parameters", "create_model", "load_pretrained"]
