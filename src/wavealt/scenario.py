"""Scenario parameters, their sampling, and the simulation config with its presets.

A dataset is a pure function of its :class:`SimConfig`: sequence ``i`` draws its scenario
and its waves from its own seed ``derive_seed(config.seed, i)``, so any subset can be
regenerated alone.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from wavealt._checks import check_choice, check_finite_number, check_known_keys
from wavealt.camera import MAX_ALTITUDE_M, focal_px_from_fov
from wavealt.sensor import SensorModel

MIN_SIZE_PX = 32
RENDERERS = ("paper", "realistic")
#: Largest camera roll or pitch, degrees (the nadir approximation of wavealt.sensor).
MAX_TILT_DEG = 20.0
_REALISTIC_FIELDS = frozenset({
    "renderer", "spectrum", "spreading", "spreading_s", "inverse_wave_age", "exposure_ev",
    "roll_deg", "pitch_deg", "vignetting", "whitecaps", "full_well_e", "read_noise_e", "srgb",
    "compression", "jpeg_quality", "h264_crf",
})


def derive_seed(seed: int, index: int) -> int:
    """Seed of sequence ``index`` of a dataset seeded ``seed`` (independent streams)."""
    return int(np.random.SeedSequence([int(seed), int(index)]).generate_state(1)[0])


@dataclass(frozen=True)
class Scenario:
    """Everything that defines one sequence (one manifest row, less its split)."""

    altitude_m: float
    wind_speed_mps: float
    wind_dir_deg: float
    sun_zenith_deg: float
    sun_azimuth_deg: float
    glint_severity: float
    fps: float
    focal_px: float
    frames: int
    seed: int
    camera_speed_mps: float = 0.0
    camera_dir_deg: float = 0.0

    def __post_init__(self) -> None:
        check_finite_number("altitude_m", self.altitude_m, low=0.0, low_open=True,
                            high=MAX_ALTITUDE_M)
        check_finite_number("wind_speed_mps", self.wind_speed_mps, low=0.0, low_open=True)
        check_finite_number("sun_zenith_deg", self.sun_zenith_deg, low=0.0, high=90.0,
                            high_open=True)
        check_finite_number("glint_severity", self.glint_severity, low=0.0)
        check_finite_number("fps", self.fps, low=0.0, low_open=True)
        check_finite_number("camera_speed_mps", self.camera_speed_mps, low=0.0)
        if self.frames < 2:
            msg = f"frames must be >= 2; got {self.frames}"
            raise ValueError(msg)

    @property
    def camera_velocity_mps(self) -> tuple[float, float]:
        a = math.radians(self.camera_dir_deg)
        return self.camera_speed_mps * math.cos(a), self.camera_speed_mps * math.sin(a)


Range = tuple[float, float]


def _check_range(name: str, r: Range, *, low: float | None = None, high: float | None = None,
                 low_open: bool = False, high_open: bool = False) -> None:
    """A config range ``(low, high)``: two finite numbers in bounds, in order."""
    if len(r) != 2 or r[0] > r[1]:
        msg = f"{name} must be a range (low, high) with low <= high; got {r!r}"
        raise ValueError(msg)
    for x in r:
        check_finite_number(name, x, low=low, high=high, low_open=low_open, high_open=high_open)


@dataclass(frozen=True)
class SimConfig:
    """Generator config: sizes, timing, optics and the ranges scenarios are drawn from.

    Every range ``(lo, hi)`` is sampled uniformly; ``lo == hi`` fixes the value.
    """

    preset: str = "paper"
    sequences: int = 200
    frames: int = 10
    size: int = 224
    fov_deg: float = 60.0
    fps: float = 30.0
    seed: int = 42
    split_seed: int = 42
    split: tuple[float, float, float] = (0.70, 0.15, 0.15)
    altitude_m: Range = (1.0, 5.0)
    wind_speed_mps: Range = (3.0, 10.0)
    wind_dir_deg: Range = (0.0, 360.0)
    sun_zenith_deg: Range = (10.0, 40.0)
    sun_azimuth_deg: Range = (0.0, 360.0)
    glint_severity: Range = (0.5, 1.0)
    camera_speed_mps: Range = (0.0, 0.0)
    camera_dir_deg: Range = (0.0, 360.0)
    clean_glint_severity: float = 0.0
    domain_pad: float = 2.0
    water_rgb: tuple[float, float, float] = (0.004, 0.020, 0.030)
    sky_rgb: tuple[float, float, float] = (0.60, 0.75, 0.95)
    display_rgb: tuple[float, float, float] = (0.10, 0.30, 0.40)
    contrast: float = 0.10
    refractive_index: float = 1.34
    lobe_exponent: float = 80.0
    # -- realistic renderer (wavealt.realistic_sim); ignored by the paper renderer.  Left out
    # of to_dict() while at their defaults, so paper datasets keep their dataset.json bytes.
    renderer: str = "paper"
    spectrum: str = "elfouhaily"
    spreading: str = "cos2s"
    spreading_s: Range = (4.0, 4.0)
    inverse_wave_age: Range = (0.84, 0.84)
    exposure_ev: Range = (0.0, 0.0)
    roll_deg: Range = (0.0, 0.0)
    pitch_deg: Range = (0.0, 0.0)
    vignetting: Range = (0.0, 0.0)
    whitecaps: bool = False
    # the camera's defaults are the sensor model's own (one source of truth)
    full_well_e: float = SensorModel.full_well_e
    read_noise_e: float = SensorModel.read_noise_e
    srgb: bool = SensorModel.srgb
    compression: str = SensorModel.compression
    jpeg_quality: int = SensorModel.jpeg_quality
    h264_crf: int = SensorModel.h264_crf

    def __post_init__(self) -> None:
        if self.preset not in PRESETS:
            msg = f"unknown preset {self.preset!r}; expected one of {', '.join(sorted(PRESETS))}"
            raise ValueError(msg)
        if int(self.sequences) != self.sequences or self.sequences < 1:
            msg = f"sequences must be a positive integer; got {self.sequences!r}"
            raise ValueError(msg)
        if int(self.frames) != self.frames or self.frames < 2:
            msg = f"frames must be an integer >= 2; got {self.frames!r}"
            raise ValueError(msg)
        if int(self.size) != self.size or self.size < MIN_SIZE_PX:
            msg = f"size must be an integer >= {MIN_SIZE_PX} px; got {self.size!r}"
            raise ValueError(msg)
        check_finite_number("fov_deg", self.fov_deg, low=0.0, high=180.0, low_open=True,
                            high_open=True)
        check_finite_number("fps", self.fps, low=0.0, low_open=True)
        check_finite_number("domain_pad", self.domain_pad, low=1.0)
        if len(self.split) != 3 or any(f < 0 for f in self.split) or not math.isclose(sum(self.split), 1.0):
            msg = f"split must be three non-negative fractions summing to 1; got {self.split!r}"
            raise ValueError(msg)
        bounds = {
            "altitude_m": (0.0, MAX_ALTITUDE_M, True),
            "wind_speed_mps": (0.0, None, True),
            "sun_zenith_deg": (0.0, 90.0, False),
            "glint_severity": (0.0, None, False),
            "camera_speed_mps": (0.0, None, False),
            "wind_dir_deg": (None, None, False),
            "sun_azimuth_deg": (None, None, False),
            "camera_dir_deg": (None, None, False),
        }
        for name, (lo, hi, lo_open) in bounds.items():
            _check_range(name, getattr(self, name), low=lo, high=hi, low_open=lo_open,
                         high_open=(name == "sun_zenith_deg"))

        self._check_realistic()

    def _check_realistic(self) -> None:
        from wavealt.ocean.realistic import SPECTRA, SPREADINGS

        choices = {"renderer": RENDERERS, "spectrum": SPECTRA, "spreading": SPREADINGS}
        for name, allowed in choices.items():
            check_choice(name, getattr(self, name), allowed)
        bounds = {
            "spreading_s": (0.0, None),
            "inverse_wave_age": (0.83, 5.0),
            "exposure_ev": (-10.0, 10.0),
            "roll_deg": (-MAX_TILT_DEG, MAX_TILT_DEG),
            "pitch_deg": (-MAX_TILT_DEG, MAX_TILT_DEG),
            "vignetting": (0.0, 1.0),
        }
        for name, (lo, hi) in bounds.items():
            _check_range(name, getattr(self, name), low=lo, high=hi)
        for name in ("whitecaps", "srgb"):
            if not isinstance(getattr(self, name), bool):
                msg = f"{name} must be true or false; got {getattr(self, name)!r}"
                raise ValueError(msg)
        if self.compression == "h264" and self.size % 2:
            msg = f"compression 'h264' needs an even size; got size {self.size}"
            raise ValueError(msg)
        SensorModel(full_well_e=self.full_well_e, read_noise_e=self.read_noise_e, srgb=self.srgb,
                    compression=self.compression, jpeg_quality=self.jpeg_quality,
                    h264_crf=self.h264_crf)

    @property
    def focal_px(self) -> float:
        return focal_px_from_fov(self.size, self.fov_deg)

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        defaults = {f.name: f.default for f in dataclasses.fields(self)}
        d = {k: v for k, v in d.items() if k not in _REALISTIC_FIELDS or v != defaults[k]}
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SimConfig:
        """Build from a dict; unknown keys are an error (a typo must not pass silently)."""
        check_known_keys(d, {f.name for f in dataclasses.fields(cls)})
        kw = {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}
        return cls(**kw)

    def replace(self, **changes: Any) -> SimConfig:
        return dataclasses.replace(self, **changes)

    def sample_scenario(self, index: int) -> Scenario:
        """The scenario of sequence ``index`` (a pure function of the config and index)."""
        seed = derive_seed(self.seed, index)
        rng = np.random.default_rng(seed)

        def draw(r: Range) -> float:
            lo, hi = r
            return float(lo + (hi - lo) * rng.random())

        return Scenario(
            altitude_m=draw(self.altitude_m),
            wind_speed_mps=draw(self.wind_speed_mps),
            wind_dir_deg=draw(self.wind_dir_deg),
            sun_zenith_deg=draw(self.sun_zenith_deg),
            sun_azimuth_deg=draw(self.sun_azimuth_deg),
            glint_severity=draw(self.glint_severity),
            fps=float(self.fps),
            focal_px=self.focal_px,
            frames=int(self.frames),
            seed=seed,
            camera_speed_mps=draw(self.camera_speed_mps),
            camera_dir_deg=draw(self.camera_dir_deg),
        )

    def splits(self) -> list[str]:
        """Split of each sequence: a permutation seeded ``split_seed``, cut 70/15/15."""
        n = int(self.sequences)
        order = np.random.default_rng(self.split_seed).permutation(n)
        n_train = int(round(self.split[0] * n))
        n_val = int(round(self.split[1] * n))
        labels = ["test"] * n
        for rank, i in enumerate(order):
            labels[i] = "train" if rank < n_train else ("val" if rank < n_train + n_val else "test")
        return labels


#: Presets: overrides of the SimConfig defaults.  ``paper`` is the paper's dataset design
#: (§3.1: altitudes 1–5 m, 224x224, 10 frames, 70/15/15 split with seed 42; 200 sequences so
#: that the test split holds 30, as in Table 2).
#: ``realistic`` (issue #6): the physical sea, sky, glitter and camera of
#: :mod:`wavealt.realistic_sim`, over calm to fresh seas (Beaufort 1-5), high to low sun,
#: altitudes up to 15 m, a moving and slightly tilted camera, JPEG-compressed sRGB frames.
PRESETS: dict[str, dict[str, Any]] = {
    "paper": {},
    "realistic": {
        "renderer": "realistic",
        "domain_pad": 1.25,
        "altitude_m": (1.0, 15.0),
        "wind_speed_mps": (1.5, 10.5),
        "sun_zenith_deg": (5.0, 75.0),
        "glint_severity": (0.6, 1.0),
        "camera_speed_mps": (0.0, 3.0),
        "spreading_s": (1.0, 10.0),
        "inverse_wave_age": (0.84, 2.0),
        "exposure_ev": (-0.5, 0.5),
        "roll_deg": (-3.0, 3.0),
        "pitch_deg": (-3.0, 3.0),
        "vignetting": (0.0, 0.5),
        "whitecaps": True,
        "compression": "jpeg",
    },
}


def preset_config(name: str, **overrides: Any) -> SimConfig:
    """The config of preset ``name`` with ``overrides`` (None values are ignored)."""
    if name not in PRESETS:
        msg = f"unknown preset {name!r}; expected one of {', '.join(sorted(PRESETS))}"
        raise ValueError(msg)
    kw = dict(PRESETS[name])
    kw.update({k: v for k, v in overrides.items() if v is not None})
    kw["preset"] = name
    return SimConfig(**kw)


__all__ = ["PRESETS", "Scenario", "SimConfig", "derive_seed", "preset_config"]
