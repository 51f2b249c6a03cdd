"""The ``realistic`` pipeline: physical sea -> sky, glint, glitter, foam -> camera.

The renderer :class:`RealisticRenderer` (``config.renderer == "realistic"``); it reads the
common config, ``config.realistic`` and ``config.sensor``.
All radiances are in units of the sun's normal irradiance per steradian (``E_sun = 1``):

    L_clean  = (1 - f) [F(N.c) L_sky(r) + (1 - F) R_rs E_d] + f A E_d / pi
    L_glinty = L_clean + (1 - f) g mu_s rho / pi

with the reflected sky ``L_sky(r)`` of :mod:`wavealt.sim.light.sky` along the mirror direction
``r``, the remote-sensing reflectance of the water ``R_rs`` (sr^-1), the downwelling
irradiance ``E_d = mu_s (1 + diffuse_ratio)``, the foam cover ``f`` of albedo ``A``
(:func:`wavealt.sim.light.glitter.whitecap_field`), the glint reflectance ``rho`` of resolved plus
sub-pixel facets (:func:`wavealt.sim.light.glitter.glint_reflectance`) and the scenario's
``glint_severity`` ``g`` as the direct-sun transmittance.  :mod:`wavealt.sim.sensor` then exposes,
adds noise, vignettes and encodes.

Per-sequence values that the manifest does not list (spreading exponent, inverse wave age,
exposure offset, roll, pitch, vignetting) are drawn from the config's ranges with the
sequence's own seed, so the dataset stays a pure function of its config.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wavealt.sim.base import SequenceData, domain_points
from wavealt.sim.config import RealisticConfig, Scenario, SimConfig
from wavealt.sim.light.glitter import (
    advected_crops,
    glint_reflectance,
    whitecap_field,
    whitecap_fraction,
)
from wavealt.sim.light.optics import fresnel_unpolarised, sun_vector
from wavealt.sim.light.sky import SkyModel, reflect_components
from wavealt.sim.sea.realistic import RealisticSea, SeaSpectrum
from wavealt.sim.sensor import attitude_view_vectors, capture_pair, vignetting_map

#: Remote-sensing reflectance of clear open water in R, G, B, sr^-1 (order of Mobley 1994).
WATER_RRS = (0.0008, 0.0030, 0.0055)
#: Albedo of fresh foam (Koepke 1984: ~0.55 in the visible for dense foam).
FOAM_ALBEDO = 0.5
DIFFUSE_RATIO = 0.15


@dataclass(frozen=True)
class RealisticDraws:
    """Per-sequence values of the realistic preset not held by :class:`Scenario`."""

    spreading_s: float
    inverse_wave_age: float
    exposure_ev: float
    roll_deg: float
    pitch_deg: float
    vignetting: float


def realistic_draws(scenario: Scenario, config: SimConfig) -> RealisticDraws:
    """Draw the extra per-sequence values from ``config``'s ranges and ``scenario.seed``."""
    rng = np.random.default_rng([scenario.seed, 2])
    rc: RealisticConfig = config.realistic

    def draw(r: tuple[float, float]) -> float:
        return float(r[0] + (r[1] - r[0]) * rng.random())

    return RealisticDraws(spreading_s=draw(rc.spreading_s),
                          inverse_wave_age=draw(rc.inverse_wave_age),
                          exposure_ev=draw(rc.exposure_ev), roll_deg=draw(rc.roll_deg),
                          pitch_deg=draw(rc.pitch_deg), vignetting=draw(rc.vignetting))


def make_sea(scenario: Scenario, config: SimConfig, draws: RealisticDraws, *,
             margin_px: int = 0) -> RealisticSea:
    """The physical sea of ``scenario`` on the pixel-GSD grid (see :mod:`wavealt.sim.sea.realistic`).

    The periodic domain spans ``domain_pad`` footprints, and at least the footprint plus
    ``margin_px`` on each side (room for the shift of a tilted camera).  Waves longer than
    the domain are the sea's long-wave modes, so a small pad shows no repetition.
    """
    size = int(config.size)
    n = max(domain_points(size, config.domain_pad),
            domain_points(size + 2 * abs(int(margin_px)), 1.0))
    spec = SeaSpectrum(wind_speed_mps=scenario.wind_speed_mps,
                       wind_dir_rad=math.radians(scenario.wind_dir_deg),
                       spectrum=config.realistic.spectrum, spreading=config.realistic.spreading, spreading_s=draws.spreading_s,
                       inverse_wave_age=draws.inverse_wave_age)
    return RealisticSea(spec, n=n,
                        dx_m=scenario.altitude_m / scenario.focal_px,
                        rng=np.random.default_rng([scenario.seed, 1]))


def render_radiance(sx: np.ndarray, sy: np.ndarray, view: np.ndarray, sun: np.ndarray, *,
                    subpixel_slope_variance: float, glint_severity: float,
                    foam: np.ndarray | None = None,
                    refractive_index: float = 1.34) -> tuple[np.ndarray, np.ndarray]:
    """Clean and glinty radiance ``(T, H, W, 3)`` float32 (module docstring equations).

    ``foam`` is the foam cover ``(T, H, W)`` in [0, 1] or None.
    """
    sky = SkyModel(sun, diffuse_ratio=DIFFUSE_RATIO)
    mu_s = float(sun[2])
    e_d = mu_s * (1.0 + DIFFUSE_RATIO)
    # channel by channel on contiguous (T, H, W) arrays: far faster than a trailing axis of 3
    rx, ry, rz, ndc = reflect_components(view, sx, sy)
    fres = fresnel_unpolarised(ndc, refractive_index).astype(np.float32)
    sky_rgb = sky.radiance_channels(rx, ry, rz)
    rho = glint_reflectance(sx, sy, view, sun, subpixel_slope_variance=subpixel_slope_variance,
                            refractive_index=refractive_index)
    glint = np.float32(glint_severity * mu_s / math.pi) * rho
    if foam is not None:
        glint *= 1.0 - foam
        foam_rad = np.float32(FOAM_ALBEDO * e_d / math.pi) * foam
    clean, glinty = [], []
    for sky_c, rrs in zip(sky_rgb, WATER_RRS):
        c = fres * sky_c + (1.0 - fres) * np.float32(rrs * e_d)
        if foam is not None:
            c = (1.0 - foam) * c + foam_rad
        clean.append(c)
        glinty.append(c + glint)
    return (np.stack(clean, axis=-1).astype(np.float32, copy=False),
            np.stack(glinty, axis=-1).astype(np.float32, copy=False))


def generate_realistic_sequence(scenario: Scenario, config: SimConfig, *,
                                with_height: bool = False) -> SequenceData:
    """Synthesise and photograph the paired clean/glinty frames of ``scenario``.

    Returns a :class:`wavealt.sim.base.SequenceData`; its ``slope_x``/``slope_y`` are the
    resolved slopes on the image grid.
    """
    size = int(config.size)
    draws = realistic_draws(scenario, config)
    view, shift = attitude_view_vectors(size, size, scenario.focal_px,
                                        roll_rad=math.radians(draws.roll_deg),
                                        pitch_rad=math.radians(draws.pitch_deg))
    sea = make_sea(scenario, config, draws, margin_px=max(abs(shift[0]), abs(shift[1])))
    times = np.arange(scenario.frames) / scenario.fps
    velocity = scenario.camera_velocity_mps
    fields = list(sea.iter_fields(times, crop=(size, size), velocity_mps=velocity,
                                  offset_px=shift, with_height=with_height))
    sx = np.stack([f["slope_x"] for f in fields])
    sy = np.stack([f["slope_y"] for f in fields])
    foam = None
    if config.realistic.whitecaps:
        frac = whitecap_fraction(scenario.wind_speed_mps)
        if frac > 0:
            n = sea.n
            field = whitecap_field((n, n), dx_m=sea.dx_m, fraction=frac,
                                   rng=np.random.default_rng([scenario.seed, 3]),
                                   wind_dir_rad=math.radians(scenario.wind_dir_deg))
            # foam rides with the water: the camera sees it drift by -v t, smoothly
            shifts = np.outer(times, [velocity[1], velocity[0]]) / sea.dx_m
            foam = advected_crops(field, shifts, (size, size),
                                  ((n - size) // 2 + shift[0], (n - size) // 2 + shift[1]))
    sun = sun_vector(math.radians(scenario.sun_zenith_deg), math.radians(scenario.sun_azimuth_deg))
    clean_rad, glinty_rad = render_radiance(
        sx, sy, view, sun, subpixel_slope_variance=sea.subpixel_slope_variance,
        glint_severity=scenario.glint_severity, foam=foam,
        refractive_index=config.refractive_index)
    vig = (vignetting_map(size, size, scenario.focal_px, strength=draws.vignetting)
           if draws.vignetting > 0 else None)
    clean, glinty = capture_pair(clean_rad, glinty_rad, sensor=config.sensor,
                                 rng=np.random.default_rng([scenario.seed, 4]),
                                 exposure_ev=draws.exposure_ev, vignetting=vig, fps=scenario.fps)
    height = np.stack([f["height_m"] for f in fields]) if with_height else None
    return SequenceData(clean=clean, glinty=glinty, slope_x=sx, slope_y=sy, height_m=height)


class RealisticRenderer:
    """The ``realistic`` renderer: reads the common config, ``config.realistic`` and
    ``config.sensor``."""

    name = "realistic"

    def render(self, scenario: Scenario, config: SimConfig, *,
               with_height: bool = False) -> SequenceData:
        return generate_realistic_sequence(scenario, config, with_height=with_height)


__all__ = ["RealisticDraws", "RealisticRenderer", "generate_realistic_sequence", "make_sea",
           "realistic_draws", "render_radiance"]
