"""Direction-dependent clear-sky radiance and its reflection in the sea.

The paper renders a constant sky (its §4 names this as a cause of the sim-to-real gap): a
tilted facet then reflects the same colour as a flat one and only the Fresnel factor changes.
Here the sky's relative luminance follows the CIE standard general sky (ISO 15469:2004 /
CIE S 011, Darula & Kittler 2002), type 12 "CIE standard clear sky, low turbidity":

    L(Z, chi) / L_z = f(chi) phi(Z) / (f(Z_s) phi(0)),                                  (CIE)
    phi(Z) = 1 + a exp(b / cos Z),   f(chi) = 1 + c (exp(d chi) - exp(d pi / 2)) + e cos^2 chi

with ``a, b, c, d, e = -1, -0.32, 10, -3, 0.45``; ``Z`` is the zenith angle of the sky
element, ``chi`` its angle from the sun and ``Z_s`` the sun's zenith angle.  The sky grows
brighter toward the horizon and around the sun, so the radiance a facet reflects depends on
its slope.  The colour goes from ``zenith_rgb`` overhead to ``horizon_rgb`` at the horizon.
The level is fixed by the ratio of diffuse to direct horizontal irradiance
``diffuse_ratio`` (about 0.1-0.2 under a clear sky), with the sun's normal irradiance
``E_sun = 1``: every radiance in the realistic renderer is in units of ``E_sun`` per sr.
"""

from __future__ import annotations

import math

import numpy as np

from wavealt._checks import check_finite_number

#: CIE standard general sky type 12 (clear, low turbidity), ISO 15469:2004 Table 1.
CIE_CLEAR_SKY = (-1.0, -0.32, 10.0, -3.0, 0.45)


def _indicatrix(chi: np.ndarray, c: float, d: float, e: float) -> np.ndarray:
    return 1.0 + c * (np.exp(d * chi) - math.exp(d * math.pi / 2.0)) + e * np.cos(chi) ** 2


def _gradation(cos_z: np.ndarray, a: float, b: float) -> np.ndarray:
    return 1.0 + a * np.exp(b / np.maximum(cos_z, 1e-3))


class SkyModel:
    """Clear-sky radiance over the upper hemisphere, equation (CIE) of the module docstring.

    Parameters
    ----------
    sun : (3,) array
        Unit vector toward the sun (``sun[2] > 0``: above the horizon).
    zenith_rgb, horizon_rgb : 3-tuples
        Relative colours of the sky overhead and at the horizon.
    diffuse_ratio : float
        Diffuse horizontal irradiance over direct horizontal irradiance (> 0).
    """

    def __init__(self, sun: np.ndarray, *, zenith_rgb: tuple[float, float, float] = (0.45, 0.62, 1.0),
                 horizon_rgb: tuple[float, float, float] = (0.85, 0.90, 1.0),
                 diffuse_ratio: float = 0.15) -> None:
        sun = np.asarray(sun, dtype=np.float64)
        if sun.shape != (3,) or not np.all(np.isfinite(sun)) or not sun[2] > 0:
            msg = f"sun must be a unit 3-vector above the horizon (z > 0); got {sun.tolist()!r}"
            raise ValueError(msg)
        self.sun = sun / np.linalg.norm(sun)
        self.diffuse_ratio = check_finite_number("diffuse_ratio", diffuse_ratio, low=0.0,
                                                 low_open=True)
        self.zenith_rgb = np.asarray(zenith_rgb, dtype=np.float64)
        self.horizon_rgb = np.asarray(horizon_rgb, dtype=np.float64)
        for name, v in (("zenith_rgb", self.zenith_rgb), ("horizon_rgb", self.horizon_rgb)):
            if v.shape != (3,) or np.any(v < 0) or not np.all(np.isfinite(v)):
                msg = f"{name} must be 3 non-negative numbers; got {v.tolist()!r}"
                raise ValueError(msg)
        a, b, c, d, e = CIE_CLEAR_SKY
        zs = math.acos(min(self.sun[2], 1.0))
        self._norm = 1.0 / (float(_indicatrix(np.asarray(zs), c, d, e)) * (1.0 + a * math.exp(b)))
        self.zenith_radiance = 1.0
        # level: diffuse horizontal irradiance (luminance) = diffuse_ratio * sun[2] * E_sun
        cz = np.linspace(0.0005, 0.9995, 200)
        az = np.linspace(0.0, 2.0 * math.pi, 144, endpoint=False)
        czz, azz = np.meshgrid(cz, az, indexing="ij")
        sz = np.sqrt(1.0 - czz**2)
        dirs = np.stack([sz * np.cos(azz), sz * np.sin(azz), czz], axis=-1)
        lum = self.relative_luminance(dirs)
        # E = int L cos Z dOmega = int int L mu dmu dazimuth
        irr = float(np.mean(lum * czz)) * 1.0 * 2.0 * math.pi
        self.zenith_radiance = self.diffuse_ratio * float(self.sun[2]) / irr

    def relative_luminance(self, directions: np.ndarray) -> np.ndarray:
        """``L / L_z`` for unit ``directions`` ``(..., 3)`` (below-horizon rays clamp to it)."""
        dirs = np.asarray(directions)
        return self._relative_luminance(dirs[..., 0], dirs[..., 1], dirs[..., 2])

    def _relative_luminance(self, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray) -> np.ndarray:
        a, b, c, d, e = CIE_CLEAR_SKY
        sx, sy, sz = (dx.dtype.type(v) for v in self.sun)
        cos_z = np.clip(dz, 0.0, 1.0)
        cos_chi = np.clip(dx * sx + dy * sy + dz * sz, -1.0, 1.0)
        chi = np.arccos(cos_chi)
        f = 1.0 + c * (np.exp(d * chi) - math.exp(d * math.pi / 2.0)) + e * cos_chi * cos_chi
        return self._norm * f * _gradation(cos_z, a, b)

    def radiance_channels(self, dx: np.ndarray, dy: np.ndarray,
                          dz: np.ndarray) -> list[np.ndarray]:
        """Sky radiance as three arrays (R, G, B) shaped like the direction components."""
        lum = self._relative_luminance(dx, dy, dz) * dx.dtype.type(self.zenith_radiance)
        w = 1.0 - np.clip(dz, 0.0, 1.0)
        w *= w
        return [lum * (z + w * (h - z)) for z, h in
                zip(self.zenith_rgb.astype(dx.dtype), self.horizon_rgb.astype(dx.dtype))]

    def radiance(self, directions: np.ndarray) -> np.ndarray:
        """Sky radiance ``(..., 3)`` float32 along unit ``directions`` ``(..., 3)``, E_sun/sr."""
        dirs = np.asarray(directions, dtype=np.float32)
        return np.stack(self.radiance_channels(dirs[..., 0], dirs[..., 1], dirs[..., 2]),
                        axis=-1).astype(np.float32)


def reflect_components(view: np.ndarray, slope_x: np.ndarray, slope_y: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`reflect` as separate arrays ``(r_x, r_y, r_z, n_dot_c)``, float32."""
    sx = np.asarray(slope_x, dtype=np.float32)
    sy = np.asarray(slope_y, dtype=np.float32)
    inv = 1.0 / np.sqrt(1.0 + sx * sx + sy * sy)
    cx, cy, cz = (np.ascontiguousarray(view[..., i], dtype=np.float32) for i in range(3))
    ndc = (cz - sx * cx - sy * cy) * inv
    two_ndc_inv = 2.0 * ndc * inv  # 2 (N.c) times the normal's common factor
    return -two_ndc_inv * sx - cx, -two_ndc_inv * sy - cy, two_ndc_inv - cz, ndc


def reflect(view: np.ndarray, slope_x: np.ndarray, slope_y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mirror direction of the view ray on the resolved facet, and ``N . c``.

    Parameters
    ----------
    view : (H, W, 3) array
        Unit vectors from the sea toward the camera ``c``.
    slope_x, slope_y : (..., H, W) arrays

    Returns
    -------
    directions : (..., H, W, 3) float32
        ``r = 2 (N . c) N - c``, the sky direction seen in the facet.
    n_dot_c : (..., H, W) float32
    """
    rx, ry, rz, ndc = reflect_components(view, slope_x, slope_y)
    return np.stack([rx, ry, rz], axis=-1), ndc


__all__ = ["CIE_CLEAR_SKY", "SkyModel", "reflect", "reflect_components"]
