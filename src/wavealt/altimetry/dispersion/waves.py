"""The waves' dispersion relation, in deep water or water of a known depth.

Linear surface waves of wavenumber ``k`` (rad/m) on water ``d`` deep obey

    omega^2 = (g k + (sigma/rho) k^3) tanh(k d)

(Lamb 1932, §228 for gravity, §267 with capillarity); ``tanh(k d)`` is 1 to within 1 % once
the depth exceeds about 0.4 of the wavelength, and deep water drops it.  ``"gravity"`` leaves
out the capillary term (the ``paper`` simulator preset's relation).
"""

from __future__ import annotations

import numpy as np

from wavealt.sim.sea.spectrum import GRAVITY_MPS2, SURFACE_TENSION_OVER_DENSITY


def deep_omega2(k: np.ndarray, dispersion: str) -> np.ndarray:
    """``omega^2`` (rad²/s²) of deep water at ``k`` (rad/m): ``g k``, or with ``dispersion``
    ``"gravity-capillary"`` ``g k + (sigma/rho) k^3``."""
    if dispersion == "gravity":
        return GRAVITY_MPS2 * k
    return k * (GRAVITY_MPS2 + SURFACE_TENSION_OVER_DENSITY * (k * k))


def omega(k: np.ndarray, dispersion: str, depth_m: float | None = None) -> np.ndarray:
    """Angular frequency (rad/s) of wavenumber ``k`` (rad/m) in water ``depth_m`` deep
    (None: deep water)."""
    if depth_m is not None:
        return np.sqrt(deep_omega2(k, dispersion) * np.tanh(k * depth_m))
    return np.sqrt(deep_omega2(k, dispersion))


def omega_and_dlog_k(k: np.ndarray, dispersion: str,
                     depth_m: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``omega`` and ``d omega / d log k`` at ``k`` (rad/m).

    With ``omega^2 = W(k) tanh(k d)``: ``d omega / dk = (W' tanh(k d) + W d sech^2(k d)) /
    (2 omega)``; deep water, ``W' / (2 omega)``."""
    w = omega(k, dispersion, depth_m)
    dw = (GRAVITY_MPS2 if dispersion == "gravity"
          else GRAVITY_MPS2 + 3.0 * SURFACE_TENSION_OVER_DENSITY * k**2)
    if depth_m is None:
        if dispersion == "gravity":
            return w, 0.5 * w
        return w, k * dw / (2.0 * w)
    th = np.tanh(k * depth_m)
    return w, k * (dw * th + deep_omega2(k, dispersion) * depth_m * (1.0 - th * th)) / (2.0 * w)


__all__ = ["deep_omega2", "omega", "omega_and_dlog_k"]
