"""What every renderer shares: the sequence it returns, the interfaces of a renderer and
of a sea, and the size of the periodic sea domain."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
import scipy.fft

from wavealt.sim.config import Scenario, SimConfig


@dataclass
class SequenceData:
    """Rendered frames and, on request, the ground-truth surface on the image grid.

    ``clean`` and ``glinty`` are ``(T, H, W, 3)`` float32 in [0, 1]; ``height_m``,
    ``slope_x`` and ``slope_y`` are ``(T, H, W)`` float32 (after Cox–Munk rescaling).
    """

    clean: np.ndarray
    glinty: np.ndarray
    slope_x: np.ndarray
    slope_y: np.ndarray
    height_m: np.ndarray | None = None


@runtime_checkable
class Sea(Protocol):
    """A periodic sea surface that evolves in time (:class:`wavealt.sim.sea.surface.OceanSurface`,
    :class:`wavealt.sim.sea.realistic.RealisticSea`)."""

    n: int
    dx_m: float

    def iter_fields(self, times_s: np.ndarray, *, crop: tuple[int, int] | None = None,
                    velocity_mps: tuple[float, float] = (0.0, 0.0),
                    with_height: bool = False) -> Iterator[dict[str, np.ndarray]]:
        """Yield ``{"slope_x", "slope_y"[, "height_m"]}`` ``(H, W)`` float32 fields, one per
        time, of the ``crop`` window seen by a camera moving at ``velocity_mps``."""
        ...


@runtime_checkable
class Renderer(Protocol):
    """Turns one scenario into its paired clean/glinty frames.

    ``name`` is the value of ``SimConfig.renderer`` that selects it; ``render`` reads the
    common config and the sub-configs of ``RENDERER_SECTIONS[name]``. Implementations:
    :class:`wavealt.sim.paper.PaperRenderer`, :class:`wavealt.sim.realistic.RealisticRenderer`;
    the registry is :data:`wavealt.sim.generate.RENDERERS`.
    """

    name: str

    def render(self, scenario: Scenario, config: SimConfig, *,
               with_height: bool = False) -> SequenceData:
        ...


def domain_points(size_px: int, pad: float) -> int:
    """Even FFT-friendly grid size of at least ``pad * size_px`` points."""
    n = scipy.fft.next_fast_len(int(math.ceil(pad * size_px)))
    while n % 2:
        n = scipy.fft.next_fast_len(n + 1)
    return n


__all__ = ["Renderer", "Sea", "SequenceData", "domain_points"]
