"""Figures (matplotlib, Agg backend): every figure is a function that writes a PNG."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

DPI = 120


def _save(fig: plt.Figure, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, bbox_inches="tight")
    plt.close(fig)
    return path


def figure_examples(clean: np.ndarray, glinty: np.ndarray, path: Path, *,
                    title: str = "", n: int = 4) -> Path:
    """Paper Fig. 2: ``n`` frames of one sequence, clean above glinty."""
    t_idx = np.linspace(0, clean.shape[0] - 1, min(n, clean.shape[0])).round().astype(int)
    fig, axes = plt.subplots(2, len(t_idx), figsize=(2.6 * len(t_idx), 5.6), squeeze=False)
    for j, t in enumerate(t_idx):
        for i, (name, arr) in enumerate((("clean", clean), ("glinty", glinty))):
            ax = axes[i, j]
            ax.imshow(np.clip(arr[t], 0, 1))
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(f"frame {t}")
            if j == 0:
                ax.set_ylabel(name)
    fig.suptitle(title or "Clean (top) vs glinty (bottom): same waves, frames advance in time")
    return _save(fig, path)


def figure_generation_steps(height_m: np.ndarray, slope_x: np.ndarray, slope_y: np.ndarray,
                            fresnel: np.ndarray, lobe: np.ndarray, clean: np.ndarray,
                            glinty: np.ndarray, path: Path, *, title: str = "") -> Path:
    """Paper Fig. 3: height map, slopes/normals, Fresnel sky term, glint term, images."""
    panels = [
        ("height (m)", height_m, "viridis"),
        ("slope magnitude", np.hypot(slope_x, slope_y), "magma"),
        ("normals (RGB = n)", None, None),
        ("Fresnel F(N·c)", fresnel, "cividis"),
        ("glint lobe (N·H)^80", lobe, "gray"),
        ("clean image", clean, None),
        ("glinty image", glinty, None),
    ]
    fig, axes = plt.subplots(1, len(panels), figsize=(2.7 * len(panels), 3.2))
    for ax, (name, arr, cmap) in zip(axes, panels):
        if name.startswith("normals"):
            inv = 1.0 / np.sqrt(1 + slope_x**2 + slope_y**2)
            nrm = np.stack([-slope_x * inv, -slope_y * inv, inv], -1)
            ax.imshow(np.clip(0.5 + 0.5 * nrm, 0, 1))
        elif cmap is None:
            ax.imshow(np.clip(arr, 0, 1))
        else:
            im = ax.imshow(arr, cmap=cmap)
            fig.colorbar(im, ax=ax, fraction=0.046, pad=0.02)
        ax.set_title(name, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title or "Wave and glint image generation (paper eq. (1)–(3))")
    return _save(fig, path)


def dataset_figures(dataset: Path | str, out: Path | str, *,
                    sequence_id: str | None = None) -> list[Path]:
    """Fig. 2 and Fig. 3 of one sequence of a dataset (re-synthesised from its seed)."""
    from wavealt.camera import Camera
    from wavealt.dataset import Dataset
    from wavealt.ocean.optics import shade, sun_vector
    from wavealt.simulate import generate_sequence, optics_of

    ds = Dataset(dataset)
    if sequence_id is None:
        test = ds.split("test") or ds.records
        sequence_id = test[0].sequence_id
    rec = ds.record(sequence_id)
    index = ds.records.index(rec)
    scen = ds.config.sample_scenario(index)
    data = generate_sequence(scen, ds.config, with_height=True)
    cam = Camera(ds.config.size, ds.config.size, scen.focal_px, scen.altitude_m)
    sun = sun_vector(math.radians(scen.sun_zenith_deg), math.radians(scen.sun_azimuth_deg))
    fres, lobe = shade(data.slope_x[0], data.slope_y[0], cam.view_vectors(), sun,
                       optics_of(ds.config))
    label = (f"{sequence_id}: altitude {scen.altitude_m:.2f} m, wind {scen.wind_speed_mps:.1f} m/s, "
             f"sun zenith {scen.sun_zenith_deg:.0f}°")
    out = Path(out)
    return [
        figure_examples(data.clean, data.glinty, out / "fig2_examples.png", title=label),
        figure_generation_steps(data.height_m[0], data.slope_x[0], data.slope_y[0], fres, lobe,
                                data.clean[0], data.glinty[0], out / "fig3_generation.png",
                                title=label),
    ]


#: Scenes of :func:`figure_presets`: altitude (m), wind (m/s), sun zenith (deg).
PRESET_SCENES = ((2.0, 3.0, 20.0), (6.0, 7.0, 35.0), (14.0, 10.0, 60.0))


def figure_presets(path: Path | str, *, size: int = 192, seed: int = 7) -> Path:
    """``paper`` frames beside ``realistic`` frames of the same scenes (README figure).

    Each row is one scene (altitude, wind, sun zenith from :data:`PRESET_SCENES`), rendered by
    both presets from the same scenario: clean and glinty frames of each.
    """
    from wavealt.scenario import Scenario, preset_config
    from wavealt.simulate import generate_sequence

    configs = {name: preset_config(name, size=size, frames=2) for name in ("paper", "realistic")}
    cols = [("paper", "clean"), ("paper", "glinty"), ("realistic", "clean"), ("realistic", "glinty")]
    fig, axes = plt.subplots(len(PRESET_SCENES), len(cols),
                             figsize=(2.7 * len(cols), 2.8 * len(PRESET_SCENES)), squeeze=False)
    for i, (alt, wind, zen) in enumerate(PRESET_SCENES):
        data = {}
        for name, cfg in configs.items():
            scen = Scenario(altitude_m=alt, wind_speed_mps=wind, wind_dir_deg=30.0,
                            sun_zenith_deg=zen, sun_azimuth_deg=200.0, glint_severity=1.0,
                            fps=cfg.fps, focal_px=cfg.focal_px, frames=2, seed=seed + i,
                            camera_speed_mps=1.0 if name == "realistic" else 0.0,
                            camera_dir_deg=0.0)
            data[name] = generate_sequence(scen, cfg)
        for j, (name, cond) in enumerate(cols):
            ax = axes[i, j]
            ax.imshow(np.clip(getattr(data[name], cond)[0], 0, 1))
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(f"{name}: {cond}", fontsize=10)
            if j == 0:
                ax.set_ylabel(f"{alt:g} m, {wind:g} m/s,\nsun zenith {zen:g}°", fontsize=9)
    fig.suptitle("Same scenes, paper preset (left) vs realistic preset (right)")
    return _save(fig, path)
