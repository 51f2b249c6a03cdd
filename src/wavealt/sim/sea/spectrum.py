"""Wave spectra and dispersion relations.

Wavenumbers are angular (rad/m); ``k = |k|``.  Angles are radians here; degrees only at the
edges (command line, manifest).
"""

from __future__ import annotations

import numpy as np

GRAVITY_MPS2 = 9.81
#: Surface tension over density of sea water, m^3/s^2 (sigma = 0.074 N/m, rho = 1025 kg/m^3).
SURFACE_TENSION_OVER_DENSITY = 0.074 / 1025.0


def cox_munk_slope_variance(wind_speed_mps: float | np.ndarray) -> float | np.ndarray:
    """Total mean-square slope of a clean sea, paper eq. (2), Cox & Munk (1954).

    ``sigma^2 = 0.003 + 5.12e-3 * U10`` (U10 in m/s; sum of the up- and cross-wind
    components).
    """
    return 0.003 + 5.12e-3 * np.asarray(wind_speed_mps, dtype=np.float64)


def deep_water_omega(k: np.ndarray, *, g: float = GRAVITY_MPS2) -> np.ndarray:
    """Deep-water gravity-wave dispersion ``omega = sqrt(g k)`` (rad/s)."""
    return np.sqrt(g * np.asarray(k, dtype=np.float64))


def gravity_capillary_omega(k: np.ndarray, *, g: float = GRAVITY_MPS2,
                            tension: float = SURFACE_TENSION_OVER_DENSITY) -> np.ndarray:
    """Deep-water gravity-capillary dispersion ``omega^2 = g k + (sigma/rho) k^3`` (rad/s)."""
    k = np.asarray(k, dtype=np.float64)
    return np.sqrt(g * k + tension * k**3)


def phillips(kx: np.ndarray, ky: np.ndarray, *, wind_speed_mps: float, wind_dir_rad: float,
             amplitude: float = 1.0, g: float = GRAVITY_MPS2) -> np.ndarray:
    """Phillips directional spectrum, paper eq. (1), Phillips (1958) / Tessendorf (2001).

    ``S(k) = A exp(-1/(k L)^2) / k^4 * max(k_hat . w_hat, 0)^2`` with ``L = U10^2 / g``.
    ``S`` is a density over the wavenumber plane (m^2 per (rad/m)^2 up to ``A``); it is zero
    at ``k = 0`` and on the upwind half-plane, so waves travel downwind only.
    """
    if not wind_speed_mps > 0:
        msg = f"wind_speed_mps must be > 0; got {wind_speed_mps!r}"
        raise ValueError(msg)
    kx = np.asarray(kx, dtype=np.float64)
    ky = np.asarray(ky, dtype=np.float64)
    k2 = kx * kx + ky * ky
    big_l2 = (wind_speed_mps**2 / g) ** 2
    # k = 0 gives 0/0 below; np.where puts the spectrum's value there (zero)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos_w = (kx * np.cos(wind_dir_rad) + ky * np.sin(wind_dir_rad)) / np.sqrt(k2)
        val = amplitude * np.exp(-1.0 / (k2 * big_l2)) / (k2 * k2) * np.maximum(cos_w, 0.0) ** 2
    return np.where(k2 > 0, val, 0.0)
