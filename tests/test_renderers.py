"""The renderer interface: every registered renderer, by name, keeps the same contract."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from wavealt.sim import RENDERERS, Renderer, Sea, SequenceData, preset_config
from wavealt.sim.config import RENDERER_SECTIONS, SECTIONS
from wavealt.sim.sea.realistic import RealisticSea
from wavealt.sim.sea.surface import OceanSurface


def test_the_registry_and_the_configs_name_the_same_renderers() -> None:
    assert set(RENDERERS) == set(RENDERER_SECTIONS)
    for name, renderer in RENDERERS.items():
        assert renderer.name == name and isinstance(renderer, Renderer)
        assert set(RENDERER_SECTIONS[name]) <= set(SECTIONS)


@pytest.mark.parametrize("name", sorted(RENDERERS))
def test_every_renderer_returns_paired_frames_in_range(name) -> None:
    cfg = preset_config("paper", size=32, frames=3).replace(renderer=name)
    data = RENDERERS[name].render(cfg.sample_scenario(0), cfg, with_height=True)
    assert isinstance(data, SequenceData)
    for frames in (data.clean, data.glinty):
        assert frames.shape == (3, 32, 32, 3) and frames.dtype == np.float32
        assert 0.0 <= frames.min() and frames.max() <= 1.0
    for field in (data.slope_x, data.slope_y, data.height_m):
        assert field.shape == (3, 32, 32)
    # the glint only adds light (compression noise aside, as in the realistic sensor)
    assert float(np.mean(data.glinty)) >= float(np.mean(data.clean))


@pytest.mark.parametrize("sea", [OceanSurface, RealisticSea])
def test_both_seas_offer_the_sea_protocols_fields(sea) -> None:
    instance = (sea(n=16, dx_m=0.05, wind_speed_mps=5.0, wind_dir_rad=0.0, rng=0)
                if sea is OceanSurface else None)
    assert instance is None or isinstance(instance, Sea)
    params = inspect.signature(sea.iter_fields).parameters
    assert {"times_s", "crop", "velocity_mps", "with_height"} <= set(params)
