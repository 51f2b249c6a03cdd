"""Simulation configs: the common scenario config, one sub-config per renderer and the
sensor's, the presets, and the per-sequence :class:`Scenario` drawn from them.

A dataset is a pure function of its :class:`SimConfig`: sequence ``i`` draws its scenario
and its waves from its own seed ``derive_seed(config.seed, i)``, so any subset can be
regenerated alone.

``SimConfig`` holds what every renderer reads (sizes, timing, the scenario ranges, the sea
domain); ``paper`` (:class:`PaperConfig`), ``realistic`` (:class:`RealisticConfig`) and
``sensor`` (:class:`SensorModel`) hold what only one renderer reads. Saved as JSON, the
sub-configs are nested objects under their names; the flat files written before version 2
of the dataset format load too.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from wavealt._checks import (
    check_choice,
    check_finite_number,
    check_integer,
    check_known_keys,
    check_rgb,
)
from wavealt.camera import MAX_ALTITUDE_M, focal_px_from_fov
from wavealt.sim.sea.realistic import SPECTRA, SPREADINGS

MIN_SIZE_PX = 32
#: Largest camera roll or pitch, degrees (the nadir approximation of wavealt.sim.sensor).
MAX_TILT_DEG = 20.0
COMPRESSIONS = ("none", "jpeg", "h264")
#: libx264's speed presets, fastest first (:attr:`SensorModel.h264_preset`).
H264_PRESETS = ("ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow",
                "slower", "veryslow")

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
class PaperConfig:
    """Optics of the ``paper`` renderer (paper eq. (3), :mod:`wavealt.sim.light.optics`).

    ``clean_glint_severity`` is the glint left in the clean frames (0: none).
    """

    water_rgb: tuple[float, float, float] = (0.004, 0.020, 0.030)
    sky_rgb: tuple[float, float, float] = (0.60, 0.75, 0.95)
    display_rgb: tuple[float, float, float] = (0.10, 0.30, 0.40)
    contrast: float = 0.10
    lobe_exponent: float = 80.0
    clean_glint_severity: float = 0.0

    def __post_init__(self) -> None:
        # the bounds of wavealt.sim.light.optics.Optics, which the renderer builds from these
        for name in ("water_rgb", "sky_rgb", "display_rgb"):
            check_rgb(name, getattr(self, name))
        check_finite_number("contrast", self.contrast, low=0.0, low_open=True, high=1.0)
        check_finite_number("lobe_exponent", self.lobe_exponent, low=0.0, low_open=True)
        check_finite_number("clean_glint_severity", self.clean_glint_severity, low=0.0)


@dataclass(frozen=True)
class RealisticConfig:
    """The physical sea, foam and camera attitude of the ``realistic`` renderer
    (:mod:`wavealt.sim.realistic`). Every range ``(lo, hi)`` is drawn per sequence."""

    spectrum: str = "elfouhaily"
    spreading: str = "cos2s"
    spreading_s: Range = (4.0, 4.0)
    inverse_wave_age: Range = (0.84, 0.84)
    exposure_ev: Range = (0.0, 0.0)
    roll_deg: Range = (0.0, 0.0)
    pitch_deg: Range = (0.0, 0.0)
    vignetting: Range = (0.0, 0.0)
    whitecaps: bool = False

    def __post_init__(self) -> None:
        check_choice("spectrum", self.spectrum, SPECTRA)
        check_choice("spreading", self.spreading, SPREADINGS)
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
        if not isinstance(self.whitecaps, bool):
            msg = f"whitecaps must be true or false; got {self.whitecaps!r}"
            raise ValueError(msg)


@dataclass(frozen=True)
class SensorModel:
    """Sensor and encoder settings (the camera of the ``realistic`` renderer, :mod:`wavealt.sim.sensor`).

    Parameters
    ----------
    full_well_e : float
        Electrons at full scale (> 0).
    read_noise_e : float
        Read noise standard deviation, electrons (>= 0).
    target_grey : float
        Linear full-scale fraction the mean clean luminance is exposed to (0, 1).
    srgb : bool
        Encode with the sRGB transfer function (else frames stay linear).
    compression : {"none", "jpeg", "h264"}
    jpeg_quality : int
        1..100 (Pillow's scale).
    h264_crf : int
        0..51, libx264 constant rate factor.
    h264_preset : str
        libx264's speed preset (:data:`H264_PRESETS`): ``"ultrafast"`` predicts each frame
        from the one before at whole-pixel motion, no B-frames and no deblocking;
        ``"medium"`` (libx264's default, like a camera's encoder) adds quarter-pixel motion,
        B-frames and the deblocking filter.
    """

    full_well_e: float = 20000.0
    read_noise_e: float = 5.0
    target_grey: float = 0.18
    srgb: bool = True
    compression: str = "none"
    jpeg_quality: int = 90
    h264_crf: int = 23
    h264_preset: str = "ultrafast"

    def __post_init__(self) -> None:
        if not isinstance(self.srgb, bool):
            msg = f"srgb must be true or false; got {self.srgb!r}"
            raise ValueError(msg)
        check_finite_number("full_well_e", self.full_well_e, low=0.0, low_open=True)
        check_finite_number("read_noise_e", self.read_noise_e, low=0.0)
        check_finite_number("target_grey", self.target_grey, low=0.0, high=1.0, low_open=True,
                            high_open=True)
        check_choice("compression", self.compression, COMPRESSIONS)
        check_integer("jpeg_quality", self.jpeg_quality, low=1, high=100)
        check_integer("h264_crf", self.h264_crf, low=0, high=51)
        check_choice("h264_preset", self.h264_preset, H264_PRESETS)


#: The sub-configs by their name in SimConfig (and in dataset.json).
SECTIONS: dict[str, type] = {"paper": PaperConfig, "realistic": RealisticConfig,
                             "sensor": SensorModel}
#: The renderers and the sub-configs each one reads (always saved with it).
RENDERER_SECTIONS: dict[str, tuple[str, ...]] = {"paper": ("paper",),
                                                 "realistic": ("realistic", "sensor")}
RENDERERS = tuple(RENDERER_SECTIONS)


@dataclass(frozen=True)
class SimConfig:
    """Generator config: sizes, timing, the sea domain and the ranges scenarios are drawn
    from, with one sub-config per renderer and the sensor's.

    Every range ``(lo, hi)`` is sampled uniformly; ``lo == hi`` fixes the value.
    """

    preset: str = "paper"
    renderer: str = "paper"
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
    domain_pad: float = 2.0
    refractive_index: float = 1.34
    paper: PaperConfig = field(default_factory=PaperConfig)
    realistic: RealisticConfig = field(default_factory=RealisticConfig)
    sensor: SensorModel = field(default_factory=SensorModel)

    def __post_init__(self) -> None:
        if self.preset not in PRESETS:
            msg = f"unknown preset {self.preset!r}; expected one of {', '.join(sorted(PRESETS))}"
            raise ValueError(msg)
        check_choice("renderer", self.renderer, RENDERERS)
        for name, cls in SECTIONS.items():
            if not isinstance(getattr(self, name), cls):
                msg = f"{name} must be a {cls.__name__}; got {type(getattr(self, name)).__name__}"
                raise ValueError(msg)
        check_integer("sequences", self.sequences, low=1)
        check_integer("frames", self.frames, low=2)
        check_integer("size", self.size, low=MIN_SIZE_PX)
        check_finite_number("fov_deg", self.fov_deg, low=0.0, high=180.0, low_open=True,
                            high_open=True)
        check_finite_number("fps", self.fps, low=0.0, low_open=True)
        check_finite_number("domain_pad", self.domain_pad, low=1.0)
        check_finite_number("refractive_index", self.refractive_index, low=1.0, low_open=True)
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
        if (self.renderer == "realistic" and self.sensor.compression == "h264"
                and self.size % 2):
            msg = f"compression 'h264' needs an even size; got size {self.size}"
            raise ValueError(msg)

    @property
    def focal_px(self) -> float:
        return focal_px_from_fov(self.size, self.fov_deg)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: the common fields, then each sub-config as a nested object —
        those the renderer reads always, the others only where they differ from defaults."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name in SECTIONS:
                if f.name in RENDERER_SECTIONS[self.renderer] or v != SECTIONS[f.name]():
                    out[f.name] = _jsonable(dataclasses.asdict(v))
            else:
                out[f.name] = list(v) if isinstance(v, tuple) else v
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SimConfig:
        """Build from a dict (:meth:`to_dict`'s, or the flat one of dataset format 1, whose
        sub-config keys sit beside the common ones); unknown keys are an error (a typo must
        not pass silently)."""
        common = {f.name for f in dataclasses.fields(cls)} - set(SECTIONS)
        flat = {k: v for k, v in d.items() if k not in SECTIONS or not isinstance(v, dict)}
        kw = _route(flat, common)
        for name, section_cls in SECTIONS.items():
            given = d.get(name)
            if isinstance(given, dict):
                check_known_keys(given, {f.name for f in dataclasses.fields(section_cls)},
                                 what=f"{name} config")
                kw.setdefault(name, {}).update(given)
        for name, section_cls in SECTIONS.items():
            if name in kw:
                if not isinstance(kw[name], dict):
                    msg = f"{name} must be an object of {name} settings; got {kw[name]!r}"
                    raise ValueError(msg)
                kw[name] = section_cls(**_tuples(kw[name]))
        return cls(**_tuples(kw))

    def replace(self, **changes: Any) -> SimConfig:
        """A copy with ``changes``; a sub-config's field may be named alone
        (``replace(compression="jpeg")``)."""
        kw = _route(changes, {f.name for f in dataclasses.fields(self)} - set(SECTIONS))
        for name in SECTIONS:
            if isinstance(kw.get(name), dict):  # a partial update of the sub-config
                kw[name] = dataclasses.replace(getattr(self, name), **_tuples(kw[name]))
        return dataclasses.replace(self, **_tuples(kw))

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


def _tuples(d: dict[str, Any]) -> dict[str, Any]:
    return {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}


def _jsonable(d: dict[str, Any]) -> dict[str, Any]:
    return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}


def _route(flat: dict[str, Any], common: set[str]) -> dict[str, Any]:
    """Sort flat keys into the common fields and the sub-configs that own them
    (``{"size": 64, "compression": "jpeg"}`` -> ``{"size": 64, "sensor": {"compression":
    "jpeg"}}``); a key that is neither is an error naming the keys allowed."""
    owner = {f.name: name for name, cls in SECTIONS.items() for f in dataclasses.fields(cls)}
    check_known_keys(flat, common | set(owner) | set(SECTIONS))
    out: dict[str, Any] = {}
    for k, v in flat.items():
        if k in common or k in SECTIONS:
            out[k] = v
        else:
            out.setdefault(owner[k], {})[k] = v
    return out


#: Presets: changes to the SimConfig defaults (sub-configs as nested dicts).  ``paper`` is
#: the paper's dataset design (§3.1: altitudes 1–5 m, 224x224, 10 frames, 70/15/15 split
#: with seed 42; 200 sequences so that the test split holds 30, as in Table 2).
#: ``realistic`` (issue #6): the physical sea, sky, glitter and camera of
#: :mod:`wavealt.sim.realistic`, over calm to fresh seas (Beaufort 1-5), high to low sun,
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
        "realistic": {
            "spreading_s": (1.0, 10.0),
            "inverse_wave_age": (0.84, 2.0),
            "exposure_ev": (-0.5, 0.5),
            "roll_deg": (-3.0, 3.0),
            "pitch_deg": (-3.0, 3.0),
            "vignetting": (0.0, 0.5),
            "whitecaps": True,
        },
        "sensor": {"compression": "jpeg"},
    },
}


def preset_config(name: str, **overrides: Any) -> SimConfig:
    """The config of preset ``name`` with ``overrides`` (None values are ignored).

    An override names a common field, a sub-config field alone (``compression="none"``)
    or a sub-config as a dict of changes (``sensor={"compression": "none"}``).
    """
    if name not in PRESETS:
        msg = f"unknown preset {name!r}; expected one of {', '.join(sorted(PRESETS))}"
        raise ValueError(msg)
    base = SimConfig(preset=name).replace(**PRESETS[name])
    return base.replace(**{k: v for k, v in overrides.items() if v is not None})


__all__ = ["PRESETS", "RENDERERS", "RENDERER_SECTIONS", "SECTIONS", "PaperConfig", "RealisticConfig",
           "Scenario", "SensorModel", "SimConfig", "derive_seed", "preset_config"]
