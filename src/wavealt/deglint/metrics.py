"""How close a deglinted sequence comes to the clean one: MAE, PSNR, SSIM, and their
pooled table over a dataset."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import ndimage

from wavealt.deglint.methods import _as_float

SSIM_SIGMA_PX = 1.5
SSIM_TRUNCATE = 3.5  # radius 5 px: the 11x11 Gaussian window of Wang et al. (2004)


def _pair(estimate: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(estimate)
    b = np.asarray(reference)
    if a.shape != b.shape:
        msg = f"estimate and reference must have one shape; got {a.shape} and {b.shape}"
        raise ValueError(msg)
    return _as_float(a).astype(np.float64), _as_float(b).astype(np.float64)


def mae(estimate: np.ndarray, reference: np.ndarray) -> float:
    """Mean absolute error in intensity units (images in [0, 1])."""
    a, b = _pair(estimate, reference)
    return float(np.mean(np.abs(a - b)))


def psnr_db(estimate: np.ndarray, reference: np.ndarray) -> float:
    """Peak signal-to-noise ratio ``10 log10(1 / MSE)`` in dB (peak 1); ``inf`` if equal."""
    a, b = _pair(estimate, reference)
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0.0 else float(10.0 * np.log10(1.0 / mse))


def ssim(estimate: np.ndarray, reference: np.ndarray) -> float:
    """Mean structural similarity (Wang et al. 2004) of images in [0, 1].

    Accepts ``(H, W)``, ``(H, W, 3)`` or a stack ``(T, H, W[, 3])``: each channel of each
    frame is compared on its own and the SSIM maps are averaged.  Gaussian window sigma 1.5 px
    (11 x 11), ``K1 = 0.01``, ``K2 = 0.03``, data range 1, population (not sample) statistics,
    reflected borders, and the 5-px border cropped before averaging (as scikit-image does with
    ``gaussian_weights=True``) when the frames are larger than 11 px.
    """
    a, b = _pair(estimate, reference)
    if a.ndim < 2:
        msg = f"ssim needs images of at least 2 dimensions; got shape {a.shape}"
        raise ValueError(msg)
    # float32 halves the filtering time; its rounding (~1e-7) is far below C2 = 9e-4
    a, b = a.astype(np.float32), b.astype(np.float32)
    if a.ndim == 2:
        spatial = (0, 1)
    elif a.ndim == 3 and a.shape[-1] == 3:
        spatial = (0, 1)
    elif a.ndim == 3:
        spatial = (1, 2)
    else:
        spatial = (a.ndim - 3, a.ndim - 2)
    sigma = [SSIM_SIGMA_PX if ax in spatial else 0.0 for ax in range(a.ndim)]

    def blur(z: np.ndarray) -> np.ndarray:
        return ndimage.gaussian_filter(z, sigma=sigma, truncate=SSIM_TRUNCATE, mode="reflect")

    c1, c2 = 0.01 ** 2, 0.03 ** 2
    mu_a, mu_b = blur(a), blur(b)
    var_a = blur(a * a) - mu_a * mu_a
    var_b = blur(b * b) - mu_b * mu_b
    cov = blur(a * b) - mu_a * mu_b
    smap = ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / (
        (mu_a ** 2 + mu_b ** 2 + c1) * (var_a + var_b + c2))
    pad = int(SSIM_TRUNCATE * SSIM_SIGMA_PX + 0.5)
    crop = [slice(None)] * a.ndim
    if all(a.shape[ax] > 2 * pad + 1 for ax in spatial):
        for ax in spatial:
            crop[ax] = slice(pad, a.shape[ax] - pad)
    return float(smap[tuple(crop)].mean())


class _QualityAccumulator:
    """Pools squared and absolute errors and per-frame SSIM over many sequences."""

    def __init__(self) -> None:
        self.sq = 0.0
        self.ab = 0.0
        self.n_values = 0
        self.ssim_sum = 0.0
        self.n_frames = 0
        self.n_sequences = 0

    def add(self, estimate: np.ndarray, reference: np.ndarray) -> None:
        a, b = _pair(estimate, reference)
        d = a - b
        self.sq += float(np.sum(d * d))
        self.ab += float(np.sum(np.abs(d)))
        self.n_values += d.size
        self.ssim_sum += ssim(a, b) * a.shape[0]
        self.n_frames += a.shape[0]
        self.n_sequences += 1

    def result(self) -> dict[str, Any]:
        mse = self.sq / self.n_values
        return {
            "psnr_db": None if mse == 0.0 else float(10.0 * np.log10(1.0 / mse)),
            "ssim": self.ssim_sum / self.n_frames,
            "mae": self.ab / self.n_values,
            "n_sequences": self.n_sequences,
            "n_frames": self.n_frames,
        }


def quality_table(metrics: dict[str, dict[str, Any]]) -> str:
    """Markdown table of ``deglint_metrics.json`` entries ranked by PSNR (best first)."""
    def key(item: tuple[str, dict[str, Any]]) -> float:
        p = item[1].get("psnr_db")
        return -float("inf") if p is None else -float(p)

    rows = sorted(metrics.items(), key=key)
    lines = ["| rank | condition | method | window | PSNR (dB) | SSIM | MAE | sequences |",
             "|---:|---|---|---:|---:|---:|---:|---:|"]
    for i, (name, m) in enumerate(rows, 1):
        p = m.get("psnr_db")
        ps = "inf" if p is None else f"{p:.2f}"
        win = m.get("window")
        lines.append(f"| {i} | {name} | {m.get('method', '-')} | "
                     f"{'-' if win is None else win} | {ps} | {m['ssim']:.4f} | "
                     f"{m['mae']:.4f} | {m['n_sequences']} |")
    return "\n".join(lines) + "\n"
