"""The ``paper`` renderer: a Phillips-spectrum sea (:mod:`wavealt.sim.sea.surface`) shaded by
paper eq. (3) (:mod:`wavealt.sim.light.optics`) with one exposure per sequence."""

from __future__ import annotations

import math

import numpy as np

from wavealt.camera import Camera
from wavealt.sim.base import SequenceData, domain_points
from wavealt.sim.config import PaperConfig, Scenario, SimConfig
from wavealt.sim.light.optics import Optics, render_pair, sun_vector
from wavealt.sim.sea.surface import OceanSurface


def optics_of(config: SimConfig) -> Optics:
    """The paper optics of ``config`` (its ``paper`` sub-config and refractive index)."""
    pc: PaperConfig = config.paper
    return Optics(water_rgb=tuple(pc.water_rgb), sky_rgb=tuple(pc.sky_rgb),
                  refractive_index=config.refractive_index,
                  lobe_exponent=pc.lobe_exponent, display_rgb=tuple(pc.display_rgb),
                  contrast=pc.contrast)


def camera_of(scenario: Scenario, size: int) -> Camera:
    return Camera(size, size, scenario.focal_px, scenario.altitude_m)


def make_surface(scenario: Scenario, size: int, pad: float) -> OceanSurface:
    """The sea of ``scenario``, sampled at the camera's nadir ground sampling distance on a
    square periodic domain ``pad`` times the footprint (so no tiling is visible)."""
    cam = camera_of(scenario, size)
    rng = np.random.default_rng([scenario.seed, 1])
    return OceanSurface(n=domain_points(size, pad), dx_m=cam.gsd_m,
                        wind_speed_mps=scenario.wind_speed_mps,
                        wind_dir_rad=math.radians(scenario.wind_dir_deg), rng=rng)


class PaperRenderer:
    """The renderer of paper §3.1: reads the common config and ``config.paper``."""

    name = "paper"

    def render(self, scenario: Scenario, config: SimConfig, *,
               with_height: bool = False) -> SequenceData:
        size = int(config.size)
        surf = make_surface(scenario, size, config.domain_pad)
        times = np.arange(scenario.frames) / scenario.fps
        fields = list(surf.iter_fields(times, crop=(size, size),
                                       velocity_mps=scenario.camera_velocity_mps,
                                       with_height=with_height))
        sx = np.stack([f["slope_x"] for f in fields])
        sy = np.stack([f["slope_y"] for f in fields])
        cam = camera_of(scenario, size)
        sun = sun_vector(math.radians(scenario.sun_zenith_deg),
                         math.radians(scenario.sun_azimuth_deg))
        clean, glinty = render_pair(sx, sy, cam.view_vectors(), sun,
                                    glint_severity=scenario.glint_severity,
                                    optics=optics_of(config),
                                    clean_glint_severity=config.paper.clean_glint_severity)
        height = np.stack([f["height_m"] for f in fields]) if with_height else None
        return SequenceData(clean=clean, glinty=glinty, slope_x=sx, slope_y=sy, height_m=height)


__all__ = ["PaperRenderer", "camera_of", "make_surface", "optics_of"]
