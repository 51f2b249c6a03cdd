"""Figures (matplotlib, Agg backend): every figure is a function that writes a PNG."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from wavealt.camera import Camera
from wavealt.dataset import Dataset, open_dataset
from wavealt.deglint import temporal_minimum, tmf_residual
from wavealt.sim.config import Scenario, preset_config
from wavealt.sim.generate import generate_sequence
from wavealt.sim.light.optics import shade, sun_vector
from wavealt.sim.paper import optics_of

DPI = 120
#: Small-multiple figures (Fig. 5, Fig. 6) wrap to this many panels a row, so that eight
#: conditions stay readable at page width.
MAX_COLUMNS = 4


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
    # (title, array, colour map, colour-bar label); a 2 x 4 grid, each colour bar labelled
    panels = [
        ("height", height_m, "viridis", "height (m)"),
        ("slope magnitude", np.hypot(slope_x, slope_y), "magma", "|∇h|"),
        ("normals (RGB = n)", None, None, None),
        ("Fresnel sky term", fresnel, "cividis", "F(N·c)"),
        ("glint lobe", lobe, "gray", "(N·H)^80"),
        ("clean image", clean, None, None),
        ("glinty image", glinty, None, None),
    ]
    fig, axes = plt.subplots(2, 4, figsize=(11.0, 5.6), layout="constrained")
    for ax, (name, arr, cmap, unit) in zip(axes.flat, panels):
        if name.startswith("normals"):
            inv = 1.0 / np.sqrt(1 + slope_x**2 + slope_y**2)
            nrm = np.stack([-slope_x * inv, -slope_y * inv, inv], -1)
            ax.imshow(np.clip(0.5 + 0.5 * nrm, 0, 1))
        elif cmap is None:
            ax.imshow(np.clip(arr, 0, 1))
        else:
            im = ax.imshow(arr, cmap=cmap)
            fig.colorbar(im, ax=ax, shrink=0.85).set_label(unit, fontsize=8)
        ax.set_title(name, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    for ax in axes.flat[len(panels):]:
        ax.axis("off")
    fig.suptitle(title or "Wave and glint image generation (paper eq. (1)–(3))")
    return _save(fig, path)


def dataset_figures(dataset: Path | str, out: Path | str, *,
                    sequence_id: str | None = None) -> list[Path]:
    """Fig. 2 and Fig. 3 of one sequence of a dataset, a folder or shards (re-synthesised
    from its seed)."""
    ds = open_dataset(dataset)
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


def figure_tmf_decomposition(glinty_frame: np.ndarray, estimated_clean: np.ndarray,
                             estimated_glint: np.ndarray, true_clean: np.ndarray,
                             path: Path, *, title: str = "") -> Path:
    """Paper Fig. 4: observed glinty frame, estimated clean surface (eq. (5) minimum),
    estimated glint (eq. (6) residual) and the true clean frame; each ``(H, W, 3)`` in [0, 1]."""
    panels = [("observed (glinty)", glinty_frame), ("estimated clean: min, eq. (5)", estimated_clean),
              ("estimated glint: residual, eq. (6)", estimated_glint),
              ("true clean", true_clean)]
    fig, axes = plt.subplots(1, 4, figsize=(11.5, 3.3))
    for ax, (name, arr) in zip(axes, panels):
        ax.imshow(np.clip(np.asarray(arr, dtype=np.float32), 0, 1))
        ax.set_title(name, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title or "TMF decomposition (paper Fig. 4)")
    return _save(fig, path)


def figure_pixel_trace(frames: np.ndarray, path: Path, *, pixel: tuple[int, int] | None = None,
                       window: int = 10, title: str = "") -> Path:
    """Paper Fig. 7: one pixel's intensity (RGB mean) over the frames of a sequence, its
    rolling eq. (5) minimum dashed and the eq. (6) residual shaded between them.

    ``frames`` is ``(T, H, W, 3)`` in [0, 1]; ``pixel`` is ``(row, col)``, by default the pixel
    whose residual peaks highest (the most glint-struck one).
    """
    x = np.asarray(frames)
    base = temporal_minimum(x, window=window)
    res = tmf_residual(x, window=window)
    lum = lambda a: a.astype(np.float32).mean(axis=-1) if a.ndim == 4 else a.astype(np.float32)  # noqa: E731
    if pixel is None:
        pixel = tuple(int(i) for i in np.unravel_index(np.argmax(lum(res).max(axis=0)), x.shape[1:3]))
    r, c = pixel
    if not (0 <= r < x.shape[1] and 0 <= c < x.shape[2]):
        msg = f"pixel must be inside the {x.shape[1]}x{x.shape[2]} frame; got {pixel}"
        raise ValueError(msg)
    t = np.arange(x.shape[0])
    obs, mn = lum(x)[:, r, c], lum(base)[:, r, c]
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    ax.plot(t, obs, "o-", color="tab:blue", label="observed intensity I")
    ax.plot(t, mn, "--", color="k", label=f"rolling minimum Ĝ (w = {window})")
    ax.fill_between(t, mn, obs, color="tab:orange", alpha=0.35, label="residual I − Ĝ")
    ax.set_xlabel("frame")
    ax.set_ylabel("intensity (RGB mean)")
    ax.set_ylim(0, 1)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(title or f"Pixel (row {r}, col {c}) over the sequence (paper Fig. 7)", fontsize=10)
    return _save(fig, path)


def deglint_figures(dataset: Path | str, out: Path | str, *, sequence_id: str | None = None,
                    window: int = 10, frame: int | None = None) -> list[Path]:
    """Fig. 4 and Fig. 7 of one sequence of a dataset (the first test sequence by default)."""
    ds = Dataset(dataset)
    if sequence_id is None:
        test = ds.split("test") or ds.records
        sequence_id = test[0].sequence_id
    glinty = ds.read_frames("glinty", sequence_id)
    clean = ds.read_frames("clean", sequence_id) if "clean" in ds.conditions else None
    base = temporal_minimum(glinty, window=window)
    res = tmf_residual(glinty, window=window)
    if frame is None:  # the frame with the most glint energy
        frame = int(np.argmax(res.reshape(res.shape[0], -1).sum(axis=1)))
    out = Path(out)
    truth = clean[frame] if clean is not None else np.zeros_like(glinty[frame])
    return [
        figure_tmf_decomposition(glinty[frame], base[frame], res[frame], truth,
                                 out / "fig4_tmf_decomposition.png",
                                 title=f"{sequence_id} frame {frame}: TMF decomposition, w = {window}"),
        figure_pixel_trace(glinty, out / "fig7_pixel_trace.png", window=window,
                           title=f"{sequence_id}: pixel trace, w = {window} (paper Fig. 7)"),
    ]


def _condition_label(c: str) -> str:
    return {"clean": "Clean", "glinty": "Glinty", "residual": "Residual (TMF)"}.get(c, c)


def figure_predicted_vs_actual(predictions: dict, path: Path, *, title: str = "") -> Path:
    """Paper Fig. 5: predicted vs actual altitude per condition; dashed identity line.

    ``predictions`` maps a condition to ``{"true_m": (N,), "pred_m": (N,)}`` arrays.
    """
    conds = list(predictions)
    fig, axes = _grid(len(conds), panel_in=2.9)
    allv = np.concatenate([np.r_[d["true_m"], d["pred_m"]] for d in predictions.values()])
    allv = allv[np.isfinite(allv)]
    lo, hi = (float(allv.min()), float(allv.max())) if allv.size else (0.0, 1.0)
    pad = 0.05 * (hi - lo + 1e-9)
    for ax, c in zip(axes.flat, conds):
        t, p = np.asarray(predictions[c]["true_m"]), np.asarray(predictions[c]["pred_m"])
        ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], "k--", lw=1, label="perfect")
        ax.scatter(t, p, s=14, alpha=0.8)
        ax.set_xlim(lo - pad, hi + pad)
        ax.set_ylim(lo - pad, hi + pad)
        ax.set_aspect("equal")
        ax.set_title(_condition_label(c), fontsize=10)
    fig.supxlabel("actual altitude (m)")
    fig.supylabel("predicted altitude (m)")
    fig.suptitle(title or "Predicted vs actual altitude (Fig. 5)")
    return _save(fig, path)


def figure_error_distribution(predictions: dict, path: Path, *, title: str = "") -> Path:
    """Paper Fig. 6: distribution of absolute errors per condition, one small histogram a
    condition on shared axes (overlaid outlines of many conditions hide each other)."""
    errs = {c: np.abs(np.asarray(d["pred_m"]) - np.asarray(d["true_m"]))
            for c, d in predictions.items()}
    errs = {c: e[np.isfinite(e)] for c, e in errs.items()}
    top = max([float(e.max()) for e in errs.values() if e.size] + [1e-3])
    bins = np.linspace(0.0, top, 16)
    fig, axes = _grid(len(errs), panel_in=2.6, aspect=0.7, share=True)
    for ax, (c, e) in zip(axes.flat, errs.items()):
        ax.hist(e, bins=bins, color="tab:blue", alpha=0.75, edgecolor="white")
        if e.size:
            ax.axvline(float(np.median(e)), color="k", lw=1, ls="--")
        ax.set_title(f"{_condition_label(c)} (n={e.size})", fontsize=10)
    fig.supxlabel("absolute error (m); dashed: median")
    fig.supylabel("test sequences")
    fig.suptitle(title or "Distribution of absolute errors (Fig. 6)")
    return _save(fig, path)


def _grid(n: int, *, panel_in: float, aspect: float = 1.0,
          share: bool = False) -> tuple[plt.Figure, np.ndarray]:
    """``n`` panels in rows of at most :data:`MAX_COLUMNS`; the unused cells are hidden."""
    ncols = max(1, min(n, MAX_COLUMNS))
    nrows = max(1, math.ceil(n / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(panel_in * ncols + 0.8,
                                                    panel_in * aspect * nrows + 0.9),
                             squeeze=False, sharex=share, sharey=share, layout="constrained")
    for ax in axes.flat[n:]:
        ax.axis("off")
    return fig, axes


def coverage_curve(true_m: np.ndarray, est_m: np.ndarray, std_m: np.ndarray,
                   ks: np.ndarray) -> np.ndarray:
    """The share of windows whose estimate lies within ``k`` of its stated standard
    deviations of the truth, ``|est - true| <= k std``, for each ``k`` of ``ks``; a window
    without an estimate (NaN) is not covered.  NaN for no windows."""
    t, e, s = (np.asarray(a, dtype=np.float64).ravel() for a in (true_m, est_m, std_m))
    if not t.shape == e.shape == s.shape:
        msg = f"true_m, est_m and std_m must have one length; got {t.size}, {e.size}, {s.size}"
        raise ValueError(msg)
    ks = np.asarray(ks, dtype=np.float64)
    if t.size == 0:
        return np.full(ks.shape, np.nan)
    off = np.abs(e - t)
    with np.errstate(invalid="ignore"):
        return np.array([float(np.mean(off <= k * s)) for k in ks.ravel()]).reshape(ks.shape)


def windows_by_row(records: list[dict], fields: tuple[str, str, str, str],
                   order: tuple[str, ...] = ()) -> dict[str, dict[str, list]]:
    """Benchmark windows ``records`` (dicts with a ``"row"``) as
    :func:`figure_altimeter_windows` takes them: per row, the truth, the estimate, its
    standard deviation and trust, read from the records' ``fields`` (in that order); the
    rows named in ``order`` first, in that order, the others after by name."""
    rows: dict[str, dict[str, list]] = {}
    for r in records:
        d = rows.setdefault(r["row"], {"true_m": [], "est_m": [], "std_m": [], "trusted": []})
        for key, field in zip(("true_m", "est_m", "std_m", "trusted"), fields):
            d[key].append(r[field])
    rank = {name: i for i, name in enumerate(order)}
    return dict(sorted(rows.items(), key=lambda kv: (rank.get(kv[0], len(rank)), kv[0])))


def figure_altimeter_windows(rows: dict, path: Path, *, title: str = "") -> Path:
    """One line of two panels a benchmark row of the dispersion altimeter: each window's
    estimate against the truth (trusted filled, not trusted hollow; the band of +-10 %
    shaded), and the share of windows within ``k`` of their stated standard deviations
    against ``k`` (all, trusted), beside what normal errors of that size would give.

    ``rows`` maps a row's name to ``{"true_m", "est_m", "std_m", "trusted"}`` arrays."""
    ks = np.linspace(0.0, 4.0, 81)
    fig, axes = plt.subplots(len(rows), 2, figsize=(8.6, 3.5 * len(rows) + 0.5),
                             squeeze=False, layout="constrained")
    for (ax, cov), (name, d) in zip(axes, rows.items()):
        t, e, s = (np.asarray(d[k], dtype=np.float64) for k in ("true_m", "est_m", "std_m"))
        tr = np.asarray(d["trusted"], dtype=bool)
        ok = np.isfinite(e) & (e > 0)
        lo, hi = float(t.min()) / 1.3, float(t.max()) * 1.3
        line = np.array([lo, hi])
        ax.fill_between(line, line / 1.1, line * 1.1, color="0.88", lw=0, label="within 10 %")
        ax.plot(line, line, "k--", lw=0.8)
        ax.scatter(t[ok & ~tr], np.clip(e[ok & ~tr], lo / 2, hi * 2), s=9, facecolors="none",
                   edgecolors="0.5", lw=0.6, label=f"not trusted ({int((~tr).sum())})")
        ax.scatter(t[ok & tr], e[ok & tr], s=9, color="tab:blue",
                   label=f"trusted ({int(tr.sum())})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(lo, hi)
        ax.set_ylim(lo / 2, hi * 2)
        mae = 100.0 * float(np.mean(np.abs(e[ok] / t[ok] - 1.0))) if ok.any() else math.nan
        ax.set_title(f"{name}: relative MAE {mae:.1f} %", fontsize=10)
        ax.set_xlabel("true altitude (m)")
        ax.set_ylabel("estimate (m)")
        ax.legend(fontsize=7, loc="upper left")
        cov.plot(ks, [math.erf(k / math.sqrt(2.0)) for k in ks], "k--", lw=0.8, label="normal errors")
        cov.plot(ks, coverage_curve(t, e, s, ks), color="0.45", label="all windows")
        if tr.any():
            cov.plot(ks, coverage_curve(t[tr], e[tr], s[tr], ks), color="tab:blue",
                     label="trusted")
        cov.axvline(3.0, color="0.7", lw=0.8)
        cov.set_xlim(0.0, 4.0)
        cov.set_ylim(0.0, 1.02)
        cov.set_xlabel("k (stated standard deviations)")
        cov.set_ylabel("share within k sigma of the truth")
        cov.legend(fontsize=7, loc="lower right")
    fig.suptitle(title or "Dispersion altimeter: estimates and their stated uncertainty")
    return _save(fig, path)


#: Scenes of :func:`figure_presets`: altitude (m), wind (m/s), sun zenith (deg).
PRESET_SCENES = ((2.0, 3.0, 20.0), (6.0, 7.0, 35.0), (14.0, 10.0, 60.0))


def figure_presets(path: Path | str, *, size: int = 192, seed: int = 7) -> Path:
    """``paper`` frames beside ``realistic`` frames of the same scenes (README figure).

    Each row is one scene (altitude, wind, sun zenith from :data:`PRESET_SCENES`), rendered by
    both presets from the same scenario: clean and glinty frames of each.
    """
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
