"""One sequence from one scenario: ocean surface -> slopes -> clean and glinty frames."""

from __future__ import annotations

import math
from pathlib import Path
from dataclasses import dataclass

import numpy as np
import scipy.fft

from wavealt.camera import Camera
from wavealt.ocean.optics import Optics, render_pair, sun_vector
from wavealt.ocean.surface import OceanSurface
from wavealt.scenario import Scenario, SimConfig


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


def domain_points(size_px: int, pad: float) -> int:
    """Even FFT-friendly grid size of at least ``pad * size_px`` points."""
    n = scipy.fft.next_fast_len(int(math.ceil(pad * size_px)))
    while n % 2:
        n = scipy.fft.next_fast_len(n + 1)
    return n


def optics_of(config: SimConfig) -> Optics:
    return Optics(water_rgb=tuple(config.water_rgb), sky_rgb=tuple(config.sky_rgb),
                  refractive_index=config.refractive_index,
                  lobe_exponent=config.lobe_exponent, display_rgb=tuple(config.display_rgb),
                  contrast=config.contrast)


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


def generate_sequence(scenario: Scenario, config: SimConfig, *,
                      with_height: bool = False) -> SequenceData:
    """Synthesise and render the paired clean/glinty frames of ``scenario``.

    Raises ``ValueError`` if a rendered frame is not finite (a scenario outside the range
    the spectrum models hold for), rather than writing blank or NaN frames.
    """
    if config.renderer == "realistic":
        from wavealt.realistic_sim import generate_realistic_sequence

        data = generate_realistic_sequence(scenario, config, with_height=with_height)
    else:
        data = _generate_paper_sequence(scenario, config, with_height=with_height)
    for name in ("clean", "glinty"):
        frames = getattr(data, name)
        if not np.isfinite(frames).all():
            bad = int(np.count_nonzero((~np.isfinite(frames)).reshape(frames.shape[0], -1)
                                       .any(axis=1)))
            msg = (f"the {config.renderer} renderer made {bad} non-finite {name} frame(s) for "
                   f"altitude {scenario.altitude_m:.3g} m, wind {scenario.wind_speed_mps:.3g} m/s "
                   f"(seed {scenario.seed})")
            raise ValueError(msg)
    return data


def _generate_paper_sequence(scenario: Scenario, config: SimConfig, *,
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
    sun = sun_vector(math.radians(scenario.sun_zenith_deg), math.radians(scenario.sun_azimuth_deg))
    clean, glinty = render_pair(sx, sy, cam.view_vectors(), sun,
                                glint_severity=scenario.glint_severity, optics=optics_of(config),
                                clean_glint_severity=config.clean_glint_severity)
    height = np.stack([f["height_m"] for f in fields]) if with_height else None
    return SequenceData(clean=clean, glinty=glinty, slope_x=sx, slope_y=sy, height_m=height)


# -- whole dataset to disk ---------------------------------------------------------------
def _write_one(args: tuple[str, dict, int, bool]) -> int:
    from wavealt.dataset import records_of_index
    from wavealt.io import atomic_save_npz, write_frames_folder

    root_s, cfg_dict, index, save_surface = args
    root = Path(root_s)
    config = SimConfig.from_dict(cfg_dict)
    rec = records_of_index(config, index)
    need = [c for c in ("clean", "glinty") if not (root / c / rec.sequence_id).is_dir()]
    surf_path = root / "surface" / f"{rec.sequence_id}.npz"
    need_surface = save_surface and not surf_path.is_file()
    if not need and not need_surface:
        return index
    data = generate_sequence(rec.scenario, config, with_height=need_surface)
    for c in need:
        write_frames_folder(root / c / rec.sequence_id, getattr(data, c))
    if need_surface:
        atomic_save_npz(surf_path, height_m=data.height_m, slope_x=data.slope_x,
                        slope_y=data.slope_y)
    return index


def simulate_dataset(out: Path | str, config: SimConfig, *, workers: int = 1,
                     save_surface: bool = False, progress: bool = True) -> Path:
    """Write the dataset of ``config`` to ``out`` (DESIGN.md folder layout).

    Resumes: sequences already complete are kept; a folder holding a dataset of another
    config is refused untouched.  ``workers`` processes give the same bytes as one.
    """
    from tqdm import tqdm

    from wavealt.dataset import Dataset, ids_missing, manifest_text, new_info, records_of, write_info
    from wavealt.io import atomic_write_text

    out = Path(out)
    if int(workers) != workers or workers < 1:
        msg = f"workers must be a positive integer; got {workers!r}"
        raise ValueError(msg)
    if out.exists() and not out.is_dir():
        msg = f"OUT {out} is an existing file; give a folder for the dataset"
        raise ValueError(msg)
    if (out / "dataset.json").is_file():
        existing = Dataset(out).config
        if existing != config:
            a, b = existing.to_dict(), config.to_dict()
            diff = ", ".join(f"{k}: {a[k]!r} -> {b[k]!r}" for k in a if a[k] != b[k])
            msg = f"OUT {out} holds a dataset made with a different config ({diff}); choose another folder"
            raise ValueError(msg)
    elif out.is_dir() and any(out.iterdir()):
        msg = f"OUT {out} is a non-empty folder that holds no wavealt dataset; choose another folder"
        raise ValueError(msg)
    out.mkdir(parents=True, exist_ok=True)
    records = records_of(config)
    if not (out / "dataset.json").is_file():
        write_info(out, new_info(config))
    atomic_write_text(out / "manifest.csv", manifest_text(records))
    todo = ids_missing(out, records, ("clean", "glinty"), save_surface)
    if save_surface:
        (out / "surface").mkdir(exist_ok=True)
    tasks = [(str(out), config.to_dict(), i, save_surface) for i in todo]
    bar = tqdm(total=len(records), initial=len(records) - len(todo), desc="simulate",
               unit="seq", disable=not progress)
    try:
        if workers == 1 or len(tasks) <= 1:
            for t in tasks:
                _write_one(t)
                bar.update()
        else:
            import multiprocessing as mp
            ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
            with ctx.Pool(int(workers)) as pool:
                for _ in pool.imap_unordered(_write_one, tasks):
                    bar.update()
    finally:
        bar.close()
    if save_surface:
        info = Dataset(out).info
        info["conditions"]["surface"] = {"description": "ground truth per sequence: surface/<id>.npz "
                                         "with height_m, slope_x, slope_y (T, H, W) float32"}
        write_info(out, info)
    return out
